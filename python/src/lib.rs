//! `caustica._caustica`, the compiled half of the `caustica` Python package: a scene loaded from a
//! glTF or run file, rendered to numpy arrays with the GIL released, and a progressive session a
//! host steps between its own simulation steps. The pure-Python half (`caustica/__init__.py`) turns
//! keyword overrides into run-file assignments and documents the API.

use caustica::film::accumulator;
use caustica::film::aov::{Aov, AovImages};
use caustica::report::Unit;
use caustica::scene::{self, RunFile};
use caustica::{Choice, Renderer};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

pyo3::create_exception!(
    _caustica,
    CausticaError,
    PyException,
    "A scene, setting or file Caustica refused: the message names the file, the object and the problem."
);

fn refused(e: impl std::fmt::Display) -> PyErr {
    CausticaError::new_err(e.to_string())
}

/// A linear RGB image as a float32 array of height × width × 3.
fn color_array<'py>(py: Python<'py>, image: &caustica::film::Image) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f32> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
    let array = PyArray1::from_vec(py, flat).reshape([image.height as usize, image.width as usize, 3])?;
    Ok(array.into_any())
}

/// Run `renderer` to its target (or `time_limit`) with the GIL released. Ctrl-C (or any pending
/// Python signal) stops it at its next step; the signal's exception is raised once it has stopped,
/// so the image so far stays valid and the renderer can go on later.
fn run_detached(
    py: Python<'_>,
    renderer: &mut Renderer,
    time_limit: Option<f64>,
) -> PyResult<caustica::Report> {
    let flag = renderer.interrupt_flag();
    let mut pending: Option<PyErr> = None;
    let report = py.detach(|| {
        renderer.run(time_limit, |_| {
            if pending.is_none()
                && let Err(e) = Python::attach(|py| py.check_signals())
            {
                pending = Some(e);
                flag.store(true, Ordering::Relaxed);
            }
        })
    });
    match pending {
        Some(e) => {
            renderer.clear_stop();
            Err(e)
        }
        None => Ok(report),
    }
}

/// What a render did, as a dict of plain numbers.
fn stats<'py>(py: Python<'py>, report: &caustica::Report) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("integrator", format!("{:?}", report.integrator).to_lowercase())?;
    d.set_item("unit", if report.unit == Unit::Samples { "spp" } else { "passes" })?;
    d.set_item("done", report.done)?;
    d.set_item("target", report.target)?;
    d.set_item("seed", report.seed)?;
    d.set_item("seconds", report.seconds)?;
    d.set_item("samples", report.paths.samples)?;
    d.set_item("rays", report.paths.rays)?;
    d.set_item("shadow_rays", report.paths.shadow_rays)?;
    d.set_item("nan_samples", report.paths.nan_samples)?;
    d.set_item("stopped_by", report.stopped_by.map(|s| format!("{s:?}").to_lowercase()))?;
    if let Some(adaptive) = &report.adaptive {
        d.set_item("pixels_converged", adaptive.estimate.converged)?;
        d.set_item("estimated_relmse", adaptive.estimate.relmse)?;
    }
    Ok(d)
}

/// A scene and its settings, loaded once; every render builds its own renderer from them.
#[pyclass(module = "caustica", frozen)]
struct Scene {
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
    /// A renderer of these settings aiming at `target`; `movable` keeps the scene as loaded, for
    /// `Session.set_transform`.
    fn renderer(
        &self,
        py: Python<'_>,
        run: &RunFile,
        target: Option<(u32, &str)>,
        movable: bool,
    ) -> PyResult<Renderer> {
        let scene = self.scene.clone();
        let made =
            py.detach(|| if movable { Renderer::movable(scene, run) } else { Renderer::new(scene, run) });
        let mut renderer = made.map_err(refused)?;
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
        Ok(renderer)
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
        format!("{:?}", self.run.render.integrator).to_lowercase()
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
        let mut renderer = self.renderer(py, &run, target_of(spp, passes)?, false)?;
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
    /// `pm` and `pppm` split; the others refuse.
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
        let (mut renderer, info) =
            py.detach(|| Renderer::for_share(self.scene.clone(), &run, part, parts)).map_err(refused)?;
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
        let renderer = self.renderer(py, &run, None, true)?;
        let final_target = renderer.target();
        Ok(Session { renderer, final_target, aovs: run.film.aovs.clone() })
    }
}

/// The feature images a render makes unless told otherwise.
fn default_aovs() -> Vec<String> {
    Aov::CHOICES.iter().map(|(_, name, _)| name.to_string()).collect()
}

