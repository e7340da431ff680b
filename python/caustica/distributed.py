"""A render split across the cores of a Ray cluster, merged into the bits of one run.

    import caustica.distributed
    result = caustica.distributed.render("scenes/cornell-spheres.toml", spp=1024, parts=16)
    result.color      # float32, height x width x 3: bit for bit what one process renders

Each of the ``parts`` shares of the samples (``pt``, ``pt-naive``, ``pm``, ``lt``) or passes (``pppm``) is a
Ray task that renders its accumulator (the file of ``caustica render --part``); the driver gathers
them, one per part whatever Ray retried, and merges them exactly. ``address=None`` starts (or joins)
a local Ray; a cluster's address (``ray://head:10001``, or ``auto`` on a node of one) spreads the
parts over its machines, each of which needs the package installed and the scene at the same path.
"""

from __future__ import annotations

import os
import sys
import tempfile
from dataclasses import dataclass
from typing import Any, Optional, Union

import numpy as np

from . import load, merge, write_image

__all__ = ["DistributedResult", "render"]

# A test hook: a worker that finds this variable naming a file that does not exist yet creates it
# and dies, as a machine lost mid-task would; Ray must then run the part again.
_CRASH_ONCE = "CAUSTICA_TEST_CRASH_ONCE"


@dataclass
class DistributedResult:
    """The merged image and what it is."""

    color: np.ndarray
    """Linear RGB, float32, height x width x 3."""
    info: dict
    """integrator, parts, units (samples per pixel or passes)."""


def _render_part(path: str, part: int, parts: int, spp, passes, overrides: dict) -> bytes:
    """One Ray task: share ``part`` of ``parts``, as the bytes of its accumulator file."""
    marker = os.environ.get(_CRASH_ONCE)
    if marker and part == 1 and not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    scene = load(path, **overrides)
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, f"part-{part}.exr")
        scene.render_part(part, parts, out, spp=spp, passes=passes)
        with open(out, "rb") as f:
            return f.read()


class _Progress:
    """Finished parts, on tqdm's bar when it is installed, else a line on stderr."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.done, self.bar = total, 0, None
        self.enabled = enabled
        if enabled:
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit="part", desc="caustica")
            except ImportError:
                pass

    def advance(self):
        self.done += 1
        if self.bar is not None:
            self.bar.update(1)
        elif self.enabled:
            print(f"\rcaustica: {self.done}/{self.total} parts", end="", file=sys.stderr, flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()
        elif self.enabled:
            print(file=sys.stderr)


def render(
    path: Union[str, os.PathLike],
    *,
    parts: int,
    spp: Optional[int] = None,
    passes: Optional[int] = None,
    address: Optional[str] = None,
    output: Union[str, os.PathLike, None] = None,
    progress: bool = True,
    max_retries: int = 3,
    **overrides: Any,
) -> DistributedResult:
    """Render ``path`` as ``parts`` Ray tasks and merge them: the same bits as
    ``caustica.load(path, **overrides).render(spp=..., passes=...)``. A task whose worker dies is
    run again by Ray (``max_retries``); a part is counted once. ``output`` (.exr or .png) is
    written too. Refused scenes and settings raise ``CausticaError`` before any task starts."""
    import ray

    if parts < 1:
        raise ValueError(f"parts = {parts}: must be at least 1")
    path = os.path.abspath(os.fspath(path))
    # Check here, where the user sees the error, that the scene loads and splits this many ways.
    scene = load(path, **overrides)
    if not scene.splits():
        raise ValueError(
            f"{path}: {scene.integrator} (or visibility-aware light selection) does not split into parts;"
            " pt, pt-naive, pm, lt and pppm do"
        )
    if not ray.is_initialized():
        ray.init(address=address)
    # Only a lost worker is retried: a refused scene fails the same way every time.
    task = ray.remote(max_retries=max_retries, retry_exceptions=False)(_render_part)
    refs = {task.remote(path, i, parts, spp, passes, overrides): i for i in range(1, parts + 1)}
    accumulators: dict[int, bytes] = {}
    bar = _Progress(parts, progress)
    try:
        pending = list(refs)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for ref in ready:
                part = refs[ref]
                data = ray.get(ref)
                if part not in accumulators:
                    accumulators[part] = data
                    bar.advance()
    finally:
        bar.close()
    with tempfile.TemporaryDirectory() as folder:
        files = []
        for part, data in sorted(accumulators.items()):
            files.append(os.path.join(folder, f"part-{part}.exr"))
            with open(files[-1], "wb") as f:
                f.write(data)
        color, info = merge(files)
    if output is not None:
        write_image(output, color)
    return DistributedResult(color=color, info=info)
