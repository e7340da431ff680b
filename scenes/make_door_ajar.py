#!/usr/bin/env python3
"""Writes door-ajar.gltf: after Veach's "door ajar" scene (Veach & Guibas 1997, Metropolis light transport), our own
layout and values. A closed room (4 x 4.4 m, 2.5 m high; a table, two stacked crates, a cabinet) is lit only from a
second, smaller room behind its back wall, through a door left ajar: the panel is turned 10° into the main room about its hinge, so light gets in only
through the narrow slot between its free edge and the jamb, and over its top edge into the wedge behind it.

The one lamp (1.0 x 0.6 m, one-sided) hangs on the lit room's side of the partition, 1 cm off the wall, facing away
from the door, so every ray it emits heads away from the partition: no light reaches the main room without bouncing
at least once in the lit room first. Seen from the main room the lamp is behind a wall and faces away (next-event
estimation finds nothing there) and the slot is a small target for BSDF sampling: the case path guiding is for.
The lamp's radiance (5000) puts the main room's pixels near 1 (image mean about 0.8); the lit room's walls seen
through the slot reach about 100.

Light-tight by construction: the shell's six walls are quads that reach 10 cm past each other at the edges, the
partition's three pieces (left of the door, right of it, the lintel) are closed boxes that reach through the shell,
and the door panel (a closed box) reaches 2 cm into the hinge jamb, 1 cm under the floor and 2 cm above the opening's
top. Every material is Lambertian (metallic 0, specular 0) apart from the emitter (black base), so Mitsuba 3 reads
it through ../shared/peers. Metres, +Y up. 256 x 256.
Run: python3 scenes/make_door_ajar.py (deterministic; standard library only)."""

import json, math, os

from gltf_build import Buffer, cross, look_at_quaternion, normalize, sub

HERE = os.path.dirname(os.path.abspath(__file__))
WIDTH, HEIGHT = 256, 256
EYE, TARGET, YFOV_DEG = (-1.65, 1.45, 2.2), (0.3, 0.6, -1.6), 58.0

X0, X1 = -2.0, 2.0            # both rooms' side walls
Y1 = 2.5                      # ceiling (floor at y = 0)
Z_BACK, Z_FRONT = -3.6, 2.4   # the lit room's far wall, the main room's front wall (behind the camera)
ZP0, ZP1 = -2.1, -2.0         # the partition: the lit room's side, the main room's side
DOOR_X0, DOOR_X1, DOOR_H = 0.6, 1.5, 2.05   # the opening; the hinge is at x = DOOR_X1 on the main room's side
DOOR_T, DOOR_ANGLE_DEG = 0.04, 10.0
LAMP = (-1.3, -0.3, 1.1, 1.7)  # x0, x1, y0, y1 on the partition's lit side
LAMP_Z = ZP0 - 0.01
LAMP_RADIANCE, LAMP_COLOUR = 5000.0, (1.0, 0.86, 0.66)
MARGIN = 0.1


def box(lo, hi, angle_deg=0.0, pivot=None):
    """A closed axis-aligned box (outward normals, counter-clockwise from outside), turned about the vertical axis
    through `pivot` by `angle_deg` (positive turns +x towards -z)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [  # four corners counter-clockwise seen from outside, outward normal
        ([(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)], (1, 0, 0)),
        ([(x0, y0, z1), (x0, y1, z1), (x0, y1, z0), (x0, y0, z0)], (-1, 0, 0)),
        ([(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)], (0, 1, 0)),
        ([(x0, y0, z1), (x0, y0, z0), (x1, y0, z0), (x1, y0, z1)], (0, -1, 0)),
        ([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], (0, 0, 1)),
        ([(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)], (0, 0, -1)),
    ]
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    px, _, pz = pivot or (0.0, 0.0, 0.0)
    turn = lambda p: (px + c * (p[0] - px) + s * (p[2] - pz), p[1], pz - s * (p[0] - px) + c * (p[2] - pz))
    turn_n = lambda n: (c * n[0] + s * n[2], n[1], -s * n[0] + c * n[2])
    return [([turn(p) for p in corners], turn_n(n)) for corners, n in faces]


def quad(corners, n):
    return [(corners, n)]


def check(faces):
    """Each quad's winding agrees with its normal."""
    for corners, n in faces:
        w = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]))
        assert sum(a * b for a, b in zip(w, n)) > 0, (corners, n)
    return faces


def geometry(faces):
    positions, normals, indices = [], [], []
    for corners, n in check(faces):
        k = len(positions)
        positions += corners
        normals += [tuple(float(x) for x in normalize(n))] * 4
        indices += [k, k + 1, k + 2, k, k + 2, k + 3]
    return positions, normals, indices


def lambert(name, rgb):
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [*rgb, 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 1.0}, "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
            "doubleSided": True}


