//! The statistics of progressive photon mapping, as pure functions: the radius and flux update of
//! Hachisuka, Ogaki & Jensen 2008, the χ² uniformity test of Lin et al. 2020, and the MSE-optimal
//! radius of Kaplanyan & Dachsbacher 2013. The systems in `systems/radius.rs` apply them per hit point.

use glam::{DVec3, Vec2};

/// Hachisuka, Ogaki & Jensen 2008, §4.2, after a pass in which `m` photons with reflected flux `phi`
/// landed within radius √`r2` of a hit point that had accumulated `n` photons and flux `tau`:
///
/// N' = N + αM,  r'² = r² (N + αM)/(N + M),  τ' = (τ + Φ_M)(N + αM)/(N + M).
///
/// Returns (N', r'², τ'). A hit point that got no photon keeps everything (the ratio would be 1).
/// The ratio is at most 1, so the radius never grows, and N' ≥ N.
#[inline]
pub fn hachisuka_update(n: f64, r2: f32, tau: DVec3, m: u32, phi: DVec3, alpha: f64) -> (f64, f32, DVec3) {
    if m == 0 {
        return (n, r2, tau);
    }
    let m = m as f64;
    let n_new = n + alpha * m;
    let ratio = n_new / (n + m);
    ((n_new), (r2 as f64 * ratio) as f32, (tau + phi) * ratio)
}

/// The global PPM radius after `pass` passes (0-based) when every hit point sees the same expected
/// photon count per pass: r_i² = r₀² Π_{j≤i} (j·α + α)/(j·α + 1) ≈ r₀² i^(α−1) (Knaus & Zwicker
/// 2011, eq. 16). Used to bound the data-driven radii.
pub fn global_radius2(r0: f32, pass: u32, alpha: f32) -> f32 {
    let mut r2 = r0 as f64 * r0 as f64;
    for j in 1..=pass {
        r2 *= (j as f64 + alpha as f64) / (j as f64 + 1.0);
    }
    r2 as f32
}

/// The starting radius when the user gives none: a disc that holds about `TARGET_PHOTONS` photons of
/// one pass if the pass's photons spread evenly over the scene's surface area `area`, never larger
/// than 5% of the scene diagonal (a huge ground plane would otherwise blur everything on it).
pub fn initial_radius(area: f32, diagonal: f32, photons_per_pass: u32) -> f32 {
    /// Enough photons that the first passes are not pure noise, few enough that the first estimate is
    /// not blurred across a whole object.
    const TARGET_PHOTONS: f32 = 20.0;
    let r = (TARGET_PHOTONS * area / (std::f32::consts::PI * photons_per_pass.max(1) as f32)).sqrt();
    let cap = 0.05 * diagonal;
    if r.is_finite() && r > 0.0 { r.min(cap) } else { cap }
}

/// Rings of the χ² test: equal-area annuli of the gather disc (Lin et al. 2020 use 2).
pub const CHI2_RINGS: usize = 2;
/// Sectors of the χ² test: equal angles in the tangent plane (Lin et al. 2020 use 6).
pub const CHI2_SECTORS: usize = 6;
/// Cells of the χ² test.
pub const CHI2_CELLS: usize = CHI2_RINGS * CHI2_SECTORS;

/// The cell of a photon at tangent-plane offset `offset` and squared distance `d2` inside a disc of
/// squared radius `r2`: ring ⌊RINGS·d²/r²⌋ (equal areas), sector by angle.
#[inline]
pub fn chi2_cell(offset: Vec2, d2: f32, r2: f32) -> usize {
    let ring = ((CHI2_RINGS as f32 * d2 / r2) as usize).min(CHI2_RINGS - 1);
    let angle = offset.y.atan2(offset.x) + std::f32::consts::PI; // [0, 2π]
    let sector = ((angle * (CHI2_SECTORS as f32 / std::f32::consts::TAU)) as usize).min(CHI2_SECTORS - 1);
    ring * CHI2_SECTORS + sector
}

