//! The `Scene` class (a scene and its settings, loaded by `load`), its renders and their
//! `RenderResult`.

use crate::convert::{aov_dict, color_array, image_of, stats};
use crate::session::Session;
use crate::{refused, run_detached};
use caustica::driver::FrameRun;
use caustica::film::accumulator;
use caustica::film::aov::{Aov, AovImages};
use caustica::scene::{self, RunFile};
use caustica::{Choice, Renderer};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A scene and its settings, loaded once; every render builds its own renderer from them.
#[pyclass(module = "caustica", frozen)]
pub(crate) struct Scene {
    scene: scene::Scene,
    run: RunFile,
    path: PathBuf,
    /// The run file's text ("" for a glTF) and the overrides it was loaded with, which a render's
    /// own overrides are applied after.
    text: String,
    sets: Vec<String>,
}

/// The feature images `names` ask for, refused by name when one is unknown.
fn aov_list(names: &[String]) -> PyResult<Vec<Aov>> {
    names
        .iter()
        .map(|name| {
            Aov::from_name(name).ok_or_else(|| {
                PyValueError::new_err(format!("unknown feature image {name:?}: use {}", Aov::names()))
            })
        })
        .collect()
}

/// A Python `**overrides` dict as run-file assignments, by the package's own rule
/// (`caustica._override_sets`: short keys to their sections, values to TOML).
fn override_sets(py: Python<'_>, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    match overrides {
        Some(d) if !d.is_empty() => py.import("caustica")?.getattr("_override_sets")?.call1((d,))?.extract(),
        _ => Ok(Vec::new()),
    }
}

impl Scene {
    /// The loaded settings with `extra` run-file assignments on top, and `aovs` as the feature
    /// images. Settings that change what is loaded (the camera's name, the environment) are the
    /// loader's: they are refused here.
    fn settings(&self, extra: &[String], aovs: &[String]) -> PyResult<RunFile> {
        if let Some(set) =
            extra.iter().find(|s| s.starts_with("camera.name") || s.starts_with("environment."))
        {
            return Err(PyValueError::new_err(format!(
                "{set}: this setting changes what is loaded; give it to caustica.load"
            )));
        }
        let mut run = if extra.is_empty() {
            self.run.clone()
        } else {
            let sets: Vec<String> = self.sets.iter().chain(extra).cloned().collect();
            let run = RunFile::parse_with_sets(&self.text, &sets).map_err(refused)?;
            run.check_settings().map_err(refused)?;
            run
        };
        run.film.aovs = aov_list(aovs)?;
        Ok(run)
    }

    /// A renderer of this scene with settings `run`, aiming at `target` units (samples per pixel, or
    /// passes) when given.
    fn renderer(&self, py: Python<'_>, run: &RunFile, target: Option<(u32, &str)>) -> PyResult<Renderer> {
        let scene = self.scene.clone();
        let mut renderer = py.detach(|| Renderer::new(scene, run)).map_err(crate::render_error)?;
        self.aim(&mut renderer, target)?;
        Ok(renderer)
    }

    /// Make `renderer` stop at whole units and aim at `target` when given.
    fn aim(&self, renderer: &mut Renderer, target: Option<(u32, &str)>) -> PyResult<()> {
        // Stop (Ctrl-C, a time limit) only at whole samples per pixel or passes, so that `done` is
        // exact and a session that goes on renders what an uninterrupted one would.
        renderer.set_whole_passes(true);
        if let Some((target, name)) = target {
            let integrator = renderer.integrator();
            let wanted = integrator.units_key();
            if name != wanted {
                return Err(PyValueError::new_err(format!(
                    "{}: {} counts its progress in {wanted}, not {name}",
                    self.path.display(),
                    integrator.name()
                )));
            }
            if target == 0 {
                return Err(PyValueError::new_err(format!("{name} must be at least 1")));
            }
            renderer.set_target(target);
        }
        Ok(())
    }
}