def main():
    m = MARGIN
    # The shell, seen from inside: each quad's normal points into the rooms; each reaches MARGIN past its neighbours.
    shell = {
        "floor": quad([(X0 - m, 0, Z_BACK - m), (X0 - m, 0, Z_FRONT + m), (X1 + m, 0, Z_FRONT + m),
                       (X1 + m, 0, Z_BACK - m)], (0, 1, 0)),
        "ceiling": quad([(X0 - m, Y1, Z_BACK - m), (X1 + m, Y1, Z_BACK - m), (X1 + m, Y1, Z_FRONT + m),
                         (X0 - m, Y1, Z_FRONT + m)], (0, -1, 0)),
        "walls": quad([(X0, -m, Z_BACK - m), (X0, Y1 + m, Z_BACK - m), (X0, Y1 + m, Z_FRONT + m),
                       (X0, -m, Z_FRONT + m)], (1, 0, 0))
        + quad([(X1, -m, Z_FRONT + m), (X1, Y1 + m, Z_FRONT + m), (X1, Y1 + m, Z_BACK - m),
                (X1, -m, Z_BACK - m)], (-1, 0, 0))
        + quad([(X0 - m, -m, Z_BACK), (X1 + m, -m, Z_BACK), (X1 + m, Y1 + m, Z_BACK), (X0 - m, Y1 + m, Z_BACK)],
               (0, 0, 1))
        + quad([(X1 + m, -m, Z_FRONT), (X0 - m, -m, Z_FRONT), (X0 - m, Y1 + m, Z_FRONT),
                (X1 + m, Y1 + m, Z_FRONT)], (0, 0, -1)),
    }
    partition = (box((X0 - m, -m, ZP0), (DOOR_X0, Y1 + m, ZP1))
                 + box((DOOR_X1, -m, ZP0), (X1 + m, Y1 + m, ZP1))
                 + box((X0 - m, DOOR_H, ZP0), (X1 + m, Y1 + m, ZP1)))
    # Closed, the panel fills the opening flush with the main room's side; the hinge is the jamb's corner
    # (DOOR_X1, ZP1). Turned by DOOR_ANGLE about it, its free edge (x < DOOR_X1) swings into the main room (+z).
    door = box((DOOR_X0 + 0.005, -0.01, ZP1 - DOOR_T), (DOOR_X1 + 0.02, DOOR_H + 0.02, ZP1),
               DOOR_ANGLE_DEG, (DOOR_X1, 0.0, ZP1))
    table = box((-0.95, 0.72, -0.9), (0.25, 0.77, -0.2))
    for x in (-0.9, 0.15):
        for z in (-0.85, -0.3):
            table += box((x, 0.0, z), (x + 0.05, 0.72, z + 0.05))
    crates = box((-1.7, 0.0, -0.75), (-1.2, 0.5, -0.25), 25.0, (-1.45, 0.0, -0.5))
    crates += box((-1.65, 0.5, -0.68), (-1.3, 0.8, -0.33), 10.0, (-1.45, 0.0, -0.5))
    cabinet = box((1.45, 0.0, -0.2), (1.95, 1.4, 0.5))
    lamp = quad([(LAMP[0], LAMP[2], LAMP_Z), (LAMP[0], LAMP[3], LAMP_Z), (LAMP[1], LAMP[3], LAMP_Z),
                 (LAMP[1], LAMP[2], LAMP_Z)], (0, 0, -1))   # faces the lit room's far wall, away from the door

    materials = [lambert("walls", (0.75, 0.74, 0.72)), lambert("floor", (0.5, 0.42, 0.34)),
                 lambert("ceiling", (0.8, 0.8, 0.8)), lambert("door", (0.7, 0.62, 0.5)),
                 lambert("table", (0.55, 0.4, 0.28)), lambert("crates", (0.45, 0.55, 0.7)),
                 lambert("cabinet", (0.7, 0.3, 0.25)),
                 {"name": "lamp", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1.0], "metallicFactor": 0.0,
                  "roughnessFactor": 1.0}, "emissiveFactor": list(LAMP_COLOUR),
                  "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": LAMP_RADIANCE},
                                 "KHR_materials_specular": {"specularFactor": 0.0}}, "doubleSided": False}]
    parts = [("floor", shell["floor"], 1), ("ceiling", shell["ceiling"], 2), ("walls", shell["walls"], 0),
             ("partition", partition, 0), ("door", door, 3), ("table", table, 4), ("crates", crates, 5),
             ("cabinet", cabinet, 6), ("lamp", lamp, 7)]
    buffer = Buffer()
    meshes = [buffer.mesh(name, *geometry(faces), material) for name, faces, material in parts]
    nodes = [{"name": m["name"], "mesh": i} for i, m in enumerate(meshes)]
    nodes.append({"name": "camera", "camera": 0, "translation": list(EYE),
                  "rotation": look_at_quaternion(sub(TARGET, EYE), (0.0, 1.0, 0.0))})
    triangles = sum(len(faces) * 2 for _, faces, _ in parts)
    gltf = {
        "asset": {"version": "2.0", "generator": "scenes/make_door_ajar.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
        "scene": 0,
        "scenes": [{"name": "door-ajar", "nodes": list(range(len(nodes))), "extras": {
            "width": WIDTH, "height": HEIGHT,
            "description": f"After Veach's door ajar: a room lit only through a door turned {DOOR_ANGLE_DEG:g} "
                           f"degrees open, by a lamp in the room behind it that faces away from the door "
                           f"({triangles} triangles; scenes/make_door_ajar.py)."}}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(YFOV_DEG),
                     "aspectRatio": WIDTH / HEIGHT, "znear": 0.01}}],
        "meshes": meshes,
        "materials": materials,
        **buffer.gltf_fields(),
    }
    with open(os.path.join(HERE, "door-ajar.gltf"), "w") as f:
        json.dump(gltf, f, indent=1)


if __name__ == "__main__":
    main()
