//! Punctual lights against their analytic irradiance: a point, a spot and a sun over a Lambertian
//! plane, the only surface in the scene, seen from straight above. Light reflected by the plane
//! leaves the scene, so a pixel's radiance is exactly ρ/π · E(x) averaged over the pixel's footprint,
//! with E the irradiance the extension's units give (I/683 · cos θ / d², E⊥/683 · cos θ).

use crate::common;

use caustica::camera::look_at;
use caustica::film::Image;
use caustica::scene::punctual::{PunctualKind, PunctualLightDesc};
use caustica::scene::{CameraDesc, IntegratorKind, LightSelection, RunFile, Scene};
use caustica::test_scenes::{diffuse, quad};
use glam::Vec3;
use std::f32::consts::PI;

const ALBEDO: f32 = 0.5;
/// Camera height above the plane, looking straight down.
const HEIGHT: f32 = 2.0;
const YFOV_DEGREES: f32 = 60.0;
const SIZE: u32 = 32;
/// Sub-pixel grid over which the analytic pixel value is averaged (the box filter's footprint).
const SUBPIXELS: u32 = 8;

fn scene(light: PunctualLightDesc) -> Scene {
    // Far larger than the view (±1.15 m), so no photon or sample feels its edge.
    let plane = quad("plane", 0.0, 8.0, true, 0);
    Scene {
        meshes: vec![plane],
        materials: vec![diffuse("plane", Vec3::splat(ALBEDO), Vec3::ZERO)],
        camera: Some(CameraDesc {
            name: "above".into(),
            camera_to_world: look_at(Vec3::new(0.0, HEIGHT, 0.0), Vec3::ZERO, Vec3::NEG_Z),
            yfov: YFOV_DEGREES.to_radians(),
            aspect_ratio: None,
        }),
        resolution: Some((SIZE, SIZE)),
        punctual_lights: vec![light],
        source: "punctual lights over a plane (procedural)".into(),
        ..Scene::default()
    }
}

fn light(kind: PunctualKind, position: Vec3, direction: Vec3, candela_or_lux: f32) -> PunctualLightDesc {
    PunctualLightDesc {
        name: format!("{kind:?}"),
        kind,
        position,
        direction: direction.normalize(),
        color: Vec3::new(1.0, 0.5, 0.25),
        intensity: candela_or_lux,
    }
}

/// Irradiance at `x` on the plane (normal +Y), per channel, as the extension defines the light.
fn irradiance(light: &PunctualLightDesc, x: Vec3) -> Vec3 {
    let radiometric = light.color * (light.intensity / 683.0);
    match light.kind {
        PunctualKind::Sun => radiometric * (-light.direction.y).max(0.0),
        PunctualKind::Point | PunctualKind::Spot { .. } => {
            let to_x = x - light.position;
            let d2 = to_x.length_squared();
            let cos_surface = (-to_x.y / d2.sqrt()).max(0.0);
            let falloff = match light.kind {
                PunctualKind::Spot { inner_cone, outer_cone } => {
                    let (ci, co) = (inner_cone.cos(), outer_cone.cos());
                    let t = ((light.direction.dot(to_x / d2.sqrt()) - co) / (ci - co)).clamp(0.0, 1.0);
                    t * t
                }
                _ => 1.0,
            };
            radiometric * falloff * cos_surface / d2
        }
    }
}

