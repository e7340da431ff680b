#!/usr/bin/env python3
"""Writes cornell-animated.gltf: the Cornell box (cornell-box.gltf) with a two-second animation, one
channel per glTF interpolation: the short block slides across the floor and back (CUBICSPLINE, eased
by its tangents), the camera dollies in (LINEAR), and the ceiling light narrows for the second half
(STEP on its x and z scale). Deterministic, standard library only.

Run: python3 scenes/make_cornell_animated.py
Then: cargo run --release -- render scenes/cornell-animated.gltf --frames 0:48 --spp 16 -o out/frame-####.png
"""

import base64, json, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    with open(os.path.join(HERE, "cornell-box.gltf")) as f:
        gltf = json.load(f)
    nodes = {n["name"]: i for i, n in enumerate(gltf["nodes"])}
    data = bytearray()
    accessors, views = gltf["accessors"], gltf["bufferViews"]
    buffer = len(gltf["buffers"])

    def add(values, kind, **extra):
        fmt = {"SCALAR": "<f", "VEC3": "<3f", "VEC4": "<4f"}[kind]
        chunk = b"".join(struct.pack(fmt, *(v if isinstance(v, tuple) else (v,))) for v in values)
        views.append({"buffer": buffer, "byteOffset": len(data), "byteLength": len(chunk)})
        data.extend(chunk)
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(values),
                          "type": kind, **extra})
        return len(accessors) - 1

    def times(keys):
        return add(keys, "SCALAR", min=[keys[0]], max=[keys[-1]])

    samplers, channels = [], []

    def channel(node, path, keys, values, kind, interpolation):
        samplers.append({"input": times(keys), "output": add(values, kind), "interpolation": interpolation})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": nodes[node], "path": path}})

    # The block: 0 → 0.12 m along +x at 1 s → back at 2 s; in-tangent, value, out-tangent per key
    # (m/s), zero at the ends so it starts and stops gently.
    zero, across = (0.0, 0.0, 0.0), (0.12, 0.0, 0.0)
    channel("short_block", "translation", [0.0, 1.0, 2.0],
            [zero, zero, zero, zero, across, zero, zero, zero, zero], "VEC3", "CUBICSPLINE")
    camera = gltf["nodes"][nodes["camera"]]
    start = tuple(camera.get("translation", [0.0, 0.0, 0.0]))
    channel("camera", "translation", [0.0, 2.0], [start, (start[0], start[1], start[2] - 0.25)], "VEC3",
            "LINEAR")
    channel("light", "scale", [0.0, 1.0], [(1.0, 1.0, 1.0), (0.6, 1.0, 0.6)], "VEC3", "STEP")

    gltf["buffers"].append({"byteLength": len(data),
                            "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(data)).decode()})
    gltf["animations"] = [{"name": "cornell", "channels": channels, "samplers": samplers}]
    gltf["asset"]["generator"] = "scenes/make_cornell_animated.py"
    out = os.path.join(HERE, "cornell-animated.gltf")
    with open(out, "w") as f:
        json.dump(gltf, f, indent=1)
    print(f"{out}: {len(channels)} channels over 2 s")


if __name__ == "__main__":
    main()
