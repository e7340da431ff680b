"""A deterministic fuzzer of the Python API's arguments (issue 31): every public function, method and
keyword of ``caustica`` fed adversarial values, alone (the single-argument sweep) and in random
combinations (``random.Random`` with a fixed seed, so a failure names a case that reproduces).

The property of every call: it returns (and then every image it gives is a finite float32 array of
the size asked), or it raises an ordinary ``Exception`` with a message. It never raises pyo3's
``PanicException`` (a ``BaseException``), never hangs, never kills the interpreter, never writes
outside the test's folder and never overwrites an input.

``CAUSTICA_FUZZ_CASES`` sets the random cases per surface (default 500: the file runs in about 15 s
in a dev-profile build, on two cores).
"""

from __future__ import annotations

import faulthandler
import hashlib
import math
import os
import pathlib
import random
import re
import signal
import stat
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import caustica

# Hostile values overflow numpy's casts on purpose; the warnings say nothing about the API.
pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

ROOT = pathlib.Path(__file__).resolve().parents[2]
SPHERES = ROOT / "scenes" / "cornell-spheres.gltf"
SEED = 31
CASES = int(os.environ.get("CAUSTICA_FUZZ_CASES", "500"))
SIDE = 8
TINY = dict(width=SIDE, height=SIDE, spp=1, passes=1, photons=2000, caustic_photons=500, photons_per_pass=1000)
# A render that asks for billions of samples is a fair request, not a hang: it is stopped (as
# Ctrl-C would) after this long, at its next whole sample or pass.
STOP_AFTER = 1.0
# Anything that has not returned after this long has hung (in code that does not look at signals):
# the interpreter is ended with every thread's traceback, as a hang must not go unnoticed.
HUNG_AFTER = 120.0

NODES = ["floor", "ceiling", "back_wall", "red_wall_left", "green_wall_right", "light", "mirror_sphere",
         "glass_sphere", "camera"]
INTEGRATORS = caustica.INTEGRATORS


class Stopped(Exception):
    """A render stopped after STOP_AFTER seconds (the fuzzer's Ctrl-C)."""


def _cheap_huge(shape):
    """An array that claims ``shape`` (terabytes) but holds one float."""
    return np.lib.stride_tricks.as_strided(np.zeros(1, np.float32), shape, (0,) * len(shape))


def adversarial(where: pathlib.Path) -> list[tuple[str, object]]:
    """The hostile values, by label: every argument gets each of them in the single-argument sweep."""
    nan, inf = float("nan"), float("inf")
    return [
        ("nan", nan), ("inf", inf), ("-inf", -inf), ("0", 0), ("-1", -1), ("2**31", 2**31), ("2**32", 2**32),
        ("2**63", 2**63), ("2**64", 2**64), ("-2**63", -2**63), ("1e308", 1e308), ("-0.0", -0.0), ("0.5", 0.5),
        ("True", True), ("np.float32(nan)", np.float32("nan")), ("np.uint64(2**64-1)", np.uint64(2**64 - 1)),
        ("''", ""), ("100k chars", "x" * 100_000), ("deep dotted key", "a." * 50_000 + "b"), ("NUL", "a\0b"),
        ("lone surrogate", "\udc80"), ("'pt'", "pt"), ("'=1'", "=1"), ("'a = 1\\n[x]'", "a = 1\n[x]"),
        ("None", None), ("[]", []), ("[nan]*3", [nan] * 3), ("[[1]*4]*4", [[1] * 4] * 4), ("{}", {}),
        ("{'a': 1}", {"a": 1}), ("bytes", b"out.exr"), ("object()", object()), ("(1, 'a')", (1, "a")),
        ("nan image", np.full((SIDE, SIDE, 3), nan, np.float32)), ("0-d array", np.array(1.0, np.float32)),
        ("float64 image", np.zeros((SIDE, SIDE, 3))), ("int32 image", np.zeros((SIDE, SIDE, 3), np.int32)),
        ("4-channel image", np.zeros((SIDE, SIDE, 4), np.float32)), ("0x0 image", np.zeros((0, 0, 3), np.float32)),
        ("1x0 image", np.zeros((1, 0, 3), np.float32)),
        ("2**20 x 2**20 image (declared)", _cheap_huge((2**20, 2**20, 3))),
        ("1 x 2**32+1 image (declared)", _cheap_huge((1, 2**32 + 1, 3))),
        ("strided image", np.ones((SIDE, 2 * SIDE, 3), np.float32)[:, ::2]),
        ("nan 4x4", np.full((4, 4), nan)), ("inf 4x4", np.full((4, 4), inf)), ("zero 4x4", np.zeros((4, 4))),
        ("3x3", np.eye(3)), ("1e38 4x4", np.eye(4) * 1e38),
        ("a directory", str(where / "a-directory")), ("a directory .exr", str(where / "folder.exr")),
        ("/dev/zero", "/dev/zero"), ("/dev/null", "/dev/null"), ("/", "/"),
        ("missing path", str(where / "no" / "such" / "file.exr")), ("a pathlib.Path", where / "plain.exr"),
    ]


