//! The kernel on hand-built hits: a 2 m square floor (Lambertian, albedo 0.5) at y = 0 under a
//! 1 m square lamp at y = 1 facing down (radiance 2), and a glass slab for the continuation. Every
//! expected value is computed here from the geometry, independently of the light and BSDF code.

use super::continuation::{MAX_SURVIVAL, survival_probability};
use super::emission::{add_escaped_radiance, add_surface_emission};
use super::*;
use crate::sampling::Sampler;
use crate::scene::{LightSelection, MaterialDesc, Scene};
use crate::test_scenes::{diffuse, quad};
use std::f32::consts::PI;

const ALBEDO: f32 = 0.5;
const LE: f32 = 2.0;

fn floor_and_lamp() -> RenderScene {
    let scene = Scene {
        meshes: vec![quad("floor", 0.0, 1.0, true, 0), quad("lamp", 1.0, 0.5, false, 1)],
        materials: vec![
            diffuse("floor", Vec3::splat(ALBEDO), Vec3::ZERO),
            diffuse("lamp", Vec3::ZERO, Vec3::splat(LE)),
        ],
        ..Scene::default()
    };
    RenderScene::build(&scene, LightSelection::Uniform)
}

/// The vertex where a ray from `o` along `d` lands.
fn vertex_along(scene: &RenderScene, o: Vec3, d: Vec3) -> (Ray, Vertex) {
    let ray = Ray { o, d: d.normalize(), t_max: f32::INFINITY, time: 0.0 };
    let hit = scene.geometry.intersect(&ray);
    assert!(hit.is_hit(), "the ray from {o} along {d} hits");
    (ray, Vertex::new(scene, &ray, scene.geometry.surface_hit(&ray, &hit)))
}

/// The lamp's solid-angle density (selection included) at `p_ref` (normal `n_ref`) for its point `p`
/// on triangle `light`: the light's own pdf, tested on its own in `lights::light` (χ², and equal to
/// what its samples report). Here the 1 m² lamp 1 m away is sampled by solid angle.
fn lamp_pdf(scene: &RenderScene, light: u32, p_ref: Vec3, n_ref: Vec3, p: Vec3) -> f32 {
    scene.lights.pdf(light, p_ref, n_ref, p, Vec3::NEG_Y, 0.0)
}

fn path_after_a_diffuse_bounce(prev_pdf: f32) -> CameraPath {
    CameraPath {
        beta: Vec3::splat(0.5),
        depth: 1,
        prev_pdf,
        prev_p: Vec3::ZERO,
        prev_n: Vec3::Y,
        ..CameraPath::START
    }
}

#[test]
fn emission_found_by_bsdf_sampling_is_weighted_by_the_rule() {
    let scene = floor_and_lamp();
    let (ray, v) = vertex_along(&scene, Vec3::ZERO, Vec3::new(0.1, 1.0, 0.2));
    let (bsdf_pdf, light_pdf) = (0.3, lamp_pdf(&scene, v.si.light, Vec3::ZERO, Vec3::Y, v.si.p));
    let mis = bsdf_pdf * bsdf_pdf / (bsdf_pdf * bsdf_pdf + light_pdf * light_pdf);
    let full = 0.5 * LE;
    for (rule, specular, expected) in [
        (EmissionWeight::One, false, full),
        (EmissionWeight::Mis, false, full * mis),
        (EmissionWeight::Mis, true, full),
        (EmissionWeight::SeenDirectly, false, 0.0),
        (EmissionWeight::SeenDirectly, true, full),
    ] {
        let mut path = CameraPath { specular_bounce: specular, ..path_after_a_diffuse_bounce(bsdf_pdf) };
        add_surface_emission(&scene, rule, &mut path, &v.si, -ray.d, 0.0);
        assert!(
            (path.l.x - expected).abs() < 1e-5 * full,
            "{rule:?}, specular {specular}: {} ≠ {expected}",
            path.l.x
        );
    }
    // Seen from the camera every rule counts it fully; the lamp's back emits nothing.
    let mut camera = CameraPath::START;
    add_surface_emission(&scene, EmissionWeight::Mis, &mut camera, &v.si, -ray.d, 0.0);
    assert_eq!(camera.l, Vec3::splat(LE));
    let (ray, back) = vertex_along(&scene, Vec3::new(0.1, 2.0, 0.2), Vec3::NEG_Y);
    let mut path = CameraPath::START;
    add_surface_emission(&scene, EmissionWeight::One, &mut path, &back.si, -ray.d, 0.0);
    assert_eq!(path.l, Vec3::ZERO);
    // No environment: a path that leaves brings back nothing.
    add_escaped_radiance(&scene, EmissionWeight::One, &mut path, Vec3::X);
    assert_eq!(path.l, Vec3::ZERO);
}

