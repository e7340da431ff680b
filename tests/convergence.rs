//! Convergence against an independent renderer: Mitsuba 3 references of the test scenes.
//!
//! The references are 256×256 with a box filter, so a 128×128 render is compared with the 2×2 block
//! average of the reference (exactly what a box-filtered half-resolution render converges to). A pixel's
//! error variance is σ²/spp whatever its size (σ² grows only slightly with the pixel's footprint), so
//! the expected relMSE is Mitsuba's at the same spp: relMSE × spp ≈ 0.31 on cornell-box
//! (shared/scenes/README).

mod common;

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
