"""Type stubs of the compiled module (see ``caustica/__init__.py`` for the API's overview)."""

import os
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

class CausticaError(Exception):
    """A scene, setting or file Caustica refused: the message names the file, the object and the problem."""

class RenderResult:
    """A finished (or stopped) render."""

    @property
    def color(self) -> npt.NDArray[np.float32]:
        """Linear RGB, float32, height x width x 3."""
    @property
    def aovs(self) -> dict[str, npt.NDArray[np.float32]]:
        """The feature images asked for, at each sample's first non-specular surface (through
        perfect mirrors and glass), averaged like colour: ``albedo`` and ``normal`` (world space,
        facing the camera) height x width x 3, ``depth`` (from the image plane along the view
        axis, 0 where the sample left the scene) height x width."""
    def denoised(self) -> npt.NDArray[np.float32]:
        """``color`` denoised by Intel Open Image Denoise, guided by the albedo and normal images
        (the render must have made both): natively in a package built with feature ``denoise``,
        otherwise through ``pyoidn`` (a dependency of the package; ``caustica.denoiser``), the same
        filter. Without either it raises ``CausticaError`` saying how to get one."""
    @property
    def stats(self) -> dict[str, Any]:
        """integrator, unit ("spp" or "passes"), done, target, seed, seconds, samples, rays,
        shadow_rays, nan_samples, stopped_by (None, "interrupted" or "timelimit"), and notes: the
        integrator's own lines of the command's summary by label (``notes["guiding"]``: path
        guiding's training passes, tree and memory)."""

class Session:
    """A render a host advances a few units at a time. One call at a time: a call from a second
    thread waits (the GIL released) until the first has returned."""

    def step(self, units: Optional[int] = None) -> dict[str, Any]:
        """Add ``units`` samples per pixel (or passes, for the progressive photon mappers), with
        the GIL released; without an argument, run to the settings' target. Returns the stats."""
    def set_transform(self, node: str, matrix: npt.ArrayLike) -> dict[str, float | bool]:
        """Move glTF node ``node`` (its name, or its index as a string) by the 4 x 4 row-major
        ``matrix``, applied to its geometry as posed (the identity puts it back); once a node has
        moved, only the moving meshes' BVH is rebuilt; the image starts over (``done`` is 0).
        Returns the seconds spent: ``pose``, ``bvh``, ``lights``."""
    def advance(self, time: float) -> dict[str, float | bool]:
        """Pose the file's glTF animations at ``time`` seconds (meshes, camera, lights) and start
        the image over; ``pm`` keeps its photon maps when only the camera moved
        (``photons_kept``). Returns the seconds spent: ``pose``, ``bvh``, ``lights``."""
    def set_camera(
        self,
        eye: Sequence[float],
        target: Sequence[float],
        up: Sequence[float] = (0.0, 1.0, 0.0),
        yfov_degrees: float | None = None,
    ) -> None:
        """Place the camera at ``eye`` looking at ``target``; the image starts over."""
    @property
    def duration(self) -> float:
        """The file's animation length in seconds (0 without one)."""
    def image(self) -> npt.NDArray[np.float32]:
        """The image so far: linear RGB, float32, height x width x 3."""
    def aovs(self) -> dict[str, npt.NDArray[np.float32]]:
        """The feature images so far, as ``RenderResult.aovs``."""
    @property
    def done(self) -> int:
        """Units done: samples per pixel, or passes."""
    @property
    def unit(self) -> str:
        """What the session counts: "spp" or "passes"."""

class Scene:
    """A scene and its settings; every render builds its own renderer from them."""

    @property
    def path(self) -> str: ...
    @property
    def integrator(self) -> str: ...
    def render(
        self,
        spp: Optional[int] = None,
        passes: Optional[int] = None,
        time_limit: Optional[float] = None,
        aovs: Sequence[str] = ("albedo", "normal", "depth"),
        **overrides: Any,
    ) -> RenderResult:
        """Render to the settings' target, or to ``spp`` samples per pixel (path tracers, ``pm``) or
        ``passes`` (the progressive photon mappers), or until ``time_limit`` seconds, with the
        feature images ``aovs`` (``()`` for none) and the run file's keys as ``overrides``
        (``integrator="sppm"``, as in ``load``; not ``camera.name`` or ``environment.*``, which
        change what is loaded)."""
    def splits(self) -> bool:
        """Whether these settings split into parts that merge exactly: pt, pt-naive, pm, lt and pppm,
        unless light selection is visibility-aware."""
    def render_part(
        self,
        part: int,
        parts: int,
        path: Union[str, os.PathLike[str]],
        spp: Optional[int] = None,
        passes: Optional[int] = None,
    ) -> dict[str, Any]:
        """Render share ``part`` (from 1) of ``parts`` and write its accumulator (.exr) to ``path``;
        ``merge`` of every part gives the bits of one render. Returns the stats."""
    def session(self, aovs: Sequence[str] = ("albedo", "normal", "depth"), **overrides: Any) -> Session:
        """A render to step: ``s = scene.session(integrator="sppm"); s.step(8); s.image()``, with
        the feature images ``aovs`` and the run file's keys as ``overrides``, as ``render``."""

def load(path: Union[str, os.PathLike[str]], sets: list[str] = ...) -> Scene: ...
def merge(paths: list[Union[str, os.PathLike[str]]]) -> tuple[npt.NDArray[np.float32], dict[str, Any]]:
    """Merge a split render's accumulators: the image and {integrator, parts, units}. Refused,
    naming the files, when a part is missing, repeated, of another render or incomplete."""
def write_image(path: Union[str, os.PathLike[str]], color: npt.NDArray[np.float32], exposure: float = 0.0) -> None:
    """Write a linear float32 height x width x 3 image as .exr or .png (tone-mapped as the CLI's PNGs)."""
def compare(image: npt.NDArray[np.float32], reference: npt.NDArray[np.float32]) -> dict[str, float]:
    """rmse, relmse, mae (linear RGB) and flip (mean LDR-FLIP after the PNG tone map), as
    ``caustica compare`` prints them."""
INTEGRATORS: list[str]
"""Every integrator's name, as ``integrator=`` and ``--integrator`` take it (the registry's order)."""

def short_keys() -> list[tuple[str, str]]:
    """The run-file keys an override may give without its table, with their tables."""
def has_denoiser() -> bool:
    """Whether this build has the native denoiser (feature ``denoise``); ``caustica.has_denoiser()``
    also counts ``pyoidn``."""
def read_exr_channels(path: Union[str, os.PathLike[str]]) -> dict[str, npt.NDArray[np.float32]]:
    """Every channel of an OpenEXR file by name (``R``, ``albedo.R``, ``N.X``, ``Z``, ...), each
    float32 height x width: the command line's ``--aov`` layers."""
def read_exr(path: Union[str, os.PathLike[str]]) -> npt.NDArray[np.float32]:
    """Read an OpenEXR image (a reference, or the command line's output) as float32, height x width x 3."""