class World:
    """The test's folder: inputs (a copy of the scene, a run file and the environment map it reads)
    that must come out unchanged, and an output folder that is the working directory."""

    def __init__(self, tmp: pathlib.Path):
        self.inputs, self.out = tmp / "in", tmp / "out"
        self.inputs.mkdir()
        self.out.mkdir()
        (self.out / "a-directory").mkdir()
        (self.out / "folder.exr").mkdir()
        self.gltf = self.inputs / "scene.gltf"
        self.gltf.write_bytes(SPHERES.read_bytes())
        self.env = self.inputs / "env.exr"
        caustica.write_image(self.env, np.full((4, 8, 3), 0.2, np.float32))
        self.png = self.inputs / "image.png"
        caustica.write_image(self.png, np.full((SIDE, SIDE, 3), 0.5, np.float32))
        self.exr = self.inputs / "image.exr"
        caustica.write_image(self.exr, np.full((SIDE, SIDE, 3), 0.5, np.float32))
        self.toml = self.inputs / "scene.toml"
        self.toml.write_text('gltf = "scene.gltf"\n\n[environment]\nfile = "env.exr"\n')
        self.parts = [self.inputs / f"part{i}.exr" for i in (1, 2)]
        scene = caustica.load(self.gltf, **{**TINY, "spp": 2})
        for i, part in enumerate(self.parts, 1):
            scene.render_part(i, 2, part)
        self.adversarial = adversarial(self.out)
        self._inputs = self._hashes()
        self._outside = self._outside_state()

    def _hashes(self):
        return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(self.inputs.iterdir())}

    @staticmethod
    def _outside_state():
        devices = {name: stat.S_ISCHR(os.stat(f"/dev/{name}").st_mode) for name in ("null", "zero")}
        scenes = {p.name: p.stat().st_mtime_ns for p in (ROOT / "scenes").iterdir()}
        return devices, scenes, sorted(n for n in os.listdir("/dev") if n.endswith(".partial"))

    def check(self):
        """Nothing outside the output folder changed, and no partial file was left anywhere."""
        assert self._hashes() == self._inputs, "an input was overwritten"
        assert self._outside_state() == self._outside, "something outside the test's folder changed"
        leftovers = [p for p in self.out.parent.rglob("*") if p.name.endswith(".partial")]
        assert not leftovers, f"partial files left behind: {leftovers}"
        assert not any((self.out.parent / "tmp").iterdir()), "temporary files left behind"


