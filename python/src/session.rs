//! The `Session` class: a progressive render a host steps between its own simulation steps.

use crate::convert::{aov_dict, color_array, stats};
use crate::{refused, run_detached};
use caustica::Renderer;
use caustica::film::aov::Aov;
use caustica::report::Unit;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A progressive render a host steps: `step(n)` adds n samples per pixel (or passes), `image()`
/// is the image so far.
#[pyclass(module = "caustica")]
pub(crate) struct Session {
    pub(crate) renderer: Renderer,
    /// The settings' target, what `step()` with no argument runs to.
    pub(crate) final_target: u32,
    /// The feature images it makes.
    pub(crate) aovs: Vec<Aov>,
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