/// 95% quantiles of χ² with 5 and 11 degrees of freedom (6 and 12 equiprobable cells).
const CHI2_95: [(usize, f64); 2] = [(CHI2_SECTORS, 11.070), (CHI2_CELLS, 19.675)];

/// Pearson's statistic for equiprobable cells, Σ (O − E)²/E = m ΣO²/ΣO − ΣO; an empty disc passes.
fn pearson_uniform(counts: &[u32]) -> f64 {
    let total: f64 = counts.iter().map(|&c| c as f64).sum();
    if total == 0.0 {
        return 0.0;
    }
    let sum_sq: f64 = counts.iter().map(|&c| (c as f64) * (c as f64)).sum();
    counts.len() as f64 * sum_sq / total - total
}

/// What the χ² test says about the photons in a gather disc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Chi2Verdict {
    /// Uniform over the whole disc at the 95% level: keep the radius.
    Keep,
    /// Not uniform over the disc, but uniform over its inner ring: shrink to the inner ring's radius.
    ShrinkToInner,
    /// Not uniform even in the inner ring: shrink by the fallback factor.
    Shrink,
}

/// Test the accumulated cell counts (ring-major, `CHI2_CELLS` of them) for uniformity over the whole
/// disc and over its inner ring (Lin et al. 2020, as in the authors' `cppm1.cpp`).
pub fn chi2_verdict(counts: &[u32; CHI2_CELLS]) -> Chi2Verdict {
    let inner = &counts[..CHI2_SECTORS];
    let passes = |cells: &[u32]| {
        let limit = CHI2_95.iter().find(|(m, _)| *m == cells.len()).map_or(f64::INFINITY, |q| q.1);
        pearson_uniform(cells) <= limit
    };
    if passes(counts) {
        Chi2Verdict::Keep
    } else if passes(inner) {
        Chi2Verdict::ShrinkToInner
    } else {
        Chi2Verdict::Shrink
    }
}

/// Second moment μ₂ = ∫ x₁² K(x) dx of the uniform disc kernel of unit radius: the bias of the disc
/// estimate is (r²/2) μ₂ ΔL = r² ΔL / 8 (Silverman 1986, §4.3.1, in 2-D).
pub const DISC_MU2: f32 = 0.25;

/// Laplacian of the 2-D biweight kernel K(d) = 3/(πr²) (1 − d²/r²)², which is C¹ at the rim, so its
/// Laplacian has no singular part there: ΔK = −24/(πr⁴) (1 − 2d²/r²) for d < r. Summing
/// photon power × this over the photons near a point estimates the Laplacian of the radiance there.
#[inline]
pub fn biweight_laplacian(d2: f32, r2: f32) -> f32 {
    if d2 >= r2 {
        return 0.0;
    }
    -24.0 / (std::f32::consts::PI * r2 * r2) * (1.0 - 2.0 * d2 / r2)
}