@pytest.fixture
def world(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # from_dict's temporary glTF too: nothing the fuzzer makes is outside tmp_path.
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    w = World(tmp_path)
    monkeypatch.chdir(w.out)  # a relative output path lands in the test's folder
    yield w
    w.check()


class Cases:
    """Runs calls as fuzz cases, collecting every broken property (so one run reports them all)."""

    def __init__(self):
        self.count = 0
        self.outcomes: dict[str, int] = {}
        self.failures: list[str] = []

    def call(self, case: str, fn, *args, stop=False, **kwargs):
        """``fn(*args, **kwargs)``: what it returned, or the ordinary exception it raised."""
        self.count += 1
        outcome = self._call(case, fn, *args, stop=stop, **kwargs)
        kind = "returned" if not isinstance(outcome, BaseException) else type(outcome).__name__
        self.outcomes[kind] = self.outcomes.get(kind, 0) + 1
        return outcome

    def _call(self, case: str, fn, *args, stop=False, **kwargs):
        faulthandler.dump_traceback_later(HUNG_AFTER, exit=True)
        previous = signal.signal(signal.SIGALRM, _stop) if stop else None
        if stop:
            signal.setitimer(signal.ITIMER_REAL, STOP_AFTER)
        try:
            return fn(*args, **kwargs)
        except Exception as e:
            if not str(e).strip():
                self.fail(case, f"{type(e).__name__} without a message")
            return e
        except BaseException as e:
            if type(e).__name__ == "PanicException":
                self.fail(case, f"PanicException: {e}")
                return e
            raise
        finally:
            if stop:
                signal.setitimer(signal.ITIMER_REAL, 0)
                signal.signal(signal.SIGALRM, previous)
            faulthandler.cancel_dump_traceback_later()

    def fail(self, case: str, problem: str):
        self.failures.append(f"{case}: {problem}")

    def check(self, case: str, condition: bool, problem: str):
        if not condition:
            self.fail(case, problem)

    def image(self, case: str, array, shape):
        """A returned image: a finite float32 array of ``shape``."""
        if not isinstance(array, np.ndarray):
            return self.fail(case, f"returned {type(array).__name__}, not an array")
        if array.dtype != np.float32 or array.shape != tuple(shape):
            return self.fail(case, f"returned {array.dtype} {array.shape}, not float32 {tuple(shape)}")
        if not np.isfinite(array).all():
            self.fail(case, "returned an image with non-finite values")

    def aovs(self, case: str, aovs, asked, size):
        if not isinstance(aovs, dict) or not set(aovs) <= set(asked):
            return self.fail(case, f"feature images {list(aovs)} for {list(asked)}")
        for name, array in aovs.items():
            self.image(f"{case} aov {name}", array, size if name in ("depth", "spp") else (*size, 3))

    def done(self, surface: str, expected_at_least: int):
        print(f"{surface}: {self.count} cases, " + ", ".join(f"{n} {k}" for k, n in sorted(self.outcomes.items())))
        assert not self.failures, f"{len(self.failures)} of {self.count} cases broke the property:\n" + "\n".join(
            self.failures[:50]
        )
        assert self.count >= expected_at_least, f"{surface}: only {self.count} cases ran"


def _stop(signum, frame):
    raise Stopped(f"stopped by the fuzzer after {STOP_AFTER} s")


# --- what is fuzzed --------------------------------------------------------------------------------

OVERRIDE_KEYS = list(caustica._SECTION) + [
    "render.spp", "film.width", "film.height", "film.exposure", "camera.name", "environment.strength",
    "environment.file", "environment.color", "render.no_such_key", "noise_threshold", "min_spp", "", ".",
    "render.", ".spp", "a..b", "render.spp.x", "a." * 50_000 + "b", "x" * 100_000, "[film]", "film.width = 9\nx",
]
GOOD_VALUES = [
    ("1", 1), ("2", 2), ("8", 8), ("0.5", 0.5), ("'pt'", "pt"), ("'sppm'", "sppm"), ("'pm'", "pm"),
    ("[0, 1, 2]", [0, 1, 2]), ("[0.1, 0.2, 0.3]", [0.1, 0.2, 0.3]), ("False", False),
]


def _key_label(key: str) -> str:
    if len(key) >= 40:
        return f"<{len(key)}-char key {key[:8]!r}...>"
    return key if BARE_KEY.fullmatch(key) else repr(key)


def random_overrides(rng: random.Random, world: World, most: int = 3) -> list[tuple[str, str, object]]:
    """Up to ``most`` run-file overrides: a key (short, dotted or hostile) and a good or hostile value."""
    chosen = []
    for _ in range(rng.randint(0, most)):
        # Mostly keys the run file has, so that cases get past parsing into the renderer.
        key = rng.choice(list(caustica._SECTION)) if rng.random() < 0.7 else rng.choice(OVERRIDE_KEYS)
        label, value = rng.choice(GOOD_VALUES) if rng.random() < 0.4 else rng.choice(world.adversarial)
        chosen.append((key, label, value))
    return chosen


def describe(call: str, positional=(), keywords=()) -> str:
    parts = [label for label, _ in positional] + [f"{_key_label(k)}={label}" for k, label, _ in keywords]
    return f"{call}({', '.join(parts)})"


def size_asked(overrides, default=(SIDE, SIDE)):
    """(height, width) the overrides ask for, when they ask for a plain number."""
    height, width = default
    for key, _, value in overrides:
        if type(value) is int and key in ("width", "film.width"):
            width = value
        if type(value) is int and key in ("height", "film.height"):
            height = value
    return height, width


# --- load and from_dict ----------------------------------------------------------------------------


def _check_scene(cases: Cases, case: str, scene):
    if isinstance(scene, BaseException):
        return
    if not isinstance(scene, caustica.Scene):
        return cases.fail(case, f"returned {type(scene).__name__}")
    cases.check(case, isinstance(scene.path, (str, os.PathLike)) and scene.integrator in INTEGRATORS, "bad path or integrator")
    cases.call(f"{case}.splits()", scene.splits)


def _load(cases: Cases, case: str, path, overrides):
    scene = cases.call(case, caustica.load, path, **{k: v for k, _, v in overrides})
    _check_scene(cases, case, scene)
    _check_keys(cases, case, scene, overrides)


BARE_KEY = re.compile(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*")


def _check_keys(cases: Cases, case: str, made, overrides):
    """A key that is not a run file's (dotted names) must be refused: it is text spliced into an
    assignment, where it could set another key than it names."""
    if not isinstance(made, BaseException):
        cases.check(case, all(BARE_KEY.fullmatch(k) for k, _, _ in overrides), "a malformed key was taken")


def load_paths(world: World):
    return [("scene.gltf", world.gltf), ("scene.toml", world.toml), ("str(scene.gltf)", str(world.gltf)),
            ("image.exr", world.exr), ("part1.exr", world.parts[0])] + world.adversarial


def test_load_and_its_overrides_keep_the_property(world):
    cases, rng = Cases(), random.Random(SEED)
    paths = load_paths(world)
    for _ in range(CASES):
        label, path = rng.choice(paths[:3]) if rng.random() < 0.6 else rng.choice(paths)
        overrides = random_overrides(rng, world, most=4)
        _load(cases, describe("load", [(label, None)], overrides), path, overrides)
    cases.done("load (random)", CASES)


def test_from_dict_keeps_the_property(world):
    cases, rng = Cases(), random.Random(SEED + 1)
    square = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    good = {
        "positions": square, "indices": faces, "normals": np.tile([0, 1, 0], (4, 1)).astype(np.float32),
        "material": "white", "name": "floor", "base_color": [0.8, 0.8, 0.8], "emission": [0, 0, 0],
        "metallic": 0.0, "roughness": 0.5, "specular": 1.0, "transmission": 0.0, "ior": 1.5,
        "eye": [0, 1, 3], "target": [0, 0, 0], "up": [0, 1, 0], "yfov_degrees": 40.0,
    }
    hostile = world.adversarial + [
        ("huge declared positions", _cheap_huge((2**40, 3))), ("indices out of range", np.array([[0, 1, 99]])),
        ("negative indices", np.array([[0, -1, 2]])), ("float indices", np.full((2, 3), 0.5)),
    ]
    fields = list(good)
    for i in range(CASES + len(fields) * len(hostile)):
        if i < CASES:
            bad = {f: rng.choice(hostile) for f in rng.sample(fields, rng.randint(1, 3))}
        else:  # the single-argument sweep: one field, each hostile value
            j = i - CASES
            bad = {fields[j // len(hostile)]: hostile[j % len(hostile)]}
        value = {f: bad[f][1] if f in bad else good[f] for f in fields}
        material = {k: value[k] for k in ("base_color", "emission", "metallic", "roughness", "specular",
                                          "transmission", "ior")}
        mesh = {k: value[k] for k in ("positions", "indices", "normals", "material", "name")}
        camera = {k: value[k] for k in ("eye", "target", "up", "yfov_degrees")}
        lamp = {"positions": square + [0, 2, 0], "indices": faces[:, ::-1], "material": "lamp"}
        scene = {"camera": camera, "materials": {"white": material, "lamp": {"emission": [5, 5, 5]}},
                 "meshes": [mesh, lamp]}
        case = "from_dict(" + ", ".join(f"{f}={label}" for f, (label, _) in bad.items()) + ")"
        made = cases.call(case, caustica.from_dict, scene, **TINY)
        _check_scene(cases, case, made)
        if isinstance(made, caustica.Scene):
            result = cases.call(f"{case}.render()", made.render, stop=True)
            if isinstance(result, caustica.RenderResult):
                cases.image(case, result.color, (SIDE, SIDE, 3))
    cases.done("from_dict (random + sweep)", CASES + len(fields) * len(hostile))


# --- Scene.render ----------------------------------------------------------------------------------

RENDER_ARGS = {
    "spp": [("1", 1), ("2", 2)],
    "passes": [("1", 1)],
    "time_limit": [("5.0", 5.0), ("0.001", 0.001)],
    "aovs": [("()", ()), ("('depth',)", ("depth",)), ("['albedo', 'normal']", ["albedo", "normal"]),
             ("('spp', 'spp')", ("spp", "spp"))],
}


def _render(cases: Cases, scene, case: str, named, overrides):
    kwargs = {k: v for k, _, v in named}
    kwargs.update({k: v for k, _, v in overrides})
    result = cases.call(case, scene.render, stop=True, **kwargs)
    _check_keys(cases, case, result, overrides)
    if isinstance(result, caustica.RenderResult):
        size = size_asked(overrides)
        cases.image(case, result.color, (*size, 3))
        asked = dict((k, v) for k, _, v in named).get("aovs", ("albedo", "normal", "depth", "spp"))
        cases.aovs(case, result.aovs, asked, size)
        cases.check(case, isinstance(result.stats, dict) and result.stats["done"] >= 0, "bad stats")
        denoised = cases.call(f"{case}.denoised()", result.denoised)
        if not isinstance(denoised, BaseException):
            cases.image(f"{case}.denoised()", denoised, (*size, 3))


def _named(rng: random.Random, world: World, table):
    """Each named argument: left out, good or hostile."""
    chosen = []
    for name, good in table.items():
        roll = rng.random()
        # spp and passes together are refused outright: one of them, mostly.
        if roll < (0.75 if name == "passes" else 0.4):
            continue
        label, value = rng.choice(good) if roll < 0.85 else rng.choice(world.adversarial)
        chosen.append((name, label, value))
    return chosen


def test_render_keywords_keep_the_property(world):
    cases, rng = Cases(), random.Random(SEED + 2)
    scenes = [caustica.load(world.gltf, **TINY), caustica.load(world.toml, **TINY),
              caustica.load(world.gltf, **{**TINY, "integrator": "sppm"})]
    for _ in range(CASES):
        scene = rng.choice(scenes)
        named, overrides = _named(rng, world, RENDER_ARGS), random_overrides(rng, world)
        _render(cases, scene, describe(f"{pathlib.Path(scene.path).name}.render", (), named + overrides), named,
                overrides)
    cases.done("Scene.render (random)", CASES)


# --- Scene.render_part and merge -------------------------------------------------------------------


def test_render_part_and_merge_keep_the_property(world):
    cases, rng = Cases(), random.Random(SEED + 3)
    scene = caustica.load(world.toml, **{**TINY, "spp": 2})
    outputs = [("part.exr", "part.exr"), ("sub/part.exr", "sub/part.exr"), ("env.exr (an input)", world.env),
               ("scene.toml (itself)", world.toml), ("scene.gltf (an input)", world.gltf)]
    table = {
        "part": [("1", 1), ("2", 2)], "parts": [("2", 2), ("1", 1)], "path": outputs,
        "spp": [("2", 2), ("4", 4)], "passes": [("1", 1)],
    }
    for _ in range(CASES):
        named = []
        for name, good in table.items():
            roll = rng.random()
            if name in ("spp", "passes") and roll < 0.5:
                continue
            label, value = rng.choice(good) if roll < 0.9 else rng.choice(world.adversarial)
            named.append((name, label, value))
        case = describe("render_part", (), named)
        kwargs = {k: v for k, _, v in named}
        stats = cases.call(case, scene.render_part, stop=True, **kwargs)
        if isinstance(stats, dict):
            path = pathlib.Path(kwargs["path"]).resolve()
            cases.check(case, path.is_relative_to(world.out) and path.is_file(), f"wrote {path}")
            if kwargs["parts"] == 1:
                merged = cases.call(f"merge([{case}])", caustica.merge, [path])
                if isinstance(merged, tuple):
                    cases.image(case, merged[0], (SIDE, SIDE, 3))
    # merge alone: good and bad lists of parts.
    good = [str(p) for p in world.parts]
    lists = [("both parts", good), ("one part", good[:1]), ("a part twice", good[:1] * 2),
             ("reversed", good[::-1]), ("with the scene", good + [str(world.gltf)]),
             ("with image.exr", good + [str(world.exr)])] + [
        (f"[{label}]", [value]) for label, value in world.adversarial] + [
        (label, value) for label, value in world.adversarial]
    for label, paths in lists:
        merged = cases.call(f"merge({label})", caustica.merge, paths)
        if isinstance(merged, tuple):
            cases.image(f"merge({label})", merged[0], (SIDE, SIDE, 3))
            cases.check(label, merged[1].get("parts") == 2, f"merged {merged[1]}")
    cases.done("Scene.render_part + merge (random + merge sweep)", CASES + len(lists))


# --- Session ---------------------------------------------------------------------------------------

IDENTITY = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]
LIFTED = [[1.0, 0, 0, 0], [0, 1.0, 0, 0.1], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]


def _check_move(cases: Cases, case: str, moved, session, done: int):
    """A move that was taken starts the image over and says what it cost; a refused one changes nothing."""
    if isinstance(moved, BaseException):
        cases.check(case, session.done == done, "a refused move changed the image")
        return
    cases.check(case, session.done == 0, "the image did not start over")
    cases.check(case, isinstance(moved, dict) and {"pose", "bvh", "lights"} <= moved.keys()
                and all(math.isfinite(moved[k]) and moved[k] >= 0 for k in ("pose", "bvh", "lights")),
                f"the move's cost {moved!r}")


def _session_op(cases: Cases, session, case: str, rng: random.Random, world: World, size):
    """One random method call on ``session``, and what must hold after it."""
    done = session.done
    op = rng.choice(["step", "step", "set_transform", "advance", "set_camera", "image", "aovs"])
    hostile = rng.random() < 0.5
    if op == "step":
        label, units = rng.choice(world.adversarial) if hostile else rng.choice([("1", 1), ("2", 2), ("None", None)])
        case = f"{case}.step({label})"
        stats = cases.call(case, session.step, units, stop=True)
        if isinstance(stats, dict) and isinstance(units, int) and not isinstance(units, bool):
            cases.check(case, session.done == done + units, f"done {done} -> {session.done}")
    elif op == "set_transform":
        node = rng.choice(world.adversarial) if hostile and rng.random() < 0.5 else rng.choice(
            [(repr(n), n) for n in NODES] + [("'0'", "0"), ("'8'", "8")])
        matrix = rng.choice(world.adversarial) if hostile else rng.choice([("identity", IDENTITY),
                                                                            ("lifted", LIFTED)])
        case = f"{case}.set_transform({node[0]}, {matrix[0]})"
        _check_move(cases, case, cases.call(case, session.set_transform, node[1], matrix[1]), session, done)
    elif op == "advance":
        label, time = rng.choice(world.adversarial) if hostile else rng.choice([("0", 0.0), ("0.5", 0.5), ("-1", -1.0)])
        case = f"{case}.advance({label})"
        _check_move(cases, case, cases.call(case, session.advance, time), session, done)
    elif op == "set_camera":
        eye = rng.choice(world.adversarial) if hostile and rng.random() < 0.5 else ("eye", [0.0, 0.3, 0.9])
        target = rng.choice(world.adversarial) if hostile and rng.random() < 0.5 else ("target", [0.0, 0.27, 0.0])
        yfov = rng.choice(world.adversarial) if hostile and rng.random() < 0.5 else ("None", None)
        case = f"{case}.set_camera({eye[0]}, {target[0]}, yfov_degrees={yfov[0]})"
        placed = cases.call(case, session.set_camera, eye[1], target[1], yfov_degrees=yfov[1])
        if isinstance(placed, BaseException):
            cases.check(case, session.done == done, "a refused camera changed the image")
        else:
            cases.check(case, session.done == 0, "the image did not start over")
    elif op == "image":
        case = f"{case}.image()"
        cases.image(case, cases.call(case, session.image), (*size, 3))
    else:
        case = f"{case}.aovs()"
        cases.aovs(case, cases.call(case, session.aovs), ("albedo", "normal", "depth", "spp"), size)
    cases.check(case, session.unit in ("spp", "passes"), f"unit {session.unit!r}")
    cases.image(f"{case} then image()", session.image(), (*size, 3))


def test_session_methods_keep_the_property(world):
    cases, rng = Cases(), random.Random(SEED + 4)
    scene = caustica.load(world.gltf, **TINY)
    sessions = 0
    while cases.count < CASES:
        aovs = rng.choice(RENDER_ARGS["aovs"] + [("omitted", None)]) if rng.random() < 0.8 else rng.choice(
            world.adversarial)
        overrides = random_overrides(rng, world, most=2)
        named = [] if aovs[0] == "omitted" else [("aovs", *aovs)]
        case = describe("session", (), named + overrides)
        kwargs = {k: v for k, _, v in named + overrides}
        session = cases.call(case, scene.session, stop=True, **kwargs)
        _check_keys(cases, case, session, overrides)
        sessions += 1
        if isinstance(session, caustica.Session):
            size = size_asked(overrides)
            for _ in range(rng.randint(1, 6)):
                _session_op(cases, session, case, rng, world, size)
    print(f"session: {sessions} sessions")
    cases.done("Session (random)", CASES)


# --- image functions -------------------------------------------------------------------------------


def test_image_functions_keep_the_property(world):
    cases, rng = Cases(), random.Random(SEED + 5)
    image = ("8x8 image", np.full((SIDE, SIDE, 3), 0.25, np.float32))
    outputs = [("out.exr", "out.exr"), ("out.png", "out.png"), ("OUT.EXR", "OUT.EXR"), ("deep/out.png", "deep/out.png"),
               ("out.jpg", "out.jpg"), ("scene.gltf (an input)", world.gltf)]
    readable = [("image.exr", world.exr), ("image.png", world.png), ("part1.exr", world.parts[0]),
                ("scene.gltf", world.gltf), ("env.exr", world.env)]
    for _ in range(CASES):
        which = rng.choice(["write_image", "compare", "read_exr", "read_exr_channels"])
        pick = lambda good: rng.choice(good) if rng.random() < 0.6 else rng.choice(world.adversarial)  # noqa: E731
        if which == "write_image":
            args = [pick(outputs), pick([image])]
            kwargs = {} if rng.random() < 0.4 else {"exposure": pick([("0.0", 0.0), ("1.5", 1.5), ("-3", -3)])}
            _write_image(cases, world, args, kwargs)
        elif which == "compare":
            _compare(cases, pick([image]), pick([image, ("zeros", np.zeros((SIDE, SIDE, 3), np.float32))]))
        else:
            _read(cases, which, pick(readable))
    cases.done("image functions (random)", CASES)


def _write_image(cases: Cases, world: World, args, kwargs):
    (plabel, path), (clabel, color) = args
    exposure = kwargs.get("exposure")
    case = f"write_image({plabel}, {clabel}" + (f", exposure={exposure[0]})" if exposure else ")")
    written = cases.call(case, caustica.write_image, path, color, **({"exposure": exposure[1]} if exposure else {}))
    if written is None:
        target = pathlib.Path(os.fsdecode(path)).resolve()
        cases.check(case, target.is_relative_to(world.out) and target.is_file(), f"wrote {target}")
        if target.suffix.lower() == ".exr" and np.isfinite(color).all():
            back = cases.call(f"read_exr after {case}", caustica.read_exr, target)
            cases.check(case, isinstance(back, np.ndarray) and np.array_equal(back, color), "reads back different")


def _compare(cases: Cases, a, b):
    case = f"compare({a[0]}, {b[0]})"
    metrics = cases.call(case, caustica.compare, a[1], b[1])
    if isinstance(metrics, dict):
        cases.check(case, set(metrics) == {"rmse", "relmse", "mae", "flip"}, f"metrics {sorted(metrics)}")
        finite_inputs = all(np.isfinite(np.asarray(x, np.float64)).all() for x in (a[1], b[1]))
        values = [metrics[k] for k in ("rmse", "relmse", "mae")]
        if finite_inputs:
            cases.check(case, all(math.isfinite(v) and v >= 0 for v in metrics.values()), f"metrics {metrics}")
        else:
            # A NaN pixel must not compare as equal. FLIP is left out: the core's FLIP sees NaN as
            # black (see test_flip_of_an_image_with_nan_is_not_a_perfect_match below).
            cases.check(case, all(math.isnan(v) for v in values), f"non-finite input, metrics {metrics}")


def _read(cases: Cases, which: str, path):
    case = f"{which}({path[0]})"
    read = cases.call(case, getattr(caustica, which), path[1])
    if isinstance(read, np.ndarray):
        cases.check(case, read.ndim == 3 and read.shape[2] == 3, f"shape {read.shape}")
        cases.image(case, read, read.shape)
    elif isinstance(read, dict):
        shapes = {a.shape for a in read.values()}
        cases.check(case, len(shapes) <= 1, f"channels of sizes {shapes}")
        for name, channel in read.items():
            cases.check(case, channel.ndim == 2 and channel.dtype == np.float32, f"channel {name}")


# --- the single-argument sweep ---------------------------------------------------------------------


def test_every_argument_alone_with_every_hostile_value(world):
    """Every argument of every surface given each hostile value, the others good."""
    cases = Cases()
    hostile = world.adversarial
    scene = caustica.load(world.gltf, **TINY)
    image = np.full((SIDE, SIDE, 3), 0.25, np.float32)
    sweep = {
        "load(path)": lambda v: caustica.load(v),
        "render(spp)": lambda v: scene.render(spp=v),
        "render(passes)": lambda v: scene.render(passes=v),
        "render(time_limit)": lambda v: scene.render(time_limit=v),
        "render(aovs)": lambda v: scene.render(aovs=v),
        "render_part(part)": lambda v: scene.render_part(v, 2, "p.exr"),
        "render_part(parts)": lambda v: scene.render_part(1, v, "p.exr"),
        "render_part(path)": lambda v: scene.render_part(1, 1, v),
        "render_part(spp)": lambda v: scene.render_part(1, 1, "p.exr", spp=v),
        "render_part(passes)": lambda v: scene.render_part(1, 1, "p.exr", passes=v),
        "session(aovs)": lambda v: scene.session(aovs=v),
        "Session.step(units)": lambda v: scene.session().step(v),
        "Session.set_transform(node)": lambda v: scene.session().set_transform(v, IDENTITY),
        "Session.set_transform(matrix)": lambda v: scene.session().set_transform("floor", v),
        "merge(paths)": lambda v: caustica.merge(v),
        "merge([path])": lambda v: caustica.merge([v]),
        "write_image(path)": lambda v: caustica.write_image(v, image),
        "write_image(color)": lambda v: caustica.write_image("sweep.exr", v),
        "write_image(exposure)": lambda v: caustica.write_image("sweep.png", image, exposure=v),
        "compare(image)": lambda v: caustica.compare(v, image),
        "compare(reference)": lambda v: caustica.compare(image, v),
        "read_exr(path)": lambda v: caustica.read_exr(v),
        "read_exr_channels(path)": lambda v: caustica.read_exr_channels(v),
    }
    for call, run in sweep.items():
        for label, value in hostile:
            out = cases.call(f"{call} = {label}", run, value, stop=True)
            if isinstance(out, np.ndarray):
                cases.image(f"{call} = {label}", out, out.shape if out.ndim == 3 else (0,))
            elif isinstance(out, caustica.RenderResult):
                cases.image(f"{call} = {label}", out.color, (SIDE, SIDE, 3))
    # Every override key (for load, render and session) with every hostile value.
    for key in OVERRIDE_KEYS:
        for label, value in hostile:
            overrides = [(key, label, value)]
            _load(cases, describe("load", [("scene.gltf", None)], overrides), world.gltf, overrides)
            if key in caustica._SECTION and key not in ("spp", "passes", "time_limit"):
                _render(cases, scene, describe("render", (), overrides), [], overrides)
    expected = len(sweep) * len(hostile) + len(OVERRIDE_KEYS) * len(hostile)
    cases.done("single-argument sweep", expected)


# --- what the fuzzer found, kept ---------------------------------------------------------------------


@pytest.mark.parametrize("call", ["write_image", "compare", "override"])
def test_an_array_that_claims_terabytes_is_refused_not_copied(world, call):
    """An array of zero strides claims 2^40 pixels: copying it as pixels aborted the interpreter
    (write_image, compare), and making it a run-file value listed it forever (overrides)."""
    huge = _cheap_huge((2**20, 2**20, 3))
    error = MemoryError if call != "override" else ValueError
    with pytest.raises(error, match="1048576|values"):
        if call == "write_image":
            caustica.write_image("huge.exr", huge)
        elif call == "compare":
            caustica.compare(huge, huge)
        else:
            caustica.load(world.gltf, eye=huge)
    with pytest.raises(ValueError, match="2\\^32"):
        caustica.compare(_cheap_huge((1, 2**32 + 1, 3)), _cheap_huge((1, 2**32 + 1, 3)))


def test_an_override_key_cannot_set_another_key(world):
    """The key is text before the core's first "=": this one set the width to 9 and the render
    came back 8 x 9 where 8 x 8 was asked."""
    with pytest.raises(ValueError, match="run-file key"):
        caustica.load(world.gltf, width=SIDE, height=SIDE, **{"film.width = 9\nx": 0})
    with pytest.raises(ValueError, match="run-file key"):
        caustica.load(world.gltf, **TINY).render(**{"render.spp=4\nrender.seed": 1})


def test_from_dict_refuses_fractional_indices_and_numbers_it_cannot_write(world):
    """Indices 0.5 were cast to vertex 0 and NaN or infinite material numbers were written as JSON
    the loader then refused as "not a valid glTF file", pointing at a deleted temporary file."""
    square = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)

    def scene(indices=((0, 1, 2), (0, 2, 3)), **material):
        return {"materials": {"m": {"emission": [1, 1, 1], **material}},
                "meshes": [{"positions": square, "indices": np.asarray(indices), "material": "m"}]}

    for bad, match in [(dict(indices=np.full((2, 3), 0.5)), "whole numbers"),
                       (dict(metallic=float("nan")), "metallic"), (dict(emission=[math.inf] * 3), "emission"),
                       (dict(emission=[-1, -1, -1]), "emission"), (dict(base_color=[2.0**64] * 3), "base_color")]:
        with pytest.raises(ValueError, match=match):
            caustica.from_dict(scene(**bad), **TINY)
    assert isinstance(caustica.from_dict(scene(indices=np.array([[0, 1, 2], [0, 2, 3]], float)), **TINY),
                      caustica.Scene)


def test_flip_of_an_image_with_nan_is_not_a_perfect_match():
    nan_image = np.full((SIDE, SIDE, 3), np.nan, np.float32)
    metrics = caustica.compare(nan_image, np.zeros((SIDE, SIDE, 3), np.float32))
    assert not metrics["flip"] == 0.0


def test_a_host_that_once_held_much_memory_can_still_render():
    # In a process of its own: the peak it raises would refuse this file's later renders.
    script = (
        "import numpy as np, caustica\n"
        "x = np.ones(700 * 2**20 // 8); del x\n"
        f"caustica.load({str(SPHERES)!r}, width=8, height=8, spp=1, memory_budget_mib=600).render()\n"
    )
    subprocess.run([sys.executable, "-c", script], check=True, capture_output=True)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS is Linux's")
def test_memory_the_machine_has_not_got_is_a_memory_error_and_the_process_goes_on():
    """A budget raised by hand past what the process may have (RLIMIT_AS, as ``ulimit -v``): the
    render is refused with a MemoryError naming the film, before anything of it is allocated, and
    the same process renders the next scene (issue 45: this aborted the interpreter)."""
    script = (
        "import resource, caustica\n"
        "resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))\n"
        f"scene = caustica.load({str(SPHERES)!r}, width=32768, height=32768, spp=1, memory_budget_mib=2**40)\n"
        "try:\n"
        "    scene.render()\n"
        "    raise SystemExit('rendered')\n"
        "except MemoryError as e:\n"
        "    assert 'cannot allocate' in str(e) and '-pixel film' in str(e), e\n"
        f"image = caustica.load({str(SPHERES)!r}, width=8, height=8, spp=1).render().color\n"
        "assert image.shape == (8, 8, 3) and image.max() > 0\n"
        "print('survived')\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0 and "survived" in done.stdout, done.stdout + done.stderr


def test_a_refused_output_name_leaves_no_folder_behind(world):
    with pytest.raises(caustica.CausticaError, match="unknown image format"):
        caustica.write_image("new/folder/out.jpg", np.zeros((2, 2, 3), np.float32))
    assert not (world.out / "new").exists()


# --- a session after refused calls, in a frame loop, and from two threads (issue 45) ---------------

ANIMATED = ROOT / "scenes" / "cornell-animated.gltf"
QUICK = dict(width=SIDE, height=SIDE, spp=1, seed=45)
NAN, INF = float("nan"), float("inf")

def _translation(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


# Each refused for a reason of its own: a value that is not finite, too large for f32, degenerate,
# out of range, of the wrong type, a node that is not there.
REFUSED_CALLS = [
    ("set_camera(eye=nan)", lambda s: s.set_camera([NAN, 0.3, 0.9], [0, 0.27, 0])),
    ("set_camera(target=inf)", lambda s: s.set_camera([0, 0.3, 0.9], [0, INF, 0])),
    ("set_camera(eye=1e308)", lambda s: s.set_camera([1e308] * 3, [0, 0.27, 0])),
    ("set_camera(eye=target)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.3, 0.9])),
    ("set_camera(up along the view)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.3, 0], up=[0, 0, -2])),
    ("set_camera(up=0)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.27, 0], up=[0, 0, 0])),
    ("set_camera(yfov=0)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.27, 0], yfov_degrees=0)),
    ("set_camera(yfov=180)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.27, 0], yfov_degrees=180)),
    ("set_camera(yfov=-40)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.27, 0], yfov_degrees=-40)),
    ("set_camera(yfov=nan)", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.27, 0], yfov_degrees=NAN)),
    ("set_camera(yfov='wide')", lambda s: s.set_camera([0, 0.3, 0.9], [0, 0.27, 0], yfov_degrees="wide")),
    ("set_camera(eye='abc')", lambda s: s.set_camera("abc", [0, 0.27, 0])),
    ("set_camera(eye=[1, 2])", lambda s: s.set_camera([1, 2], [0, 0.27, 0])),
    ("set_camera(eye=None)", lambda s: s.set_camera(None, [0, 0.27, 0])),
    ("advance(nan)", lambda s: s.advance(NAN)),
    ("advance(inf)", lambda s: s.advance(INF)),
    ("advance(-inf)", lambda s: s.advance(-INF)),
    ("advance(1e308)", lambda s: s.advance(1e308)),
    ("advance('1')", lambda s: s.advance("1")),
    ("advance(None)", lambda s: s.advance(None)),
    ("set_transform(unknown node)", lambda s: s.set_transform("no_such_node", IDENTITY)),
    ("set_transform(node index 99)", lambda s: s.set_transform("99", IDENTITY)),
    ("set_transform(nan matrix)", lambda s: s.set_transform("floor", np.full((4, 4), NAN))),
    ("set_transform(inf matrix)", lambda s: s.set_transform("floor", np.eye(4) * INF)),
    ("set_transform(1e39 matrix)", lambda s: s.set_transform("floor", np.eye(4) * 1e39)),
    ("set_transform(singular)", lambda s: s.set_transform("floor", np.zeros((4, 4)))),
    ("set_transform(3x3)", lambda s: s.set_transform("floor", np.eye(3))),
    # A projective last row, which moving points as affine would drop without a word.
    ("set_transform(projective)", lambda s: s.set_transform("floor", [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0],
                                                                      [0.5, 0, 0, 1]])),
    ("set_transform(matrix='x')", lambda s: s.set_transform("floor", "x")),
    ("set_transform(node=None)", lambda s: s.set_transform(None, IDENTITY)),
    # Finite and invertible, but beyond the ±1e6 m the loader allows: the BVH's boxes no longer
    # nest, and lt panicked on a light moved to 1e37 m.
    ("set_transform(light squashed far up)", lambda s: s.set_transform("light", np.diag([3e-25, 1e38, 3e-25, 1.0]))),
    ("set_transform(light 1e30 m away)", lambda s: s.set_transform("light", _translation(1e30, 0, 0))),
    ("set_transform(floor scaled 1e30)", lambda s: s.set_transform("floor", np.diag([1e30, 1e30, 1e30, 1.0]))),
    ("step(0)", lambda s: s.step(0)),
    ("step(-1)", lambda s: s.step(-1)),
    ("step(2**32)", lambda s: s.step(2**32)),
    ("step(nan)", lambda s: s.step(NAN)),
    ("step('1')", lambda s: s.step("1")),
]


def _refused(case, call, session):
    """``call(session)`` must raise an ordinary exception with a message, and leave ``done`` alone."""
    done = session.done
    faulthandler.dump_traceback_later(HUNG_AFTER, exit=True)
    try:
        call(session)
    except Exception as e:
        assert str(e).strip(), f"{case}: {type(e).__name__} without a message"
    else:
        pytest.fail(f"{case} was taken")
    finally:
        faulthandler.cancel_dump_traceback_later()
    assert session.done == done, f"{case}: a refused call changed the image"


@pytest.mark.parametrize("scene_path", [SPHERES, ANIMATED], ids=["spheres", "animated"])
def test_a_refused_call_leaves_the_session_as_if_it_had_never_come(scene_path):
    """Between two samples, each refused call; the image is then that of a session that never saw
    it, bit for bit (a refusal that half-applied a move, a camera or a time would show here)."""
    scene = caustica.load(scene_path, **QUICK)
    clean = scene.session(aovs=())
    clean.step(2)
    expected = clean.image()
    for case, call in REFUSED_CALLS:
        session = scene.session(aovs=())
        session.step(1)
        _refused(case, call, session)
        session.step(1)
        assert session.done == 2, case
        assert np.array_equal(session.image(), expected), f"{case}: the image differs from a session that never saw it"


@pytest.mark.parametrize("integrator", caustica.INTEGRATORS)
def test_geometry_moved_beyond_reach_is_refused_by_every_integrator(integrator):
    """A move that takes a light 1e37 m up is refused by name (lt panicked in the BVH), and the
    session renders on as if it had not come."""
    scene = caustica.load(SPHERES, **{**TINY, "seed": 45, "integrator": integrator})
    clean = scene.session(aovs=())
    clean.step(2)
    session = scene.session(aovs=())
    session.step(1)
    with pytest.raises(ValueError, match="light.*beyond"):
        session.set_transform("light", np.diag([3e-25, 1e38, 3e-25, 1.0]))
    session.step(1)
    assert np.array_equal(session.image(), clean.image())


def test_a_frame_loop_with_refused_times_renders_the_frames_of_the_clean_loop():
    scene = caustica.load(ANIMATED, **QUICK)
    assert scene.session(aovs=()).duration > 0, "the scene is animated"

    def frames(times):
        session, images = scene.session(aovs=()), []
        for t in times:
            try:
                session.advance(t)
            except (ValueError, TypeError, caustica.CausticaError):
                continue
            session.step(1)
            images.append(session.image())
        return images

    clean = frames([0.0, 0.25, 0.5, 0.75])
    hostile = frames([0.0, NAN, 0.25, INF, "x", 0.5, -INF, None, 1e308, 0.75])
    assert len(hostile) == len(clean)
    for i, (a, b) in enumerate(zip(clean, hostile)):
        assert np.array_equal(a, b), f"frame {i}: a refused time changed the next frame"
    assert not np.array_equal(clean[0], clean[-1]), "the frames move"


def test_a_session_is_usable_in_any_order_of_calls():
    """What a host may call first: an image, feature images or a move before any sample."""
    session = caustica.load(SPHERES, **QUICK).session()
    assert session.done == 0
    assert np.array_equal(session.image(), np.zeros((SIDE, SIDE, 3), np.float32)), "nothing rendered is black"
    assert set(session.aovs()) <= {"albedo", "normal", "depth", "spp"}
    session.advance(0.0)
    session.set_transform("floor", IDENTITY)
    session.set_camera([0, 0.3, 0.9], [0, 0.27, 0])
    session.step(1)
    assert session.done == 1 and np.isfinite(session.image()).all() and session.image().max() > 0


def _in_threads(count, work):
    """Run ``work(i)`` on ``count`` threads at once; what each returned or raised. A thread still
    running after HUNG_AFTER seconds is a deadlock."""
    import threading

    outcomes = [None] * count
    start = threading.Barrier(count)

    def run(i):
        start.wait()
        try:
            outcomes[i] = work(i)
        except BaseException as e:  # noqa: BLE001 - a PanicException must be seen, not lost
            outcomes[i] = e

    threads = [threading.Thread(target=run, args=(i,)) for i in range(count)]
    faulthandler.dump_traceback_later(HUNG_AFTER, exit=True)
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        faulthandler.cancel_dump_traceback_later()
    return outcomes


def test_one_session_stepped_from_two_threads_is_serialised():
    """Two threads stepping one session: the steps are taken one at a time (the second waits, the
    GIL released), and the image is that of one session stepped as often."""
    scene = caustica.load(SPHERES, **{**QUICK, "spp": 1})
    session = scene.session(aovs=())

    def work(i):
        for _ in range(3):
            session.step(1)
            assert session.image().shape == (SIDE, SIDE, 3)
        return session.done

    outcomes = _in_threads(2, work)
    for outcome in outcomes:
        assert isinstance(outcome, int), f"{type(outcome).__name__}: {outcome}"
    assert session.done == 6
    alone = scene.session(aovs=())
    alone.step(6)
    assert np.array_equal(session.image(), alone.image())


def test_a_session_moved_while_another_thread_steps_it_stays_consistent():
    """One thread steps, the other moves the camera back and forth: every call is taken whole, in
    some order; afterwards the session renders what a fresh one does."""
    scene = caustica.load(SPHERES, **QUICK)
    session = scene.session(aovs=())
    eye, target = [0, 0.3, 0.9], [0, 0.27, 0]

    def work(i):
        for k in range(4):
            if i == 0:
                session.step(1)
            elif k % 2:
                session.set_camera(eye, target)
            else:
                session.advance(0.0)
        return True

    assert _in_threads(2, work) == [True, True]
    session.set_camera(eye, target)
    session.step(2)
    fresh = scene.session(aovs=())
    fresh.set_camera(eye, target)
    fresh.step(2)
    assert np.array_equal(session.image(), fresh.image())


def test_two_sessions_on_two_threads_render_what_they_render_alone():
    scene = caustica.load(SPHERES, **QUICK)
    sessions = [scene.session(aovs=()), scene.session(aovs=(), integrator="lt")]

    def work(i):
        sessions[i].step(2)
        return sessions[i].image()

    images = _in_threads(2, work)
    for i, integrator in enumerate(["pt", "lt"]):
        alone = scene.session(aovs=(), integrator=integrator)
        alone.step(2)
        assert isinstance(images[i], np.ndarray), f"{integrator}: {images[i]!r}"
        assert np.array_equal(images[i], alone.image()), integrator
