"""A simulation host's frame loop: a small rigid-body step in numpy drops the Cornell box's short
block onto the floor, where it bounces and comes to rest; each frame moves the block
(`Session.set_transform`: only the moving block's BVH is rebuilt), renders 4 samples per pixel,
denoises them with Open Image Denoise (pyoidn, installed with the package) and writes
out/bouncing/frame-NNNN.png, printing where the frame's time went.

    pip install ./python
    python examples/bouncing_block.py [FRAMES]
"""

import os
import sys
import time

import numpy as np

import caustica
from caustica import denoiser

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "..", "scenes", "cornell-box.gltf")
OUT = os.path.join("out", "bouncing")
FPS = 24.0
GRAVITY = np.array([0.0, -9.81, 0.0])
RESTITUTION = 0.55


class Block:
    """A falling block: its lift above where the file rests it, its velocity, and a spin about y."""

    def __init__(self) -> None:
        self.position = np.array([0.0, 0.35, 0.0])
        self.velocity = np.array([0.4, 0.0, -0.2])
        self.angle, self.spin = 0.0, 2.5

    def step(self, dt: float) -> None:
        # Semi-implicit Euler with a bounce off the floor (the lift is 0 where the file rests it).
        self.velocity += GRAVITY * dt
        self.position += self.velocity * dt
        if self.position[1] < 0.0:
            self.position[1] = -self.position[1] * RESTITUTION
            self.velocity[1] = -self.velocity[1] * RESTITUTION
            self.velocity[[0, 2]] *= 0.8
            self.spin *= 0.7
        self.angle += self.spin * dt

    def matrix(self) -> np.ndarray:
        """The 4 x 4 row-major move of the block from where the file places it."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        m = np.eye(4)
        m[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
        m[:3, 3] = self.position
        return m


def main() -> None:
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 48
    os.makedirs(OUT, exist_ok=True)
    session = caustica.load(SCENE, width=256, height=256).session(aovs=("albedo", "normal"))
    can_denoise = denoiser.available()
    if not can_denoise:
        print("pyoidn is not installed: the frames are written as rendered (pip install pyoidn)")
    block = Block()
    for frame in range(frames):
        start = time.perf_counter()
        block.step(1.0 / FPS)
        simulate = time.perf_counter() - start
        update = session.set_transform("short_block", block.matrix())
        start = time.perf_counter()
        session.step(4)
        render = time.perf_counter() - start
        start = time.perf_counter()
        image = session.image()
        if can_denoise:
            aovs = session.aovs()
            image = denoiser.denoise(image, aovs["albedo"], aovs["normal"])
        denoise = time.perf_counter() - start
        start = time.perf_counter()
        caustica.write_image(os.path.join(OUT, f"frame-{frame:04d}.png"), image)
        write = time.perf_counter() - start
        print(
            f"frame {frame:3d}: simulate {1e3 * simulate:.2f} ms, pose {1e3 * update['pose']:.2f} ms, "
            f"BVH {1e3 * update['bvh']:.2f} ms, lights {1e3 * update['lights']:.2f} ms, "
            f"render {1e3 * render:.0f} ms, denoise {1e3 * denoise:.0f} ms, write {1e3 * write:.1f} ms"
        )
    print(f"wrote {frames} frames to {OUT}/")


if __name__ == "__main__":
    main()
