//! White furnaces for the GGX lobes: the directional albedo E(ωo) = ∫ f(ωo, ωi) |cos θi| dωi of a white
//! conductor (F = 1) and of a rough dielectric of IOR 1.5, from outside and from inside, in two steps:
//!
//! 1. Microfacet theory, written out here from the visible-normal formulation (Heitz 2014, 2018):
//!    E(ωo) = E_{m ~ D_ωo}[F·G(ωo, ωr)/G1(ωo) + (1 − F)·G(ωo, ωt)/G1(ωo)/η²], with the exact Fresnel
//!    and refraction written here too. With the separable masking-shadowing G = G1·G1 that Mitsuba 3
//!    uses it must match Mitsuba's own albedos (tests/data/mitsuba-albedo.csv, made by
//!    tests/data/tools/mitsuba_albedo.py): an independent answer for the distribution, its
//!    visible-normal sampling, the masking and the Fresnel.
//! 2. Our BSDFs must match the same theory with the height-correlated G = 1/(1 + Λ(ωo) + Λ(ωi)) they
//!    use (pbrt-v4's choice; it keeps more energy at grazing angles: up to 25% more than Mitsuba's
//!    for a white conductor of roughness 1 seen at cos θ = 0.2).
//!
//! Every side is a Monte Carlo mean, so each bound is 4 standard errors of the difference plus 0.2%
//! for what two implementations may legitimately differ by (f32 rounding). A lobe that lost or
//! doubled a factor — a missing masking term, a Fresnel on the wrong side, the 1/η² of radiance
//! through an interface — misses by 5% to 100%.

use caustica::materials::microfacet::Ggx;
use caustica::materials::{Bsdf, ShadingParams, TransportMode};
use caustica::sampling::Sampler;
use glam::Vec3;

struct Row {
    lobe: String,
    roughness: f32,
    cos: f32,
    albedo: f64,
    standard_error: f64,
}

fn mitsuba_albedos() -> Vec<Row> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/mitsuba-albedo.csv");
    let text = std::fs::read_to_string(path).expect("the Mitsuba albedo table");
    text.lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            Row {
                lobe: f[0].to_owned(),
                roughness: f[1].parse().unwrap(),
                cos: f[2].parse().unwrap(),
                albedo: f[3].parse().unwrap(),
                standard_error: f[4].parse().unwrap(),
            }
        })
        .collect()
}

fn params(lobe: &str, roughness: f32) -> ShadingParams {
    let base = ShadingParams { metallic: 0.0, roughness, thickness: 1.0, ..ShadingParams::default() };
    match lobe {
        "conductor" => ShadingParams { metallic: 1.0, ..base },
        "dielectric" => ShadingParams { transmission: 1.0, ..base },
        other => panic!("unknown lobe {other}"),
    }
}

/// Mean and standard error of our sample weights for `wo` at cosine `cos`.
fn our_albedo(bsdf: &Bsdf, cos: f32) -> (f64, f64) {
    let n = 200_000u32;
    let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let s = Sampler::new(17, i, 0);
        let weight = bsdf
            .sample(wo, s.get1d(0), s.get2d(1), TransportMode::Radiance)
            .filter(|b| b.pdf > 0.0)
            .map_or(0.0, |b| (b.f.x * b.wi.z.abs() / b.pdf) as f64);
        sum += weight;
        sum2 += weight * weight;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean) / n as f64).sqrt())
}

/// Exact Fresnel reflectance of an interface with relative IOR `eta` = n_t / n_i at incidence cosine
/// `cos_i` > 0, and the transmitted cosine (None: total internal reflection).
fn fresnel(cos_i: f32, eta: f32) -> (f32, Option<f32>) {
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, None);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), Some(cos_t))
}

/// E(ωo) by microfacet theory (module docs); `separable` picks G1·G1 over the height-correlated form.
fn theory_albedo(lobe: &str, roughness: f32, cos: f32, separable: bool) -> (f64, f64) {
    let ggx = Ggx::from_roughness(roughness);
    // Work on the side ωo is on: from inside the glass the other side's relative IOR is 1/1.5.
    let (w, eta) = if cos > 0.0 { (1.0, 1.5) } else { (-1.0, 1.0 / 1.5) };
    let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos) * w;
    let shadowing = |wi: Vec3| {
        if separable { ggx.g1(wi) } else { (1.0 + ggx.lambda(wo)) / (1.0 + ggx.lambda(wo) + ggx.lambda(wi)) }
    };
    let n = 200_000u32;
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let m = ggx.sample_wm(wo, Sampler::new(23, i, 0).get2d(0));
        let cos_m = wo.dot(m);
        let mut value = 0.0f32;
        let (f, cos_t) = if lobe == "conductor" { (1.0, None) } else { fresnel(cos_m, eta) };
        let wr = 2.0 * cos_m * m - wo;
        if wr.z > 0.0 {
            value += f * shadowing(wr);
        }
        if let Some(cos_t) = cos_t {
            let wt = -wo / eta + (cos_m / eta - cos_t) * m;
            if wt.z < 0.0 {
                value += (1.0 - f) * shadowing(wt) / (eta * eta);
            }
        }
        sum += value as f64;
        sum2 += (value * value) as f64;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean) / n as f64).sqrt())
}

