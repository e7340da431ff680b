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
            let previous_mean =
                luminance(hp.tau.as_vec3()) as f64 / (std::f64::consts::PI * config.pass as f64);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::resources::RadiusRule;
    use bevy_ecs::system::RunSystemOnce;
    use glam::DVec3;

    fn world(rule: RadiusRule) -> World {
        crate::render::init_thread_pools(None);
        let mut world = World::new();
        world.insert_resource(ProgressiveConfig {
            rule,
            alpha: 2.0 / 3.0,
            r0: 0.1,
            photons_per_pass: 100,
            pass: 0,
        });
        world
    }

    fn hit_point(n: f64, r2: f32, tau: f64, m: u32, phi: f32) -> HitPoint {
        HitPoint { n, tau: DVec3::splat(tau), m, phi: Vec3::splat(phi), beta: Vec3::ONE, ..HitPoint::new(r2) }
    }

    #[test]
    fn a_hit_point_that_got_photons_shrinks_as_the_paper_says() {
        let mut world = world(RadiusRule::Shrinking);
        let e = world.spawn(hit_point(30.0, 0.01, 2.0, 12, 0.5)).id();
        world.run_system_once(update_hit_point_radii).unwrap();
        let hp = world.get::<HitPoint>(e).unwrap();
        let alpha = (2.0f32 / 3.0) as f64;
        let ratio = (30.0 + alpha * 12.0) / (30.0 + 12.0);
        assert!((hp.n - (30.0 + alpha * 12.0)).abs() < 1e-9, "N = {}", hp.n);
        assert!((hp.r2 as f64 - 0.01 * ratio).abs() < 1e-9, "r² = {}", hp.r2);
        assert!((hp.tau.x - 2.5 * ratio).abs() < 1e-6, "τ = {}", hp.tau);
        assert_eq!((hp.m, hp.phi), (0, Vec3::ZERO), "the pass's M and Φ are cleared");
    }

    #[test]
    fn a_hit_point_without_photons_keeps_its_radius_and_flux() {
        let mut world = world(RadiusRule::Shrinking);
        let e = world.spawn(hit_point(30.0, 0.01, 2.0, 0, 0.0)).id();
        world.run_system_once(update_hit_point_radii).unwrap();
        let hp = world.get::<HitPoint>(e).unwrap();
        assert_eq!((hp.n, hp.r2, hp.tau), (30.0, 0.01, DVec3::splat(2.0)));
    }

    /// 10⁵ passes of 0–199 photons each: the radius never grows, N never falls, and everything stays
    /// positive and finite (f64 N and τ do not stall: N ends near 6.6·10⁶).
    #[test]
    fn over_a_hundred_thousand_passes_the_radius_never_grows_and_stays_positive() {
        let mut world = world(RadiusRule::Shrinking);
        let e = world.spawn(hit_point(0.0, 0.01, 0.0, 0, 0.0)).id();
        let mut schedule = Schedule::default();
        schedule.add_systems(update_hit_point_radii);
        for pass in 0..100_000u32 {
            let before = *world.get::<HitPoint>(e).unwrap();
            {
                let mut hp = world.get_mut::<HitPoint>(e).unwrap();
                hp.m = crate::sampling::Sampler::new(1, pass, 0).get1d(0).mul_add(200.0, 0.0) as u32;
                hp.phi = Vec3::splat(hp.m as f32 * 1e-3);
            }
            schedule.run(&mut world);
            let hp = world.get::<HitPoint>(e).unwrap();
            assert!(
                hp.r2 <= before.r2 && hp.n >= before.n,
                "pass {pass}: r² {} → {}, N {} → {}",
                before.r2,
                hp.r2,
                before.n,
                hp.n
            );
        }
        let hp = world.get::<HitPoint>(e).unwrap();
        assert!(hp.r2 > 0.0 && hp.r2.is_finite() && hp.n.is_finite() && hp.tau.is_finite(), "{hp:?}");
        assert!(hp.n > 6.0e6, "N = {}", hp.n);
        assert!(hp.tau.x > 0.0, "τ = {}: the flux correction underflowed", hp.tau.x);
    }

    #[test]
    fn chi2_rule_keeps_a_uniform_disc_and_shrinks_a_one_sided_one() {
        use crate::photon::progressive::{CHI2_CELLS, CHI2_SECTORS};
        let mut world = world(RadiusRule::ChiSquare);
        let uniform = Chi2Cells { counts: [20; CHI2_CELLS], min_photons: CHI2_FIRST_TEST };
        let mut half = [0; CHI2_CELLS];
        for ring in 0..2 {
            half[ring * CHI2_SECTORS..ring * CHI2_SECTORS + 3].fill(40);
        }
        let one_sided = Chi2Cells { counts: half, min_photons: CHI2_FIRST_TEST };
        let a = world.spawn((hit_point(0.0, 0.01, 0.0, 240, 1.0), uniform)).id();
        let b = world.spawn((hit_point(0.0, 0.01, 0.0, 240, 1.0), one_sided)).id();
        world.run_system_once(update_radii_by_chi2).unwrap();
        let (ha, ca) = (world.get::<HitPoint>(a).unwrap(), world.get::<Chi2Cells>(a).unwrap());
        assert_eq!(ha.r2, 0.01);
        assert_eq!(ca.counts, [20; CHI2_CELLS], "a kept radius keeps counting");
        assert!((ha.tau.x * 0.01 - 1.0).abs() < 1e-6, "τ gains Φ/r²: {}", ha.tau.x);
        let (hb, cb) = (world.get::<HitPoint>(b).unwrap(), world.get::<Chi2Cells>(b).unwrap());
        assert!((hb.r2 - 0.008).abs() < 1e-9, "r² {}", hb.r2);
        assert_eq!(cb.counts, [0; CHI2_CELLS]);
        assert!(cb.min_photons > CHI2_FIRST_TEST);
    }
}
