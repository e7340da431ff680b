import os
from typing import Any, Union

from ._caustica import CausticaError as CausticaError
from ._caustica import RenderResult as RenderResult
from ._caustica import Scene as Scene
from ._caustica import Session as Session
from ._caustica import compare as compare
from ._caustica import merge as merge
from ._caustica import read_exr as read_exr
from ._caustica import read_exr_channels as read_exr_channels
from ._caustica import write_image as write_image

def has_denoiser() -> bool:
    """Whether ``RenderResult.denoised()`` works here: a build with feature ``denoise``, or ``pyoidn``
    (a dependency of the package) importable."""

def load(path: Union[str, os.PathLike[str]], **overrides: Any) -> Scene:
    """Load a glTF (.gltf, .glb) or run file (.toml), with the run file's keys as overrides:
    ``spp=``, ``integrator=``, ``width=``, ``seed=``, ``light_selection=``, ``passes=``, ... or any
    key dotted (``**{"progressive.alpha": 0.7}``)."""

def from_dict(scene: dict[str, Any], **overrides: Any) -> Scene:
    """A scene described in Python: ``camera`` (eye, target, up, yfov_degrees), ``materials`` (name ->
    base_color, metallic, roughness, emission, specular, transmission, ior) and ``meshes`` (name,
    positions N x 3, indices M x 3, normals, material); the run file's keys as overrides."""
