//! Conversions between the renderer's images and reports and Python's numpy arrays and dicts.

use caustica::Choice;
use caustica::film::aov::{Aov, AovImages};
use caustica::report::Unit;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A linear RGB image as a float32 array of height × width × 3.
pub(crate) fn color_array<'py>(
    py: Python<'py>,
    image: &caustica::film::Image,
) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f32> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
    let array = PyArray1::from_vec(py, flat).reshape([image.height as usize, image.width as usize, 3])?;
    Ok(array.into_any())
}

/// What a render did, as a dict of plain numbers.
pub(crate) fn stats<'py>(py: Python<'py>, report: &caustica::Report) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("integrator", caustica::Choice::name(report.integrator))?;
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
    // The integrator's own lines of the command's summary (the guide's, bdpt's subpaths), by label.
    let notes = PyDict::new(py);
    for (label, text) in &report.notes {
        notes.set_item(*label, text)?;
    }
    d.set_item("notes", notes)?;
    Ok(d)
}

/// The feature images `which` as numpy arrays by name: `albedo` and `normal` float32 height ×
/// width × 3, `depth` float32 height × width.
pub(crate) fn aov_dict<'py>(
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

/// A float32 height × width × 3 array as an image.
pub(crate) fn image_of(color: &numpy::PyReadonlyArray3<'_, f32>) -> PyResult<caustica::film::Image> {
    let array = color.as_array();
    let shape = array.shape();
    if shape[2] != 3 {
        return Err(PyValueError::new_err(format!("an image is height x width x 3, not {shape:?}")));
    }
    let (Ok(width), Ok(height)) = (u32::try_from(shape[1]), u32::try_from(shape[0])) else {
        return Err(PyValueError::new_err(format!(
            "an image is at most 2^32 - 1 pixels a side, not {shape:?}"
        )));
    };
    if width == 0 || height == 0 {
        return Err(PyValueError::new_err(format!("an image has at least one pixel, not {shape:?}")));
    }
    // An array can claim a shape it does not hold (numpy's zero strides): its copy as pixels is
    // refused when it cannot fit, where allocating it would abort the interpreter.
    let bytes = (width as u64 * height as u64).saturating_mul(size_of::<glam::Vec3>() as u64);
    let mut pixels = Vec::new();
    if bytes > caustica::memory::physical_bytes() || pixels.try_reserve_exact(shape[0] * shape[1]).is_err() {
        return Err(PyMemoryError::new_err(format!(
            "an image of {shape:?} takes {bytes} bytes as pixels, more than this machine has"
        )));
    }
    pixels.extend(array.rows().into_iter().map(|p| glam::Vec3::new(p[0], p[1], p[2])));
    Ok(caustica::film::Image { width, height, pixels })
}
