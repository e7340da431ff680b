//! `caustica merge`: a split render's parts added into one image.

use crate::outputs::check_outputs;
use anyhow::Result;
use caustica::film::{accumulator, output};
use std::path::PathBuf;
use std::time::Instant;

/// `caustica merge`: the parts' sums added, the image written to every output.
pub fn merge(parts: &[PathBuf], outputs: &[PathBuf], exposure: f32) -> Result<()> {
    check_outputs(outputs, parts)?;
    let start = Instant::now();
    let (film, info) = accumulator::merge_parts(parts)?;
    let image = film.image();
    for path in outputs {
        output::write_image(&image, path, exposure)?;
    }
    outln!(
        "merged      {} parts of {}x{}, {} spp ({}) in {:.3} s",
        parts.len(),
        film.width,
        film.height,
        info.spp,
        info.integrator,
        start.elapsed().as_secs_f64()
    );
    for path in outputs {
        outln!("wrote       {}", path.display());
    }
    Ok(())
}
