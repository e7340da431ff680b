#!/usr/bin/env python3
"""Writes many-lights.gltf: a one-storey building of 4 x 4 rooms (6 m x 6 m, 3 m high) joined by
doorways, with 64 small ceiling lamps per room (1024 lamps, 2048 emissive triangles) of varied power
and colour. From any point most lamps are behind walls: the case a light tree and visibility-aware
selection are for. Run: python3 scenes/make_many_lights.py (deterministic; no dependencies)."""

import base64, json, math, os, struct

ROOMS, SIZE, HEIGHT = 4, 6.0, 3.0
DOOR_W, DOOR_H = 1.2, 2.2
LAMPS_PER_SIDE, LAMP = 8, 0.15

def quad(a, b, c, d):
    """Two triangles a-b-c, a-c-d (counter-clockwise seen from the front)."""
    return [(a, b, c), (a, c, d)]

def wall_x(x, z0, z1, door):
    """A wall in the plane x = const from z0 to z1, optionally with a centred doorway."""
    tris = []
    if not door:
        return quad((x, 0, z0), (x, 0, z1), (x, HEIGHT, z1), (x, HEIGHT, z0))
    zm0, zm1 = (z0 + z1 - DOOR_W) / 2, (z0 + z1 + DOOR_W) / 2
    tris += quad((x, 0, z0), (x, 0, zm0), (x, HEIGHT, zm0), (x, HEIGHT, z0))
    tris += quad((x, 0, zm1), (x, 0, z1), (x, HEIGHT, z1), (x, HEIGHT, zm1))
    tris += quad((x, DOOR_H, zm0), (x, DOOR_H, zm1), (x, HEIGHT, zm1), (x, HEIGHT, zm0))
    return tris

def wall_z(z, x0, x1, door):
    return [tuple((p[2], p[1], p[0]) for p in t) for t in wall_x(z, x0, x1, door)]

def hash01(i, k):
    """A deterministic number in [0, 1) for lamp i, stream k."""
    h = (i * 0x9E3779B1 + k * 0x85EBCA77) & 0xFFFFFFFF
    h ^= h >> 15; h = (h * 0x2C1B3C6D) & 0xFFFFFFFF; h ^= h >> 12
    h = (h * 0x297A2D39) & 0xFFFFFFFF; h ^= h >> 15
    return h / 2**32

extent = ROOMS * SIZE
floor = quad((0, 0, 0), (0, 0, extent), (extent, 0, extent), (extent, 0, 0))
ceiling = quad((0, HEIGHT, 0), (extent, HEIGHT, 0), (extent, HEIGHT, extent), (0, HEIGHT, extent))
walls = []
for k in range(ROOMS + 1):
    for r in range(ROOMS):
        inner = 0 < k < ROOMS
        walls += wall_x(k * SIZE, r * SIZE, (r + 1) * SIZE, inner)
        walls += wall_z(k * SIZE, r * SIZE, (r + 1) * SIZE, inner)

COLOURS = [(1.0, 0.85, 0.6), (1.0, 0.95, 0.9), (0.7, 0.8, 1.0), (1.0, 0.6, 0.4),
           (0.6, 1.0, 0.7), (1.0, 0.7, 0.9), (0.9, 0.9, 0.5), (0.5, 0.7, 1.0)]
STRENGTHS = [2.0, 8.0, 30.0, 120.0]
lamps = {}  # material index -> triangles
for room_x in range(ROOMS):
    for room_z in range(ROOMS):
        for a in range(LAMPS_PER_SIDE):
            for b in range(LAMPS_PER_SIDE):
                i = ((room_x * ROOMS + room_z) * LAMPS_PER_SIDE + a) * LAMPS_PER_SIDE + b
                cx = room_x * SIZE + (a + 0.5) * SIZE / LAMPS_PER_SIDE
                cz = room_z * SIZE + (b + 0.5) * SIZE / LAMPS_PER_SIDE
                y, h = HEIGHT - 0.02, LAMP / 2
                # Facing down: counter-clockwise seen from below.
                tris = quad((cx - h, y, cz - h), (cx + h, y, cz - h), (cx + h, y, cz + h), (cx - h, y, cz + h))
                m = int(hash01(i, 0) * len(COLOURS)) * len(STRENGTHS) + int(hash01(i, 1) ** 2 * len(STRENGTHS))
                lamps.setdefault(m, []).extend(tris)

