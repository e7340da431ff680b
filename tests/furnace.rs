//! Furnace tests: closed scenes whose radiance is known exactly.

mod common;

use caustica::scene::{IntegratorKind, RunFile};
use caustica::test_scenes::furnace;

/// Every pixel estimates L = le / (1 − albedo). Pixels are independent, so the image mean has
/// standard error σ/√n with σ the spread of pixel values; the bound is 4 standard errors plus the
/// float rounding of the accumulation.
#[test]
fn closed_sphere_with_half_albedo_has_unit_radiance() {
    for kind in [IntegratorKind::Pt, IntegratorKind::PtNaive] {
        for (albedo, le) in [(0.5f32, 0.5f32), (0.8, 0.2)] {
            let mut run = RunFile::default();
            run.render.integrator = kind;
            run.render.spp = 32;
            let image = common::render(furnace(albedo, le), &run);
            let values: Vec<f64> = image.pixels.iter().flat_map(|p| p.to_array()).map(|v| v as f64).collect();
            let n = values.len() as f64;
            let mean = values.iter().sum::<f64>() / n;
            let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            let expected = (le / (1.0 - albedo)) as f64;
            let bound = 4.0 * sd / n.sqrt() + 1e-4;
            assert!(
                (mean - expected).abs() < bound,
                "{kind:?}, albedo {albedo}: mean radiance {mean}, expected {expected} ± {bound}"
            );
            for v in &values {
                assert!(v.is_finite() && *v >= 0.0, "{kind:?}: pixel value {v}");
            }
        }
    }
}

/// The progressive photon mappers in the same furnace. Hit points share photons, so pixels are not
/// independent and the per-pixel bound above does not apply; what does: the power deposited in a
/// pass is the emitted power times the albedo series up to Russian-roulette noise, about
/// 1/√(photons) ≈ 0.2% over 20 × 20 000 photons, and the disc estimate on the sphere's inner
/// surface is biased by its curvature by about r²/(2R²) < 0.1%. 2% covers both with room; a lost
/// bounce costs 25% (albedo 0.5), a missing NEE or double-counted direct light 50%.
#[test]
fn progressive_photon_mappers_give_unit_radiance_in_the_furnace() {
    for kind in [IntegratorKind::Ppm, IntegratorKind::Sppm, IntegratorKind::Appm, IntegratorKind::Cppm] {
        let mut run = RunFile::default();
        run.render.integrator = kind;
        run.progressive.passes = 20;
        run.progressive.photons_per_pass = 20_000;
        run.film.width = Some(48);
        run.film.height = Some(48);
        caustica::systems::render::init_thread_pools(None);
        let mut renderer =
            caustica::systems::progressive::prepare_progressive(furnace(0.5, 0.5), &run).unwrap();
        renderer.run(None, |_, _| {});
        let image = renderer.image();
        let mean = image.mean().to_array().iter().sum::<f32>() / 3.0;
        assert!((mean - 1.0).abs() < 0.02, "{kind:?}: mean radiance {mean}, expected 1");
        assert!(image.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0), "{kind:?}: bad pixel");
    }
}