/// The radius that minimises the asymptotic MSE of the disc estimate averaged over `passes` passes
/// (Kaplanyan & Dachsbacher 2013, eq. 12, in our notation): with per-pass variance C / r² and bias
/// r² μ₂ ΔL / 2, MSE(r) = (μ₂ΔL/2)² r⁴ + C/(r² i), minimal at r⁶ = 2C / (μ₂² ΔL² i).
/// Returns `None` when the statistics do not determine it (no variance or no curvature seen yet).
pub fn mse_optimal_radius(c: f64, laplacian: f64, passes: u32) -> Option<f32> {
    let mu2 = DISC_MU2 as f64;
    let denominator = mu2 * mu2 * laplacian * laplacian * passes.max(1) as f64;
    let r6 = 2.0 * c / denominator;
    (c > 0.0 && denominator > 0.0 && r6.is_finite()).then(|| r6.powf(1.0 / 6.0) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn update_shrinks_by_the_papers_ratio() {
        let (n, r2, tau) = hachisuka_update(10.0, 4.0, DVec3::splat(2.0), 6, DVec3::splat(1.0), 2.0 / 3.0);
        let ratio = (10.0 + 4.0) / 16.0;
        assert!((n - 14.0).abs() < 1e-12);
        assert!((r2 as f64 - 4.0 * ratio).abs() < 1e-6);
        assert!((tau - DVec3::splat(3.0 * ratio)).abs().max_element() < 1e-12);
    }

    #[test]
    fn update_without_photons_changes_nothing() {
        assert_eq!(hachisuka_update(3.0, 1.5, DVec3::ONE, 0, DVec3::ZERO, 0.7), (3.0, 1.5, DVec3::ONE));
    }

    #[test]
    fn global_radius_follows_the_power_law() {
        // r_i² / r₀² → i^(α−1) up to a constant: the log-log slope over a decade is α − 1.
        let alpha = 2.0 / 3.0;
        let slope = (global_radius2(1.0, 10_000, alpha) / global_radius2(1.0, 1000, alpha)).log10();
        assert!((slope - (alpha - 1.0)).abs() < 0.01, "slope {slope}");
    }

    #[test]
    fn chi2_accepts_uniform_and_rejects_one_sided_discs() {
        let uniform = [50u32; CHI2_CELLS];
        assert_eq!(chi2_verdict(&uniform), Chi2Verdict::Keep);
        // Light on the inner ring only (a caustic smaller than the disc).
        let mut inner = [0u32; CHI2_CELLS];
        inner[..CHI2_SECTORS].fill(40);
        assert_eq!(chi2_verdict(&inner), Chi2Verdict::ShrinkToInner);
        // Light on one side only (an edge of a shadow through the middle).
        let mut half = [0u32; CHI2_CELLS];
        for ring in 0..CHI2_RINGS {
            half[ring * CHI2_SECTORS..ring * CHI2_SECTORS + 3].fill(40);
        }
        assert_eq!(chi2_verdict(&half), Chi2Verdict::Shrink);
    }

    #[test]
    fn chi2_cells_have_equal_area() {
        // Uniform points in the unit disc land evenly in the cells.
        let mut counts = [0u32; CHI2_CELLS];
        let n = 120_000;
        for i in 0..n {
            let s = crate::sampling::Sampler::new(3, i, 0);
            let p = crate::sampling::warp::concentric_disk(s.get2d(0));
            counts[chi2_cell(p, p.length_squared(), 1.0)] += 1;
        }
        // 11 degrees of freedom: the 0.999 quantile is 31.3.
        assert!(pearson_uniform(&counts) < 31.3, "{counts:?}");
    }

    #[test]
    fn biweight_laplacian_integrates_to_zero_and_recovers_a_quadratic() {
        // ∫ΔK = 0 (no singular rim term), and ∫ΔK(x) f(x) dx = Δf for f = x² + y² (Δf = 4).
        let (r2, steps) = (0.25f32, 400);
        let (mut total, mut quadratic) = (0.0f64, 0.0f64);
        let h = 1.0 / steps as f32;
        for i in 0..steps {
            for j in 0..steps {
                let x = (i as f32 + 0.5) * h - 0.5;
                let y = (j as f32 + 0.5) * h - 0.5;
                let w = biweight_laplacian(x * x + y * y, r2) as f64 * (h * h) as f64;
                total += w;
                quadratic += w * (x * x + y * y) as f64;
            }
        }
        assert!(total.abs() < 1e-2, "∫ΔK = {total}");
        assert!((quadratic - 4.0).abs() < 0.05, "∫ΔK f = {quadratic}, expected 4");
    }

    #[test]
    fn optimal_radius_balances_bias_and_variance() {
        let (c, lap, i) = (0.3, 20.0, 50);
        let r = mse_optimal_radius(c, lap, i).unwrap() as f64;
        let mse = |r: f64| (DISC_MU2 as f64 * lap / 2.0).powi(2) * r.powi(4) + c / (r * r * i as f64);
        assert!(mse(r) <= mse(r * 1.05) && mse(r) <= mse(r * 0.95));
        assert_eq!(mse_optimal_radius(0.0, lap, i), None);
        assert_eq!(mse_optimal_radius(c, 0.0, i), None);
    }
}
