"""Caustica from Python: load a glTF or run file, render it to numpy arrays, or step a
progressive render between the steps of your own simulation.

    import caustica
    scene = caustica.load("scenes/cornell-box.gltf", spp=64, width=256, height=256)
    result = scene.render()
    result.color          # float32, height x width x 3, linear RGB
    result.aovs["depth"]  # float32, height x width (also "albedo" and "normal", height x width x 3)
    result.stats          # samples, rays, seconds, NaN count, ...

    session = scene.session(integrator="sppm", aovs=())   # any run-file key, as in load()
    session.step(8)
    frame = session.image()

Rendering releases the GIL, so other Python threads keep running; a session takes one call at a
time (another thread's call waits for it). Ctrl-C stops a render at its next step and raises
KeyboardInterrupt. Refused input raises ``CausticaError`` with the message the
command line prints (the file, the object, the problem).
"""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any, Union

from ._caustica import (
    INTEGRATORS, CausticaError, RenderResult, Scene, Session, compare, merge, read_exr, read_exr_channels,
    write_image,
)
from ._caustica import has_denoiser as _native_denoiser
from ._caustica import load as _load
from ._caustica import short_keys as _short_keys

__all__ = [
    "INTEGRATORS", "CausticaError", "RenderResult", "Scene", "Session", "compare", "from_dict", "has_denoiser", "load", "merge",
    "read_exr", "read_exr_channels", "write_image",
]

# The run-file section of each short keyword (`spp=` is `render.spp`): the core's list, which
# `--set spp=16` and `-D spp=16` take too; any other key is given dotted, as in the run file:
# `caustica.load(path, **{"environment.strength": 2.0})`.
_SECTION = dict(_short_keys())


def has_denoiser() -> bool:
    """Whether `RenderResult.denoised()` works here: a build with feature `denoise`, or the `pyoidn`
    package (a dependency of this one) importable."""
    from . import denoiser

    return _native_denoiser() or denoiser.available()


_KEY = re.compile(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*")

# Far more than any run-file list (a colour, a point, a shutter interval) holds.
_MOST_VALUES = 1 << 16


def _toml(value: Any, key: str) -> str:
    """A Python value as a TOML value, for a run-file assignment."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{key} = {value}: must be finite")
        return repr(value)
    if isinstance(value, (str, os.PathLike)):
        return json.dumps(os.fspath(value))  # a TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v, key) for v in value) + "]"
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        # An array may claim a size it does not hold (zero strides): its list would never end.
        if getattr(value, "size", 1) > _MOST_VALUES:
            raise ValueError(f"{key}: an array of {value.size} values; a run-file value has at most {_MOST_VALUES}")
        return _toml(value.tolist(), key)
    raise TypeError(f"{key} = {value!r}: a run-file value is a bool, number, string or list")


def _override_sets(overrides: dict[str, Any]) -> list[str]:
    """Keyword overrides as run-file assignments (``spp=16`` is ``render.spp=16``); also what
    ``Scene.render(**overrides)`` and ``Scene.session(**overrides)`` use."""
    sets = []
    for key, value in overrides.items():
        # The assignment is text the core splits at its first "=": a key holding "=" or a newline
        # would set another key than the one named (`**{"film.width = 9\nx": 0}` set width 9).
        if not _KEY.fullmatch(key):
            shown = key if len(key) <= 40 else key[:40] + "..."
            raise ValueError(f"{shown!r}: a run-file key is names (letters, digits, _ and -) joined by dots")
        # An unknown key without a table goes as it is: the core's error lists the keys it knows.
        dotted = f"{_SECTION[key]}.{key}" if key in _SECTION else key
        sets.append(f"{dotted}={_toml(value, key)}")
    return sets


def load(path: Union[str, os.PathLike], **overrides: Any) -> Scene:
    """Load a glTF (.gltf, .glb) or run file (.toml), with the run file's keys as overrides:
    ``spp=``, ``integrator=``, ``width=``, ``seed=``, ``light_selection=``, ``passes=``, ... or any
    key dotted (``**{"progressive.alpha": 0.7}``)."""
    return _load(os.fspath(path), _override_sets(overrides))


from .scene_dict import from_dict  # noqa: E402  (it needs `load` above)
