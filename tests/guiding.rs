//! Path guiding (`[guiding]`): unbiased against the references, the same bits for any thread count
//! and chunk size, and refused where its training cannot be reproduced (parts, checkpoints).

use crate::common;

use caustica::film::output::read_exr;
use caustica::scene::{IntegratorKind, RunFile, load};
use std::process::Command;

fn guided_half(gltf: &str, kind: IntegratorKind, spp: u32) -> caustica::film::Image {
    let (scene, mut run): (_, RunFile) = load(&common::data(gltf)).expect("test scene loads");
    run.render.integrator = kind;
    run.render.spp = spp;
    run.guiding.enabled = true;
    run.film.width = Some(128);
    run.film.height = Some(128);
    common::render(scene, &run)
}

/// Guided `pt` and `pt-naive` against Mitsuba, region by region (`common::assert_blocks_match`):
/// their training passes and the passes sampled by the guide are all unbiased, so a pdf that
/// disagreed with the sampling (or a light counted twice by MIS) would move a block's mean.
#[test]
fn guided_path_tracing_matches_mitsuba_by_region() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-box.ref.exr")).unwrap());
    for kind in [IntegratorKind::Pt, IntegratorKind::PtNaive] {
        let image = guided_half("cornell-box.gltf", kind, 64);
        common::assert_blocks_match(&image, &reference);
    }
}

fn render(args: &[&str], out: &std::path::Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_caustica"))
        .arg("render")
        .arg(common::data("cornell-spheres.gltf"))
        .args(["--width", "48", "--height", "48", "--spp", "16", "--guiding", "--quiet"])
        .args(["--set", "guiding.spatial_threshold=200", "-o"])
        .arg(out)
        .args(args)
        .output()
        .expect("caustica runs")
}

#[test]
fn a_guided_render_is_the_same_bits_for_any_thread_count_and_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let runs =
        [&["--threads", "1"][..], &["--threads", "2"], &["--threads", "3", "--set", "render.chunk=37"]];
    let images: Vec<_> = runs
        .iter()
        .enumerate()
        .map(|(i, args)| {
            let out = dir.path().join(format!("{i}.exr"));
            let output = render(args, &out);
            assert!(output.status.success(), "{args:?}: {}", String::from_utf8_lossy(&output.stderr));
            read_exr(&out).unwrap()
        })
        .collect();
    assert!(images[0].mean().max_element() > 0.0, "black image");
    for (image, args) in images.iter().zip(runs).skip(1) {
        assert!(image.pixels == images[0].pixels, "{args:?} differs from one thread");
    }
}

#[test]
fn parts_and_checkpoints_of_a_guided_render_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let part = render(&["--part", "1/2"], &dir.path().join("part.exr"));
    let stderr = String::from_utf8_lossy(&part.stderr);
    assert!(!part.status.success() && stderr.contains("path guiding"), "{stderr}");
    let checkpoint = dir.path().join("c.exr");
    let output = render(&["--checkpoint", checkpoint.to_str().unwrap()], &dir.path().join("o.exr"));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && stderr.contains("path guiding"), "{stderr}");
}

#[test]
fn guiding_is_refused_by_the_integrators_that_do_not_take_it() {
    let dir = tempfile::tempdir().unwrap();
    let output = render(&["--integrator", "sppm"], &dir.path().join("o.exr"));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success() && stderr.contains("guiding.enabled applies to pt and pt-naive"),
        "{stderr}"
    );
}
