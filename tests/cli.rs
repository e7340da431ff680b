//! The command line: bad input fails with a message naming the file, leaves no output behind.

mod common;

use std::path::PathBuf;
use std::process::{Command, Output};

fn caustica(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).output().expect("caustica runs")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn assert_fails_naming(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure, stderr: {stderr}");
    assert!(stderr.contains(needle), "stderr does not name {needle:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
}

#[test]
fn missing_scene_file_is_an_error_naming_it_and_writes_nothing() {
    let dir = scratch("missing");
    let out_file = dir.join("x.exr");
    let out = caustica(&["render", "no/such/scene.gltf", "-q", "-o", out_file.to_str().unwrap()]);
    assert_fails_naming(&out, "no/such/scene.gltf");
    assert!(!out_file.exists());
}

#[test]
fn a_file_that_is_not_gltf_is_an_error_naming_it() {
    let dir = scratch("notgltf");
    let bogus = dir.join("bogus.gltf");
    std::fs::write(&bogus, "this is not json").unwrap();
    let out = caustica(&["render", bogus.to_str().unwrap(), "-q", "-o", dir.join("x.png").to_str().unwrap()]);
    assert_fails_naming(&out, "bogus.gltf");
    assert!(!dir.join("x.png").exists());
}

#[test]
fn zero_samples_and_unknown_integrator_are_rejected() {
    let scene = common::data("cornell-box.gltf");
    let out = caustica(&["render", scene.to_str().unwrap(), "--spp", "0", "-q"]);
    assert_fails_naming(&out, "spp");
    let out = caustica(&["render", scene.to_str().unwrap(), "--integrator", "magic", "-q"]);
    assert_fails_naming(&out, "magic");
    let out = caustica(&["render", scene.to_str().unwrap(), "--spp", "-3", "-q"]);
    assert_fails_naming(&out, "-3");
}

#[test]
fn unknown_output_format_fails_before_rendering() {
    let dir = scratch("format");
    let scene = common::data("cornell-box.gltf");
    let target = dir.join("image.bmp");
    let out = caustica(&["render", scene.to_str().unwrap(), "-q", "-o", target.to_str().unwrap()]);
    assert_fails_naming(&out, "image.bmp");
    assert!(!target.exists());
}

#[test]
fn compare_prints_the_three_metrics_and_zero_for_identical_files() {
    let reference = common::data("cornell-box.ref.exr");
    let r = reference.to_str().unwrap();
    let out = caustica(&["compare", r, r]);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    for metric in ["RMSE 0.000000", "relMSE 0.000000", "MAE 0.000000"] {
        assert!(stdout.contains(metric), "missing {metric}: {stdout}");
    }
}
