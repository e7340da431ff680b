"""The Python package against the command line and itself: shapes, the same pixels, errors, the
GIL released while rendering, Ctrl-C, and a session's steps adding up to one render."""

import _thread
import base64
import json
import math
import os
import pathlib
import shutil
import subprocess
import threading
import sys
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


def test_a_guided_render_reports_its_training_in_the_stats():
    result = caustica.load(BOX, spp=8, seed=1, **SMALL, **{"guiding.enabled": True}).render()
    assert np.isfinite(result.color).all() and result.color.mean() > 0.01
    guiding = result.stats["notes"]["guiding"]
    assert guiding.startswith("1 training pass (1 spp)"), guiding
    assert "MiB of the" in guiding, guiding
    assert "guiding" not in caustica.load(BOX, spp=2, **SMALL).render().stats["notes"]


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


def test_every_registered_integrator_is_taken_by_name_and_no_other_is():
    assert len(set(caustica.INTEGRATORS)) == len(caustica.INTEGRATORS) and "pt" in caustica.INTEGRATORS
    for name in caustica.INTEGRATORS:
        assert caustica.load(BOX, integrator=name).integrator == name
    with pytest.raises(caustica.CausticaError, match="integrator"):
        caustica.load(BOX, integrator="not-" + caustica.INTEGRATORS[0])


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


