//! `caustica._caustica`, the compiled half of the `caustica` Python package: a scene loaded from a
//! glTF or run file, rendered to numpy arrays with the GIL released, and a progressive session a
//! host steps between its own simulation steps. The pure-Python half (`caustica/__init__.py`) turns
//! keyword overrides into run-file assignments and documents the API.
//!
//! This file holds the error, the run with the GIL released and the module's registration; the
//! classes are in `scene.rs` (`Scene`, `RenderResult`, `load`) and `session.rs` (`Session`), the
//! image-file functions in `images.rs`, and the conversions to numpy arrays and dicts in
//! `convert.rs`.

mod convert;
mod images;
mod scene;
mod session;

use caustica::Renderer;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
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

/// The renderer's error as Python's: memory the machine has not got is a `MemoryError` (the process
/// goes on: nothing of it was allocated), the rest a `CausticaError`.
fn render_error(e: caustica::error::Error) -> PyErr {
    match e {
        caustica::error::Error::OutOfMemory { .. } => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
        e => refused(e),
    }
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

#[pymodule]
fn _caustica(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Every core, as the command line without --threads: the pools are per process.
    caustica::world::init_thread_pools(None);
    m.add("CausticaError", m.py().get_type::<CausticaError>())?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<scene::RenderResult>()?;
    m.add_class::<session::Session>()?;
    m.add_function(wrap_pyfunction!(scene::load, m)?)?;
    m.add_function(wrap_pyfunction!(images::read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(images::read_exr_channels, m)?)?;
    m.add_function(wrap_pyfunction!(scene::has_denoiser, m)?)?;
    m.add_function(wrap_pyfunction!(images::merge, m)?)?;
    m.add_function(wrap_pyfunction!(images::write_image, m)?)?;
    m.add_function(wrap_pyfunction!(images::compare, m)?)?;
    m.add_function(wrap_pyfunction!(short_keys, m)?)?;
    // The registry's names, so that Python code and tests go over the integrators as the command does.
    m.add("INTEGRATORS", caustica::integrators::names().collect::<Vec<_>>())?;
    Ok(())
}

/// The run-file keys an override may give without its table, each with its table: the core's one
/// list, which `--set` and `-D` read too.
#[pyfunction]
fn short_keys() -> Vec<(&'static str, &'static str)> {
    caustica::scene::run_file::SHORT_KEYS.to_vec()
}