/// The feature images `which` as numpy arrays by name: `albedo` and `normal` float32 height ×
/// width × 3, `depth` float32 height × width.
fn aov_dict<'py>(
    py: Python<'py>,
    features: Option<&AovImages>,
    which: &[Aov],
    size: [usize; 2],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let Some(features) = features else { return Ok(d) };
    for &aov in which {
        let array = match aov {
            Aov::Albedo => color_array(py, &features.albedo)?,
            Aov::Normal => color_array(py, &features.normal)?,
            Aov::Depth => PyArray1::from_slice(py, &features.depth).reshape(size)?.into_any(),
            Aov::Spp => PyArray1::from_slice(py, &features.spp).reshape(size)?.into_any(),
        };
        d.set_item(aov.name(), array)?;
    }
    Ok(d)
}

/// A finished (or stopped) render: `color` (float32, height × width × 3, linear), the feature
/// images `aovs` by name, and `stats`.
#[pyclass(module = "caustica", frozen)]
struct RenderResult {
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
    /// `aovs["normal"]` (float32, height × width × 3), with the GIL released. Needs a build with
    /// feature `denoise` and a render with those two feature images.
    fn denoised<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        caustica::film::denoise::check_available().map_err(refused)?;
        let aovs = self.aovs.bind(py);
        let guide = |name: &str| -> PyResult<caustica::film::Image> {
            let array = aovs.get_item(name)?.ok_or_else(|| {
                refused(format!(
                    "cannot denoise: the render has no {name} image; render with aovs including \"albedo\" and \"normal\""
                ))
            })?;
            image_of(&array.extract::<numpy::PyReadonlyArray3<'_, f32>>()?)
        };
        let features = AovImages {
            albedo: guide("albedo")?,
            normal: guide("normal")?,
            depth: Vec::new(),
            spp: Vec::new(),
        };
        let color = image_of(&self.color.bind(py).extract::<numpy::PyReadonlyArray3<'_, f32>>()?)?;
        let clean = py.detach(|| caustica::film::denoise::denoise(&color, &features)).map_err(refused)?;
        color_array(py, &clean)
    }
}

/// Whether this build of the package has the denoiser (`RenderResult.denoised`).
#[pyfunction]
fn has_denoiser() -> bool {
    caustica::film::denoise::AVAILABLE
}

/// A progressive render a host steps: `step(n)` adds n samples per pixel (or passes), `image()`
/// is the image so far.
#[pyclass(module = "caustica")]
struct Session {
    renderer: Renderer,
    /// The settings' target, what `step()` with no argument runs to.
    final_target: u32,
    /// The feature images it makes.
    aovs: Vec<Aov>,
}

#[pymethods]
impl Session {
    /// Add `units` samples per pixel (or passes, for the progressive photon mappers), with the GIL
    /// released; without an argument, run to the settings' target.
    #[pyo3(signature = (units=None))]
    fn step(&mut self, py: Python<'_>, units: Option<u32>) -> PyResult<Py<PyDict>> {
        let done = self.renderer.units_done();
        let target = match units {
            Some(0) => return Err(PyValueError::new_err("step(units): units must be at least 1")),
            Some(n) => done.saturating_add(n),
            None => self.final_target.max(done),
        };
        self.renderer.set_target(target);
        let report = run_detached(py, &mut self.renderer, None)?;
        Ok(stats(py, &report)?.unbind())
    }

    /// Move glTF node `node` (its name, or its index) by the 4 × 4 `matrix` (row-major, applied to
    /// the node's geometry as loaded, so the identity puts it back), rebuild what the renderer
    /// traces against, and start the image over: `done` is 0 again, and the next `step` renders
    /// the moved scene.
    fn set_transform(&mut self, py: Python<'_>, node: String, matrix: [[f32; 4]; 4]) -> PyResult<()> {
        let m = glam::Mat4::from_cols_array_2d(&matrix).transpose();
        py.detach(|| self.renderer.move_node(&node, m)).map_err(|e| match e {
            caustica::error::Error::Setting { .. } => PyValueError::new_err(e.to_string()),
            e => refused(e),
        })
    }

    /// The image so far: float32, height × width × 3, linear.
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let image = py.detach(|| self.renderer.image());
        color_array(py, &image)
    }

    /// The feature images so far, by name (empty when the session makes none).
    fn aovs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let features = py.detach(|| self.renderer.aov_images());
        let film = self.renderer.film();
        aov_dict(py, features.as_ref(), &self.aovs, [film.height as usize, film.width as usize])
    }

    /// Units done: samples per pixel, or passes.
    #[getter]
    fn done(&self) -> u32 {
        self.renderer.units_done()
    }

    /// What the session counts: "spp" or "passes".
    #[getter]
    fn unit(&self) -> &'static str {
        if self.renderer.progress().unit == Unit::Samples { "spp" } else { "passes" }
    }
}

