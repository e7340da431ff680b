//! `--denoise` without a second build: a build with feature `denoise` runs Open Image Denoise in
//! process (`film::denoise`); any other finds it the way `pip install ./python` does, through the
//! `pyoidn` package (PyPI's wheel carries OIDN 2.5's libraries), run by a Python interpreter
//! (`CAUSTICA_PYTHON`, else `python3`) on the colour and guides written as raw floats beside each
//! other in a scratch folder. The filter and its settings are the Python package's (RT, HDR, guides
//! prefiltered by the denoiser, high quality), so the images are those `RenderResult.denoised()` gives.

use anyhow::{Context, Result};
use caustica::film::Image;
use caustica::film::aov::AovImages;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The filter as the Python package calls it (python/caustica/denoiser.py), on `color.f32`,
/// `albedo.f32` and `normal.f32` of argv[1] (height × width × 3 little-endian floats), into `out.f32`.
const SCRIPT: &str = r#"
import sys
import numpy as np
import pyoidn
folder, width, height = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
load = lambda name: np.fromfile(f"{folder}/{name}.f32", dtype="<f4").reshape(height, width, 3)
clean = pyoidn.denoise(load("color"), load("albedo"), load("normal"), hdr=True, clean_aux=False, quality="high")
np.ascontiguousarray(clean, dtype="<f4").tofile(f"{folder}/out.f32")
"#;

/// How this process denoises.
#[derive(Clone, Debug)]
enum Denoiser {
    /// Feature `denoise`: OIDN linked in.
    Native,
    /// `pyoidn` through this interpreter.
    Python(PathBuf),
}

static CHOSEN: OnceLock<Denoiser> = OnceLock::new();

/// The interpreter to look for pyoidn with.
fn interpreter() -> PathBuf {
    std::env::var_os("CAUSTICA_PYTHON").map_or_else(|| PathBuf::from("python3"), PathBuf::from)
}

/// Ok when a denoiser can run here (checked before a render whose output would be denoised), saying
/// which; otherwise the error that says how to get one.
pub fn check() -> Result<()> {
    if CHOSEN.get().is_some() {
        return Ok(());
    }
    let chosen = if caustica::film::denoise::AVAILABLE {
        Denoiser::Native
    } else {
        let python = interpreter();
        let imports = Command::new(&python).args(["-c", "import numpy, pyoidn"]).output();
        match imports {
            Ok(out) if out.status.success() => {
                tracing::info!("denoising with pyoidn through {}", python.display());
                Denoiser::Python(python)
            }
            _ => anyhow::bail!(
                "no denoiser: this build has none and {} cannot import pyoidn. `pip install pyoidn` (the \
                 denoiser `pip install ./python` uses) lets this build denoise through it (CAUSTICA_PYTHON \
                 names another interpreter); or build one with the denoiser linked in: {}",
                python.display(),
                caustica::film::denoise::BUILD_WITH_DENOISER
            ),
        }
    };
    let _ = CHOSEN.set(chosen);
    Ok(())
}

/// The denoised `color`, guided by the albedo and normal of `features`. What the denoiser returns
/// is checked as the film checks samples: a NaN or infinite pixel fails the denoise (its images
/// are not written), rather than reaching a file.
pub fn denoise(color: &Image, features: &AovImages) -> Result<Image> {
    check()?;
    let (clean, which) = match CHOSEN.get().expect("checked") {
        Denoiser::Native => {
            (caustica::film::denoise::denoise(color, features)?, "Open Image Denoise".to_owned())
        }
        Denoiser::Python(python) => {
            (through_python(python, color, features)?, format!("pyoidn through {}", python.display()))
        }
    };
    finite(&clean, &which)?;
    Ok(clean)
}

/// An error naming the denoiser unless every pixel of `image` is finite.
fn finite(image: &Image, denoiser: &str) -> Result<()> {
    let bad = image.pixels.iter().filter(|p| !p.is_finite()).count();
    anyhow::ensure!(
        bad == 0,
        "the denoiser ({denoiser}) returned {bad} NaN or infinite pixels of {}: its image is not written",
        image.pixels.len()
    );
    Ok(())
}

