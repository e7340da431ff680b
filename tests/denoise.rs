//! `caustica render --denoise`: with feature `denoise`, Open Image Denoise guided by the render's
//! albedo and normal brings a Cornell box at 8 spp far closer to Mitsuba's reference; without it,
//! the command refuses before rendering and says how to get a denoiser.

use crate::common;

use std::process::Command;
#[cfg(feature = "denoise")]
use std::process::Output;

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
