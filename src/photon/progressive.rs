//! The statistics of progressive photon mapping, as pure functions: the radius and flux update of
//! Hachisuka, Ogaki & Jensen 2008, the χ² uniformity test of Lin et al. 2020, and the MSE-optimal
//! radius of Kaplanyan & Dachsbacher 2013, and how each rule turns a hit point's statistics into
//! radiance. The update systems in `systems/` apply them per hit point.

use glam::{DVec3, Vec2, Vec3};

/// How a progressive integrator turns a hit point's statistics into radiance and a new radius.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RadiusRule {
    /// Hachisuka, Ogaki & Jensen 2008: flux-corrected shrinking with α; L = τ / (π r² passes).
    Shrinking,
    /// Kaplanyan & Dachsbacher 2013: per-pass estimates averaged, radius from estimated bias and
    /// variance; L = τ / (π passes) with τ = Σ Φ_i / r_i².
    Adaptive,
    /// Lin et al. 2020: per-pass estimates averaged, radius kept while the χ² test finds the photons
    /// uniform in the disc; L as for `Adaptive`.
    ChiSquare,
    /// Knaus & Zwicker 2011 (`pppm`): every pass gathers at the global radius of its index and adds
    /// its estimate Φ/(π r²) to the film as it ends; τ stays zero.
    Global,
}

impl RadiusRule {
    /// The radiance of a hit point with accumulated flux `tau` and squared radius `r2` after `passes`
    /// photon passes (photon powers are already divided by the photons per pass): L = τ / (π r²
    /// passes) for the shrinking rule, τ / (π passes) for the averaging rules, whose τ is per unit
    /// area already. Before the first pass τ is zero, and so is L.
    #[inline]
    pub fn radiance(self, tau: DVec3, r2: f32, passes: u32) -> DVec3 {
        let area = match self {
            Self::Shrinking => std::f64::consts::PI * r2 as f64,
            Self::Adaptive | Self::ChiSquare | Self::Global => std::f64::consts::PI,
        };
        tau / (area * passes.max(1) as f64)
    }
}

/// The accumulation of the rules that average per-pass estimates: τ += Φ_i / r_i², N += M, for a
/// pass in which `m` photons with flux `phi` landed within √`r2`. Returns (τ', N').
#[inline]
pub fn add_pass_estimate(tau: DVec3, n: f64, m: u32, phi: Vec3, r2: f32) -> (DVec3, f64) {
    if m == 0 {
        return (tau, n);
    }
    (tau + phi.as_dvec3() / r2 as f64, n + m as f64)
}

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

/// Photons the χ² cells must hold before the first test: about five per cell, the usual floor for
/// Pearson's statistic to follow its χ² law.
pub const CHI2_FIRST_TEST: f32 = 64.0;
/// After each rejection the next test waits for this many times more photons (Lin et al.'s β = 1.25²:
/// the disc's area shrinks by about that much, so the evidence per unit area stays comparable).
pub const CHI2_PATIENCE: f32 = 1.5625;
/// Shrink factor of r² when even the inner ring is not uniform (Lin et al.'s k = 0.8).
pub const CHI2_FALLBACK_SHRINK: f32 = 0.8;

/// `cppm`'s radius rule (Lin et al. 2020, following the authors' `cppm1.cpp`): once the cells hold
/// `min_photons`, test them and keep the radius, shrink it to the inner ring (r²/2), or shrink r² by
/// the fallback factor. Returns the new r² and the photons the next test waits for when the radius
/// shrinks (the counts then restart), None when it stays.
pub fn chi2_shrink(counts: &[u32; CHI2_CELLS], min_photons: f32, r2: f32) -> Option<(f32, f32)> {
    let total: u32 = counts.iter().sum();
    if (total as f32) < min_photons {
        return None;
    }
    let factor = match chi2_verdict(counts) {
        Chi2Verdict::Keep => return None,
        Chi2Verdict::ShrinkToInner => 0.5,
        Chi2Verdict::Shrink => CHI2_FALLBACK_SHRINK,
    };
    Some((r2 * factor, min_photons * CHI2_PATIENCE))
}

