//! What every lobe's tests share (parameters, directions, the chi-square and reciprocity checks,
//! a Monte Carlo albedo), and the tests of [`Bsdf`] over any parameters.

use super::{Bsdf, ShadingParams, TransportMode};
use crate::sampling::Sampler;
use crate::sampling::chi2::{Chi2Config, chi2_test};
use crate::sampling::warp::uniform_sphere;
use glam::{DVec3, Vec2, Vec3};

/// Samples per chi-square test.
const CHI2_SAMPLES: u32 = 100_000;

/// Shading parameters of a solid (any positive thickness) with a white specular colour.
pub(crate) fn params(
    base_color: Vec3,
    metallic: f32,
    roughness: f32,
    transmission: f32,
    ior: f32,
    specular: f32,
) -> ShadingParams {
    ShadingParams {
        base_color,
        metallic,
        roughness,
        transmission,
        ior,
        specular,
        thickness: 1.0,
        ..ShadingParams::default()
    }
}

/// Outgoing directions from normal to grazing incidence, on both sides of the surface.
pub(crate) fn grazing_directions() -> [Vec3; 6] {
    let at = |cos: f32, phi: f32| {
        let sin = (1.0 - cos * cos).sqrt();
        Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
    };
    [at(1.0, 0.0), at(0.8, 0.3), at(0.3, 2.0), at(0.05, 4.0), at(-0.5, 1.0), at(-0.05, 5.5)]
}

pub(crate) fn close(a: Vec3, b: Vec3, relative: f32) -> bool {
    (a - b).abs().max_element() <= relative * a.abs().max_element().max(b.abs().max_element()) + 1e-12
}

/// Chi-square test of `sample` against `pdf` for `wo`, plus: the sample's f and pdf equal eval and pdf,
/// directions are unit, and the transmission flag matches the side of wi.
pub(crate) fn check_sampling(bsdf: &Bsdf, wo: Vec3, mode: TransportMode, test_count: u32, label: &str) {
    assert!(!bsdf.is_delta(), "{label}: delta BSDFs have no density to test");
    let config = Chi2Config { test_count, ..Default::default() };
    let draw = |i: u32| {
        let s = Sampler::new(17, i, 0);
        bsdf.sample(wo, s.get1d(0), s.get2d(1), mode)
    };
    for i in 0..2_000 {
        let Some(s) = draw(i) else { continue };
        assert!(!s.is_specular, "{label}, wo {wo}: specular sample from a rough BSDF");
        assert!((s.wi.length() - 1.0).abs() < 1e-4, "{label}, wo {wo}: |wi| = {}", s.wi.length());
        assert_eq!(s.is_transmission, s.wi.z * wo.z < 0.0, "{label}, wo {wo}, wi {}", s.wi);
        let pdf = bsdf.pdf(wo, s.wi);
        let f = bsdf.eval(wo, s.wi, mode);
        assert!(
            close(Vec3::splat(s.pdf), Vec3::splat(pdf), 2e-3),
            "{label}, wo {wo}: pdf {} vs {pdf}",
            s.pdf
        );
        assert!(close(s.f, f, 2e-3), "{label}, wo {wo}, wi {}: f {} vs {f}", s.wi, s.f);
    }
    let result = chi2_test(|i| draw(i).map(|s| s.wi), |wi| bsdf.pdf(wo, wi), CHI2_SAMPLES, &config);
    assert!(result.is_ok(), "{label}, wo {wo}: {}", result.unwrap_err());
}

/// False for refraction pairs whose microfacet is within ~3° of grazing on either side: near the
/// critical angle the transmitted cosine is so ill-conditioned in f32 that swapping the arguments
/// changes 1 - F by more than the reciprocity tests' 1e-4 (the error grows as 1e-7 / cos²).
pub(crate) fn well_conditioned(wo: Vec3, wi: Vec3, ior: f32) -> bool {
    if wo.z * wi.z >= 0.0 {
        return true;
    }
    let etap = if wo.z > 0.0 { ior } else { 1.0 / ior };
    let wm = (wi * etap + wo).normalize();
    wo.dot(wm).abs() > 0.05 && wi.dot(wm).abs() > 0.05
}