fn target_of(spp: Option<u32>, passes: Option<u32>) -> PyResult<Option<(u32, &'static str)>> {
    match (spp, passes) {
        (Some(_), Some(_)) => Err(PyValueError::new_err("give spp or passes, not both")),
        (Some(n), None) => Ok(Some((n, "spp"))),
        (None, Some(n)) => Ok(Some((n, "passes"))),
        (None, None) => Ok(None),
    }
}

#[pymethods]
impl Scene {
    /// The file the scene was loaded from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The integrator the settings choose.
    #[getter]
    fn integrator(&self) -> String {
        caustica::Choice::name(self.run.render.integrator).to_owned()
    }

    /// Render to the target, or to `spp`/`passes` when given, or until `time_limit` seconds, with
    /// the feature images `aovs` and the run file's keys as `overrides`.
    #[pyo3(signature = (spp=None, passes=None, time_limit=None, aovs=default_aovs(), **overrides))]
    fn render(
        &self,
        py: Python<'_>,
        spp: Option<u32>,
        passes: Option<u32>,
        time_limit: Option<f64>,
        aovs: Vec<String>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<RenderResult> {
        if time_limit.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
            return Err(PyValueError::new_err("time_limit must be a positive number of seconds"));
        }
        let run = self.settings(&override_sets(py, overrides)?, &aovs)?;
        let mut renderer = self.renderer(py, &run, target_of(spp, passes)?)?;
        let report = run_detached(py, &mut renderer, time_limit)?;
        let (image, features) = py.detach(|| (renderer.image(), renderer.aov_images()));
        Ok(RenderResult {
            color: color_array(py, &image)?.unbind(),
            aovs: aov_dict(
                py,
                features.as_ref(),
                &run.film.aovs,
                [image.height as usize, image.width as usize],
            )?
            .unbind(),
            stats: stats(py, &report)?.unbind(),
        })
    }

    /// Whether a render of these settings splits into parts that merge exactly (`render_part`), as
    /// the driver rules (`caustica::driver::share_refusal`).
    fn splits(&self) -> bool {
        caustica::driver::share_refusal(&self.run).is_none()
    }

    /// Render share `part` (from 1) of `parts` of the render of `spp` samples per pixel or `passes`
    /// (the settings' when not given) and write its accumulator to `path` (.exr): the shares of
    /// every part, merged by `merge`, are the bits of one render of the whole. `pt`, `pt-naive`,
    /// `pm`, `lt` and `pppm` split; the others refuse.
    #[pyo3(signature = (part, parts, path, spp=None, passes=None))]
    fn render_part(
        &self,
        py: Python<'_>,
        part: u32,
        parts: u32,
        path: PathBuf,
        spp: Option<u32>,
        passes: Option<u32>,
    ) -> PyResult<Py<PyDict>> {
        let mut run = self.settings(&[], &[])?;
        if let Some((n, unit)) = target_of(spp, passes)? {
            let integrator = caustica::integrators::of_run(&run);
            if unit != integrator.units_key() {
                return Err(PyValueError::new_err(format!(
                    "{}: {} does not count its progress in {unit}",
                    self.path.display(),
                    integrator.name()
                )));
            }
            integrator.set_units(&mut run, n);
        }
        let inputs = caustica::files::scene_inputs(&self.path, &run);
        if let Some(input) = caustica::files::overwritten_input(&path, inputs.iter().map(PathBuf::as_path)) {
            return Err(refused(format!(
                "{}: the part would overwrite {}, which the scene reads",
                path.display(),
                input.display()
            )));
        }
        let (mut renderer, info) = py
            .detach(|| Renderer::for_share(self.scene.clone(), &run, part, parts))
            .map_err(crate::render_error)?;
        let report = run_detached(py, &mut renderer, None)?;
        py.detach(|| accumulator::write_part(renderer.film(), &info, &path)).map_err(refused)?;
        Ok(stats(py, &report)?.unbind())
    }