/// Load a glTF (.gltf, .glb) or run file (.toml), with `sets` (`"render.spp=16"`, any run-file key)
/// applied as if the run file had them.
#[pyfunction]
#[pyo3(signature = (path, sets=Vec::new()))]
fn load(py: Python<'_>, path: PathBuf, sets: Vec<String>) -> PyResult<Scene> {
    let (scene, run) = py.detach(|| scene::load_with_sets(&path, &sets, |_| {})).map_err(refused)?;
    let is_run_file = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let text = if is_run_file {
        std::fs::read_to_string(&path).map_err(|e| refused(format!("{}: {e}", path.display())))?
    } else {
        String::new()
    };
    Ok(Scene { scene, run, path, text, sets })
}

/// Merge the accumulators of a split render (`Scene.render_part`, or `caustica render --part`):
/// the image, float32 height × width × 3, and what it is (integrator, parts, units). Refused,
/// naming the files, when a part is missing, repeated, of another render or incomplete.
#[pyfunction]
fn merge<'py>(py: Python<'py>, paths: Vec<PathBuf>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let (film, info) = py.detach(|| accumulator::merge_parts(&paths)).map_err(refused)?;
    let image = py.detach(|| film.image());
    let d = PyDict::new(py);
    d.set_item("integrator", info.integrator)?;
    d.set_item("parts", paths.len())?;
    d.set_item("units", info.spp)?;
    Ok((color_array(py, &image)?, d))
}

/// Write a float32 height × width × 3 linear image as .exr or .png (tone-mapped as the command
/// line's PNGs), through a temporary file renamed over `path`.
#[pyfunction]
#[pyo3(signature = (path, color, exposure=1.0))]
fn write_image(
    py: Python<'_>,
    path: PathBuf,
    color: numpy::PyReadonlyArray3<'_, f32>,
    exposure: f32,
) -> PyResult<()> {
    let image = image_of(&color)?;
    py.detach(|| caustica::film::output::write_image(&image, &path, exposure)).map_err(refused)
}

/// A float32 height × width × 3 array as an image.
fn image_of(color: &numpy::PyReadonlyArray3<'_, f32>) -> PyResult<caustica::film::Image> {
    let array = color.as_array();
    let shape = array.shape();
    if shape[2] != 3 {
        return Err(PyValueError::new_err(format!("an image is height x width x 3, not {shape:?}")));
    }
    let pixels = array.rows().into_iter().map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect();
    Ok(caustica::film::Image { width: shape[1] as u32, height: shape[0] as u32, pixels })
}

/// The error of `image` against `reference` (float32 height × width × 3, linear): RMSE, relMSE and
/// MAE over linear RGB, and mean LDR-FLIP, as `caustica compare` prints them.
#[pyfunction]
fn compare<'py>(
    py: Python<'py>,
    image: numpy::PyReadonlyArray3<'_, f32>,
    reference: numpy::PyReadonlyArray3<'_, f32>,
) -> PyResult<Bound<'py, PyDict>> {
    let (a, b) = (image_of(&image)?, image_of(&reference)?);
    let sizes =
        || PyValueError::new_err(format!("{}x{} against {}x{}", a.width, a.height, b.width, b.height));
    let (e, perceptual) =
        py.detach(|| (caustica::film::compare::compare(&a, &b), caustica::film::flip::flip(&a, &b)));
    let (e, perceptual) = (e.ok_or_else(sizes)?, perceptual.ok_or_else(sizes)?);
    let d = PyDict::new(py);
    d.set_item("rmse", e.rmse)?;
    d.set_item("relmse", e.relmse)?;
    d.set_item("mae", e.mae)?;
    d.set_item("flip", perceptual.mean)?;
    Ok(d)
}

/// Read an OpenEXR image (a reference, or the command line's output) as float32, height × width × 3.
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let image = py.detach(|| caustica::film::output::read_exr(&path)).map_err(refused)?;
    color_array(py, &image)
}

/// Every channel of an OpenEXR file by name (`R`, `albedo.R`, `N.X`, `Z`, …), each float32 height
/// × width: the command line's feature-image layers.
#[pyfunction]
fn read_exr_channels<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let (width, height, channels) =
        py.detach(|| caustica::film::output::read_exr_channels(&path)).map_err(refused)?;
    let d = PyDict::new(py);
    for (name, samples) in channels {
        d.set_item(name, PyArray1::from_vec(py, samples).reshape([height as usize, width as usize])?)?;
    }
    Ok(d)
}

#[pymodule]
fn _caustica(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Every core, as the command line without --threads: the pools are per process.
    caustica::world::init_thread_pools(None);
    m.add("CausticaError", m.py().get_type::<CausticaError>())?;
    m.add_class::<Scene>()?;
    m.add_class::<RenderResult>()?;
    m.add_class::<Session>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr_channels, m)?)?;
    m.add_function(wrap_pyfunction!(has_denoiser, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    Ok(())
}
