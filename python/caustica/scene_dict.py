"""``caustica.from_dict``: a scene described in Python (numpy meshes, materials, a camera) for the
simulation tool that has no file. The dict becomes a glTF 2.0 document (buffers embedded) that the
ordinary loader reads, so a dict scene gets every check, warning and material rule a file gets.

    scene = caustica.from_dict({
        "camera": {"eye": [0, 0.273, 0.8], "target": [0, 0.273, 0], "yfov_degrees": 39.3},
        "materials": {"white": {"base_color": [0.8, 0.8, 0.8]},
                      "lamp": {"base_color": [0, 0, 0], "emission": [17, 12, 4]}},
        "meshes": [{"name": "floor", "positions": P, "indices": I, "material": "white"}, ...],
    }, spp=64, width=256, height=256)

Meshes: ``positions`` (N x 3), ``indices`` (M x 3, counter-clockwise front faces), optional
``normals`` (N x 3); ``material`` names an entry of ``materials``. Materials: ``base_color``,
``metallic`` (0), ``roughness`` (1), ``emission`` (radiance, 0), ``specular`` (glTF's specular
factor, 1), ``transmission`` (0), ``ior`` (1.5). Lights are emissive meshes; an environment or
punctual lights come from overrides of a run file's keys (``**{"environment.color": [1, 1, 1]}``).
"""

from __future__ import annotations

import base64
import json
import math
import os
import tempfile
from typing import Any

import numpy as np

_MATERIAL_KEYS = {"base_color", "metallic", "roughness", "emission", "specular", "transmission", "ior"}
_MESH_KEYS = {"name", "positions", "indices", "normals", "material"}


def _array(value: Any, what: str, dtype, columns: int) -> np.ndarray:
    # The shape first: an array of zero strides can claim billions of values it does not hold, and
    # anything done to each of them would make them.
    given = np.asarray(value)
    if given.ndim != 2 or given.shape[1] != columns or given.shape[0] == 0:
        raise ValueError(f"{what}: an array of shape (n, {columns}) with n >= 1, not {given.shape}")
    # A cast to integers truncates: 0.5 would be vertex 0, NaN any vertex at all.
    if dtype != np.float32 and given.dtype.kind not in "iu" and not (
        given.dtype.kind == "f" and np.isfinite(given).all() and (given == np.round(given)).all()
    ):
        raise ValueError(f"{what}: not whole numbers ({given.dtype})")
    array = np.ascontiguousarray(given, dtype=dtype)
    if dtype == np.float32 and not np.isfinite(array).all():
        raise ValueError(f"{what}: not every value is finite")
    return array


