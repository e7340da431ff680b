//! Images that go wrong when two decisions of a path share the sampler's numbers.
//!
//! A furnace cannot tell: its radiance is the same whatever the directions, so a direction drawn from
//! the wrong dimension still gives the right answer. These scenes make the answer depend on the
//! directions. Two collisions matter, and neither adds a bias of the same kind:
//! - the light sample and the BSDF sample of one vertex sharing numbers leaves every term of the
//!   estimate unbiased (each term reads one of them only), but their sum's variance changes: the
//!   first test predicts that variance in closed form and checks it;
//! - every vertex drawing the first vertex's numbers repeats one direction along the path, which
//!   biases everything from the second bounce on: the second test checks the indirect light of a
//!   sphere against its closed form.
//!
//! The unit tests in `src/kernel/dimensions.rs` check the layout itself; these check that the
//! renderer's paths really get independent numbers.

use crate::common;

use caustica::camera::look_at;
use caustica::film::Image;
use caustica::sampling::SamplerKind;
use caustica::scene::environment::EnvironmentDesc;
use caustica::scene::punctual::{LUMENS_PER_WATT, PunctualKind, PunctualLightDesc};
use caustica::scene::{CameraDesc, IntegratorKind, Mesh, RunFile, Scene, Sphere};
use caustica::test_scenes::{diffuse, quad};
use glam::{Mat4, Vec3};
use std::f64::consts::PI;

/// Grey value of each pixel (the scenes are grey, so the channels are one path's, equal).
fn grey(image: &Image) -> Vec<f64> {
    image.pixels.iter().map(|p| p.to_array().iter().map(|&v| v as f64).sum::<f64>() / 3.0).collect()
}

/// A flat horizontal ring at height `y` between radii `inner` and `outer` (`segments` sides).
fn ring(y: f32, inner: f32, outer: f32, segments: u32, material: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..segments {
        let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
        let (s, c) = phi.sin_cos();
        positions.push(Vec3::new(inner * c, y, inner * s));
        positions.push(Vec3::new(outer * c, y, outer * s));
    }
    let indices = (0..segments)
        .flat_map(|j| {
            let (a, b) = (2 * j, 2 * j + 1);
            let (c, d) = (2 * ((j + 1) % segments), 2 * ((j + 1) % segments) + 1);
            [[a, b, d], [a, d, c]]
        })
        .collect();
    Mesh { name: "ring".into(), positions, indices, material, ..Mesh::default() }
}

/// Radiance of the environment over the floor (the floor's albedo is 1/2, so ρ·L = 1).
const SKY: f32 = 2.0;

/// A Lambertian floor (albedo 1/2) under a constant sky, seen straight down through the 1 m hole of
/// a black ring 1 m above it, from 0.5 m: every pixel sees the floor within 5 cm of the hole's axis,
/// where the sky fills a cone of half-angle ≈ 45° (cosine-weighted share v ≈ sin² 45° = 1/2).
fn floor_under_a_hole() -> Scene {
    let mut floor = quad("floor", 0.0, 20.0, true, 0);
    floor.uvs.clear();
    Scene {
        meshes: vec![floor, ring(1.0, 1.0, 20.0, 256, 1)],
        materials: vec![
            diffuse("floor", Vec3::splat(0.5), Vec3::ZERO),
            diffuse("black ring", Vec3::ZERO, Vec3::ZERO),
        ],
        camera: Some(CameraDesc {
            name: "down".into(),
            camera_to_world: look_at(Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO, Vec3::Z),
            yfov: 0.2,
            aspect_ratio: None,
        }),
        resolution: Some((16, 16)),
        environment: Some(EnvironmentDesc::constant(Vec3::splat(SKY))),
        source: "floor under a hole (procedural)".into(),
        ..Scene::default()
    }
}

/// The light sample and the BSDF sample of a vertex draw independent numbers, checked by the
/// variance of the estimate, which is where sharing them shows (the mean stays unbiased).
///
/// At the floor both samples are cosine-distributed about the normal (the constant sky is sampled
/// so, and so is the Lambertian BSDF), so the power heuristic weighs each 1/2 and one sample's
/// estimate is ρL/2 · (V(ω_light) + V(ω_bsdf)), V the sky's visibility through the hole (the ring is
/// black: nothing comes back from it). Independent directions give variance (ρL)² v(1 − v)/2 with
/// v = E[V]; shared numbers give the same direction, up to a turn about the normal, and V depends
/// on the elevation only, so the two terms are equal and the variance doubles: (ρL)² v(1 − v).
///
/// Each pixel's mean m over K = 8 seeds estimates v (ρL = 1), and its spread s² over the seeds has
/// expectation v(1 − v)/(2N) at N spp. The ratio R = Σ s² / Σ m(1 − m)/(2N) over the P = 256 pixels
/// is 1 up to the plug-in's bias, −1/(2NK) < 0.4%, and the pixel's spread of v within its
/// footprint (v falls off as the square of the distance from the axis: far below 1%); its standard
/// deviation is √(2 / (P(K − 1))) = 3.3% (a pixel's mean of 16 samples is near normal). Five
/// standard deviations bound it: 1 ± 0.17. Shared numbers give R ≈ 2.
#[test]
fn light_and_bsdf_samples_of_a_vertex_do_not_share_numbers() {
    const K: u32 = 8;
    let n = 16u32;
    let images: Vec<Vec<f64>> = (0..K)
        .map(|seed| {
            let mut run = RunFile::default();
            run.render.integrator = IntegratorKind::Pt;
            run.render.sampler = SamplerKind::Independent;
            run.render.spp = n;
            run.render.seed = seed as u64;
            run.render.max_depth = Some(4);
            grey(&common::render(floor_under_a_hole(), &run))
        })
        .collect();
    let pixels = images[0].len();
    let (mut spread, mut predicted, mut mean_v) = (0.0, 0.0, 0.0);
    for p in 0..pixels {
        let m = images.iter().map(|image| image[p]).sum::<f64>() / K as f64;
        spread += images.iter().map(|image| (image[p] - m).powi(2)).sum::<f64>() / (K - 1) as f64;
        predicted += m * (1.0 - m) / (2.0 * n as f64);
        mean_v += m / pixels as f64;
    }
    // The geometry is what the derivation assumes: the sky's share near one half.
    assert!((mean_v - 0.5).abs() < 0.02, "the floor sees {mean_v} of the sky, expected about 1/2");
    let ratio = spread / predicted;
    let sd = (2.0 / (pixels as f64 * (K - 1) as f64)).sqrt();
    assert!(
        (ratio - 1.0).abs() < 5.0 * sd,
        "the spread of pixels over seeds is {ratio:.3} × the variance of independent light and BSDF \
         samples (bound 1 ± {:.3}; 2 if they share numbers)",
        5.0 * sd
    );
}