def cornell_box_as_dict():
    """The Cornell box glTF's meshes, materials and camera, read with numpy, as a scene dict."""
    gltf = json.loads(BOX.read_text())
    blob = base64.b64decode(gltf["buffers"][0]["uri"].split(",", 1)[1])

    def accessor(i, dtype, columns):
        a, view = gltf["accessors"][i], gltf["bufferViews"][gltf["accessors"][i]["bufferView"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        return np.frombuffer(blob, dtype, a["count"] * columns, start).reshape(-1, columns)

    materials = {}
    for m in gltf["materials"]:
        pbr = m["pbrMetallicRoughness"]
        strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        materials[m["name"]] = {
            "base_color": pbr["baseColorFactor"][:3],
            "metallic": pbr["metallicFactor"],
            "roughness": pbr["roughnessFactor"],
            "emission": [c * strength for c in m.get("emissiveFactor", [0, 0, 0])],
            "specular": m["extensions"]["KHR_materials_specular"]["specularFactor"],
        }
    meshes = []
    for node in gltf["nodes"]:
        if "mesh" not in node:
            continue
        (primitive,) = gltf["meshes"][node["mesh"]]["primitives"]
        meshes.append({
            "name": node["name"],
            "positions": accessor(primitive["attributes"]["POSITION"], np.float32, 3),
            "normals": accessor(primitive["attributes"]["NORMAL"], np.float32, 3),
            "indices": accessor(primitive["indices"], np.uint32, 1).reshape(-1, 3),
            "material": gltf["materials"][primitive["material"]]["name"],
        })
    (camera_node,) = [n for n in gltf["nodes"] if "camera" in n]
    eye = camera_node["translation"]
    yfov = gltf["cameras"][0]["perspective"]["yfov"]
    camera = {"eye": eye, "target": [eye[0], eye[1], eye[2] - 1.0], "yfov_degrees": math.degrees(yfov)}
    return {"camera": camera, "materials": materials, "meshes": meshes}


def test_a_scene_from_a_dict_renders_the_bits_of_the_same_scene_from_gltf():
    settings = dict(spp=4, seed=3, width=40, height=40)
    from_gltf = caustica.load(BOX, **settings).render().color
    from_dict = caustica.from_dict(cornell_box_as_dict(), **settings).render().color
    assert np.array_equal(from_dict, from_gltf)


def test_a_bad_scene_dict_is_refused_naming_the_mesh_or_material():
    scene = cornell_box_as_dict()
    scene["meshes"][0]["indices"] = scene["meshes"][0]["indices"] + 100
    with pytest.raises(ValueError, match="mesh 'floor' indices"):
        caustica.from_dict(scene)
    scene = cornell_box_as_dict()
    scene["meshes"][1]["positions"] = scene["meshes"][1]["positions"] * np.nan
    with pytest.raises(ValueError, match="mesh 'ceiling' positions: not every value is finite"):
        caustica.from_dict(scene)
    scene = cornell_box_as_dict()
    scene["meshes"][2]["material"] = "chrome"
    with pytest.raises(ValueError, match="no material named 'chrome'"):
        caustica.from_dict(scene)
    scene = cornell_box_as_dict()
    scene["materials"]["white"]["colour"] = [1, 1, 1]
    with pytest.raises(ValueError, match="material 'white': unknown keys"):
        caustica.from_dict(scene)


def test_compare_gives_the_metrics_of_caustica_compare():
    scene = caustica.load(BOX, seed=4, **SMALL)
    noisy, reference = scene.render(spp=2).color, scene.render(spp=32).color
    e = caustica.compare(noisy, reference)
    a, b = noisy.astype(np.float64), reference.astype(np.float64)
    assert e["relmse"] == pytest.approx(np.mean((a - b) ** 2 / (b**2 + 0.01)), rel=1e-9)
    assert e["rmse"] == pytest.approx(np.sqrt(np.mean((a - b) ** 2)), rel=1e-9)
    assert e["mae"] == pytest.approx(np.mean(np.abs(a - b)), rel=1e-9)
    assert 0.0 < e["flip"] < 1.0
    assert caustica.compare(reference, reference) == {"rmse": 0.0, "relmse": 0.0, "mae": 0.0, "flip": 0.0}
    with pytest.raises(ValueError, match="32x24 against 24x32"):
        caustica.compare(noisy, np.ascontiguousarray(noisy.transpose(1, 0, 2)))


def test_adaptive_sampling_sends_samples_where_the_noise_is():
    result = caustica.load(SPHERES, spp=64, seed=3, noise_threshold=0.05, min_spp=8, **SMALL).render(aovs=("spp",))
    spp = result.aovs["spp"]
    assert spp.shape == (24, 32) and spp.min() == 8 and spp.max() == 64
    assert result.stats["samples"] == int(spp.sum())
    assert 0 < result.stats["pixels_converged"] < 24 * 32 and result.stats["estimated_relmse"] > 0


def test_feature_images_are_float32_arrays_of_the_image_size():
    result = caustica.load(BOX, spp=2, **SMALL).render()
    aovs = result.aovs
    assert sorted(aovs) == ["albedo", "depth", "normal", "spp"]
    assert aovs["albedo"].shape == aovs["normal"].shape == (24, 32, 3)
    assert aovs["depth"].shape == aovs["spp"].shape == (24, 32)
    assert (aovs["spp"] == 2).all(), "without a noise threshold every pixel takes every sample"
    assert all(a.dtype == np.float32 for a in aovs.values())
    assert ((aovs["albedo"] >= 0) & (aovs["albedo"] <= 1)).all()
    assert (np.linalg.norm(aovs["normal"], axis=2) <= 1 + 1e-5).all()
    assert (aovs["depth"] >= 0).all()
    assert (aovs["depth"][8:16, 12:20] > 0).all(), "the middle of the frame sees the box"
    assert caustica.load(BOX, spp=1, **SMALL).render(aovs=()).aovs == {}
    with pytest.raises(ValueError, match="shadows"):
        caustica.load(BOX, spp=1, **SMALL).render(aovs=("shadows",))


def test_feature_images_are_the_command_lines_layers(tmp_path):
    out = tmp_path / "cli.exr"
    subprocess.run(
        [cli_binary(), "render", str(SPHERES), "--spp", "3", "--seed", "5", "--width", "32", "--height", "24",
         "--aov", "albedo,normal,depth", "--quiet", "-o", str(out)],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    layers = caustica.read_exr_channels(out)
    aovs = caustica.load(SPHERES, spp=3, seed=5, **SMALL).render().aovs
    assert np.array_equal(np.stack([layers[f"albedo.{c}"] for c in "RGB"], axis=2), aovs["albedo"])
    assert np.array_equal(np.stack([layers[f"N.{c}"] for c in "XYZ"], axis=2), aovs["normal"])
    assert np.array_equal(layers["Z"], aovs["depth"])


def test_render_and_session_take_run_file_overrides():
    scene = caustica.load(BOX, spp=2, **SMALL)
    session = scene.session(integrator="sppm", photons_per_pass=2000, aovs=("depth",))
    assert session.unit == "passes"
    session.step(2)
    assert session.done == 2
    assert sorted(session.aovs()) == ["depth"]
    assert session.aovs()["depth"].shape == (24, 32)
    assert scene.integrator == "pt", "the scene's own settings stay as loaded"
    result = scene.render(seed=9, aovs=())
    assert result.stats["seed"] == 9
    with pytest.raises(ValueError, match="load"):
        scene.render(**{"camera.name": "other"})


def test_denoised_is_closer_to_the_reference_or_says_how_to_get_a_denoiser():
    result = caustica.load(ROOT / "tests" / "data" / "cornell-box.gltf", spp=4, seed=2).render()
    if not caustica.has_denoiser():
        with pytest.raises(caustica.CausticaError, match="pip install pyoidn"):
            result.denoised()
        return
    clean = result.denoised()
    assert clean.shape == result.color.shape and clean.dtype == np.float32
    reference = caustica.read_exr(ROOT / "tests" / "data" / "cornell-box.ref.exr")
    raw, denoised = caustica.compare(result.color, reference), caustica.compare(clean, reference)
    assert denoised["relmse"] <= raw["relmse"] / 3, (raw, denoised)
    assert denoised["flip"] < raw["flip"], (raw, denoised)
    without_guides = caustica.load(BOX, spp=1, **SMALL).render(aovs=("depth",))
    with pytest.raises(caustica.CausticaError, match="albedo"):
        without_guides.denoised()


def test_pyoidn_denoises_as_the_native_build_does():
    """A plain `pip install` denoises through pyoidn (caustica.denoiser); a build with feature
    `denoise` runs the same filter on the same OIDN libraries (CI links pyoidn's): the same bits."""
    from caustica import denoiser, _caustica

    if not denoiser.available():
        pytest.skip("pyoidn is not installed")
    result = caustica.load(BOX, spp=2, **SMALL).render()
    through_pyoidn = denoiser.denoise(result.color, result.aovs["albedo"], result.aovs["normal"])
    assert through_pyoidn.shape == result.color.shape and through_pyoidn.dtype == np.float32
    assert np.isfinite(through_pyoidn).all()
    noisy = caustica.compare(result.color, through_pyoidn)["rmse"]
    assert noisy > 0, "the filter changed nothing"
    if _caustica.has_denoiser():
        native = result.denoised()
        assert np.array_equal(native, through_pyoidn), np.abs(native - through_pyoidn).max()


def test_the_command_line_without_the_feature_denoises_through_pyoidn(tmp_path):
    """`caustica render --denoise` from a build without feature `denoise` (CAUSTICA_PLAIN_BIN, which
    .ci/run keeps aside) runs pyoidn through this interpreter: the same bits as the command line that
    links OIDN (CAUSTICA_BIN), or as pyoidn run by hand where that one has no denoiser either."""
    from caustica import denoiser

    plain = os.environ.get("CAUSTICA_PLAIN_BIN")
    if plain is None or not denoiser.available():
        pytest.skip("needs CAUSTICA_PLAIN_BIN (a build without feature denoise) and pyoidn")
    env = dict(os.environ, CAUSTICA_PYTHON=sys.executable)
    images = []
    for name, binary in (("plain", plain), ("native", cli_binary())):
        out = tmp_path / f"{name}.exr"
        done = subprocess.run([binary, "render", str(BOX), "--spp", "2", "--width", "32", "--height", "24",
                               "--seed", "3", "--denoise", "-q", "-o", str(out)], env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        images.append(caustica.read_exr(tmp_path / f"{name}-denoised.exr"))
    assert images[0].shape == (24, 32, 3) and np.isfinite(images[0]).all()
    assert np.array_equal(images[0], images[1]), np.abs(images[0] - images[1]).max()


def test_advance_poses_the_files_animation_and_starts_the_image_over():
    session = caustica.load(ROOT / "tests/data/gltf-samples/AnimatedTriangle.gltf", width=16, height=16,
                            spp=2).session(aovs=())
    assert session.duration == pytest.approx(1.0)
    session.step()
    first = session.image().copy()
    update = session.advance(0.25)
    assert session.done == 0
    assert not update["whole_build"] and update["bvh"] >= 0.0
    session.step()
    assert not np.array_equal(first, session.image()), "the quarter turn changed nothing"
    with pytest.raises(ValueError, match="finite"):
        session.advance(float("nan"))


def test_set_camera_moves_the_view_and_refuses_a_degenerate_one():
    session = caustica.load(ROOT / "scenes/cornell-box.gltf", width=16, height=16, spp=1).session(aovs=())
    session.step()
    before = session.image().copy()
    session.set_camera(eye=(0.0, 0.27, 0.5), target=(0.0, 0.27, 0.0), yfov_degrees=60.0)
    assert session.done == 0
    session.step()
    assert not np.array_equal(before, session.image())
    with pytest.raises(ValueError, match="eye"):
        session.set_camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, 0.0))
    # An eye so far away that the distance's square overflows is refused as such, not as a bad up.
    with pytest.raises(ValueError, match="whose square is finite"):
        session.set_camera(eye=(1e30, 0.0, 1.0), target=(0.0, 0.0, 0.0))
    # The field of view is in degrees here, and the message says so.
    for yfov in (0.0, 180.0, float("nan")):
        with pytest.raises(ValueError, match=r"yfov_degrees must be in \(0, 180\)"):
            session.set_camera(eye=(0.0, 0.27, 0.5), target=(0.0, 0.27, 0.0), yfov_degrees=yfov)
    assert session.done == 1, "a refused camera changes nothing"


def test_the_bouncing_block_example_writes_denoised_frames_of_a_moving_block(tmp_path):
    script = ROOT / "examples/bouncing_block.py"
    done = subprocess.run([sys.executable, str(script), "3"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stdout.splitlines() if line.startswith("frame")]
    assert len(lines) == 3 and all("BVH" in line and "denoise" in line for line in lines), done.stdout
    frames = sorted((tmp_path / "out/bouncing").glob("frame-*.png"))
    assert [f.name for f in frames] == ["frame-0000.png", "frame-0001.png", "frame-0002.png"]
    assert frames[0].read_bytes() != frames[2].read_bytes(), "the block did not move"


def test_the_readme_quick_start_runs_and_says_what_it_made(tmp_path):
    """The README's Python quick start, as a new user pastes it (from the repository's root, the
    paths as written): it runs, prints what it rendered and writes the image it names."""
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Python"):]
    start = section.index("```python\n") + len("```python\n")
    block = section[start:section.index("```", start)]
    # The scenes are named from the repository's root, the image lands in the test's folder.
    block = block.replace('"scenes/', f'"{ROOT / "scenes"}/').replace('"cornell.png"', f'"{tmp_path / "cornell.png"}"')
    if not caustica.has_denoiser():
        block = block.replace("clean = result.denoised()", "clean = result.color")
    script = tmp_path / "quick_start.py"
    script.write_text(block)
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "samples in" in run.stdout and "cornell.png" in run.stdout, run.stdout
    assert "sppm: 64 of 64 passes" in run.stdout, run.stdout
    assert (tmp_path / "cornell.png").stat().st_size > 0
