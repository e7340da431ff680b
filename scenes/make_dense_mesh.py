#!/usr/bin/env python3
"""Writes dense-mesh.gltf and dense-mesh.bin: the Cornell box (its walls, light and camera, from
cornell-box.gltf) with its two blocks replaced by one bumpy ball of 990 x 990 quads (1,960,200
triangles, 982,081 vertices, with normals): the big-mesh case of the speed benchmarks (BVH build,
buffer reading, memory per triangle, trace speed on a deep tree). Deterministic, no dependencies.

Run: python3 scenes/make_dense_mesh.py [N]   (N quads per side, default 990; files are ~47 MB, not
committed). Then: cargo run --release -- render scenes/dense-mesh.gltf --spp 16
"""

import json, math, os, struct, sys
from array import array

HERE = os.path.dirname(os.path.abspath(__file__))
N = int(sys.argv[1]) if len(sys.argv) > 1 else 990
CENTER, RADIUS = (0.0, 0.26, 0.0), 0.2


def surface(u, v):
    """Point on the ball for u (longitude) and v (latitude) in [0, 1], with a bumpy radius."""
    phi, theta = 2.0 * math.pi * u, math.pi * v
    st = math.sin(theta)
    d = (st * math.cos(phi), math.cos(theta), st * math.sin(phi))
    bump = 1.0 + 0.06 * math.sin(9.0 * phi) * math.sin(7.0 * theta) + 0.02 * math.sin(31.0 * phi + 3.0 * theta)
    r = RADIUS * bump
    return tuple(CENTER[i] + r * d[i] for i in range(3))


def main():
    base_path = os.path.join(HERE, "cornell-box.gltf")
    with open(base_path) as f:
        doc = json.load(f)
    # Keep every mesh of the box but its blocks, with their data re-packed into our one buffer.
    import base64
    old = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1]) if doc["buffers"][0]["uri"].startswith("data:") \
        else open(os.path.join(HERE, doc["buffers"][0]["uri"]), "rb").read()
    blob = bytearray(old)
    for view in doc["bufferViews"]:
        view["buffer"] = 0
    keep = [i for i, m in enumerate(doc["meshes"]) if m.get("name") not in ("short_block", "tall_block")]
    remap = {old_i: new_i for new_i, old_i in enumerate(keep)}
    doc["meshes"] = [doc["meshes"][i] for i in keep]
    nodes = []
    for node in doc["nodes"]:
        if "mesh" in node:
            if node["mesh"] not in remap:
                continue
            node["mesh"] = remap[node["mesh"]]
        nodes.append(node)
    doc["nodes"] = nodes
    doc["scenes"][0]["nodes"] = list(range(len(nodes)))

    # The ball: (N + 1) x (N + 1) vertices in u, v; normals from central differences.
    positions, normals = array("f"), array("f")
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    eps = 1e-4
    for j in range(N + 1):
        v = min(max(j / N, 1e-6), 1 - 1e-6)
        for i in range(N + 1):
            u = i / N
            p = surface(u, v)
            du = [a - b for a, b in zip(surface(u + eps, v), surface(u - eps, v))]
            dv = [a - b for a, b in zip(surface(u, v + eps), surface(u, v - eps))]
            n = (dv[1] * du[2] - dv[2] * du[1], dv[2] * du[0] - dv[0] * du[2], dv[0] * du[1] - dv[1] * du[0])
            length = math.sqrt(sum(c * c for c in n)) or 1.0
            positions.extend(p)
            normals.extend(c / length for c in n)
            for k in range(3):
                lo[k], hi[k] = min(lo[k], p[k]), max(hi[k], p[k])
    indices = array("I")
    row = N + 1
    for j in range(N):
        for i in range(N):
            a, b, c, d = j * row + i, j * row + i + 1, (j + 1) * row + i + 1, (j + 1) * row + i
            indices.extend((a, b, c, a, c, d))

    def append(data, target):
        while len(blob) % 4:
            blob.append(0)
        offset = len(blob)
        blob.extend(data.tobytes())
        doc["bufferViews"].append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob) - offset, "target": target})
        return len(doc["bufferViews"]) - 1

    count = len(positions) // 3
    pv, nv, iv = append(positions, 34962), append(normals, 34962), append(indices, 34963)
    acc = doc["accessors"]
    acc.append({"bufferView": pv, "componentType": 5126, "count": count, "type": "VEC3", "min": lo, "max": hi})
    acc.append({"bufferView": nv, "componentType": 5126, "count": count, "type": "VEC3"})
    acc.append({"bufferView": iv, "componentType": 5125, "count": len(indices), "type": "SCALAR"})
    white = next(i for i, m in enumerate(doc["materials"]) if m.get("name") == "white")
    doc["meshes"].append({"name": "bumpy_ball", "primitives": [
        {"attributes": {"POSITION": len(acc) - 3, "NORMAL": len(acc) - 2}, "indices": len(acc) - 1, "material": white}]})
    doc["nodes"].append({"name": "bumpy_ball", "mesh": len(doc["meshes"]) - 1})
    doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    doc["buffers"] = [{"uri": "dense-mesh.bin", "byteLength": len(blob)}]
    doc.setdefault("asset", {})["generator"] = "scenes/make_dense_mesh.py"
    with open(os.path.join(HERE, "dense-mesh.bin"), "wb") as f:
        f.write(blob)
    with open(os.path.join(HERE, "dense-mesh.gltf"), "w") as f:
        json.dump(doc, f, indent=1)
    print(f"dense-mesh.gltf: {len(indices) // 3} triangles in the ball, {count} vertices, {len(blob) / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
