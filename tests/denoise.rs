//! `caustica render --denoise`: with feature `denoise`, Open Image Denoise guided by the render's
//! albedo and normal brings a Cornell box at 8 spp far closer to Mitsuba's reference; without it,
//! the command refuses before rendering and says how to get a denoiser.

use crate::common;

use std::process::{Command, Output};

#[cfg(feature = "denoise")]
fn caustica(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).output().expect("caustica runs")
}

/// The bound: the denoised image's relMSE is at most a third of the raw one's. A denoiser
/// that only blurred would fail it at the walls' edges and the blocks; OIDN measures about a thirtieth
/// here (README, "Denoising").
#[cfg(feature = "denoise")]
#[test]
fn denoising_the_cornell_box_at_8_spp_cuts_its_relmse_to_under_a_third() {
    use caustica::film::{compare::compare, output::read_exr};
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("box.exr");
    let scene = common::data("cornell-box.gltf");
    let out = caustica(&[
        "render",
        scene.to_str().unwrap(),
        "--spp",
        "8",
        "--seed",
        "1",
        "--denoise",
        "-q",
        "-o",
        raw.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let reference = read_exr(&common::data("cornell-box.ref.exr")).unwrap();
    let noisy = compare(&read_exr(&raw).unwrap(), &reference).unwrap();
    let clean = compare(&read_exr(&dir.path().join("box-denoised.exr")).unwrap(), &reference).unwrap();
    println!("relMSE raw {:.5}, denoised {:.5}", noisy.relmse, clean.relmse);
    assert!(clean.relmse <= noisy.relmse / 3.0, "denoised {} against raw {}", clean.relmse, noisy.relmse);
}

/// The library's denoiser alone: a flat grey wall under white noise comes out far closer to the
/// wall's grey. (Here rather than in the core's unit tests, so that CI builds one test binary with
/// the feature, not two.)
#[cfg(feature = "denoise")]
#[test]
fn noise_on_a_flat_wall_goes_away() {
    use caustica::film::Image;
    use caustica::film::aov::AovImages;
    use glam::Vec3;
    let (w, h) = (48u32, 32u32);
    let n = (w * h) as usize;
    let mut state = 1u32;
    let mut noise = || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1 << 24) as f32 - 0.5
    };
    let pixels = (0..n).map(|_| Vec3::splat(0.5) + 0.4 * Vec3::new(noise(), noise(), noise())).collect();
    let color = Image { width: w, height: h, pixels };
    let features = AovImages {
        albedo: Image { width: w, height: h, pixels: vec![Vec3::splat(0.8); n] },
        normal: Image { width: w, height: h, pixels: vec![Vec3::Z; n] },
        depth: vec![1.0; n],
        spp: Vec::new(),
    };
    let out = caustica::film::denoise::denoise(&color, &features).unwrap();
    let mse =
        |image: &Image| image.pixels.iter().map(|p| (*p - 0.5).length_squared()).sum::<f32>() / n as f32;
    assert!(mse(&out) < mse(&color) / 10.0, "{} against {}", mse(&out), mse(&color));
}

/// Without the feature and without pyoidn (an interpreter that is not there), the command refuses
/// before rendering and names both ways to a denoiser.
#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_or_pyoidn_denoise_is_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("box.exr");
    let scene = common::data("cornell-box.gltf");
    let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene.to_str().unwrap(), "--denoise", "-q", "-o", raw.to_str().unwrap()])
        .env("CAUSTICA_PYTHON", dir.path().join("no-python"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The one command that gets the libraries and builds with them, whole and runnable as printed.
    let command = caustica::film::denoise::BUILD_WITH_DENOISER;
    assert!(!out.status.success() && stderr.contains(command), "{stderr}");
    assert!(stderr.contains("cannot import pyoidn") && stderr.contains("`pip install pyoidn`"), "{stderr}");
    assert!(
        command.contains("pip install pyoidn")
            && command.contains("--features denoise")
            && !command.contains('\n')
    );
    assert!(!raw.exists(), "nothing is rendered");
}

/// Without the feature, `--denoise` runs pyoidn through the interpreter CAUSTICA_PYTHON names. Here
/// a stand-in that imports anything and "denoises" by returning the albedo guide: the denoised image
/// must then be the albedo layer, bit for bit, so the colour and guides went out and the result came
/// back in the layout the script reads. (python/tests runs the real pyoidn and compares with the
/// feature build's image.)
#[cfg(all(not(feature = "denoise"), unix))]
#[test]
fn without_the_feature_denoise_runs_pyoidn_through_python() {
    use caustica::film::output::{read_exr, read_exr_channels};
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let python = dir.path().join("python");
    std::fs::write(
        &python,
        "#!/bin/sh\n# -c CODE [FOLDER WIDTH HEIGHT]: the import check passes; the filter returns the albedo.\n\
         [ -z \"$3\" ] && exit 0\ncp \"$3/albedo.f32\" \"$3/out.f32\"\n",
    )
    .unwrap();
    std::fs::set_permissions(&python, std::fs::Permissions::from_mode(0o755)).unwrap();
    let raw = dir.path().join("box.exr");
    let scene = common::data("cornell-box.gltf");
    let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene.to_str().unwrap(), "--spp", "2", "--width", "12", "--height", "8"])
        .args(["--aov", "albedo", "--denoise", "-q", "-o", raw.to_str().unwrap()])
        .env("CAUSTICA_PYTHON", &python)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let denoised = read_exr(&dir.path().join("box-denoised.exr")).unwrap();
    let (_, _, channels) = read_exr_channels(&raw).unwrap();
    let albedo: Vec<f32> = denoised.pixels.iter().flat_map(|p| p.to_array()).collect();
    let layer: Vec<f32> = (0..albedo.len() / 3)
        .flat_map(|i| ["albedo.R", "albedo.G", "albedo.B"].map(|c| channels[c][i]))
        .collect();
    assert_eq!((denoised.width, denoised.height), (12, 8));
    assert!(albedo.iter().zip(&layer).all(|(a, b)| a.to_bits() == b.to_bits()), "the albedo came back");
    assert!(albedo.iter().any(|&a| a > 0.0), "and it is not black");
}

