//! Functions on image files and arrays: merging a split render's parts, writing, comparing and
//! reading images.

use crate::convert::{color_array, image_of};
use crate::refused;
use caustica::film::accumulator;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Merge the accumulators of a split render (`Scene.render_part`, or `caustica render --part`):
/// the image, float32 height × width × 3, and what it is (integrator, parts, units). Refused,
/// naming the files, when a part is missing, repeated, of another render or incomplete.
#[pyfunction]
pub(crate) fn merge<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
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
#[pyo3(signature = (path, color, exposure=0.0))]
pub(crate) fn write_image(
    py: Python<'_>,
    path: PathBuf,
    color: numpy::PyReadonlyArray3<'_, f32>,
    exposure: f32,
) -> PyResult<()> {
    let image = image_of(&color)?;
    py.detach(|| caustica::film::output::write_image(&image, &path, exposure)).map_err(refused)
}

/// The error of `image` against `reference` (float32 height × width × 3, linear): RMSE, relMSE and
/// MAE over linear RGB, and mean LDR-FLIP, as `caustica compare` prints them.
#[pyfunction]
pub(crate) fn compare<'py>(
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
pub(crate) fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let image = py.detach(|| caustica::film::output::read_exr(&path)).map_err(refused)?;
    color_array(py, &image)
}

/// Every channel of an OpenEXR file by name (`R`, `albedo.R`, `N.X`, `Z`, …), each float32 height
/// × width: the command line's feature-image layers.
#[pyfunction]
pub(crate) fn read_exr_channels<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let (width, height, channels) =
        py.detach(|| caustica::film::output::read_exr_channels(&path)).map_err(refused)?;
    let d = PyDict::new(py);
    for (name, samples) in channels {
        d.set_item(name, PyArray1::from_vec(py, samples).reshape([height as usize, width as usize])?)?;
    }
    Ok(d)
}
