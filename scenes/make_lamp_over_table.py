#!/usr/bin/env python3
"""Writes lamp-over-table.gltf: the Cornell box (cornell-box.gltf) with its ceiling light replaced by a
large lamp (40 x 44 cm, facing down) hung 5 cm under the ceiling over the blocks (the "tables"): a
large area light close to the surfaces it lights (the walls beside it, the ceiling above its edges are
lit only indirectly), where sampling the lamp by area leaves 1/r^2 noise and sampling it by solid angle
does not. The lamp's radiance is scaled so that it emits the ceiling light's power.
Run: python3 scenes/make_lamp_over_table.py (deterministic; no dependencies)."""

import base64, json, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))
X0, X1, Z0, Z1, Y = -0.2, 0.2, -0.5, -0.06, 0.5

def main():
    g = json.load(open(os.path.join(HERE, "cornell-box.gltf")))
    head, payload = g["buffers"][0]["uri"].split(",", 1)
    data = bytearray(base64.b64decode(payload))
    light = next(m for m in g["meshes"] if m.get("name") == "light")
    access = g["accessors"][light["primitives"][0]["attributes"]["POSITION"]]
    view = g["bufferViews"][access["bufferView"]]
    offset = view.get("byteOffset", 0) + access.get("byteOffset", 0)
    old = [struct.unpack_from("<3f", data, offset + 12 * k) for k in range(access["count"])]
    lo = [min(p[i] for p in old) for i in range(3)]
    hi = [max(p[i] for p in old) for i in range(3)]
    # An affine map with positive scales keeps the triangles' winding: the front still faces down.
    def place(p):
        x = X0 + (p[0] - lo[0]) / (hi[0] - lo[0]) * (X1 - X0)
        z = Z0 + (p[2] - lo[2]) / (hi[2] - lo[2]) * (Z1 - Z0)
        return (x, Y, z)
    new = [place(p) for p in old]
    for k, p in enumerate(new):
        struct.pack_into("<3f", data, offset + 12 * k, *p)
    access["min"] = [min(p[i] for p in new) for i in range(3)]
    access["max"] = [max(p[i] for p in new) for i in range(3)]
    g["buffers"][0]["uri"] = head + "," + base64.b64encode(bytes(data)).decode()
    scale = ((hi[0] - lo[0]) * (hi[2] - lo[2])) / ((X1 - X0) * (Z1 - Z0))
    material = g["materials"][light["primitives"][0]["material"]]
    material["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] *= scale
    if "radiance" in material.get("extras", {}):
        material["extras"]["radiance"] = [r * scale for r in material["extras"]["radiance"]]
    scene = g["scenes"][0]
    scene["name"] = "lamp-over-table"
    scene.setdefault("extras", {})["description"] = (
        "Cornell box with a 40 x 44 cm lamp 5 cm under the ceiling (scenes/make_lamp_over_table.py).")
    with open(os.path.join(HERE, "lamp-over-table.gltf"), "w") as f:
        json.dump(g, f, indent=1)

if __name__ == "__main__":
    main()
