//! Helpers shared by the integration tests.
#![allow(dead_code)]

use caustica::film::Image;
use caustica::scene::{RunFile, Scene};
use caustica::systems::render::{init_thread_pools, prepare};
use std::path::{Path, PathBuf};

/// A file under tests/data.
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// Render a scene with the given run settings and return the image.
pub fn render(scene: Scene, run: &RunFile) -> Image {
    init_thread_pools(None);
    let mut renderer = prepare(scene, run).expect("scene prepares");
    renderer.run(|_| {});
    renderer.image()
}

/// Average 2×2 blocks: a box-filtered image at half resolution is exactly this of the full one.
pub fn downsample2(image: &Image) -> Image {
    let (w, h) = (image.width / 2, image.height / 2);
    let mut pixels = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let at = |dx: u32, dy: u32| image.pixels[((2 * y + dy) * image.width + 2 * x + dx) as usize];
            pixels.push((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) * 0.25);
        }
    }
    Image { width: w, height: h, pixels }
}

/// Mean and standard error of the per-pixel, per-channel differences a − b (pixels are independent
/// estimates, so the mean difference of two unbiased renders is 0 within a few standard errors).
pub fn paired_difference(a: &Image, b: &Image) -> (f64, f64) {
    let d: Vec<f64> =
        a.pixels.iter().zip(&b.pixels).flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]) as f64)).collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}
