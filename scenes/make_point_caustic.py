#!/usr/bin/env python3
"""Writes point-caustic.gltf: scenes/point-caustic.toml as a glTF file that Mitsuba 3 reads too
(../shared/peers/mitsuba_render.py), for measuring light tracers side by side: a point light (5000 cd,
warm white) 2 m above a white floor (albedo 0.8, a 20 m square), a glass ball (IOR 1.5, r = 0.3 m,
the UV sphere of cornell-spheres.gltf with its smooth normals) at 0.6 m between them, the camera and
the 400 x 300 film of the run file.
Run: python3 scenes/make_point_caustic.py (deterministic; no dependencies beyond the standard library)."""

import base64, json, math, os, struct

from gltf_build import look_at_quaternion, sub

HERE = os.path.dirname(os.path.abspath(__file__))
EYE, TARGET, YFOV_DEG = (0.0, 1.3, 2.4), (0.0, 0.35, 0.0), 40.0


def main():
    spheres = json.load(open(os.path.join(HERE, "..", "tests", "data", "cornell-spheres.gltf")))
    data = bytearray(base64.b64decode(spheres["buffers"][0]["uri"].split(",", 1)[1]))
    glass_mesh = next(m for m in spheres["meshes"] if m["name"] == "glass_sphere")
    glass_material = next(m for m in spheres["materials"] if m["name"] == "glass")
    prim = glass_mesh["primitives"][0]
    # The sphere's accessors and views, copied; the floor's appended after them.
    accessors, views, out = [], [], bytearray()
    def copy(index):
        a = dict(spheres["accessors"][index])
        v = spheres["bufferViews"][a["bufferView"]]
        start = v.get("byteOffset", 0)
        chunk = data[start:start + v["byteLength"]]
        views.append({"buffer": 0, "byteOffset": len(out), "byteLength": len(chunk)})
        out.extend(chunk)
        while len(out) % 4:
            out.append(0)
        a["bufferView"] = len(views) - 1
        accessors.append(a)
        return len(accessors) - 1
    sphere_attributes = {k: copy(i) for k, i in prim["attributes"].items()}
    sphere_indices = copy(prim["indices"])
    def add(values, fmt, kind, component, count, **extra):
        chunk = b"".join(struct.pack(fmt, *v) if isinstance(v, tuple) else struct.pack(fmt, v) for v in values)
        views.append({"buffer": 0, "byteOffset": len(out), "byteLength": len(chunk)})
        out.extend(chunk)
        accessors.append({"bufferView": len(views) - 1, "componentType": component, "count": count,
                          "type": kind, **extra})
        return len(accessors) - 1
    h = 10.0
    corners = [(-h, 0.0, -h), (h, 0.0, -h), (h, 0.0, h), (-h, 0.0, h)]
    floor_positions = add(corners, "<3f", "VEC3", 5126, 4, min=[-h, 0.0, -h], max=[h, 0.0, h])
    floor_normals = add([(0.0, 1.0, 0.0)] * 4, "<3f", "VEC3", 5126, 4)
    # Counter-clockwise seen from above: the front faces up.
    floor_indices = add([0, 2, 1, 0, 3, 2], "<I", "SCALAR", 5125, 6)
    white = {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
             "metallicFactor": 0.0, "roughnessFactor": 1.0},
             "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}, "doubleSided": True}
    gltf = {
        "asset": {"version": "2.0", "generator": "scenes/make_point_caustic.py"},
        "extensionsUsed": sorted(set(spheres["extensionsUsed"]) | {"KHR_lights_punctual"}),
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "bulb", "type": "point", "color": [1.0, 0.9, 0.75], "intensity": 5000.0}]}},
        "scene": 0,
        "scenes": [{"name": "point-caustic", "nodes": [0, 1, 2, 3], "extras": {
            "width": 400, "height": 300,
            "description": "scenes/point-caustic.toml as glTF (scenes/make_point_caustic.py): a point light "
                           "over a glass ball over a white floor."}}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "glass ball", "mesh": 1, "translation": [0.0, 0.6, 0.0], "scale": [0.3, 0.3, 0.3]},
            {"name": "bulb", "translation": [0.0, 2.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "camera", "camera": 0, "translation": list(EYE), "rotation": look_at_quaternion(sub(TARGET, EYE), (0.0, 1.0, 0.0))},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(YFOV_DEG),
                     "aspectRatio": 400 / 300, "znear": 0.01}}],
        "meshes": [
            {"name": "floor", "primitives": [{"attributes": {"POSITION": floor_positions, "NORMAL": floor_normals},
                                              "indices": floor_indices, "material": 0, "mode": 4}]},
            {"name": "glass ball", "primitives": [{"attributes": sphere_attributes, "indices": sphere_indices,
                                                   "material": 1, "mode": 4}]},
        ],
        "materials": [white, glass_material],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(out),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(out)).decode()}],
    }
    with open(os.path.join(HERE, "point-caustic.gltf"), "w") as f:
        json.dump(gltf, f, indent=1)


if __name__ == "__main__":
    main()
