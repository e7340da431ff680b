"""The Python package against the command line and itself: shapes, the same pixels, errors, the
GIL released while rendering, Ctrl-C, and a session's steps adding up to one render."""

import _thread
import json
import os
import pathlib
import shutil
import subprocess
import threading
import time

import numpy as np
import pytest

import caustica

ROOT = pathlib.Path(__file__).resolve().parents[2]
BOX = ROOT / "scenes" / "cornell-box.gltf"
SPHERES = ROOT / "scenes" / "cornell-spheres.gltf"
SMALL = dict(width=32, height=24)


def cli_binary():
    """The command line built by `cargo test` or `cargo build` (CAUSTICA_BIN overrides)."""
    if "CAUSTICA_BIN" in os.environ:
        return os.environ["CAUSTICA_BIN"]
    for profile in ("release", "debug"):
        candidate = ROOT / "target" / profile / "caustica"
        if candidate.exists():
            return str(candidate)
    pytest.skip("no caustica binary: run `cargo build --release` first")


def test_a_render_is_a_float32_image_of_the_asked_size_with_its_stats():
    result = caustica.load(BOX, spp=4, seed=3, **SMALL).render()
    assert result.color.shape == (24, 32, 3)
    assert result.color.dtype == np.float32
    assert np.isfinite(result.color).all()
    assert result.color.mean() > 0.01, "the box is lit"
    stats = result.stats
    assert stats["samples"] == 32 * 24 * 4
    assert stats["done"] == 4 and stats["unit"] == "spp" and stats["integrator"] == "pt"
    assert stats["nan_samples"] == 0 and stats["stopped_by"] is None


@pytest.mark.parametrize("integrator, flag", [("pt", "--spp"), ("sppm", "--passes")])
def test_the_same_pixels_as_the_command_line(tmp_path, integrator, flag):
    count = 4
    out = tmp_path / "cli.exr"
    subprocess.run(
        [cli_binary(), "render", str(SPHERES), "--integrator", integrator, flag, str(count), "--seed", "7",
         "--width", "32", "--height", "24", "--photons-per-pass", "5000", "--quiet", "-o", str(out)],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    overrides = dict(integrator=integrator, seed=7, photons_per_pass=5000, **SMALL)
    overrides["spp" if flag == "--spp" else "passes"] = count
    python = caustica.load(SPHERES, **overrides).render().color
    assert np.array_equal(python, caustica.read_exr(out)), "the Python render differs from the CLI's"


def test_session_steps_add_up_to_one_render():
    scene = caustica.load(BOX, spp=6, seed=11, **SMALL)
    session = scene.session()
    assert session.unit == "spp" and session.done == 0
    session.step(2)
    first = session.image()
    session.step(3)
    assert session.done == 5
    stats = session.step()  # to the settings' target
    assert session.done == 6 and stats["done"] == 6
    assert not np.array_equal(first, session.image())
    assert np.array_equal(session.image(), scene.render().color), "2 + 3 + 1 spp is not one 6-spp render"


def test_a_progressive_session_counts_passes():
    scene = caustica.load(SPHERES, integrator="sppm", passes=3, photons_per_pass=2000, **SMALL)
    session = scene.session()
    assert session.unit == "passes"
    session.step(1)
    session.step(2)
    assert np.array_equal(session.image(), scene.render().color)
    with pytest.raises(ValueError, match="passes"):
        scene.render(spp=4)


def test_refused_input_raises_caustica_error_naming_the_file_and_the_problem(tmp_path):
    with pytest.raises(caustica.CausticaError, match="missing.gltf"):
        caustica.load(tmp_path / "missing.gltf")
    with pytest.raises(caustica.CausticaError, match="no_such_key"):
        caustica.load(BOX, **{"render.no_such_key": 1})
    with pytest.raises(caustica.CausticaError, match="spp"):
        caustica.load(BOX, spp=-1)
    broken = tmp_path / "broken.gltf"
    broken.write_text('{"asset": {"version": "2.0"}, "meshes": [')
    with pytest.raises(caustica.CausticaError, match="broken.gltf"):
        caustica.load(broken)
    with pytest.raises(TypeError, match="eye"):
        caustica.load(BOX, eye={"x": 1})


def test_a_threaded_host_keeps_running_while_a_render_is_in_progress():
    scene = caustica.load(BOX, spp=64, width=96, height=72)
    done = threading.Event()
    ticks_during = 0

    def render():
        scene.render()
        done.set()

    worker = threading.Thread(target=render)
    worker.start()
    while not done.is_set():
        ticks_during += 1  # needs the GIL: only runs if the render released it
        time.sleep(0.001)
    worker.join()
    assert ticks_during > 20, f"the host ran {ticks_during} times during the render"


def test_ctrl_c_stops_a_render_and_the_session_goes_on():
    session = caustica.load(BOX, spp=100000, width=64, height=48).session()
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        session.step()
    assert time.monotonic() - start < 30
    stopped_at = session.done
    assert stopped_at < 100000
    session.step(1)
    assert session.done == stopped_at + 1, "the session goes on after an interrupt"
    assert np.isfinite(session.image()).all()


def test_a_moved_object_changes_the_image_and_the_identity_puts_it_back(tmp_path):
    session = caustica.load(BOX, spp=4, seed=1, width=48, height=48).session()
    session.step()
    before = session.image()
    shift = np.eye(4)
    shift[0, 3] = 0.12  # 12 cm along +x, row-major: the translation is the last column
    session.set_transform("short_block", shift)
    assert session.done == 0, "moving an object starts the image over"
    session.step()
    assert not np.array_equal(session.image(), before)
    # The same scene written as a glTF whose node carries the translation renders the same bits.
    gltf = json.loads(BOX.read_text())
    (node,) = [n for n in gltf["nodes"] if n.get("name") == "short_block"]
    node["translation"] = [0.12, 0.0, 0.0]
    moved_file = tmp_path / "moved.gltf"
    moved_file.write_text(json.dumps(gltf))
    expected = caustica.load(moved_file, spp=4, seed=1, width=48, height=48).render().color
    assert np.array_equal(session.image(), expected), "not the scene with the block moved"
    session.set_transform("short_block", np.eye(4))
    session.step()
    assert np.array_equal(session.image(), before), "the identity does not restore the loaded scene"
    with pytest.raises(caustica.CausticaError, match="no_such_node"):
        session.set_transform("no_such_node", np.eye(4))
    with pytest.raises(ValueError, match="invertible"):
        session.set_transform("short_block", np.zeros((4, 4)))
