//! The `Session` class: a progressive render a host steps between its own simulation steps.

use crate::convert::{aov_dict, color_array, stats};
use crate::{refused, run_detached};
use caustica::driver::FrameRun;
use caustica::film::aov::Aov;
use caustica::report::Unit;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Mutex, MutexGuard, TryLockError};

/// A progressive render a host steps: `step(n)` adds n samples per pixel (or passes), `image()`
/// is the image so far.
///
/// One call at a time: a call from a second Python thread waits (the GIL released) until the
/// first ends, rather than fail or see a renderer half-way through a step. Without the lock,
/// pyo3's borrow check refused the second thread's call with "Already borrowed", a message that
/// names neither the session nor the cause.
#[pyclass(module = "caustica", frozen)]
pub(crate) struct Session {
    frames: Mutex<FrameRun>,
    /// The settings' target, what `step()` with no argument runs to.
    final_target: u32,
    /// The feature images it makes.
    aovs: Vec<Aov>,
}

impl Session {
    pub(crate) fn new(frames: FrameRun, aovs: Vec<Aov>) -> Self {
        let final_target = frames.renderer().target();
        Self { frames: Mutex::new(frames), final_target, aovs }
    }

    /// The render, once no other thread's call holds it. The wait releases the GIL (the call
    /// holding the lock may need it to check for Ctrl-C) and looks at this thread's signals, so
    /// Ctrl-C ends a wait as it ends a step.
    fn lock(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, FrameRun>> {
        loop {
            match self.frames.try_lock() {
                Ok(frames) => return Ok(frames),
                // A panic in a call was raised as PanicException; the renderer is whole between
                // calls, as every change to it is made by one call.
                Err(TryLockError::Poisoned(e)) => return Ok(e.into_inner()),
                Err(TryLockError::WouldBlock) => {
                    py.detach(|| std::thread::sleep(std::time::Duration::from_millis(2)));
                    py.check_signals()?;
                }
            }
        }
    }
}

#[pymethods]
impl Session {
    /// Add `units` samples per pixel (or passes, for the progressive photon mappers), with the GIL
    /// released; without an argument, run to the settings' target.
    #[pyo3(signature = (units=None))]
    fn step(&self, py: Python<'_>, units: Option<u32>) -> PyResult<Py<PyDict>> {
        let mut frames = self.lock(py)?;
        let renderer = frames.renderer_mut();
        let done = renderer.units_done();
        let target = match units {
            Some(0) => return Err(PyValueError::new_err("step(units): units must be at least 1")),
            Some(n) => done.saturating_add(n),
            None => self.final_target.max(done),
        };
        renderer.set_target(target);
        let report = run_detached(py, renderer, None)?;
        Ok(stats(py, &report)?.unbind())
    }

    /// Move glTF node `node` (its name, or its index) by the 4 × 4 `matrix` (row-major, applied to
    /// the node's geometry as posed, so the identity puts it back), update what the renderer traces
    /// against (once a node has moved, only the moving meshes' BVH is rebuilt), and start the image
    /// over: `done` is 0 again, and the next `step` renders the moved scene. Returns where the time
    /// went (`pose`, `bvh`, `lights` seconds).
    fn set_transform<'py>(
        &self,
        py: Python<'py>,
        node: String,
        matrix: [[f32; 4]; 4],
    ) -> PyResult<Bound<'py, PyDict>> {
        let m = glam::Mat4::from_cols_array_2d(&matrix).transpose();
        let mut guard = self.lock(py)?;
        let frames = &mut *guard;
        let update = py.detach(|| frames.move_node(&node, m)).map_err(setting_or_refused)?;
        frame_dict(py, &update)
    }

    /// Pose the file's animations at `time` seconds (meshes, its camera, its lights) and start the
    /// image over, the moved meshes' BVH rebuilt alone; `pm` keeps its photon maps when only the
    /// camera moved. Returns where the time went (`pose`, `bvh`, `lights` seconds, `photons_kept`).
    fn advance<'py>(&self, py: Python<'py>, time: f32) -> PyResult<Bound<'py, PyDict>> {
        let mut guard = self.lock(py)?;
        let frames = &mut *guard;
        let update = py.detach(|| frames.set_time(time)).map_err(setting_or_refused)?;
        frame_dict(py, &update)
    }

    /// Place the camera at `eye` looking at `target`, `up` up, with vertical field of view
    /// `yfov_degrees` (None keeps the current one), and start the image over.
    #[pyo3(signature = (eye, target, up=[0.0, 1.0, 0.0], yfov_degrees=None))]
    fn set_camera(
        &self,
        py: Python<'_>,
        eye: [f32; 3],
        target: [f32; 3],
        up: [f32; 3],
        yfov_degrees: Option<f32>,
    ) -> PyResult<()> {
        if let Some(y) = yfov_degrees
            && !(y > 0.0 && y < 180.0)
        {
            return Err(PyValueError::new_err(format!(
                "set_camera: yfov_degrees must be in (0, 180), got {y}"
            )));
        }
        self.lock(py)?
            .set_camera(eye.into(), target.into(), up.into(), yfov_degrees.map(f32::to_radians))
            .map_err(setting_or_refused)
    }

    /// The length of the file's animation in seconds (its last keyframe; 0 without one).
    #[getter]
    fn duration(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.lock(py)?.animation_duration())
    }

    /// The image so far: float32, height × width × 3, linear.
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let guard = self.lock(py)?;
        let renderer = guard.renderer();
        let image = py.detach(|| renderer.image());
        color_array(py, &image)
    }

    /// The feature images so far, by name (empty when the session makes none).
    fn aovs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let guard = self.lock(py)?;
        let renderer = guard.renderer();
        let features = py.detach(|| renderer.aov_images());
        let film = renderer.film();
        aov_dict(py, features.as_ref(), &self.aovs, [film.height as usize, film.width as usize])
    }

    /// Units done: samples per pixel, or passes.
    #[getter]
    fn done(&self, py: Python<'_>) -> PyResult<u32> {
        Ok(self.lock(py)?.renderer().units_done())
    }

    /// What the session counts: "spp" or "passes".
    #[getter]
    fn unit(&self, py: Python<'_>) -> PyResult<&'static str> {
        let samples = self.lock(py)?.renderer().progress().unit == Unit::Samples;
        Ok(if samples { "spp" } else { "passes" })
    }
}

/// A bad value is a `ValueError`; anything else the renderer refuses as the module does.
fn setting_or_refused(e: caustica::error::Error) -> PyErr {
    match e {
        caustica::error::Error::Setting { .. } => PyValueError::new_err(e.to_string()),
        e => refused(e),
    }
}

/// A frame update's times as a dict.
fn frame_dict<'py>(py: Python<'py>, update: &caustica::driver::FrameUpdate) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("pose", update.pose_seconds + update.camera_seconds)?;
    d.set_item("bvh", update.scene.geometry_seconds)?;
    d.set_item("lights", update.scene.lights_seconds)?;
    d.set_item("whole_build", update.scene.whole_build)?;
    d.set_item("photons_kept", update.photons_kept)?;
    Ok(d)
}