def normal(t):
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = t
    u, v = (bx - ax, by - ay, bz - az), (cx - ax, cy - ay, cz - az)
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    l = math.sqrt(sum(c * c for c in n)) or 1.0
    return tuple(c / l for c in n)

buffer, views, accessors, primitives = bytearray(), [], [], []
def add_primitive(tris, material):
    positions = [p for t in tris for p in t]
    normals = [normal(t) for t in tris for _ in range(3)]
    indices = list(range(len(positions)))
    for data, fmt, target, kind, ctype in ((positions, "3f", 34962, "VEC3", 5126), (normals, "3f", 34962, "VEC3", 5126),
                                           (indices, "I", 34963, "SCALAR", 5125)):
        offset = len(buffer)
        for item in data:
            buffer.extend(struct.pack("<" + fmt, *(item if isinstance(item, tuple) else (item,))))
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(buffer) - offset, "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": ctype, "count": len(data), "type": kind}
        if kind == "VEC3" and data is positions:
            acc["min"] = [min(p[k] for p in data) for k in range(3)]
            acc["max"] = [max(p[k] for p in data) for k in range(3)]
        accessors.append(acc)
    n = len(accessors)
    primitives.append({"attributes": {"POSITION": n - 3, "NORMAL": n - 2}, "indices": n - 1, "material": material})

def diffuse(name, c):
    return {"name": name, "doubleSided": True, "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
            "pbrMetallicRoughness": {"baseColorFactor": [c, c, c, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}

materials = [diffuse("floor", 0.45), diffuse("ceiling", 0.75), diffuse("walls", 0.65)]
add_primitive(floor, 0)
add_primitive(ceiling, 1)
add_primitive(walls, 2)
for m, tris in sorted(lamps.items()):
    colour, strength = COLOURS[m // len(STRENGTHS)], STRENGTHS[m % len(STRENGTHS)]
    materials.append({"name": f"lamp_{m}", "emissiveFactor": list(colour),
                      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength},
                                     "KHR_materials_specular": {"specularFactor": 0.0}},
                      "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    add_primitive(tris, len(materials) - 1)

eye, target = (1.2, 1.6, 1.2), (9.0, 1.2, 9.0)
f = [t - e for t, e in zip(target, eye)]; l = math.sqrt(sum(c * c for c in f)); f = [c / l for c in f]
right = [-f[2], 0.0, f[0]]; rl = math.sqrt(sum(c * c for c in right)); right = [c / rl for c in right]
up = [right[1] * f[2] - right[2] * f[1], right[2] * f[0] - right[0] * f[2], right[0] * f[1] - right[1] * f[0]]
matrix = right + [0.0] + up + [0.0] + [-c for c in f] + [0.0] + list(eye) + [1.0]

gltf = {
    "asset": {"version": "2.0", "generator": "scenes/make_many_lights.py"},
    "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
    "scene": 0,
    "scenes": [{"nodes": [0, 1], "extras": {"width": 320, "height": 240}}],
    "nodes": [{"name": "building", "mesh": 0}, {"name": "camera", "camera": 0, "matrix": matrix}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(70.0), "aspectRatio": 320 / 240,
                                                        "znear": 0.01}}],
    "meshes": [{"name": "building", "primitives": primitives}],
    "materials": materials,
    "buffers": [{"byteLength": len(buffer), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buffer)).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "many-lights.gltf")
with open(out, "w") as fh:
    json.dump(gltf, fh, separators=(",", ":"))
print(f"wrote {out}: {sum(len(t) for t in lamps.values())} emissive triangles, {len(materials)} materials")