/// How long the denoiser may take before it is stopped: two minutes, and twenty seconds more a
/// megapixel (Open Image Denoise's high-quality filter takes about a second a megapixel on two
/// cores; a denoiser past this bound is stuck, not slow).
/// `CAUSTICA_DENOISE_SECONDS` sets another bound.
fn time_bound(pixels: usize) -> std::time::Duration {
    let seconds = std::env::var("CAUSTICA_DENOISE_SECONDS").ok().and_then(|s| s.parse::<f64>().ok());
    let seconds = seconds.filter(|s| s.is_finite() && *s > 0.0).unwrap_or(120.0 + 20.0 * pixels as f64 / 1e6);
    std::time::Duration::from_secs_f64(seconds.min(1e9))
}

fn through_python(python: &Path, color: &Image, features: &AovImages) -> Result<Image> {
    let (width, height) = (color.width, color.height);
    for (name, guide) in [("albedo", &features.albedo), ("normal", &features.normal)] {
        anyhow::ensure!(
            (guide.width, guide.height) == (width, height),
            "cannot denoise: the {name} image is {}x{}, the colour {width}x{height}",
            guide.width,
            guide.height
        );
    }
    let folder = tempfile_folder()?;
    let result = (|| {
        for (name, image) in [("color", color), ("albedo", &features.albedo), ("normal", &features.normal)] {
            std::fs::write(folder.join(format!("{name}.f32")), as_bytes(&image.pixels))
                .with_context(|| format!("writing the {name} for the denoiser in {}", folder.display()))?;
        }
        // Its messages go to a file (a pipe nobody reads while waiting could fill and stall it).
        let log = folder.join("stderr.txt");
        let mut child = Command::new(python)
            .arg("-c")
            .arg(SCRIPT)
            .arg(&folder)
            .args([width.to_string(), height.to_string()])
            .stdout(std::process::Stdio::null())
            .stderr(std::fs::File::create(&log).with_context(|| format!("creating {}", log.display()))?)
            .spawn()
            .with_context(|| format!("running the denoiser's interpreter {}", python.display()))?;
        let bound = time_bound(color.pixels.len());
        let started = std::time::Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().context("waiting for the denoiser")? {
                break status;
            }
            if started.elapsed() > bound {
                let _ = child.kill();
                let _ = child.wait();
                anyhow::bail!(
                    "the denoiser (pyoidn through {}) did not finish within {:.0} s and was stopped",
                    python.display(),
                    bound.as_secs_f64()
                );
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        let said = || {
            let text = std::fs::read_to_string(&log).unwrap_or_default();
            let text = text.trim();
            if text.is_empty() {
                "it printed nothing on stderr".to_owned()
            } else {
                format!("its stderr: {text}")
            }
        };
        anyhow::ensure!(
            status.success(),
            "the denoiser (pyoidn through {}) failed ({status}); {}",
            python.display(),
            said()
        );
        let expected = folder.join("out.f32");
        let bytes = std::fs::read(&expected).map_err(|e| {
            anyhow::anyhow!(
                "the denoiser (pyoidn through {}) ended without writing {} ({e}); {}",
                python.display(),
                expected.display(),
                said()
            )
        })?;
        let pixels = from_bytes(&bytes);
        anyhow::ensure!(
            pixels.len() == color.pixels.len(),
            "the denoiser (pyoidn through {}) wrote {} pixels to {} for a {width}x{height} image; {}",
            python.display(),
            pixels.len(),
            expected.display(),
            said()
        );
        Ok(Image { width, height, pixels })
    })();
    let _ = std::fs::remove_dir_all(&folder);
    result
}

/// A fresh scratch folder of this process.
fn tempfile_folder() -> Result<PathBuf> {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let folder = std::env::temp_dir().join(format!("caustica-denoise-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&folder).with_context(|| format!("creating {}", folder.display()))?;
    Ok(folder)
}

fn as_bytes(pixels: &[Vec3]) -> Vec<u8> {
    pixels.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect()
}

fn from_bytes(bytes: &[u8]) -> Vec<Vec3> {
    let floats: Vec<f32> =
        bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    floats.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The floats go out and come back in the layout the script reads: height × width × RGB.
    #[test]
    fn pixels_survive_the_round_trip_through_raw_floats() {
        let pixels = vec![Vec3::new(1.0, -2.5, f32::MIN_POSITIVE), Vec3::new(0.0, 3.25, 1e30)];
        let bytes = as_bytes(&pixels);
        assert_eq!(bytes.len(), 24);
        assert_eq!(&bytes[4..8], &(-2.5f32).to_le_bytes());
        assert_eq!(from_bytes(&bytes), pixels);
    }
}