def _material(name: str, spec: dict) -> dict:
    unknown = set(spec) - _MATERIAL_KEYS
    if unknown:
        raise ValueError(f"material {name!r}: unknown keys {sorted(unknown)}; known: {sorted(_MATERIAL_KEYS)}")
    base = [float(c) for c in spec.get("base_color", [0.8, 0.8, 0.8])]
    if len(base) != 3 or not all(0.0 <= c <= 1.0 for c in base):
        raise ValueError(f"material {name!r}: base_color is three numbers in [0, 1], not {base}")
    material = {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": base + [1.0],
            "metallicFactor": float(spec.get("metallic", 0.0)),
            "roughnessFactor": float(spec.get("roughness", 1.0)),
        },
        "doubleSided": True,
    }
    extensions = {}
    emission = [float(c) for c in spec.get("emission", [0.0, 0.0, 0.0])]
    if len(emission) != 3 or not all(0.0 <= c < math.inf for c in emission):
        raise ValueError(f"material {name!r}: emission is three finite radiances, at least 0, not {emission}")
    strength = max(emission)
    if strength > 0.0:
        # glTF's emissive factor is at most 1: the rest is the emissive-strength extension.
        material["emissiveFactor"] = [c / strength for c in emission]
        if strength != 1.0:
            extensions["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
    if "specular" in spec:
        extensions["KHR_materials_specular"] = {"specularFactor": float(spec["specular"])}
    if "transmission" in spec:
        extensions["KHR_materials_transmission"] = {"transmissionFactor": float(spec["transmission"])}
    if "ior" in spec:
        extensions["KHR_materials_ior"] = {"ior": float(spec["ior"])}
    if extensions:
        material["extensions"] = extensions
    for key in ("metallic", "roughness", "specular", "transmission", "ior"):
        if key in spec and not math.isfinite(float(spec[key])):
            raise ValueError(f"material {name!r}: {key} is {spec[key]}, not a finite number")
    return material


def _look_at(eye, target, up) -> list:
    """The camera node's column-major matrix: looking down its -z from ``eye`` towards ``target``."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    if not all(v.shape == (3,) and np.isfinite(v).all() for v in (eye, target, up)):
        raise ValueError("camera: eye, target and up are three finite numbers each")
    back = eye - target
    if not np.linalg.norm(back) > 0:
        raise ValueError("camera: eye and target must differ")
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    if not np.linalg.norm(right) > 0:
        raise ValueError("camera: up must not be along the view direction")
    right /= np.linalg.norm(right)
    true_up = np.cross(back, right)
    return [*right, 0.0, *true_up, 0.0, *back, 0.0, *eye, 1.0]


def to_gltf(scene: dict) -> dict:
    """The glTF 2.0 document of a scene dict (see the module's documentation)."""
    unknown = set(scene) - {"camera", "materials", "meshes"}
    if unknown:
        raise ValueError(f"scene dict: unknown keys {sorted(unknown)}; known: camera, materials, meshes")
    materials = scene.get("materials", {})
    names = list(materials)
    gltf_materials = [_material(name, materials[name]) for name in names]
    blob, views, accessors, meshes, nodes = bytearray(), [], [], [], []

    def add(array: np.ndarray, component: int, kind: str, target: int, bounds: bool) -> int:
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": array.nbytes, "target": target})
        blob.extend(array.tobytes())
        accessor = {"bufferView": len(views) - 1, "componentType": component, "count": int(array.size // 3 if kind == "VEC3" else array.size), "type": kind}
        if bounds:
            accessor["min"] = array.min(axis=0).tolist()
            accessor["max"] = array.max(axis=0).tolist()
        accessors.append(accessor)
        return len(accessors) - 1

    for i, mesh in enumerate(scene.get("meshes", [])):
        name = str(mesh.get("name", f"mesh {i}"))
        unknown = set(mesh) - _MESH_KEYS
        if unknown:
            raise ValueError(f"mesh {name!r}: unknown keys {sorted(unknown)}; known: {sorted(_MESH_KEYS)}")
        positions = _array(mesh.get("positions"), f"mesh {name!r} positions", np.float32, 3)
        indices = _array(mesh.get("indices"), f"mesh {name!r} indices", np.int64, 3)
        if indices.min() < 0 or indices.max() >= len(positions):
            raise ValueError(f"mesh {name!r} indices: not all in 0..{len(positions) - 1}")
        attributes = {"POSITION": add(positions, 5126, "VEC3", 34962, True)}
        if mesh.get("normals") is not None:
            normals = _array(mesh["normals"], f"mesh {name!r} normals", np.float32, 3)
            if len(normals) != len(positions):
                raise ValueError(f"mesh {name!r}: {len(normals)} normals for {len(positions)} positions")
            attributes["NORMAL"] = add(normals, 5126, "VEC3", 34962, False)
        flat = indices.astype(np.uint32).reshape(-1)
        primitive = {"attributes": attributes, "indices": add(flat, 5125, "SCALAR", 34963, False), "mode": 4}
        if "material" in mesh:
            if mesh["material"] not in materials:
                raise ValueError(f"mesh {name!r}: no material named {mesh['material']!r} (known: {names})")
            primitive["material"] = names.index(mesh["material"])
        meshes.append({"name": name, "primitives": [primitive]})
        nodes.append({"name": name, "mesh": len(meshes) - 1})
    if not meshes:
        raise ValueError("scene dict: no meshes")
    gltf = {
        "asset": {"version": "2.0", "generator": "caustica.from_dict"},
        "scene": 0,
        "materials": gltf_materials,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{
            "byteLength": len(blob),
            "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode(),
        }],
    }
    used = sorted({e for m in gltf_materials for e in m.get("extensions", {})})
    if used:
        gltf["extensionsUsed"] = used
    camera = scene.get("camera")
    if camera is not None:
        unknown = set(camera) - {"eye", "target", "up", "yfov_degrees"}
        if unknown:
            raise ValueError(f"camera: unknown keys {sorted(unknown)}; known: eye, target, up, yfov_degrees")
        yfov = math.radians(float(camera.get("yfov_degrees", 39.3)))
        if not math.isfinite(yfov):
            raise ValueError(f"camera: yfov_degrees is {camera['yfov_degrees']}, not a finite number")
        gltf["cameras"] = [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.001}}]
        matrix = _look_at(camera["eye"], camera["target"], camera.get("up", [0.0, 1.0, 0.0]))
        nodes.append({"name": "camera", "camera": 0, "matrix": matrix})
    gltf["nodes"] = nodes
    gltf["scenes"] = [{"nodes": list(range(len(nodes)))}]
    return gltf


def from_dict(scene: dict, **overrides: Any):
    """A ``Scene`` from a dict (see the module's documentation), with the run file's keys as
    overrides, as ``caustica.load`` takes them."""
    from . import load

    # NaN or infinity would be written as JSON the loader cannot read, reported against a
    # temporary file: refused here, by Python, instead.
    document = json.dumps(to_gltf(scene), allow_nan=False)
    with tempfile.TemporaryDirectory(prefix="caustica-dict-") as folder:
        path = os.path.join(folder, "scene-from-dict.gltf")
        with open(path, "w") as f:
            f.write(document)
        return load(path, **overrides)