/// A stand-in interpreter for pyoidn whose filter runs `filter` (a shell line, `$3` the scratch
/// folder): the import check passes.
#[cfg(all(not(feature = "denoise"), unix))]
fn stand_in_python(dir: &std::path::Path, filter: &str) -> std::path::PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let python = dir.join("python");
    std::fs::write(&python, format!("#!/bin/sh\n[ -z \"$3\" ] && exit 0\n{filter}\n")).unwrap();
    std::fs::set_permissions(&python, std::fs::Permissions::from_mode(0o755)).unwrap();
    python
}

/// Render the Cornell box with `--denoise` through the stand-in `python`: the command's output, and
/// whether the raw and the denoised images were written.
#[cfg(all(not(feature = "denoise"), unix))]
fn denoise_through(dir: &std::path::Path, python: &std::path::Path, seconds: &str) -> (Output, bool, bool) {
    let raw = dir.join("box.exr");
    let scene = common::data("cornell-box.gltf");
    let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene.to_str().unwrap(), "--spp", "2", "--width", "12", "--height", "8"])
        .args(["--denoise", "-q", "-o", raw.to_str().unwrap()])
        .env("CAUSTICA_PYTHON", python)
        .env("CAUSTICA_DENOISE_SECONDS", seconds)
        .output()
        .unwrap();
    (out, raw.exists(), dir.join("box-denoised.exr").exists())
}

/// A denoiser's output is not trusted: NaN or infinite pixels fail the denoise and write no
/// denoised image (the raw one is written); one that never returns is stopped after its bound; one
/// that fails, or ends without writing its image, is named with the file it was expected to write
/// and what it printed. Each exits non-zero.
#[cfg(all(not(feature = "denoise"), unix))]
#[test]
fn what_a_denoiser_returns_is_checked_and_a_stuck_one_stopped() {
    let stderr = |out: &Output| String::from_utf8_lossy(&out.stderr).into_owned();
    // 12 × 8 × 3 floats of NaN (0x7fc00000, little-endian).
    let dir = tempfile::tempdir().unwrap();
    let nans = "printf '\\000\\000\\300\\177%.0s' $(seq 288) > \"$3/out.f32\"";
    let (out, raw, denoised) = denoise_through(dir.path(), &stand_in_python(dir.path(), nans), "60");
    assert!(!out.status.success() && raw && !denoised, "{}", stderr(&out));
    assert!(stderr(&out).contains("96 NaN or infinite pixels of 96"), "{}", stderr(&out));

    let dir = tempfile::tempdir().unwrap();
    let started = std::time::Instant::now();
    let (out, raw, denoised) = denoise_through(dir.path(), &stand_in_python(dir.path(), "sleep 600"), "1");
    assert!(!out.status.success() && raw && !denoised, "{}", stderr(&out));
    assert!(stderr(&out).contains("did not finish within 1 s and was stopped"), "{}", stderr(&out));
    assert!(started.elapsed().as_secs() < 60, "the stuck denoiser was waited for");

    let dir = tempfile::tempdir().unwrap();
    let python = stand_in_python(dir.path(), "echo 'no module named pyoidn.oidn' >&2; exit 3");
    let (out, raw, denoised) = denoise_through(dir.path(), &python, "60");
    assert!(!out.status.success() && raw && !denoised, "{}", stderr(&out));
    let said = stderr(&out);
    assert!(
        said.contains(python.to_str().unwrap()) && said.contains("no module named pyoidn.oidn"),
        "{said}"
    );

    let dir = tempfile::tempdir().unwrap();
    let python = stand_in_python(dir.path(), "echo 'wrote it elsewhere' >&2");
    let (out, raw, denoised) = denoise_through(dir.path(), &python, "60");
    assert!(!out.status.success() && raw && !denoised, "{}", stderr(&out));
    let said = stderr(&out);
    assert!(said.contains("out.f32") && said.contains("wrote it elsewhere"), "{said}");
}
