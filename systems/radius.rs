//! Update: fold each pass's photons into the hit points' statistics and choose their next radius.
//!
//! Reads and writes `HitPoint` (`n`, `r2`, `tau`; clears `m`, `phi`), with `Chi2Cells` (`cppm`) or
//! `AdaptiveStats` (`appm`); reads `ProgressiveConfig`. `update_hit_point_radii` is the rule of
//! Hachisuka, Ogaki & Jensen 2008 (`ppm`, `sppm`); the other two choose the radius from the data and
//! average the passes' estimates instead, as their papers' implementations do.

use super::components::{AdaptiveStats, Chi2Cells, HitPoint};
use super::resources::ProgressiveConfig;
use crate::lights::area::luminance;
use crate::photon::progressive::{
    Chi2Verdict, chi2_verdict, global_radius2, hachisuka_update, mse_optimal_radius,
};
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Photons the χ² cells must hold before the first test: about five per cell, the usual floor for
/// Pearson's statistic to follow its χ² law.
pub const CHI2_FIRST_TEST: f32 = 64.0;
/// After each rejection the next test waits for this many times more photons (Lin et al.'s β = 1.25²:
/// the disc's area shrinks by about that much, so the evidence per unit area stays comparable).
const CHI2_PATIENCE: f32 = 1.5625;
/// Shrink factor of r² when even the inner ring is not uniform (Lin et al.'s k = 0.8).
const CHI2_FALLBACK_SHRINK: f32 = 0.8;
/// Passes of statistics `appm` collects before it trusts its variance and Laplacian estimates.
const ADAPTIVE_WARM_UP: u32 = 4;
/// `appm`'s radius stays within these factors of the global PPM radius of the same pass: the
/// estimates are noisy, and the band keeps one bad estimate from blurring or starving a pixel.
const ADAPTIVE_BAND: (f32, f32) = (0.25, 2.0);

/// N' = N + αM, r'² = r² (N+αM)/(N+M), τ' = (τ + Φ_M)(N+αM)/(N+M) (Hachisuka, Ogaki & Jensen 2008,
/// eqs. 6–10). α < 1 keeps only a fraction of each pass's photons, which is what lets the radius
/// shrink; α = 2/3 balances the decay of variance and bias for the fastest asymptotic MSE
/// (Knaus & Zwicker 2011, §4.3).
pub fn update_hit_point_radii(config: Res<ProgressiveConfig>, mut hit_points: Query<&mut HitPoint>) {
    let alpha = config.alpha as f64;
    hit_points.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(|mut hp| {
        let (n, r2, tau) = hachisuka_update(hp.n, hp.r2, hp.tau, hp.m, hp.phi.as_dvec3(), alpha);
        (hp.n, hp.r2, hp.tau) = (n, r2, tau);
        clear_pass(&mut hp);
    });
}

/// `cppm`: add this pass's estimate Φ/r² to τ; once the cells hold enough photons, test them for
/// uniformity and keep the radius, shrink it to the inner ring (r²/2), or shrink it by k (Lin et al.
/// 2020, following the authors' `cppm1.cpp`). A shrink restarts the cell counts.
pub fn update_radii_by_chi2(mut hit_points: Query<(&mut HitPoint, &mut Chi2Cells)>) {
    hit_points.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut hp, mut cells)| {
            add_pass_estimate(&mut hp);
            let total: u32 = cells.counts.iter().sum();
            if (total as f32) >= cells.min_photons {
                let shrink = match chi2_verdict(&cells.counts) {
                    Chi2Verdict::Keep => None,
                    Chi2Verdict::ShrinkToInner => Some(0.5),
                    Chi2Verdict::Shrink => Some(CHI2_FALLBACK_SHRINK),
                };
                if let Some(factor) = shrink {
                    hp.r2 *= factor;
                    cells.counts = [0; crate::photon::progressive::CHI2_CELLS];
                    cells.min_photons *= CHI2_PATIENCE;
                }
            }
            clear_pass(&mut hp);
        },
    );
}

/// `appm`: add this pass's estimate to τ, update the running variance and Laplacian estimates, and
/// set the next radius to the MSE-optimal one, r⁶ = 2C / (μ₂² ΔL² i), within a band around the
/// global PPM radius (Kaplanyan & Dachsbacher 2013, eq. 12; see `photon::progressive`).
pub fn update_radii_adaptive(
    config: Res<ProgressiveConfig>,
    mut hit_points: Query<(&mut HitPoint, &mut AdaptiveStats)>,
) {
    let passes = config.pass + 1;
    let global2 = global_radius2(config.r0, passes, config.alpha);
    let (lo, hi) = (ADAPTIVE_BAND.0 * ADAPTIVE_BAND.0 * global2, ADAPTIVE_BAND.1 * ADAPTIVE_BAND.1 * global2);
    let hi = hi.min(config.r0 * config.r0);
    hit_points.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut hp, mut stats)| {
            let previous_mean = luminance(hp.tau.as_vec3()) as f64 / (std::f64::consts::PI * config.pass as f64);
            let estimate = luminance(hp.phi) as f64 / (std::f64::consts::PI * hp.r2 as f64);
            if config.pass > 0 {
                stats.variance_sum += (estimate - previous_mean).powi(2) * hp.r2 as f64;
            }
            stats.laplacian_sum += stats.laplacian as f64;
            stats.passes += 1;
            stats.laplacian = 0.0;
            add_pass_estimate(&mut hp);
            let chosen = (stats.passes >= ADAPTIVE_WARM_UP)
                .then(|| {
                    let c = stats.variance_sum / (stats.passes - 1) as f64;
                    let laplacian = stats.laplacian_sum / stats.passes as f64;
                    mse_optimal_radius(c, laplacian, passes + 1)
                })
                .flatten()
                .map_or(global2, |r| r * r);
            hp.r2 = chosen.clamp(lo, hi);
            clear_pass(&mut hp);
        },
    );
}

/// τ += Φ_i / r_i², N += M: the accumulation of the rules that average per-pass estimates.
fn add_pass_estimate(hp: &mut HitPoint) {
    if hp.m > 0 {
        let per_area = hp.phi.as_dvec3() / hp.r2 as f64;
        hp.tau += per_area;
        hp.n += hp.m as f64;
    }
}

fn clear_pass(hp: &mut HitPoint) {
    hp.m = 0;
    hp.phi = Vec3::ZERO;
}
