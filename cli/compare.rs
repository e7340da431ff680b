//! `caustica compare`: the error of one image against another.

use anyhow::{Context, Result};
use caustica::film::{compare::compare, flip::flip, output};
use std::path::Path;

/// Print RMSE, relMSE, MAE and mean FLIP of `image` against `reference`, over `window` (X0,Y0,X1,Y1) if given.
pub fn compare_files(image: &Path, reference: &Path, window: Option<&[u32]>) -> Result<()> {
    let mut a = output::read_exr(image)?;
    let mut b = output::read_exr(reference)?;
    match window {
        Some(&[x0, y0, x1, y1]) => {
            if !(x0 < x1 && y0 < y1 && x1 <= a.width && y1 <= a.height) {
                anyhow::bail!(
                    "--window {x0},{y0},{x1},{y1} is not a non-empty rectangle inside {} ({}x{})",
                    image.display(),
                    a.width,
                    a.height
                );
            }
            (a, b) = (a.crop(x0, y0, x1, y1), b.crop(x0, y0, x1, y1))
        }
        Some(w) => anyhow::bail!("--window takes X0,Y0,X1,Y1 (four numbers), got {} numbers", w.len()),
        None => {}
    }
    let e = compare(&a, &b).with_context(|| {
        format!(
            "{} is {}x{} but {} is {}x{}",
            image.display(),
            a.width,
            a.height,
            reference.display(),
            b.width,
            b.height
        )
    })?;
    let perceptual = flip(&a, &b).expect("sizes checked above");
    outln!("RMSE {:.6}\nrelMSE {:.6}\nMAE {:.6}", e.rmse, e.relmse, e.mae);
    outln!("FLIP {:.6}  (mean LDR-FLIP after the PNG tone map, 67 pixels per degree)", perceptual.mean);
    Ok(())
}