/// The exact image: ρ/π · E averaged over each pixel's footprint on the plane (midpoint rule on a
/// fine sub-grid), and each pixel's range of values over that footprint: the extremes on a grid
/// that reaches the footprint's edges, widened by how far the radiance can move between grid
/// points (the largest difference of neighbouring grid values on the footprint and one step around
/// it: a sliver of a spot's cone that crosses a pixel between grid points holds no more than that).
fn analytic(light: &PunctualLightDesc) -> (Vec<Vec3>, Vec<f32>) {
    let tan_half = (0.5 * YFOV_DEGREES.to_radians()).tan();
    let radiance = |sx: f32, sy: f32| {
        let (u, v) = (sx / SIZE as f32, sy / SIZE as f32);
        // The camera looks along −Y with right +X and up −Z.
        let (cx, cy) = ((2.0 * u - 1.0) * tan_half, (1.0 - 2.0 * v) * tan_half);
        irradiance(light, Vec3::new(HEIGHT * cx, 0.0, -HEIGHT * cy)) * (ALBEDO / PI)
    };
    // Values at every half sub-pixel step over the whole image, edges included.
    let steps = 2 * SUBPIXELS * SIZE + 1;
    let step = 1.0 / (2 * SUBPIXELS) as f32;
    let grid: Vec<f32> = (0..steps * steps)
        .map(|k| radiance((k % steps) as f32 * step, (k / steps) as f32 * step).max_element())
        .collect();
    let at = |i: u32, j: u32| grid[(j * steps + i) as usize];
    let mut means = Vec::new();
    let mut ranges = Vec::new();
    let per_pixel = 2 * SUBPIXELS;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let mut sum = Vec3::ZERO;
            for j in 0..SUBPIXELS {
                for i in 0..SUBPIXELS {
                    let sub = |k: u32| (k as f32 + 0.5) / SUBPIXELS as f32;
                    sum += radiance(x as f32 + sub(i), y as f32 + sub(j));
                }
            }
            means.push(sum / (SUBPIXELS * SUBPIXELS) as f32);
            let (x0, y0) = (x * per_pixel, y * per_pixel);
            let (mut lo, mut hi, mut slack) = (f32::INFINITY, 0.0f32, 0.0f32);
            for j in y0.saturating_sub(1)..=(y0 + per_pixel + 1).min(steps - 1) {
                for i in x0.saturating_sub(1)..=(x0 + per_pixel + 1).min(steps - 1) {
                    let v = at(i, j);
                    if (x0..=x0 + per_pixel).contains(&i) && (y0..=y0 + per_pixel).contains(&j) {
                        (lo, hi) = (lo.min(v), hi.max(v));
                    }
                    if i + 1 < steps {
                        slack = slack.max((at(i + 1, j) - v).abs());
                    }
                    if j + 1 < steps {
                        slack = slack.max((at(i, j + 1) - v).abs());
                    }
                }
            }
            ranges.push(hi - lo + 2.0 * slack);
        }
    }
    (means, ranges)
}

fn render(light: &PunctualLightDesc, integrator: IntegratorKind) -> Image {
    let mut run = RunFile::default();
    run.render.integrator = integrator;
    run.render.spp = 16;
    run.progressive.passes = 16;
    run.progressive.photons_per_pass = 20_000;
    run.photons.photons = 200_000;
    common::render(scene(light.clone()), &run)
}

fn lights() -> [PunctualLightDesc; 3] {
    [
        light(PunctualKind::Point, Vec3::new(0.3, 1.0, -0.2), Vec3::NEG_Y, 683.0 * 2.0),
        light(
            PunctualKind::Spot { inner_cone: 20f32.to_radians(), outer_cone: 35f32.to_radians() },
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.1, -1.0, 0.0),
            683.0 * 3.0,
        ),
        light(PunctualKind::Sun, Vec3::ZERO, Vec3::new(0.6, -0.8, 0.0), 683.0),
    ]
}

/// The image mean's relative error and the worst pixel's error in units of its footprint's range.
fn errors(image: &Image, exact: &[Vec3], ranges: &[f32]) -> (f64, f32) {
    let mean =
        |v: &mut dyn Iterator<Item = Vec3>| v.map(|p| p.as_dvec3()).sum::<glam::DVec3>() / exact.len() as f64;
    let (ours, theirs) = (mean(&mut image.pixels.iter().copied()), mean(&mut exact.iter().copied()));
    let relative = ((ours - theirs) / theirs).abs().max_element();
    let worst = image
        .pixels
        .iter()
        .zip(exact)
        .zip(ranges)
        .map(|((p, e), r)| (*p - *e).abs().max_element() / (r + 1e-4 * e.max_element()))
        .fold(0.0f32, f32::max);
    (relative, worst)
}

