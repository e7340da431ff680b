//! Helpers shared by the integration tests.
#![allow(dead_code)]

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::film::Image;
use caustica::scene::{RunFile, Scene};
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, TestRng, TestRunner};
use std::path::{Path, PathBuf};

/// A file under tests/data.
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// tests/data/cornell-box.gltf with one animation channel: node `node`'s `path` ("translation",
/// "rotation" needs four values, so "translation" or "scale") from `values[0]` at 0 s to `values[1]`
/// at 1 s by `interpolation`, its keyframes in a .bin beside it; written into `dir` as `name`.
/// `edit` changes the file's JSON before it is written (a light added, a rest scale).
pub fn keyframed_cornell(
    dir: &Path,
    name: &str,
    (node, path): (&str, &str),
    values: [[f32; 3]; 2],
    interpolation: &str,
    edit: impl FnOnce(&mut serde_json::Value),
) -> PathBuf {
    let mut gltf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data("cornell-box.gltf")).unwrap()).unwrap();
    let index = gltf["nodes"].as_array().unwrap().iter().position(|n| n["name"] == node).unwrap();
    let keys = format!("{name}.bin");
    let floats = [0.0f32, 1.0].into_iter().chain(values.into_iter().flatten());
    std::fs::write(dir.join(&keys), floats.flat_map(f32::to_le_bytes).collect::<Vec<u8>>()).unwrap();
    let buffer = gltf["buffers"].as_array().unwrap().len();
    gltf["buffers"].as_array_mut().unwrap().push(serde_json::json!({"uri": keys, "byteLength": 32}));
    let view = gltf["bufferViews"].as_array().unwrap().len();
    gltf["bufferViews"].as_array_mut().unwrap().extend([
        serde_json::json!({"buffer": buffer, "byteOffset": 0, "byteLength": 8}),
        serde_json::json!({"buffer": buffer, "byteOffset": 8, "byteLength": 24}),
    ]);
    let accessor = gltf["accessors"].as_array().unwrap().len();
    gltf["accessors"].as_array_mut().unwrap().extend([
        serde_json::json!({"bufferView": view, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0.0], "max": [1.0]}),
        serde_json::json!({"bufferView": view + 1, "componentType": 5126, "count": 2, "type": "VEC3"}),
    ]);
    gltf["animations"] = serde_json::json!([{
        "channels": [{"sampler": 0, "target": {"node": index, "path": path}}],
        "samplers": [{"input": accessor, "output": accessor + 1, "interpolation": interpolation}],
    }]);
    edit(&mut gltf);
    let file = dir.join(name);
    std::fs::write(&file, gltf.to_string()).unwrap();
    file
}

/// A proptest runner with a fixed seed and no persisted failures, so CI runs the same cases every
/// time; `PROPTEST_CASES=N` runs N cases instead of `default_cases`.
pub fn fuzz_runner(default_cases: u32) -> TestRunner {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default_cases);
    let config = Config {
        cases,
        failure_persistence: None::<FileFailurePersistence>.map(|p| Box::new(p) as _),
        max_shrink_iters: 256,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]))
}

/// Render a scene with the given run settings and return the image.
pub fn render(scene: Scene, run: &RunFile) -> Image {
    try_render(scene, run).expect("scene prepares")
}

/// Render with the driver; Err carries the error message.
pub fn try_render(scene: Scene, run: &RunFile) -> Result<Image, String> {
    init_thread_pools(None);
    let mut renderer = Renderer::new(scene, run).map_err(|e| e.to_string())?;
    renderer.run(None, |_| {});
    Ok(renderer.image())
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

/// Mean and standard error of the per-pixel differences a − b, channels averaged first (the channels
/// of one pixel come from the same paths; pixels are independent estimates, so the mean difference of
/// two unbiased renders is 0 within a few standard errors).
pub fn paired_difference(a: &Image, b: &Image) -> (f64, f64) {
    let d: Vec<f64> = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (0..3).map(|c| (x[c] - y[c]) as f64).sum::<f64>() / 3.0)
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// z-score of the mean difference a − b in each cell of an n×n grid of pixel blocks: a bias confined
/// to one object (a glass sphere, a caustic) shows in its block long before it moves the image mean.
pub fn block_z_scores(a: &Image, b: &Image, n: u32) -> Vec<f64> {
    let (bw, bh) = (a.width / n, a.height / n);
    let mut z = Vec::new();
    for by in 0..n {
        for bx in 0..n {
            let d: Vec<f64> = (by * bh..(by + 1) * bh)
                .flat_map(|y| (bx * bw..(bx + 1) * bw).map(move |x| (y * a.width + x) as usize))
                .map(|i| (0..3).map(|c| (a.pixels[i][c] - b.pixels[i][c]) as f64).sum::<f64>() / 3.0)
                .collect();
            let m = d.len() as f64;
            let mean = d.iter().sum::<f64>() / m;
            let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (m - 1.0);
            z.push(if var > 0.0 { mean / (var / m).sqrt() } else { 0.0 });
        }
    }
    z
}

/// What `tracing` logs (as text) while `f` runs, and what `f` returns.
pub fn capture_logs<T>(f: impl FnOnce() -> T) -> (T, String) {
    use std::io::Write;
    use std::sync::{Arc, Mutex};
    #[derive(Clone, Default)]
    struct Buffer(Arc<Mutex<Vec<u8>>>);
    impl Write for Buffer {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0.lock().expect("log buffer").extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let buffer = Buffer::default();
    let writer = buffer.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_ansi(false)
        .without_time()
        .finish();
    let result = tracing::subscriber::with_default(subscriber, f);
    let logs = String::from_utf8(buffer.0.lock().expect("log buffer").clone()).expect("utf-8 logs");
    (result, logs)
}

/// `image` against `reference` region by region: no |z| above 4.4 over a 4×4 grid of blocks
/// (Bonferroni over 16, p ≈ 2e-4) and Σz² below the χ²₁₆ quantile 44.3; the mean difference within
/// 4.4 standard errors.
pub fn assert_blocks_match(image: &caustica::film::Image, reference: &caustica::film::Image) {
    let z = block_z_scores(image, reference, 4);
    let chi2: f64 = z.iter().map(|v| v * v).sum();
    let worst = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (mean, standard_error) = paired_difference(image, reference);
    eprintln!("block z {z:.1?}; mean difference {mean:.2e} ± {standard_error:.1e}");
    assert!(worst < 4.4 && chi2 < 44.3, "block z-scores {z:.1?}: max |z| {worst:.1}, Σz² {chi2:.1}");
    assert!(mean.abs() < 4.4 * standard_error, "mean difference {mean} ± {standard_error}");
}

/// The mean of `image`'s red channel over its pixels is `expected` within 4.4 standard errors of the
/// mean (floored at 1e-4, for an estimator that happens to have no variance): a furnace's exact
/// radiance, seen by `what`.
pub fn assert_mean_radiance(image: &caustica::film::Image, expected: f64, what: &str) {
    let values: Vec<f64> = image.pixels.iter().map(|p| p.x as f64).collect();
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let standard_error = (variance / n).sqrt();
    eprintln!("{what}: {mean} ± {standard_error}");
    assert!(
        (mean - expected).abs() < 4.4 * standard_error.max(1e-4),
        "{what}: radiance {mean} ± {standard_error}, expected {expected}"
    );
}
