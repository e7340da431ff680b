//! False-colour images of the per-pixel error, for seeing where an integrator is wrong.

use caustica::film::Image;
use caustica::{Error, Result};
use std::path::Path;

/// Decades of relative squared error the colour ramp spans: 1e-6 (black) to 1 (white).
const DECADES: f32 = 6.0;

/// The colour of t ∈ [0, 1] on a black → blue → magenta → orange → white ramp (perceptually ordered,
/// readable in greyscale too).
fn ramp(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 5] =
        [[0.0, 0.0, 0.0], [0.1, 0.1, 0.6], [0.7, 0.1, 0.6], [1.0, 0.6, 0.1], [1.0, 1.0, 1.0]];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let (i, f) = ((x as usize).min(STOPS.len() - 2), x.fract());
    let i = if x >= (STOPS.len() - 1) as f32 { STOPS.len() - 2 } else { i };
    let f = if x >= (STOPS.len() - 1) as f32 { 1.0 } else { f };
    std::array::from_fn(|c| ((STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f) * 255.0).round() as u8)
}

/// Write the per-pixel relative squared error (a − b)² / (b² + 0.01), averaged over channels (the
/// pixel's share of relMSE), on a log scale, as a PNG.
pub fn write_error_image(image: &Image, reference: &Image, path: &Path) -> Result<()> {
    let fail = |message: String| Error::Output { path: path.into(), message };
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(fail("the image and the reference differ in size".into()));
    }
    let mut pixels = Vec::with_capacity(image.pixels.len() * 3);
    for (a, b) in image.pixels.iter().zip(&reference.pixels) {
        let e = (0..3).map(|c| (a[c] - b[c]).powi(2) / (b[c] * b[c] + 0.01)).sum::<f32>() / 3.0;
        let t = if e.is_finite() { (e.max(1e-12).log10() + DECADES) / DECADES } else { 1.0 };
        pixels.extend(ramp(t));
    }
    image::RgbImage::from_raw(image.width, image.height, pixels)
        .ok_or_else(|| fail("buffer size".into()))?
        .save(path)
        .map_err(|e| fail(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::ramp;

    #[test]
    fn ramp_runs_from_black_to_white_and_brightens_monotonically() {
        assert_eq!(ramp(0.0), [0, 0, 0]);
        assert_eq!(ramp(1.0), [255, 255, 255]);
        let luminance = |c: [u8; 3]| 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = luminance(ramp(i as f32 / 100.0));
            assert!(l >= last - 0.5, "luminance falls at {i}: {l} < {last}");
            last = l;
        }
    }
}