/// Path tracing sees a delta light only by next-event estimation, whose sample is exact at its hit
/// point: a pixel is the mean of the exact radiance at its samples' hit points, so it lies within
/// the range of the radiance over its footprint (the float accumulation aside: 1e-4 relative), and
/// the image mean, an average of 1024 pixels' 16-point Sobol quadratures of a smooth function,
/// is within 0.5% of the exact one.
#[test]
fn path_tracing_matches_the_analytic_irradiance_of_a_point_a_spot_and_a_sun() {
    for light in lights() {
        let (exact, ranges) = analytic(&light);
        let image = render(&light, IntegratorKind::Pt);
        let (relative, worst) = errors(&image, &exact, &ranges);
        eprintln!("pt {}: mean error {relative:.2e}, worst pixel {worst:.2} ranges", light.name);
        assert!(worst <= 1.0, "{}: a pixel outside its footprint's range ({worst:.2} ranges)", light.name);
        assert!(relative < 5e-3, "{}: image mean off by {relative:.2e}", light.name);
    }
}

/// Every light selection with the three lights at once: each picks one light per sample and divides
/// by its probability, so pixels scatter around the exact sum, independently (one scramble per
/// pixel); the image mean of (ours − exact) must be within 4 standard errors of zero. Uniform
/// selection gives the sun (weak here) as many samples as the point: a wrong pmf would show as a
/// bias far beyond the bound.
#[test]
fn every_light_selection_is_unbiased_over_points_spots_and_a_sun() {
    let all = lights();
    let mut exact = vec![Vec3::ZERO; (SIZE * SIZE) as usize];
    for light in &all {
        for (sum, value) in exact.iter_mut().zip(analytic(light).0) {
            *sum += value;
        }
    }
    for selection in
        [LightSelection::Uniform, LightSelection::Power, LightSelection::Tree, LightSelection::Visibility]
    {
        let mut scene = scene(all[0].clone());
        scene.punctual_lights = all.to_vec();
        let mut run = RunFile::default();
        run.render.spp = 16;
        run.render.light_selection = selection;
        let image = common::render(scene, &run);
        let differences: Vec<f64> = image
            .pixels
            .iter()
            .zip(&exact)
            .map(|(p, e)| ((*p - *e).to_array().iter().sum::<f32>() / 3.0) as f64)
            .collect();
        let n = differences.len() as f64;
        let mean = differences.iter().sum::<f64>() / n;
        let sd = (differences.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let level = exact.iter().map(|e| e.to_array().iter().sum::<f32>() as f64 / 3.0).sum::<f64>() / n;
        eprintln!(
            "{selection:?}: mean difference {mean:.2e} (image mean {level:.3e}), standard error {:.2e}",
            sd / n.sqrt()
        );
        assert!(mean.abs() < 4.0 * sd / n.sqrt() + 1e-5 * level, "{selection:?}: biased by {mean:.3e}");
    }
}

/// The photon integrators. `pm`, `sppm`, `appm` and `cppm` take direct light by next-event
/// estimation, as `pt` does (a photon's first hit is not also counted: that would double the
/// image), so the same bounds hold; `ppm` reads direct light from photons, blurred over its gather
/// disc and noisy, so only the image mean is held: 320 000 photons, about a third of them landing in
/// view, put its noise near 0.3%, and the blur of a smooth irradiance over a disc of radius r biases
/// it by about 0.75 r² relative (0.2% at r = 0.05); 3% leaves room for the spot's edges, where the
/// blur carries light past the cone, and still catches a lost cosine or a doubled photon.
#[test]
fn photon_integrators_match_the_analytic_irradiance_within_their_bias() {
    for light in lights() {
        let (exact, ranges) = analytic(&light);
        for integrator in [
            IntegratorKind::Pm,
            IntegratorKind::Sppm,
            IntegratorKind::Appm,
            IntegratorKind::Cppm,
            IntegratorKind::Ppm,
        ] {
            let image = render(&light, integrator);
            let (relative, worst) = errors(&image, &exact, &ranges);
            eprintln!(
                "{integrator:?} {}: mean error {relative:.2e}, worst pixel {worst:.2} ranges",
                light.name
            );
            if integrator == IntegratorKind::Ppm {
                assert!(relative < 0.03, "ppm {}: image mean off by {relative:.2e}", light.name);
            } else {
                assert!(worst <= 1.0, "{integrator:?} {}: a pixel off by {worst:.2} ranges", light.name);
                assert!(relative < 5e-3, "{integrator:?} {}: image mean off by {relative:.2e}", light.name);
            }
        }
    }
}

/// The point light's caustic through a glass ball (`scenes/point-caustic.toml`), which no camera
/// path can render: `sppm` converges on it. Its error against a long render of another seed must
/// fall with 4× the passes by at least 4^(−1/3) ≈ 0.63 in RMSE at the reference's noise floor
/// aside (Hachisuka & Jensen's α = 2/3 gives MSE ∝ N^(−2/3)); 0.8 is the bound with the
/// reference's own error (256 passes: a quarter of the 64-pass render's MSE) added.
#[test]
fn sppm_converges_on_a_point_lights_caustic_through_glass() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/point-caustic.toml");
    let render = |passes: u32, seed: u64| {
        let (scene, mut run) = caustica::scene::load(&path).expect("scene loads");
        run.film.width = Some(48);
        run.film.height = Some(36);
        run.progressive.passes = passes;
        run.progressive.photons_per_pass = 20_000;
        run.render.seed = seed;
        common::render(scene, &run)
    };
    let reference = render(256, 1);
    let rmse = |image: &Image| {
        let sum: f64 = image
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(a, b)| (*a - *b).as_dvec3().length_squared() / 3.0)
            .sum();
        (sum / image.pixels.len() as f64).sqrt()
    };
    let (coarse, fine) = (rmse(&render(16, 2)), rmse(&render(64, 2)));
    eprintln!("caustic: RMSE {coarse:.4e} at 16 passes, {fine:.4e} at 64 (ratio {:.3})", fine / coarse);
    assert!(fine < 0.8 * coarse, "4× the passes took the error from {coarse:.4e} to {fine:.4e}");
    // The caustic is there: light focused by the ball makes pixels brighter than the bulb makes
    // any part of the floor directly (at most ρ/π · I/683 / h² straight below it, h = 2 m).
    let direct_max = 0.8 / PI * (5000.0 / 683.0) / 4.0;
    let brightest = reference.pixels.iter().map(|p| p.max_element()).fold(0.0f32, f32::max);
    assert!(
        brightest > 2.0 * direct_max,
        "no caustic: brightest pixel {brightest}, direct at most {direct_max}"
    );
}