/// eval(wo, wi) = eval(wi, wo) for random pairs on one side of the surface (relative 1e-4).
pub(crate) fn check_reciprocity(bsdf: &Bsdf) {
    for i in 0..2_000 {
        let s = Sampler::new(19, i, 0);
        let (wo, mut wi) = (uniform_sphere(s.get2d(0)), uniform_sphere(s.get2d(2)));
        if wi.z * wo.z < 0.0 {
            wi.z = -wi.z;
        }
        let (a, b) = (bsdf.eval(wo, wi, TransportMode::Radiance), bsdf.eval(wi, wo, TransportMode::Radiance));
        assert!(close(a, b, 1e-4), "{bsdf:?}: f({wo}, {wi}) = {a} but f({wi}, {wo}) = {b}");
    }
}

/// Monte Carlo hemispherical albedo ∫ f |cos θi| dωi with its standard error, per channel.
pub(crate) fn albedo(bsdf: &Bsdf, wo: Vec3, mode: TransportMode, n: u32) -> (Vec3, Vec3) {
    // Accumulate in f64: an f32 sum of thousands of terms drifts by more than the tests' tolerance.
    let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
    for i in 0..n {
        let s = Sampler::new(23, i, 0);
        if let Some(bs) = bsdf.sample(wo, s.get1d(0), s.get2d(1), mode) {
            let w = (bs.f * bs.wi.z.abs() / bs.pdf).as_dvec3();
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(DVec3::ZERO);
    (mean.as_vec3(), (var / n as f64).powf(0.5).as_vec3())
}

#[test]
fn samples_are_finite_or_none_for_any_parameters() {
    for i in 0..20_000 {
        let s = Sampler::new(31, i, 0);
        let p = ShadingParams {
            base_color: Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)),
            metallic: (s.get1d(3) * 3.0).floor() / 2.0,
            roughness: [0.0, 0.001, 0.05, 0.3, 1.0][(s.get1d(4) * 5.0) as usize],
            transmission: (s.get1d(5) * 3.0).floor() / 2.0,
            ior: [1.0, 1.5, 2.5, 0.8][(s.get1d(6) * 4.0) as usize],
            specular: (s.get1d(7) * 3.0).floor() / 2.0,
            thickness: 1.0,
            ..ShadingParams::default()
        };
        let bsdf = Bsdf::new(&p);
        let mut wo = uniform_sphere(s.get2d(8));
        if i % 7 == 0 {
            wo = Vec3::new(wo.x, wo.y, 1e-7).normalize();
        }
        let mode = if i % 2 == 0 { TransportMode::Radiance } else { TransportMode::Importance };
        if let Some(bs) = bsdf.sample(wo, s.get1d(10), s.get2d(11), mode) {
            assert!(bs.f.is_finite() && bs.f.min_element() >= 0.0, "{p:?}, {wo}: {bs:?}");
            assert!(bs.pdf.is_finite() && bs.pdf > 0.0 && bs.wi.is_finite(), "{p:?}, {wo}: {bs:?}");
            assert!(bs.eta.is_finite() && bs.eta > 0.0);
        }
        let wi = uniform_sphere(s.get2d(13));
        assert!(bsdf.eval(wo, wi, mode).is_finite() && bsdf.pdf(wo, wi).is_finite());
    }
    let bsdf = Bsdf::new(&params(Vec3::ONE, 0.5, 0.5, 0.5, 1.5, 1.0));
    assert!(bsdf.sample(Vec3::X, 0.5, Vec2::splat(0.5), TransportMode::Radiance).is_none());
}

#[test]
fn albedo_hint_matches_simple_cases() {
    let base = Vec3::new(0.8, 0.4, 0.1);
    let lambert = Bsdf::new(&params(base, 0.0, 1.0, 0.0, 1.5, 0.0));
    assert!((lambert.albedo_hint() - base).abs().max_element() < 1e-6);
    let glass = Bsdf::new(&params(Vec3::ONE, 0.0, 0.0, 1.0, 1.5, 1.0));
    assert!((glass.albedo_hint() - Vec3::ONE).abs().max_element() < 1e-6);
    let black = Bsdf::new(&params(Vec3::ZERO, 0.0, 1.0, 0.0, 1.5, 0.0));
    assert_eq!(black.albedo_hint(), Vec3::ZERO);
    assert!(black.sample(Vec3::Z, 0.5, Vec2::splat(0.5), TransportMode::Radiance).is_none());
}
