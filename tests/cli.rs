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

/// Two constant images, 1 and 1.5 in every channel but one pixel at 3: RMSE, relMSE
/// = mean((a − b)² / (b² + 0.01)) and MAE computed by hand.
#[test]
fn compare_prints_the_three_metrics_of_two_images() {
    use caustica::film::{Image, output::write_image};
    let dir = scratch("compare");
    let mut a = Image { width: 4, height: 2, pixels: vec![glam::Vec3::splat(1.5); 8] };
    a.pixels[5] = glam::Vec3::splat(3.0);
    let b = Image { width: 4, height: 2, pixels: vec![glam::Vec3::ONE; 8] };
    let (pa, pb) = (dir.join("a.exr"), dir.join("b.exr"));
    write_image(&a, &pa, 0.0).unwrap();
    write_image(&b, &pb, 0.0).unwrap();
    let out = caustica(&["compare", pa.to_str().unwrap(), pb.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let squared: f64 = (7.0 * 0.25 + 4.0) / 8.0;
    let expected = [
        format!("RMSE {:.6}", squared.sqrt()),
        format!("relMSE {:.6}", squared / 1.01),
        format!("MAE {:.6}", (7.0 * 0.5 + 2.0) / 8.0),
    ];
    for metric in expected {
        assert!(stdout.contains(&metric), "missing {metric}: {stdout}");
    }
    let same = caustica(&["compare", pb.to_str().unwrap(), pb.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&same.stdout).contains("RMSE 0.000000"));
}
