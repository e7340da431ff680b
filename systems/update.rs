//! Update: fold each pass's photons into the hit points' statistics and choose their next radius.
//!
//! Reads and writes `HitPoint` (`n`, `r2`, `tau`; clears `m`, `phi`), with `Chi2Cells` (`cppm`) or
//! `AdaptiveStats` (`appm`); reads `ProgressiveConfig`. The rules are pure functions of
//! `caustica_core::photon::progressive`: `update_hit_point_radii` is Hachisuka, Ogaki & Jensen 2008's
//! (`ppm`, `sppm`); the other two choose the radius from the data and average the passes' estimates
//! instead, as their papers' implementations do.

use super::components::{AdaptiveStats, Chi2Cells, HitPoint};
use super::resources::{ProgressiveConfig, wavefront_batching};
use bevy_ecs::prelude::*;
use caustica_core::lights::light::luminance;
use caustica_core::photon::progressive::{
    CHI2_CELLS, add_pass_estimate, chi2_shrink, global_radius2, hachisuka_update,
};
use glam::Vec3;

/// N' = N + αM, r'² = r² (N+αM)/(N+M), τ' = (τ + Φ_M)(N+αM)/(N+M) (Hachisuka, Ogaki & Jensen 2008,
/// eqs. 6–10). α < 1 keeps only a fraction of each pass's photons, which is what lets the radius
/// shrink; α = 2/3 balances the decay of variance and bias for the fastest asymptotic MSE
/// (Knaus & Zwicker 2011, §4.3).
pub fn update_hit_point_radii(config: Res<ProgressiveConfig>, mut hit_points: Query<&mut HitPoint>) {
    let alpha = config.alpha as f64;
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|mut hp| {
        let (n, r2, tau) = hachisuka_update(hp.n, hp.r2, hp.tau, hp.m, hp.phi.as_dvec3(), alpha);
        (hp.n, hp.r2, hp.tau) = (n, r2, tau);
        clear_pass(&mut hp);
    });
}

/// `cppm`: add this pass's estimate Φ/r² to τ; once the cells hold enough photons, test them for
/// uniformity and keep or shrink the radius (`chi2_shrink`). A shrink restarts the cell counts.
pub fn update_radii_by_chi2(mut hit_points: Query<(&mut HitPoint, &mut Chi2Cells)>) {
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut hp, mut cells)| {
        add_pass(&mut hp);
        if let Some((r2, next_test)) = chi2_shrink(&cells.counts, cells.min_photons, hp.r2) {
            hp.r2 = r2;
            cells.counts = [0; CHI2_CELLS];
            cells.min_photons = next_test;
        }
        clear_pass(&mut hp);
    });
}

/// `appm`: add this pass's estimate to τ, update the running variance and Laplacian estimates, and
/// set the next radius to the MSE-optimal one within a band around the global PPM radius
/// (`AdaptiveStatistics::update`, Kaplanyan & Dachsbacher 2013, eq. 12).
pub fn update_radii_adaptive(
    config: Res<ProgressiveConfig>,
    mut hit_points: Query<(&mut HitPoint, &mut AdaptiveStats)>,
) {
    let global2 = global_radius2(config.r0, config.pass + 1, config.alpha);
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut hp, mut stats)| {
        // Only read when a pass came before (the mean of no passes is not a number).
        let previous_mean = luminance(hp.tau.as_vec3()) as f64 / (std::f64::consts::PI * config.pass as f64);
        let estimate = luminance(hp.phi) as f64 / (std::f64::consts::PI * hp.r2 as f64);
        let r2 = hp.r2;
        add_pass(&mut hp);
        hp.r2 = stats.0.update(config.pass, estimate, previous_mean, r2, global2, config.r0);
        clear_pass(&mut hp);
    });
}

/// τ += Φ_i / r_i², N += M.
fn add_pass(hp: &mut HitPoint) {
    (hp.tau, hp.n) = add_pass_estimate(hp.tau, hp.n, hp.m, hp.phi, hp.r2);
}

fn clear_pass(hp: &mut HitPoint) {
    hp.m = 0;
    hp.phi = Vec3::ZERO;
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::system::RunSystemOnce;
    use caustica_core::photon::progressive::{CHI2_FIRST_TEST, RadiusRule};
    use glam::DVec3;

    fn world(rule: RadiusRule) -> World {
        crate::world::init_thread_pools(None);
        let mut world = World::new();
        world.insert_resource(ProgressiveConfig {
            rule,
            alpha: 2.0 / 3.0,
            r0: 0.1,
            r0_given: true,
            photons_per_pass: 100,
            hit_points_per_pixel: 1,
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
                hp.m = caustica_core::sampling::Sampler::new(1, pass, 0).get1d(0).mul_add(200.0, 0.0) as u32;
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
        use caustica_core::photon::progressive::{CHI2_CELLS, CHI2_SECTORS};
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
