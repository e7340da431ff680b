//! Convergence against an independent renderer: Mitsuba 3 references of the test scenes.
//!
//! The references are 256×256 with a box filter, so a 128×128 render is compared with the 2×2 block
//! average of the reference (exactly what a box-filtered half-resolution render converges to). A pixel's
//! error variance is σ²/spp whatever its size (σ² grows only slightly with the pixel's footprint), so
//! the expected relMSE is Mitsuba's at the same spp: relMSE × spp ≈ 0.31 on cornell-box
//! (shared/scenes/README).

use crate::common;

use caustica::film::compare::compare;
use caustica::film::output::read_exr;
use caustica::scene::{IntegratorKind, RunFile, load};

fn render_half(gltf: &str, kind: IntegratorKind, spp: u32) -> caustica::film::Image {
    let (scene, mut run): (_, RunFile) = load(&common::data(gltf)).expect("test scene loads");
    run.render.integrator = kind;
    run.render.spp = spp;
    run.film.width = Some(128);
    run.film.height = Some(128);
    common::render(scene, &run)
}

/// A bias (a lost Fresnel factor, a wrong η² in transport) confined to one object moves the mean of
/// its region; noise does not. On a 4×4 grid of blocks the z-scores of an unbiased render are
/// standard normal: no |z| above 4.4 (Bonferroni over 16 blocks, p ≈ 2e-4) and Σz² below the χ²₁₆
/// quantile 44.3 (p ≈ 2e-4). Dimming the glass's transmission by 7% gives z = −5.2 and Σz² ≈ 65.
fn assert_unbiased_by_region(image: &caustica::film::Image, reference: &caustica::film::Image) {
    let z = common::block_z_scores(image, reference, 4);
    let chi2: f64 = z.iter().map(|v| v * v).sum();
    let worst = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(worst < 4.4 && chi2 < 44.3, "block z-scores {z:.1?}: max |z| {worst:.1}, Σz² {chi2:.1}");
}

#[test]
fn pt_on_cornell_box_matches_mitsuba_within_its_own_error_at_equal_samples() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-box.ref.exr")).unwrap());
    let spp = 16;
    let image = render_half("cornell-box.gltf", IntegratorKind::Pt, spp);
    let e = compare(&image, &reference).unwrap();
    // Mitsuba: relMSE ≈ 0.31 / spp, so 0.019 at 16 spp; allow 1.5× for a different noise
    // distribution, plus the reference's own residual relMSE (2e-5). A missing factor, a lost MIS
    // weight or a light counted twice each add a bias far above that.
    let bound = 1.5 * 0.31 / spp as f64 + 2e-5;
    assert!(e.relmse < bound, "relMSE {} ≥ {bound} (RMSE {}, MAE {})", e.relmse, e.rmse, e.mae);
    assert_unbiased_by_region(&image, &reference);
}

#[test]
fn pt_on_cornell_spheres_matches_mitsuba_within_its_own_error_at_equal_samples() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-spheres.ref.exr")).unwrap());
    let spp = 32;
    let image = render_half("cornell-spheres.gltf", IntegratorKind::Pt, spp);
    let e = compare(&image, &reference).unwrap();
    // The caustics are found only by BSDF sampling, so relMSE is ruled by rare bright samples; the
    // MSE is the steadier figure. Mitsuba's 8192-spp reference has residual RMSE 0.0047, i.e.
    // MSE × spp ≈ 0.18 (its 2×2 average keeps a quarter of that, 5.5e-6). Allow 1.5× Mitsuba's rate.
    let mse = e.rmse * e.rmse;
    let bound = 1.5 * 0.18 / spp as f64 + 5.5e-6;
    assert!(mse < bound, "MSE {mse} ≥ {bound} (relMSE {}, MAE {})", e.relmse, e.mae);
    assert_unbiased_by_region(&image, &reference);
}

/// The punctual-light and rough-glass reference: cornell-spheres with its glass sphere at roughness
/// 0.3 and a 205 cd point light beside the area light, rendered by Mitsuba 3 (roughdielectric GGX,
/// point emitter) at 8192 spp. Mitsuba's own MSE × spp is 1.6 (64 spp: MSE 0.0249 against the
/// reference; a pixel's variance is σ²/spp whatever its size), so its reference keeps 2e-4, a
/// quarter of that in the 2×2 average; allow 1.5× Mitsuba's rate, as above (ours is 0.6: MSE
/// 0.0097, 0.0026, 0.00076 at 64, 256, 1024 spp, falling as 1/spp down to the reference's floor).
/// The region test then catches a bias confined to the rough glass or to the point light's share;
/// the rough glass's fireflies make block variances heavy-tailed, so it runs at 64 spp (max |z|
/// 2.2 to 4.3 over seeds 0 to 5 at 128 spp).
#[test]
fn pt_with_a_point_light_and_rough_glass_matches_mitsuba_within_its_own_error() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-point-rough.ref.exr")).unwrap());
    let spp = 64;
    let image = render_half("cornell-point-rough.gltf", IntegratorKind::Pt, spp);
    let e = compare(&image, &reference).unwrap();
    let mse = e.rmse * e.rmse;
    let bound = 1.5 * 1.6 / spp as f64 + 5e-5;
    assert!(mse < bound, "MSE {mse} ≥ {bound} (relMSE {}, MAE {})", e.relmse, e.mae);
    assert_unbiased_by_region(&image, &reference);
}

#[test]
fn pt_and_pt_naive_agree_on_both_scenes() {
    for (gltf, spp) in [("cornell-box.gltf", 16), ("cornell-spheres.gltf", 16)] {
        let pt = render_half(gltf, IntegratorKind::Pt, spp);
        let naive = render_half(gltf, IntegratorKind::PtNaive, spp);
        let (mean, se) = common::paired_difference(&naive, &pt);
        assert!(mean.abs() < 4.0 * se, "{gltf}: mean difference {mean} exceeds 4 standard errors ({se})");
        let mean_pt = pt.mean().to_array().iter().sum::<f32>() as f64 / 3.0;
        assert!(mean.abs() < 0.02 * mean_pt, "{gltf}: mean difference {mean} is over 2% of {mean_pt}");
    }
}