    /// A render that a host advances a few units at a time (`step`), looking at it in between, with
    /// the feature images `aovs` and the run file's keys as `overrides`.
    #[pyo3(signature = (aovs=default_aovs(), **overrides))]
    fn session(
        &self,
        py: Python<'_>,
        aovs: Vec<String>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Session> {
        let run = self.settings(&override_sets(py, overrides)?, &aovs)?;
        // The scene kept as loaded, for `Session.set_transform` and `advance`.
        let scene = self.scene.clone();
        let mut frames = py.detach(|| FrameRun::new(scene, &run)).map_err(crate::render_error)?;
        self.aim(frames.renderer_mut(), None)?;
        Ok(Session::new(frames, run.film.aovs.clone()))
    }
}

/// The feature images a render makes unless told otherwise.
fn default_aovs() -> Vec<String> {
    Aov::CHOICES.iter().map(|(_, name, _)| name.to_string()).collect()
}

/// A finished (or stopped) render: `color` (float32, height × width × 3, linear), the feature
/// images `aovs` by name, and `stats`.
#[pyclass(module = "caustica", frozen)]
pub(crate) struct RenderResult {
    #[pyo3(get)]
    color: Py<PyAny>,
    #[pyo3(get)]
    aovs: Py<PyDict>,
    #[pyo3(get)]
    stats: Py<PyDict>,
}

#[pymethods]
impl RenderResult {
    /// `color` denoised by Intel Open Image Denoise, guided by `aovs["albedo"]` and
    /// `aovs["normal"]` (float32, height × width × 3): natively, with the GIL released, in a build
    /// with feature `denoise`; otherwise through the `pyoidn` package, a dependency of this one
    /// (`caustica.denoiser`, the same filter), so that a plain `pip install` denoises.
    fn denoised<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let aovs = self.aovs.bind(py);
        let guide = |name: &str| -> PyResult<Bound<'py, PyAny>> {
            aovs.get_item(name)?.ok_or_else(|| {
                refused(format!(
                    "cannot denoise: the render has no {name} image; render with aovs including \"albedo\" and \"normal\""
                ))
            })
        };
        let (albedo, normal) = (guide("albedo")?, guide("normal")?);
        let color = self.color.bind(py);
        if !caustica::film::denoise::AVAILABLE {
            return py.import("caustica.denoiser")?.call_method1("denoise", (color, albedo, normal));
        }
        let image =
            |array: &Bound<'py, PyAny>| image_of(&array.extract::<numpy::PyReadonlyArray3<'_, f32>>()?);
        let features = AovImages {
            albedo: image(&albedo)?,
            normal: image(&normal)?,
            depth: Vec::new(),
            spp: Vec::new(),
        };
        let color = image(color)?;
        let clean = py.detach(|| caustica::film::denoise::denoise(&color, &features)).map_err(refused)?;
        color_array(py, &clean)
    }
}

/// Whether this build of the package has the native denoiser (feature `denoise`); the package's
/// `has_denoiser()` also counts `pyoidn`.
#[pyfunction]
pub(crate) fn has_denoiser() -> bool {
    caustica::film::denoise::AVAILABLE
}

/// Load a glTF (.gltf, .glb) or run file (.toml), with `sets` (`"render.spp=16"`, any run-file key)
/// applied as if the run file had them.
#[pyfunction]
#[pyo3(signature = (path, sets=Vec::new()))]
pub(crate) fn load(py: Python<'_>, path: PathBuf, sets: Vec<String>) -> PyResult<Scene> {
    let (scene, run) = py.detach(|| scene::load_with_sets(&path, &sets, |_| {})).map_err(refused)?;
    let is_run_file = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let text = if is_run_file {
        std::fs::read_to_string(&path).map_err(|e| refused(format!("{}: {e}", path.display())))?
    } else {
        String::new()
    };
    Ok(Scene { scene, run, path, text, sets })
}
