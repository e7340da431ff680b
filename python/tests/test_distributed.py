"""Split renders from Python: parts rendered by Ray tasks (or by hand) merge into the bits of one
run; a task whose worker dies is run again and counted once; what cannot split, or a missing part,
is refused."""

import os
import pathlib

import numpy as np
import pytest

import caustica

ROOT = pathlib.Path(__file__).resolve().parents[2]
BOX = ROOT / "scenes" / "cornell-box.gltf"
SPHERES = ROOT / "scenes" / "cornell-spheres.gltf"
SMALL = dict(width=32, height=24)


def test_parts_rendered_by_hand_merge_into_one_render_and_a_missing_one_is_named(tmp_path):
    scene = caustica.load(BOX, seed=5, **SMALL)
    paths = [tmp_path / f"part-{i}.exr" for i in range(1, 5)]
    for i, path in reversed(list(enumerate(paths, 1))):
        scene.render_part(i, 4, path, spp=8)
    color, info = caustica.merge(paths)
    assert info == {"integrator": "pt", "parts": 4, "units": 8}
    assert np.array_equal(color, scene.render(spp=8).color)
    with pytest.raises(caustica.CausticaError, match="missing part 3/4"):
        caustica.merge([paths[0], paths[1], paths[3]])
    with pytest.raises(caustica.CausticaError):
        caustica.load(BOX, integrator="sppm", passes=4, **SMALL).render_part(1, 2, tmp_path / "s.exr")


def test_a_part_never_overwrites_the_scene_it_renders_and_exposure_must_be_finite(tmp_path):
    scene_file = tmp_path / "box.gltf"
    scene_file.write_bytes(BOX.read_bytes())
    scene = caustica.load(scene_file, **SMALL)
    with pytest.raises(caustica.CausticaError, match="which the scene reads"):
        scene.render_part(1, 2, tmp_path / "." / "box.gltf", spp=2)
    assert scene_file.read_bytes() == BOX.read_bytes()
    color = np.full((2, 2, 3), 0.5, dtype=np.float32)
    for exposure in (float("nan"), float("inf")):
        with pytest.raises(caustica.CausticaError, match="exposure"):
            caustica.write_image(tmp_path / "x.png", color, exposure=exposure)
    assert not (tmp_path / "x.png").exists()


ray = pytest.importorskip("ray")
import caustica.distributed  # noqa: E402


@pytest.fixture(scope="module")
def local_ray(tmp_path_factory):
    marker = tmp_path_factory.mktemp("crash") / "crashed"
    marker.touch()  # no crash until a test asks for one by removing it
    os.environ["CAUSTICA_TEST_CRASH_ONCE"] = str(marker)  # inherited by the workers ray.init starts
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield marker
    ray.shutdown()


@pytest.mark.parametrize(
    "scene, units, overrides",
    [(BOX, {"spp": 8}, {}), (SPHERES, {"passes": 6}, {"integrator": "pppm", "photons_per_pass": 3000})],
)
def test_ray_parts_merge_into_the_bits_of_one_process(local_ray, scene, units, overrides):
    result = caustica.distributed.render(scene, parts=3, seed=9, progress=False, **units, **overrides, **SMALL)
    whole = caustica.load(scene, seed=9, **overrides, **SMALL).render(**units).color
    assert result.info["parts"] == 3
    assert np.array_equal(result.color, whole)


def test_a_part_whose_worker_dies_is_run_again_and_counted_once(local_ray, tmp_path):
    local_ray.unlink()  # the first worker to render part 1 now dies
    out = tmp_path / "merged.exr"
    result = caustica.distributed.render(BOX, parts=4, spp=8, seed=2, progress=False, output=out, **SMALL)
    assert local_ray.exists(), "no worker died: the test tested nothing"
    whole = caustica.load(BOX, seed=2, **SMALL).render(spp=8).color
    assert np.array_equal(result.color, whole)
    assert np.array_equal(caustica.read_exr(out), whole)


def test_what_does_not_split_is_refused_before_any_task(local_ray):
    with pytest.raises(ValueError, match="does not split"):
        caustica.distributed.render(SPHERES, parts=2, integrator="sppm", passes=4, **SMALL)
    with pytest.raises(caustica.CausticaError, match="no_such_file"):
        caustica.distributed.render(ROOT / "no_such_file.gltf", parts=2, spp=4)