#[test]
fn a_light_sample_carries_the_lambertian_integrand_over_its_pdf() {
    let scene = floor_and_lamp();
    let (_, v) = vertex_along(&scene, Vec3::new(0.2, 0.5, -0.1), Vec3::NEG_Y);
    let beta = Vec3::new(1.0, 0.5, 0.25);
    let mut checked = 0;
    for sample in 0..64 {
        let u = VertexSampler::new(Sampler::new(1, 0, sample), 1);
        let plain = sample_light(&scene, &v, &CameraPath { beta, ..CameraPath::START }, 0.0, &u, false)
            .expect("the lamp is above");
        let weighted = sample_light(&scene, &v, &CameraPath { beta, ..CameraPath::START }, 0.0, &u, true)
            .expect("the lamp is above");
        let p = plain.ray.o + plain.ray.d; // the shadow ray spans the segment to the lamp
        let wi = (p - v.si.p).normalize();
        let (light_pdf, bsdf_pdf) = (lamp_pdf(&scene, plain.light, v.si.p, v.n_side(), p), wi.y / PI);
        let integrand = beta * (ALBEDO / PI) * wi.y * LE;
        let w = light_pdf * light_pdf / (light_pdf * light_pdf + bsdf_pdf * bsdf_pdf);
        assert!((plain.contribution - integrand / light_pdf).abs().max_element() < 1e-3 * integrand.x);
        assert!((weighted.contribution - integrand * w / light_pdf).abs().max_element() < 1e-3 * integrand.x);
        assert!(plain.ray.t_max < 1.0 && (p.y - 1.0).abs() < 1e-3, "ends just short of the lamp at {p}");
        checked += 1;
    }
    assert_eq!(checked, 64);
}

/// Without MIS, the mean light sample is the reflected direct radiance: ρ/π ∫ Le cos θ cos θ' / d² dA
/// over the lamp, here by a 400² midpoint rule; 20 000 samples, within 4 standard errors.
#[test]
fn light_samples_average_to_the_reflected_direct_radiance() {
    let scene = floor_and_lamp();
    let (_, v) = vertex_along(&scene, Vec3::new(0.3, 0.5, 0.0), Vec3::NEG_Y);
    let p = v.si.p;
    let steps = 400;
    let mut quadrature = 0.0f64;
    for i in 0..steps {
        for j in 0..steps {
            let q = Vec3::new(
                -0.5 + (i as f32 + 0.5) / steps as f32,
                1.0,
                -0.5 + (j as f32 + 0.5) / steps as f32,
            );
            let d = q - p;
            let cos = d.y / d.length();
            quadrature += (cos * cos / d.length_squared()) as f64 / (steps * steps) as f64;
        }
    }
    let expected = quadrature * (ALBEDO / PI * LE) as f64;
    let n = 20_000;
    let values: Vec<f64> = (0..n)
        .map(|s| {
            let u = VertexSampler::new(Sampler::new(2, 0, s), 1);
            sample_light(&scene, &v, &CameraPath::START, 0.0, &u, false)
                .map_or(0.0, |s| s.contribution.x as f64)
        })
        .collect();
    let mean = values.iter().sum::<f64>() / n as f64;
    let se = (values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n as f64 * (n - 1) as f64)).sqrt();
    assert!((mean - expected).abs() < 4.0 * se, "mean {mean}, expected {expected} ± {se}");
}

