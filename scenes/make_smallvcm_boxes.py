#!/usr/bin/env python3
"""Writes SmallVCM's Cornell box (Davidovič & Georgiev's SmallVCM, src/scene.hxx, MIT licence) as glTF, for
measuring `vcm` side by side with SmallVCM's own VCM (benches/smallvcm/run.sh). Two files:

- smallvcm-box.gltf: the box with a diffuse floor (SmallVCM's mask without kGlossyFloor), no lamp;
  smallvcm-point.toml adds the point light and the two small balls (mirror left, glass IOR 1.6 right).
- smallvcm-lamp.gltf: the same box with SmallVCM's light box at the ceiling (its underside emits 25.03 W/(m² sr));
  smallvcm-lamp.toml adds the two balls (SmallVCM's kDefault scene).

SmallVCM is z-up; glTF y-up: (x, y, z) → (x, z, −y), a rotation. The camera, field of view (45°, square) and
512² film are SmallVCM's. The balls are analytic spheres in the run files, as they are in SmallVCM.
Run: python3 scenes/make_smallvcm_boxes.py (deterministic; standard library only)."""

import json, math, os

from gltf_build import Buffer, cross, dot, look_at_quaternion, normalize, sub

HERE = os.path.dirname(os.path.abspath(__file__))


def to_gltf(p):
    return (p[0], p[2], -p[1])


# The box's corners (SmallVCM's cb[]): 0-3 at the back, 4-7 at the open front.
X0, X1, Y0, Y1, Z0, Z1 = -1.27029, 1.28975, -1.25549, 1.30455, -1.28002, 1.28002
BOX = [(X0, Y1, Z0), (X1, Y1, Z0), (X1, Y1, Z1), (X0, Y1, Z1),
       (X0, Y0, Z0), (X1, Y0, Z0), (X1, Y0, Z1), (X0, Y0, Z1)]
# The light box (lb[]): a 0.5 m square, 2 cm deep, under the ceiling.
L0, L1 = 1.26002, 1.28002
LAMP = [(-0.25, 0.25, L0), (0.25, 0.25, L0), (0.25, 0.25, L1), (-0.25, 0.25, L1),
        (-0.25, -0.25, L0), (0.25, -0.25, L0), (0.25, -0.25, L1), (-0.25, -0.25, L1)]
CENTRE = (0.5 * (X0 + X1), 0.5 * (Y0 + Y1), 0.5 * (Z0 + Z1))

EYE = (-0.0439815, -4.12529, 0.222539)
FORWARD = (0.00688625, 0.998505, -0.0542161)
UP = (3.73896e-4, 0.0542148, 0.998529)


def facing(tri, towards):
    """The triangle wound so that its front faces the point `towards` (inside the box, or down for the lamp)."""
    n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))
    centroid = tuple(sum(c) / 3 for c in zip(*tri))
    return tri if dot(n, sub(towards, centroid)) > 0 else (tri[0], tri[2], tri[1])


def quad(corners, a, b, c, d, towards):
    return [facing((corners[a], corners[b], corners[c]), towards), facing((corners[c], corners[d], corners[a]), towards)]


def diffuse(name, rgb):
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [*rgb, 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 1.0}, "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
            "doubleSided": True}


WHITE, GREEN, RED = (0.803922,) * 3, (0.156863, 0.803922, 0.172549), (0.803922, 0.152941, 0.152941)
LAMP_RADIANCE = 25.03329895614464


def write(name, with_lamp):
    inside = CENTRE
    surfaces = {  # material → triangles, in SmallVCM's coordinates
        "white": quad(BOX, 0, 4, 5, 1, inside) + quad(BOX, 0, 1, 2, 3, inside) + quad(BOX, 2, 6, 7, 3, inside),
        "green": quad(BOX, 3, 7, 4, 0, inside),
        "red": quad(BOX, 1, 5, 6, 2, inside),
    }
    materials = [diffuse("white", WHITE), diffuse("green", GREEN), diffuse("red", RED)]
    if with_lamp:
        lamp_inside = (0.0, 0.0, 0.5 * (L0 + L1))
        below = (0.0, 0.0, -1.0)
        # The light box's four sides face out of it; its underside faces down and emits.
        for a, b, c, d in [(0, 1, 2, 3), (3, 7, 4, 0), (1, 5, 6, 2), (4, 5, 6, 7)]:
            for tri in quad(LAMP, a, b, c, d, lamp_inside):
                surfaces["white"].append((tri[0], tri[2], tri[1]))
        surfaces["lamp"] = quad(LAMP, 0, 4, 5, 1, below)
        materials.append({"name": "lamp", "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0],
                          "metallicFactor": 0.0, "roughnessFactor": 1.0}, "emissiveFactor": [1.0, 1.0, 1.0],
                          "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": LAMP_RADIANCE},
                                         "KHR_materials_specular": {"specularFactor": 0.0}},
                          "doubleSided": False})
    buffer, meshes, nodes = Buffer(), [], []

    for index, material in enumerate(m["name"] for m in materials):
        triangles = surfaces[material]
        positions = [to_gltf(p) for tri in triangles for p in tri]
        normal_of = [normalize(cross(sub(t[1], t[0]), sub(t[2], t[0]))) for t in triangles]
        normals = [to_gltf(n) for n in normal_of for _ in range(3)]
        meshes.append(buffer.mesh(material, positions, normals, list(range(len(positions))), index))
        nodes.append({"name": material, "mesh": index})
    nodes.append({"name": "camera", "camera": 0, "translation": list(to_gltf(EYE)),
                  "rotation": look_at_quaternion(to_gltf(FORWARD), to_gltf(UP))})
    extensions = ["KHR_materials_specular"] + (["KHR_materials_emissive_strength"] if with_lamp else [])
    gltf = {
        "asset": {"version": "2.0", "generator": "scenes/make_smallvcm_boxes.py",
                  "copyright": "Geometry of SmallVCM's Cornell box (github.com/SmallVCM/SmallVCM, MIT licence)"},
        "extensionsUsed": sorted(extensions),
        "scene": 0,
        "scenes": [{"name": name, "nodes": list(range(len(nodes))), "extras": {"width": 512, "height": 512}}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(45.0), "aspectRatio": 1.0,
                                                            "znear": 0.01}}],
        "meshes": meshes,
        "materials": materials,
        **buffer.gltf_fields(),
    }
    with open(os.path.join(HERE, name + ".gltf"), "w") as f:
        json.dump(gltf, f, indent=1)


def balls():
    """SmallVCM's two small balls (r = 0.5 on the floor, 2/7 of the width in from each wall), in glTF axes."""
    r = 0.5
    y = 0.5 * (Y0 + Y1)
    inset = 2.0 * (X1 - X0) / 7.0
    return [to_gltf((X0 + inset, y, Z0 + r)), to_gltf((X1 - inset, y, Z0 + r))]


if __name__ == "__main__":
    write("smallvcm-box", with_lamp=False)
    write("smallvcm-lamp", with_lamp=True)
    mirror, glass = balls()
    print("mirror ball", [round(c, 6) for c in mirror], "glass ball", [round(c, 6) for c in glass])
    print("point light", [round(c, 6) for c in to_gltf((0.0, -0.5, 1.0))],
          "intensity cd", round(70.0 / (4 * math.pi) * 683.0, 4))