/// Radius of the sphere, albedo of its inside, and the depth the paths stop at.
const RADIUS: f32 = 1.0;
const ALBEDO: f32 = 0.7;
const DEPTH: u32 = 8;

/// A point light of 1 W/sr at `light` inside a Lambertian sphere (analytic, seen from inside), the
/// camera at the centre.
fn lit_sphere(light: Vec3) -> Scene {
    Scene {
        spheres: vec![Sphere {
            name: "room".into(),
            center: Vec3::ZERO,
            radius: RADIUS,
            material: 0,
            motion: None,
        }],
        materials: vec![diffuse("room", Vec3::splat(ALBEDO), Vec3::ZERO)],
        punctual_lights: vec![PunctualLightDesc {
            name: "bulb".into(),
            kind: PunctualKind::Point,
            position: light,
            direction: Vec3::NEG_Y,
            color: Vec3::ONE,
            intensity: LUMENS_PER_WATT,
        }],
        camera: Some(CameraDesc {
            name: "centre".into(),
            camera_to_world: Mat4::IDENTITY,
            yfov: 1.2,
            aspect_ratio: None,
        }),
        resolution: Some((32, 32)),
        source: "point light in a sphere (procedural)".into(),
        ..Scene::default()
    }
}

/// Every vertex of a path draws its own numbers, checked by light that needs two bounces or more to
/// be right.
///
/// Inside a Lambertian sphere a cosine-sampled direction lands uniformly over the sphere, from
/// anywhere on it (the form factor between two points of a sphere is dA / 4πR²), so every vertex
/// after the first is uniform and sees on average the irradiance of the light's whole flux spread
/// over the sphere, Ē = 4πI / 4πR². Next-event estimation at depths 1 to D − 1 then adds
/// ρ/π · Ē · ρ^k each: the indirect light is (ρ/π) Ē Σₖ ρ^k in every pixel, however uneven the
/// direct light (the light is off centre: its irradiance varies 16-fold over the sphere). A vertex
/// that reuses the first one's numbers turns by the same angles in its own frame as the first
/// did, so the path drifts the way the frames lead it instead of landing uniformly, and sees the
/// wrong light. How wrong depends on where the light is against the frames' directions: with the
/// first bounce's numbers at every vertex the indirect light is off by +0.4% (z = 5), −1.5%
/// (z = −14) and +8.8% (z = 65) with the light on the y, x and z axes, so the test puts it on each.
///
/// The indirect light is the render to depth D less the render of direct light alone (depth 1)
/// with the same seed: the camera ray and the first vertex's light sample are the same numbers in
/// both (a point light's sample is exact), so the difference is the indirect estimate of the same
/// paths. Roulette is off (it would only add noise; the unit tests check its numbers). Over K = 4
/// seeds each pixel is an independent estimate (per-pixel scrambles), so the mean of the K·P
/// differences has standard error sd / √(K·P); it must lie within 5 of them of the closed form
/// (with the real layout: z = 0.4, 1.1 and −0.6).
#[test]
fn every_vertex_of_a_path_draws_its_own_numbers() {
    const K: u32 = 4;
    for light in [Vec3::X, Vec3::Y, Vec3::Z].map(|axis| 0.6 * RADIUS * axis) {
        let render = |seed: u64, max_depth: u32| {
            let mut run = RunFile::default();
            run.render.integrator = IntegratorKind::Pt;
            run.render.spp = 16;
            run.render.seed = seed;
            run.render.max_depth = Some(max_depth);
            run.render.rr_depth = DEPTH + 1;
            grey(&common::render(lit_sphere(light), &run))
        };
        let mut indirect = Vec::new();
        for seed in 0..K as u64 {
            let (full, direct) = (render(seed, DEPTH), render(seed, 1));
            indirect.extend(full.iter().zip(&direct).map(|(f, d)| f - d));
        }
        let n = indirect.len() as f64;
        let mean = indirect.iter().sum::<f64>() / n;
        let sd = (indirect.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let (rho, r) = (ALBEDO as f64, RADIUS as f64);
        let irradiance = 1.0 / (r * r);
        let expected = rho / PI * irradiance * (1..DEPTH).map(|k| rho.powi(k as i32)).sum::<f64>();
        let z = (mean - expected) / (sd / n.sqrt());
        assert!(
            z.abs() < 5.0,
            "light at {light}: indirect light in the sphere {mean:.5}, closed form {expected:.5} \
             ({:+.2}%, {z:+.1} standard errors)",
            100.0 * (mean / expected - 1.0)
        );
    }
}
