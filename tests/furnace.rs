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