/// Refracted into glass, radiance is compressed by 1/η² (f carries it), so β drops to 0.44; Russian
/// roulette must divide that by the η-scale (2.25) first, so the path survives with the cap 0.95, not
/// with 0.44, and β is divided by what it survived with.
#[test]
fn russian_roulette_divides_the_eta_scale_out_of_the_throughput() {
    let glass = MaterialDesc {
        shading: ShadingParams {
            transmission: 1.0,
            // A solid: a thin-walled sheet would not bend the light or scale it by 1/η².
            thickness: 1.0,
            ior: 1.5,
            roughness: 0.0,
            metallic: 0.0,
            ..ShadingParams::default()
        },
        ..MaterialDesc::default()
    };
    let scene =
        Scene { meshes: vec![quad("slab", 0.0, 1.0, true, 0)], materials: vec![glass], ..Scene::default() };
    let scene = RenderScene::build(&scene, LightSelection::Uniform);
    let (ray, v) = vertex_along(&scene, Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.05, -1.0, 0.0));
    let limits = PathLimits { max_depth: u32::MAX, rr_depth: 0 };
    let mut refracted = 0;
    for sample in 0..200 {
        let u = VertexSampler::new(Sampler::new(3, 0, sample), 0);
        let bs = v
            .bsdf
            .sample(v.wo, u.bsdf_lobe(), u.bsdf_direction(), crate::materials::TransportMode::Radiance)
            .unwrap();
        let mut path = CameraPath::START;
        let next = continue_path(&mut path, &v, ray.time, &u, limits);
        if !bs.is_transmission {
            continue;
        }
        let before = bs.f * bs.wi.z.abs() / bs.pdf;
        // Transmission is picked with probability T, so β scales by exactly 1/η².
        assert!((bs.eta - 1.5).abs() < 1e-6 && (before.x - 1.0 / 2.25).abs() < 1e-4, "{bs:?}");
        let survive = survival_probability(before, 2.25);
        assert_eq!(survive, MAX_SURVIVAL, "β η² = 1 is capped");
        assert_ne!(survive, survival_probability(before, 1.0), "the η-scale matters here");
        assert!((path.eta_scale - 2.25).abs() < 1e-5);
        if let Some(next) = next {
            refracted += 1;
            assert!(
                (path.beta - before / survive).abs().max_element() < 1e-6,
                "{} vs {}",
                path.beta,
                before / survive
            );
            assert!(path.specular_bounce && path.depth == 1 && path.prev_p == v.si.p);
            assert!(next.d.y < 0.0 && (next.o - v.si.p).length() < 1e-4, "{next:?}");
        }
    }
    assert!(refracted > 100, "{refracted} of 200 samples refracted and survived");
    // At the maximum depth nothing is sampled.
    let mut path = CameraPath { depth: 3, ..CameraPath::START };
    let u = VertexSampler::new(Sampler::new(3, 0, 0), 3);
    assert_eq!(continue_path(&mut path, &v, 0.0, &u, PathLimits { max_depth: 3, rr_depth: 0 }), None);
    assert_eq!(path, CameraPath { depth: 3, ..CameraPath::START });
}

/// A shading point on an emissive sphere, the sphere its only light: a sphere seen from its own
/// surface fills the hemisphere below, and sampling it collapses every point onto the shading point
/// (a zero-length direction, NaN). A light never lights itself, so no sample is made, and no NaN.
#[test]
fn a_vertex_on_an_emissive_sphere_does_not_sample_that_sphere() {
    let scene = Scene {
        spheres: vec![crate::scene::Sphere {
            name: "lamp".into(),
            center: Vec3::ZERO,
            radius: 0.1,
            material: 0,
            motion: None,
        }],
        materials: vec![diffuse("lamp", Vec3::ZERO, Vec3::splat(LE))],
        ..Scene::default()
    };
    let scene = RenderScene::build(&scene, LightSelection::Uniform);
    // Hit points land just inside or just outside the surface; from inside a sphere light gives
    // nothing anyway, so look at those outside, where the sample collapsed.
    let mut outside = 0;
    for i in 0..64 {
        let o = crate::sampling::warp::uniform_sphere(Sampler::new(6, i, 0).get2d(0));
        let (_, v) = vertex_along(&scene, o, -o);
        assert_ne!(v.si.light, crate::geometry::bvh::NO_LIGHT, "the hit is on the lamp");
        if v.si.p.length_squared() <= 0.01 {
            continue;
        }
        outside += 1;
        for sample in 0..16 {
            let u = VertexSampler::new(Sampler::new(5, i, sample), 0);
            assert_eq!(sample_light(&scene, &v, &CameraPath::START, 0.0, &u, true), None);
            assert_eq!(sample_light(&scene, &v, &CameraPath::START, 0.0, &u, false), None);
        }
    }
    assert!(outside > 8, "{outside} of 64 hits lie outside the sphere");
}

#[test]
fn the_first_quantity_that_goes_bad_is_remembered_with_its_depth() {
    let mut path = CameraPath { depth: 3, ..CameraPath::START };
    path.add(Vec3::ONE, Quantity::Emission);
    assert_eq!(path.first_bad, None);
    path.add(Vec3::new(f32::NAN, 0.0, 0.0), Quantity::LightSample);
    path.depth = 4;
    path.add(Vec3::INFINITY, Quantity::PhotonEstimate);
    assert_eq!(path.first_bad, Some((Quantity::LightSample, 3)));
    assert!(!path.l.is_finite());
}
