//! Adaptive sampling (`render.noise_threshold`): where the samples go, that the images stay
//! bit-identical for any thread count and unbiased, what it reports, and the renders it refuses.

use crate::common;

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::film::output::read_exr_channels;
use caustica::resources::AdaptiveSampling;
use caustica::scene::{IntegratorKind, RunFile, Scene};
use std::process::Command;

/// The glass-and-mirror box at `size`² with adaptive sampling at `threshold`, `spp` samples at most.
fn spheres(size: u32, spp: u32, threshold: f64, seed: u64) -> (Scene, RunFile) {
    let (scene, mut run) = caustica::scene::load(&common::data("cornell-spheres.gltf")).expect("loads");
    (run.film.width, run.film.height) = (Some(size), Some(size));
    (run.render.spp, run.render.seed, run.render.noise_threshold) = (spp, seed, threshold);
    (scene, run)
}

fn rendered(scene: Scene, run: &RunFile) -> Renderer {
    init_thread_pools(None);
    let mut renderer = Renderer::new(scene, run).expect("prepares");
    renderer.run(None, |_| {});
    renderer
}

/// Every pixel takes at least the minimum and at most `spp`; the lamp, whose samples are all
/// alike, stops at the minimum, the glass and the shadows go on to the end; the report counts
/// every sample and says where they went.
#[test]
fn quiet_pixels_stop_at_the_minimum_and_noisy_ones_take_the_most() {
    // 192 pixels across, so that the lamp is rows deep and has pixels with only lamp pixels within
    // two (the neighbours that judge them).
    let (scene, run) = spheres(192, 32, 0.05, 3);
    let renderer = rendered(scene, &run);
    let film = renderer.film();
    let counts: Vec<u32> = (0..192 * 192).map(|p| film.samples(p)).collect();
    let (min_spp, spp) = (run.render.min_spp, run.render.spp);
    assert!(counts.iter().all(|&n| (min_spp..=spp).contains(&n)), "a pixel outside {min_spp}..={spp}");
    let at = |n: u32| counts.iter().filter(|&&c| c == n).count();
    assert!(at(min_spp) > 64, "the lamp and other quiet regions stop at the minimum: {}", at(min_spp));
    assert!(at(spp) > 64, "the noisiest pixels take every sample: {}", at(spp));
    // Inside the lamp (seen directly: every pixel alike, unlike its reflections), pixels and
    // their neighbours see emission alone: no variance.
    let image = film.image();
    let emission = image.pixels.iter().map(|p| p.x).fold(0.0, f32::max);
    let lamp = |x: i32, y: i32| image.pixels[(y * 192 + x) as usize].x == emission;
    let inside: Vec<usize> = (2..190)
        .flat_map(|y| (2..190).map(move |x| (x, y)))
        .filter(|&(x, y)| (-2..=2).all(|dy| (-2..=2).all(|dx| lamp(x + dx, y + dy))))
        .map(|(x, y)| (y * 192 + x) as usize)
        .collect();
    assert!(inside.len() >= 10, "the lamp is in view: {} pixels inside it", inside.len());
    let late: Vec<(usize, u32)> =
        inside.iter().filter(|&&p| counts[p] != min_spp).map(|&p| (p, counts[p])).collect();
    assert!(late.is_empty(), "pixels inside the lamp stop at the minimum: {late:?} of {}", inside.len());
    let report = renderer.report();
    let adaptive = report.adaptive.expect("an adaptive render reports it");
    assert_eq!(report.paths.samples, counts.iter().map(|&n| n as u64).sum::<u64>());
    assert_eq!((adaptive.fewest, adaptive.most), (min_spp, spp));
    assert!(adaptive.estimate.converged > 0 && adaptive.estimate.converged < 192 * 192);
    assert!(adaptive.estimate.relmse > 0.0 && adaptive.estimate.relmse.is_finite());
}

/// Which pixels stop is decided by their neighbours' samples, never by their own, so the image's
/// mean agrees with a uniform render of another seed within the standard error of their paired
/// difference. Judged by its own samples (Cycles' way) a pixel stops when its samples happen to be
/// low and the image was 2.3% dark here (README, "Adaptive sampling").
#[test]
fn when_a_pixel_stops_does_not_bias_the_image() {
    let (scene, run) = spheres(64, 64, 0.05, 11);
    let adaptive = rendered(scene, &run).image();
    let (scene, run) = spheres(64, 64, 0.0, 12);
    let uniform = rendered(scene, &run).image();
    let (mean, standard_error) = common::paired_difference(&adaptive, &uniform);
    // Four standard errors: a false alarm once in 16,000 seeds for a normal mean.
    assert!(mean.abs() < 4.0 * standard_error, "mean difference {mean:.5} ± {standard_error:.5}");
}

