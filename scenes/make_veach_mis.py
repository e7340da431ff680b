#!/usr/bin/env python3
"""Writes veach-mis.gltf: a scene after Veach's multiple-importance-sampling figure (thesis, fig. 9.2): four rough
metal plates, from nearly a mirror to broadly glossy, tilted so that the camera sees four spherical lamps of
very different sizes but equal power reflected in each. Light sampling wins on the rough plates with the small
lamps, BSDF sampling on the sharp plates with the large ones; bidirectional methods and photon mapping meet glossy
reflections of small sources, the case photon mapping handles worst. Our own layout and values, not Veach's.

The plates are GGX conductors with a white base (F = 1, as Mitsuba's material 'none' in ../shared/peers), alpha =
roughness² = 0.005, 0.02, 0.06, 0.2; the lamps' radii 0.9, 0.3, 0.1, 0.03 with radiance ∝ 1/r² (equal power);
a grey diffuse floor and back wall (albedo 0.4) catch the light. Mitsuba 3 reads it through the peers kit.
Run: python3 scenes/make_veach_mis.py (deterministic; standard library only)."""

import json, math, os

from gltf_build import Buffer, cross, look_at_quaternion, normalize, sub

HERE = os.path.dirname(os.path.abspath(__file__))
EYE, TARGET, YFOV_DEG, WIDTH, HEIGHT = (0.0, 2.0, 12.0), (0.0, 0.4, 0.0), 32.0, 512, 384
LAMP_ROW = (0.0, 3.2, -3.0)
LAMPS = [  # x, radius, colour (radiance × (0.9 / r)² keeps the powers equal)
    (-3.6, 0.9, (1.0, 0.35, 0.25)), (-1.2, 0.3, (1.0, 0.8, 0.3)), (1.2, 0.1, (0.35, 1.0, 0.45)),
    (3.6, 0.03, (0.35, 0.55, 1.0))]
LAMP_RADIANCE = 1.5
PLATES = [(0.0, -0.6, 3.2, 0.005), (0.0, 0.0, 2.0, 0.02), (0.0, 0.6, 0.8, 0.06), (0.0, 1.2, -0.4, 0.2)]
PLATE_WIDTH, PLATE_DEPTH = 9.0, 0.9


def plate_triangles(centre):
    """A plate whose normal halves the angle between the camera and the lamps' row: the lamps show in it."""
    to_eye = normalize(sub(EYE, centre))
    to_lamps = normalize(sub(LAMP_ROW, centre))
    n = normalize(tuple(a + b for a, b in zip(to_eye, to_lamps)))
    along = (1.0, 0.0, 0.0)
    across = normalize(cross(n, along))
    hw, hd = PLATE_WIDTH / 2, PLATE_DEPTH / 2
    corner = lambda s, t: tuple(c + s * hw * a + t * hd * b for c, a, b in zip(centre, along, across))
    positions = [corner(-1, -1), corner(1, -1), corner(1, 1), corner(-1, 1)]
    e1, e2 = sub(positions[1], positions[0]), sub(positions[2], positions[0])
    indices = [0, 1, 2, 0, 2, 3] if sum(a * b for a, b in zip(cross(e1, e2), n)) > 0 else [0, 2, 1, 0, 3, 2]
    return positions, [n] * 4, indices


def sphere(centre, radius, rings=32, segments=64):
    positions, normals, indices = [], [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            normals.append(n)
            positions.append(tuple(c + radius * x for c, x in zip(centre, n)))
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            if i > 0:  # the poles' rows have one triangle a quad, not a degenerate second
                indices += [a, b, a + 1]
            if i < rings - 1:
                indices += [a + 1, b, b + 1]
    return positions, normals, indices


def main():
    buffer, meshes, nodes, materials = Buffer(), [], [], []
    grey = {"name": "backdrop", "pbrMetallicRoughness": {"baseColorFactor": [0.4, 0.4, 0.4, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}, "doubleSided": True}
    materials.append(grey)
    h = 12.0
    floor = [(-h, -1.2, -5.0), (h, -1.2, -5.0), (h, -1.2, h), (-h, -1.2, h)]
    wall = [(-h, -1.2, -5.0), (-h, 8.0, -5.0), (h, 8.0, -5.0), (h, -1.2, -5.0)]
    meshes.append(buffer.mesh("floor", floor, [(0.0, 1.0, 0.0)] * 4, [0, 2, 1, 0, 3, 2], 0))
    meshes.append(buffer.mesh("back wall", wall, [(0.0, 0.0, 1.0)] * 4, [0, 2, 1, 0, 3, 2], 0))
    for i, (x, y, z, alpha) in enumerate(PLATES):
        materials.append({"name": f"plate alpha {alpha}", "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 1.0, "roughnessFactor": math.sqrt(alpha)},
            "doubleSided": True})
        meshes.append(buffer.mesh(f"plate {i + 1}", *plate_triangles((x, y, z)), len(materials) - 1))
    for i, (x, radius, colour) in enumerate(LAMPS):
        strength = LAMP_RADIANCE * (0.9 / radius) ** 2
        materials.append({"name": f"lamp r {radius}", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1.0],
                          "metallicFactor": 0.0, "roughnessFactor": 1.0}, "emissiveFactor": list(colour),
                          "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": strength},
                                         "KHR_materials_specular": {"specularFactor": 0.0}}, "doubleSided": False})
        centre = (LAMP_ROW[0] + x, LAMP_ROW[1], LAMP_ROW[2])
        meshes.append(buffer.mesh(f"lamp {i + 1}", *sphere(centre, radius), len(materials) - 1))
    nodes = [{"name": m["name"], "mesh": i} for i, m in enumerate(meshes)]
    nodes.append({"name": "camera", "camera": 0, "translation": list(EYE),
                  "rotation": look_at_quaternion(sub(TARGET, EYE), (0.0, 1.0, 0.0))})
    gltf = {
        "asset": {"version": "2.0", "generator": "scenes/make_veach_mis.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
        "scene": 0,
        "scenes": [{"name": "veach-mis", "nodes": list(range(len(nodes))), "extras": {
            "width": WIDTH, "height": HEIGHT,
            "description": "After Veach's MIS figure: four GGX plates (alpha 0.005 to 0.2) reflecting four "
                           "spherical lamps of equal power (radii 0.9 to 0.03)."}}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(YFOV_DEG),
                     "aspectRatio": WIDTH / HEIGHT, "znear": 0.01}}],
        "meshes": meshes,
        "materials": materials,
        **buffer.gltf_fields(),
    }
    with open(os.path.join(HERE, "veach-mis.gltf"), "w") as f:
        json.dump(gltf, f, indent=1)


if __name__ == "__main__":
    main()