fn check(
    what: &str,
    rows: &[Row],
    mut expected: impl FnMut(&Row) -> (f64, f64),
    mut got: impl FnMut(&Row) -> (f64, f64),
) {
    let mut failures = Vec::new();
    for row in rows {
        let ((want, want_se), (have, have_se)) = (expected(row), got(row));
        let bound = 4.0 * (want_se * want_se + have_se * have_se).sqrt() + 0.002 * want;
        if (have - want).abs() > bound {
            failures.push(format!(
                "{} roughness {} cos {}: {have:.5} ± {have_se:.5}, expected {want:.5} ± {want_se:.5}",
                row.lobe, row.roughness, row.cos
            ));
        }
    }
    assert!(failures.is_empty(), "{what}:\n{}", failures.join("\n"));
}

#[test]
fn microfacet_theory_with_separable_shadowing_matches_mitsubas_albedos() {
    let rows = mitsuba_albedos();
    assert!(rows.len() >= 40, "the table has {} rows", rows.len());
    check(
        "theory (separable G) against Mitsuba",
        &rows,
        |row| (row.albedo, row.standard_error),
        |row| theory_albedo(&row.lobe, row.roughness, row.cos, true),
    );
}

#[test]
fn our_conductor_and_dielectric_albedos_match_the_theory() {
    let rows = mitsuba_albedos();
    check(
        "our BSDFs against the theory (height-correlated G)",
        &rows,
        |row| theory_albedo(&row.lobe, row.roughness, row.cos, false),
        |row| our_albedo(&Bsdf::new(&params(&row.lobe, row.roughness)), row.cos),
    );
}

/// glTF's dielectric base (our `plastic`): the GGX layer with Schlick's Fresnel F(μ) = F0 + (F90 − F0)(1 − μ)⁵
/// (F0 = 0.04 for IOR 1.5, F90 = 1) over a Lambertian coupled by (1 − F(cos θo))(1 − F(cos θi)). Its
/// albedo is the layer's by microfacet theory (as above, with Schlick) plus the diffuse part in
/// closed form: base · (1 − F(cos θo)) · 2∫₀¹ (1 − F(μ)) μ dμ = base · (1 − F(cos θo)) · (1 − F0 −
/// (F90 − F0)/21). With base 0 the layer is checked alone; with 0.5 the coupling too.
#[test]
fn our_plastic_albedo_is_its_layer_by_microfacet_theory_plus_the_coupled_diffuse_in_closed_form() {
    let (f0, f90) = (0.04f32, 1.0f32);
    let schlick = |mu: f32| f0 + (f90 - f0) * (1.0 - mu).powi(5);
    let mut failures = Vec::new();
    for roughness in [0.3f32, 0.5, 0.7, 1.0] {
        let ggx = Ggx::from_roughness(roughness);
        for cos in [0.2f32, 0.5, 0.8, 1.0] {
            let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
            let n = 200_000u32;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for i in 0..n {
                let m = ggx.sample_wm(wo, Sampler::new(29, i, 0).get2d(0));
                let wr = 2.0 * wo.dot(m) * m - wo;
                let v = if wr.z > 0.0 {
                    schlick(wo.dot(m)) * (1.0 + ggx.lambda(wo)) / (1.0 + ggx.lambda(wo) + ggx.lambda(wr))
                } else {
                    0.0
                };
                sum += v as f64;
                sum2 += (v * v) as f64;
            }
            let layer = sum / n as f64;
            let layer_se = ((sum2 / n as f64 - layer * layer) / n as f64).sqrt();
            for base in [0.0f32, 0.5] {
                let diffuse = base * (1.0 - schlick(cos)) * (1.0 - f0 - (f90 - f0) / 21.0);
                let expected = layer + diffuse as f64;
                let params = ShadingParams {
                    base_color: Vec3::splat(base),
                    roughness,
                    ..params("conductor", roughness)
                };
                let plastic = Bsdf::new(&ShadingParams { metallic: 0.0, ..params });
                let (ours, se) = our_albedo(&plastic, cos);
                let bound = 4.0 * (se * se + layer_se * layer_se).sqrt() + 0.002 * expected;
                if (ours - expected).abs() > bound {
                    failures.push(format!(
                        "roughness {roughness} cos {cos} base {base}: ours {ours:.5} ± {se:.5}, expected {expected:.5}"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "plastic albedos that differ:\n{}", failures.join("\n"));
}