/// Passes of statistics `appm` collects before it trusts its variance and Laplacian estimates.
pub const ADAPTIVE_WARM_UP: u32 = 4;
/// `appm`'s radius stays within these factors of the global PPM radius of the same pass: the
/// estimates are noisy, and the band keeps one bad estimate from blurring or starving a pixel.
pub const ADAPTIVE_BAND: (f32, f32) = (0.25, 2.0);

/// What `appm` keeps per hit point to choose its radius (Kaplanyan & Dachsbacher 2013).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdaptiveStatistics {
    /// Σ over passes of the luminance Laplacian estimate ΔL_i.
    pub laplacian_sum: f64,
    /// Σ over passes of (L_i − L̄)² r_i²: the per-pass variance times r², which is radius-free.
    pub variance_sum: f64,
    /// Passes that contributed to the sums.
    pub passes: u32,
    /// This pass's Laplacian estimate (luminance), cleared by the update.
    pub laplacian: f32,
}

impl AdaptiveStatistics {
    /// Fold pass `pass` (0-based) into the statistics — its estimate of luminance `estimate` at
    /// squared radius `r2`, against the mean `previous_mean` of the passes before — and return the
    /// squared radius for the next pass: the MSE-optimal one, r⁶ = 2C / (μ₂² ΔL² i) (Kaplanyan &
    /// Dachsbacher 2013, eq. 12), within [`ADAPTIVE_BAND`] of the global PPM radius `global2` and
    /// below the initial radius `r0`; `global2` itself until the estimates have warmed up.
    pub fn update(
        &mut self,
        pass: u32,
        estimate: f64,
        previous_mean: f64,
        r2: f32,
        global2: f32,
        r0: f32,
    ) -> f32 {
        let (lo, hi) =
            (ADAPTIVE_BAND.0 * ADAPTIVE_BAND.0 * global2, ADAPTIVE_BAND.1 * ADAPTIVE_BAND.1 * global2);
        let hi = hi.min(r0 * r0);
        if pass > 0 {
            self.variance_sum += (estimate - previous_mean).powi(2) * r2 as f64;
        }
        self.laplacian_sum += self.laplacian as f64;
        self.passes += 1;
        self.laplacian = 0.0;
        let chosen = (self.passes >= ADAPTIVE_WARM_UP)
            .then(|| {
                let c = self.variance_sum / (self.passes - 1) as f64;
                let laplacian = self.laplacian_sum / self.passes as f64;
                mse_optimal_radius(c, laplacian, pass + 2)
            })
            .flatten()
            .map_or(global2, |r| r * r);
        chosen.clamp(lo, hi)
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

/// `FOOTPRINT_PIXELS` pixel footprints at the median of `distances` from the eye, if there is one.
pub fn radius_cap(camera: &crate::camera::Camera, distances: Vec<f32>) -> Option<f32> {
    /// A first estimate blurred over up to ten pixels is smooth enough and sharpens within passes.
    const FOOTPRINT_PIXELS: f32 = 10.0;
    pixel_footprint(camera, distances).map(|footprint| FOOTPRINT_PIXELS * footprint)
}

/// The width a pixel covers at the median of `distances` from the eye, if there is one.
pub fn pixel_footprint(camera: &crate::camera::Camera, mut distances: Vec<f32>) -> Option<f32> {
    let (cx, cy) = (camera.width / 2, camera.height / 2);
    let ray = |x| camera.generate_ray(x, cy, Vec2::splat(0.5), Vec2::splat(0.5), 0.0);
    let pixel_angle = ray(cx).d.normalize().angle_between(ray(cx + 1).d.normalize());
    if distances.is_empty() || pixel_angle.is_nan() || pixel_angle <= 0.0 {
        return None;
    }
    let mid = distances.len() / 2;
    let median = *distances.select_nth_unstable_by(mid, f32::total_cmp).1;
    let footprint = pixel_angle * median;
    (footprint > 0.0).then_some(footprint)
}

/// The distances from the eye of the first hits of rays through the centres of a grid of at most
/// 64 × 64 of the camera's pixels: what `pppm` caps its first radius by before any pass, so that
/// the radius is a function of the scene and camera alone (any share of a split render computes it).
pub fn probe_hit_distances(camera: &crate::camera::Camera, geometry: &crate::geometry::Geometry) -> Vec<f32> {
    let step = |n: u32| n.div_ceil(64).max(1) as usize;
    let mut distances = Vec::new();
    for y in (0..camera.height).step_by(step(camera.height)) {
        for x in (0..camera.width).step_by(step(camera.width)) {
            let ray = camera.generate_ray(x, y, Vec2::splat(0.5), Vec2::splat(0.5), 0.0);
            let hit = geometry.intersect(&ray);
            if hit.t.is_finite() {
                distances.push(hit.t * ray.d.length());
            }
        }
    }
    distances
}

/// A pass's radiance estimate at a hit point from the flux Φ its photons brought within radius²
/// `r2` (Knaus & Zwicker 2011, eq. 9 with the uniform kernel): Φ / (π r²).
#[inline]
pub fn pass_estimate(phi: Vec3, r2: f32) -> Vec3 {
    phi / (std::f32::consts::PI * r2)
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
    fn each_rule_turns_its_statistics_into_radiance() {
        // Shrinking: τ / (π r² passes); averaging rules: τ / (π passes), τ being per unit area already.
        let tau = DVec3::new(2.0, 4.0, 6.0);
        let l = RadiusRule::Shrinking.radiance(tau, 0.5, 4);
        assert!((l - tau / (std::f64::consts::PI * 0.5 * 4.0)).abs().max_element() < 1e-12);
        for rule in [RadiusRule::Adaptive, RadiusRule::ChiSquare] {
            let l = rule.radiance(tau, 0.5, 4);
            assert!((l - tau / (std::f64::consts::PI * 4.0)).abs().max_element() < 1e-12);
        }
        assert_eq!(RadiusRule::Shrinking.radiance(tau, 0.5, 0), RadiusRule::Shrinking.radiance(tau, 0.5, 1));
    }

    #[test]
    fn averaging_rules_add_flux_per_area_and_skip_empty_passes() {
        let (tau, n) = add_pass_estimate(DVec3::ONE, 10.0, 4, Vec3::splat(0.5), 0.25);
        assert_eq!((tau, n), (DVec3::splat(3.0), 14.0));
        assert_eq!(add_pass_estimate(DVec3::ONE, 10.0, 0, Vec3::ZERO, 0.25), (DVec3::ONE, 10.0));
    }

    #[test]
    fn chi2_rule_waits_for_photons_then_shrinks_by_its_verdict() {
        let mut inner = [0u32; CHI2_CELLS];
        inner[..CHI2_SECTORS].fill(40);
        // 240 photons, short of a threshold of 300: no test yet.
        assert_eq!(chi2_shrink(&inner, 300.0, 0.01), None);
        let (r2, next) = chi2_shrink(&inner, CHI2_FIRST_TEST, 0.01).unwrap();
        assert!((r2 - 0.005).abs() < 1e-9 && (next - CHI2_FIRST_TEST * CHI2_PATIENCE).abs() < 1e-6);
        assert_eq!(chi2_shrink(&[50; CHI2_CELLS], CHI2_FIRST_TEST, 0.01), None);
    }

    #[test]
    fn adaptive_radius_uses_the_global_radius_until_warm_then_stays_in_its_band() {
        let mut stats = AdaptiveStatistics::default();
        let (global2, r0) = (0.01f32, 1.0f32);
        for pass in 0..ADAPTIVE_WARM_UP - 1 {
            stats.laplacian = 5.0;
            let r2 = stats.update(pass, 1.0 + pass as f64 * 0.1, 1.0, 0.01, global2, r0);
            assert_eq!(r2, global2, "pass {pass}: not warmed up");
        }
        stats.laplacian = 5.0;
        let r2 = stats.update(ADAPTIVE_WARM_UP - 1, 1.3, 1.0, 0.01, global2, r0);
        assert_eq!(stats.passes, ADAPTIVE_WARM_UP);
        assert_eq!(stats.laplacian, 0.0, "the pass's Laplacian is folded in and cleared");
        let (lo, hi) = (0.0625 * global2, 4.0 * global2);
        assert!((lo..=hi).contains(&r2) && r2 != global2, "r² = {r2}");
        // A huge variance asks for a huge radius: the band's top, and never above r0².
        stats.variance_sum = 1e9;
        assert_eq!(stats.update(ADAPTIVE_WARM_UP, 1.0, 1.0, 0.01, global2, 0.15), 0.15 * 0.15);
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
