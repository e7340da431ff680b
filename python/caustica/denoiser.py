"""Open Image Denoise for a package built without feature `denoise`: the `pyoidn` package (a
dependency of this one, from PyPI) carries OIDN 2.5's libraries and a numpy binding, so
`RenderResult.denoised()` works from a plain `pip install ./python`. The filter is the one the
native build runs (`film::denoise`): RT, HDR colour, albedo and normal as guides that it prefilters
itself (cleanAux off), the default high quality.
"""

from __future__ import annotations

import numpy as np

from ._caustica import CausticaError

INSTALL = "pip install pyoidn"


def available() -> bool:
    """Whether pyoidn imports and finds its libraries."""
    try:
        import pyoidn  # noqa: F401
    except (ImportError, OSError):
        return False
    return True


def denoise(color: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """`color` denoised with `albedo` and `normal` as guides (float32, height × width × 3 each)."""
    try:
        import pyoidn
    except (ImportError, OSError) as e:
        raise CausticaError(f"cannot denoise: Open Image Denoise is not installed ({e}); `{INSTALL}` gets it") from e
    as_rgb = lambda a: np.ascontiguousarray(a, dtype=np.float32)
    return pyoidn.denoise(as_rgb(color), as_rgb(albedo), as_rgb(normal), hdr=True, clean_aux=False, quality="high")
