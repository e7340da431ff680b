//! `caustica render --denoise`: with feature `denoise`, Open Image Denoise guided by the render's
//! albedo and normal brings a Cornell box at 8 spp far closer to Mitsuba's reference; without it,
//! the command refuses before rendering and says how to get a denoiser.

use crate::common;

use std::process::{Command, Output};

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

#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_denoise_is_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("box.exr");
    let scene = common::data("cornell-box.gltf");
    let out = caustica(&["render", scene.to_str().unwrap(), "--denoise", "-q", "-o", raw.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The one command that gets the libraries and builds with them, whole and runnable as printed.
    let command = caustica::film::denoise::BUILD_WITH_DENOISER;
    assert!(!out.status.success() && stderr.contains(command), "{stderr}");
    assert!(
        command.contains("pip install pyoidn")
            && command.contains("--features denoise")
            && !command.contains('\n')
    );
    assert!(!raw.exists(), "nothing is rendered");
}