/// A pixel's samples and their random numbers depend on the pixel and the sample index alone, and
/// which pixels go on depends on the film's fixed-point sums: one and two threads give the same bits.
#[test]
fn adaptive_images_and_sample_maps_are_the_same_for_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let render = |threads: u32| {
        let out = dir.path().join(format!("t{threads}.exr"));
        let output = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .args(["render", common::data("cornell-spheres.gltf").to_str().unwrap()])
            .args(["--spp", "48", "--width", "40", "--height", "40", "--seed", "5", "--quiet"])
            .args(["--noise-threshold", "0.1", "--min-spp", "8", "--aov", "spp"])
            .args(["--threads", &threads.to_string(), "-o"])
            .arg(&out)
            .output()
            .expect("caustica runs");
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let summary = String::from_utf8_lossy(&output.stdout).to_string();
        let adaptive =
            summary.lines().find(|l| l.starts_with("adaptive")).expect("an adaptive line").to_owned();
        (read_exr_channels(&out).unwrap().2, adaptive)
    };
    let (one, summary_one) = render(1);
    let (two, summary_two) = render(2);
    let spp = &one["spp"];
    assert!(spp.contains(&8.0) && spp.contains(&48.0), "the map spans 8..48");
    for (name, channel) in &one {
        assert!(
            channel.iter().zip(&two[name]).all(|(a, b)| a.to_bits() == b.to_bits()),
            "channel {name} differs"
        );
    }
    assert_eq!(summary_one, summary_two);
}

/// With a threshold every pixel reaches, a render ends when they all have, long before its sample
/// count.
#[test]
fn a_render_ends_when_every_pixel_is_under_the_threshold() {
    // Bounded by a sample count far above what the threshold needs (at most 181 here), not by time: a
    // render that never converges then ends, and fails the test, instead of running on.
    let cap = 4096;
    let (scene, run) = spheres(24, cap, 0.5, 1);
    init_thread_pools(None);
    let mut renderer = Renderer::new(scene, &run).expect("prepares");
    let report = renderer.run(None, |_| {});
    assert!(renderer.converged(), "every pixel under 0.5");
    assert_eq!(report.stopped_by, None);
    let adaptive = report.adaptive.unwrap();
    assert!(adaptive.most < cap, "the threshold ended it, not the cap: {} samples", adaptive.most);
    assert_eq!(adaptive.estimate.converged, adaptive.estimate.pixels);
}

/// Threshold 0 is the uniform render, bit for bit, without adaptive sampling's state.
#[test]
fn threshold_zero_is_the_uniform_render() {
    let (scene, run) = spheres(32, 8, 0.0, 2);
    let renderer = rendered(scene, &run);
    assert!(!renderer.world.contains_resource::<AdaptiveSampling>() && renderer.report().adaptive.is_none());
    let film = renderer.film();
    assert!((0..32 * 32).all(|p| film.samples(p) == 8));
}

/// A share of a split render and a checkpoint lack what the decisions are made from: refused, with
/// the reason; bad settings are named.
#[test]
fn splits_checkpoints_and_bad_settings_are_refused_by_name() {
    let (scene, run) = spheres(16, 32, 0.05, 1);
    init_thread_pools(None);
    let mut renderer = Renderer::new(scene, &run).expect("prepares");
    let refusal = renderer.set_samples(0..16).unwrap_err().to_string();
    assert!(refusal.contains("adaptive sampling"), "{refusal}");
    assert!(renderer.checkpoint_refusal().is_some_and(|r| r.contains("adaptive sampling")));
    let (_, mut run) = spheres(16, 32, 0.05, 1);
    run.render.integrator = IntegratorKind::Sppm;
    let refusal =
        caustica::integrators::of(run.render.integrator).check_settings(&run).unwrap_err().to_string();
    assert!(refusal.contains("pt and pt-naive, not sppm"), "{refusal}");
    for (threshold, min_spp, said) in [
        (-0.1, 16, "noise_threshold is -0.1"),
        (f64::NAN, 16, "noise_threshold is NaN"),
        (0.05, 1, "min_spp is 1"),
    ] {
        let (_, mut run) = spheres(16, 32, threshold, 1);
        run.render.min_spp = min_spp;
        let problem = run.check_settings().unwrap_err();
        assert!(problem.contains(said), "{problem}");
    }
}