/// KHR_lights_punctual from a file: each light at its node's world transform (a parent's rotation
/// included), shining along the node's −Z, in the extension's units; `range` ignored with a warning.
#[test]
fn gltf_lights_load_at_their_nodes_in_the_extensions_units() {
    let path = common::data("punctual-lights.gltf");
    let ((scene, _run), logs) = common::capture_logs(|| caustica::scene::load(&path).expect("loads"));
    assert!(!logs.contains("not supported"), "{logs}");
    assert!(logs.contains("range") && logs.contains("light 'spot'"), "no range warning: {logs}");
    let expected = lights();
    assert_eq!(scene.punctual_lights.len(), 3);
    for (loaded, want) in scene.punctual_lights.iter().zip(&expected) {
        assert_eq!(loaded.kind, want.kind, "{}", loaded.name);
        assert!(loaded.radiometric().max_element() > 0.0);
        assert!((loaded.intensity - want.intensity).abs() < 1e-3, "{}", loaded.name);
        if want.kind != PunctualKind::Sun {
            assert!(
                (loaded.position - want.position).length() < 1e-5,
                "{}: {}",
                loaded.name,
                loaded.position
            );
        }
        if want.kind != PunctualKind::Point {
            // The spot in the file points straight down; the procedural one leans by 0.1.
            let direction =
                if matches!(want.kind, PunctualKind::Spot { .. }) { Vec3::NEG_Y } else { want.direction };
            assert!((loaded.direction - direction).length() < 1e-4, "{}: {}", loaded.name, loaded.direction);
        }
    }
    assert_eq!(scene.punctual_lights[0].color, Vec3::new(1.0, 0.5, 0.25));
    assert!(scene.punctual_lights[0].name.contains("node 'bulb node'"));
}

/// Without light sampling a delta light lights nothing: pt-naive says so instead of rendering black
/// without a word.
#[test]
fn pt_naive_warns_that_it_cannot_see_delta_lights() {
    let mut run = RunFile::default();
    run.render.integrator = IntegratorKind::PtNaive;
    run.render.spp = 1;
    let (image, logs) = common::capture_logs(|| common::render(scene(lights()[0].clone()), &run));
    assert!(logs.contains("light nothing without light sampling"), "{logs}");
    assert_eq!(image.mean(), Vec3::ZERO);
}
