//! Gather: splat finished camera paths onto the film and hand their entity the next work item; hand
//! `bdpt`'s and `vcm`'s light subpaths their next subpath; gather each progressive pass's photons
//! into the hit points; learn light visibility from shadow rays.
//!
//! | system | reads | writes |
//! |---|---|---|
//! | `splat_paths_to_film` | finished `PathState`s and their `PathAov`s, `PassRange` | `FilmResource`, `AovFilmResource`, `RenderStats`, `Workload`, `PathState` (next pixel and sample) |
//! | `learn_light_visibility` | fresh `ShadowRay`s | `SceneResource` (the visibility grid) |
//! | `build_pass_photon_map` | `PhotonBuffer` (ordered by `order_photon_deposits`) | `PassPhotons` |
//! | `gather_photons_into_hit_points` (`_into_chi2_cells`, `_with_laplacian`) | `PassPhotons` | `HitPoint::m`, `phi` (`Chi2Cells`, `AdaptiveStats`) |
//!
//! The splat runs on every thread: the film's sums are fixed point, so their bits do not depend on
//! the order samples arrive in; nor do the learned grid's, which are integer counts. The light
//! subpaths' hand-out runs on one thread on purpose: visiting entities in order gives each the same
//! subpath whatever the thread count. The photon maps' deposits are ordered on the vector core
//! (`order_photon_deposits`), so their kd-trees are the same bits whatever the thread count.

use super::components::{AdaptiveStats, Chi2Cells, HitPoint, PathAov, PathState, PathStatus, ShadowRay};
use super::resources::{
    AdaptiveSampling, AovFilmResource, BadSample, FilmResource, PassPhotons, PassRange, PhotonBuffer,
    ProgressiveConfig, RenderStats, SceneResource, Workload, wavefront_batching,
};
use bevy_ecs::prelude::*;
use caustica_core::lights::light::luminance;
use caustica_core::photon::progressive::{biweight_laplacian, chi2_cell};
use caustica_core::render_scene::RenderScene;
use glam::Vec3;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Splat finished paths, count rays and dropped samples, and advance each entity's work, on every
/// thread: the film's fixed-point sums do not depend on the order samples arrive in, and which entity
/// takes which work item does not change what is rendered (a sample's random numbers are a function
/// of its pixel and index). The set of items in flight after each step is the same for any thread
/// count, so the counters are too.
pub fn splat_paths_to_film(
    range: Res<PassRange>,
    workload: Res<Workload>,
    film: Res<FilmResource>,
    aov_film: Option<Res<AovFilmResource>>,
    adaptive: Option<Res<AdaptiveSampling>>,
    mut stats: ResMut<RenderStats>,
    mut paths: Query<(&mut PathState, Option<&PathAov>)>,
) {
    let totals = SplatTotals::default();
    let aov_film = aov_film.as_deref();
    let squares = adaptive.as_deref().map(|a| &a.squares);
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each_init(
        || SplatTally::new(&totals),
        |tally, (mut state, aov)| {
            if !finished(state.status, &mut tally.active) {
                return;
            }
            let state = &mut *state;
            // NaN/Inf (and absurd magnitudes) never reach the film: the sample counts, its radiance
            // does not.
            let l = if caustica_core::film::fixed::accepts(state.path.l) {
                state.path.l
            } else {
                tally.bad += 1;
                let bad = BadSample { pixel: state.pixel, sample: state.sample, cause: state.path.first_bad };
                if tally.first_bad.is_none_or(|first| bad.order() < first.order()) {
                    tally.first_bad = Some(bad);
                }
                Vec3::ZERO
            };
            film.add(state.pixel, l);
            if let Some(squares) = squares {
                squares.add(state.pixel, l);
            }
            // Feature images count every sample, as colour does; one that never found a
            // non-specular surface adds zeros.
            if let (Some(aov_film), Some(aov)) = (aov_film, aov) {
                aov_film.add(state.pixel, &aov.0.sample);
            }
            tally.samples += 1;
            tally.rays += state.rays as u64;
            tally.shadow_rays += state.shadow_rays as u64;
            tally.lookups += state.lookups as u64;
            state.lookups = 0;
            state.rays = 0;
            state.shadow_rays = 0;
            let next = if range.stop {
                None
            } else {
                workload.take(workload.lane_of_item(state.pixel, state.sample))
            };
            match next {
                Some((pixel, sample)) => {
                    state.pixel = pixel;
                    state.sample = sample;
                    state.status = PathStatus::NeedsStart;
                    tally.active += 1;
                }
                None => state.status = PathStatus::Idle,
            }
        },
    );
    let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
    stats.samples += load(&totals.samples);
    stats.rays += load(&totals.rays);
    stats.shadow_rays += load(&totals.shadow_rays);
    stats.lookups += load(&totals.lookups);
    stats.nan_samples += load(&totals.bad);
    if let Some(bad) = totals.first_bad.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner())
        && stats.first_bad.is_none_or(|first| bad.order() < first.order())
    {
        stats.first_bad = Some(bad);
    }
    stats.active_paths = load(&totals.active) as u32;
    stats.steps += 1;
}

/// The splat's counters over all batches.
#[derive(Default)]
struct SplatTotals {
    samples: AtomicU64,
    rays: AtomicU64,
    shadow_rays: AtomicU64,
    lookups: AtomicU64,
    bad: AtomicU64,
    active: AtomicU64,
    first_bad: Mutex<Option<BadSample>>,
}

/// One batch's counters, added to the totals once, when the batch ends (not once per path, which
/// would have every thread contend for the same cache lines).
struct SplatTally<'a> {
    totals: &'a SplatTotals,
    samples: u64,
    rays: u64,
    shadow_rays: u64,
    lookups: u64,
    bad: u64,
    active: u32,
    first_bad: Option<BadSample>,
}

impl<'a> SplatTally<'a> {
    fn new(totals: &'a SplatTotals) -> Self {
        Self { totals, samples: 0, rays: 0, shadow_rays: 0, lookups: 0, bad: 0, active: 0, first_bad: None }
    }
}

impl Drop for SplatTally<'_> {
    fn drop(&mut self) {
        let t = self.totals;
        t.samples.fetch_add(self.samples, Ordering::Relaxed);
        t.rays.fetch_add(self.rays, Ordering::Relaxed);
        t.shadow_rays.fetch_add(self.shadow_rays, Ordering::Relaxed);
        t.lookups.fetch_add(self.lookups, Ordering::Relaxed);
        t.bad.fetch_add(self.bad, Ordering::Relaxed);
        t.active.fetch_add(self.active as u64, Ordering::Relaxed);
        if let Some(bad) = self.first_bad {
            let mut first = t.first_bad.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            if first.is_none_or(|f| bad.order() < f.order()) {
                *first = Some(bad);
            }
        }
    }
}

/// Whether an entity has just finished and waits to be gathered; counts it in `active` if it is still
/// working.
#[inline]
fn finished(status: PathStatus, active: &mut u32) -> bool {
    match status {
        PathStatus::Idle => false,
        PathStatus::Active | PathStatus::NeedsStart => {
            *active += 1;
            false
        }
        PathStatus::Finished => true,
    }
}

/// Visibility-aware light selection: learn from every shadow ray traced this step which light
/// clusters are visible from where.
pub fn learn_light_visibility(scene: Res<SceneResource>, mut shadows: Query<&mut ShadowRay>) {
    if !scene.lights.is_learning() {
        return;
    }
    for mut shadow in &mut shadows {
        if !shadow.fresh {
            continue;
        }
        shadow.fresh = false;
        scene.lights.record_visibility(shadow.ray.o, shadow.normal, shadow.light, shadow.visible);
    }
}

/// Arrange the pass's photon deposits into a kd-tree (parallel, deterministic) for gathering.
pub fn build_pass_photon_map(mut buffer: ResMut<PhotonBuffer>, mut pass: ResMut<PassPhotons>) {
    pass.map = caustica_core::photon::PhotonMap::build(std::mem::take(&mut buffer.photons));
}

/// Visit every photon of the pass that counts for hit point `hp` (`GatherPoint::contribution`):
/// `visit(tangent-plane offset, squared distance, β · f · ΔΦ)`. Contributions that are not finite
/// are counted in `PassPhotons::dropped` instead.
#[inline]
fn for_each_gathered_photon(
    scene: &RenderScene,
    pass: &PassPhotons,
    index: u32,
    hp: &HitPoint,
    mut visit: impl FnMut(glam::Vec2, f32, Vec3),
) {
    let mut dropped = 0u64;
    let point = hp.gather_point(scene);
    pass.map.within(hp.p, hp.r2, |photon, d2| {
        let Some((offset, contribution)) = point.contribution(photon) else { return };
        if contribution.is_finite() {
            visit(offset, d2, contribution);
        } else {
            dropped += 1;
        }
    });
    if dropped > 0 {
        pass.dropped.fetch_add(dropped, Ordering::Relaxed);
        pass.first_dropped_pass.fetch_min(index, Ordering::Relaxed);
    }
}

/// Gather: add every photon of the pass within a hit point's radius to its M and Φ_M
/// (Hachisuka, Ogaki & Jensen 2008, §4.1). One hit point per task, photons in kd-tree order, so the
/// sums do not depend on the thread count.
pub fn gather_photons_into_hit_points(
    scene: Res<SceneResource>,
    config: Res<ProgressiveConfig>,
    pass: Res<PassPhotons>,
    mut hit_points: Query<&mut HitPoint>,
) {
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|mut hp| {
        if !hp.is_valid() || pass.map.is_empty() {
            return;
        }
        let (mut m, mut phi) = (0u32, Vec3::ZERO);
        for_each_gathered_photon(&scene, &pass, config.pass, &hp, |_, _, contribution| {
            m += 1;
            phi += contribution;
        });
        hp.m += m;
        hp.phi += phi;
    });
}

/// Gather for `cppm`: as [`gather_photons_into_hit_points`], and count the photons per ring × sector
/// of the disc for the χ² test (Lin et al. 2020).
pub fn gather_photons_into_chi2_cells(
    scene: Res<SceneResource>,
    config: Res<ProgressiveConfig>,
    pass: Res<PassPhotons>,
    mut hit_points: Query<(&mut HitPoint, &mut Chi2Cells)>,
) {
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut hp, mut cells)| {
        if !hp.is_valid() || pass.map.is_empty() {
            return;
        }
        let (mut m, mut phi, r2) = (0u32, Vec3::ZERO, hp.r2);
        for_each_gathered_photon(&scene, &pass, config.pass, &hp, |offset, d2, contribution| {
            m += 1;
            phi += contribution;
            cells.counts[chi2_cell(offset, d2, r2)] += 1;
        });
        hp.m += m;
        hp.phi += phi;
    });
}

/// Gather for `appm`: as [`gather_photons_into_hit_points`], and estimate the Laplacian of the
/// reflected radiance's luminance with the biweight kernel's Laplacian (Kaplanyan & Dachsbacher 2013).
pub fn gather_photons_with_laplacian(
    scene: Res<SceneResource>,
    config: Res<ProgressiveConfig>,
    pass: Res<PassPhotons>,
    mut hit_points: Query<(&mut HitPoint, &mut AdaptiveStats)>,
) {
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut hp, mut stats)| {
        if !hp.is_valid() || pass.map.is_empty() {
            return;
        }
        let (mut m, mut phi, mut laplacian, r2) = (0u32, Vec3::ZERO, 0.0f32, hp.r2);
        for_each_gathered_photon(&scene, &pass, config.pass, &hp, |_, d2, contribution| {
            m += 1;
            phi += contribution;
            laplacian += luminance(contribution) * biweight_laplacian(d2, r2);
        });
        hp.m += m;
        hp.phi += phi;
        stats.0.laplacian += laplacian;
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::PathState;
    use bevy_ecs::system::RunSystemOnce;
    use caustica_core::film::Film;
    use caustica_core::kernel::Quantity;

    /// The film drops non-finite samples, counts them, and remembers the first in sample order with
    /// what the kernel saw go bad.
    #[test]
    fn a_non_finite_sample_is_dropped_counted_and_the_first_is_named() {
        crate::world::init_thread_pools(None);
        let mut world = World::new();
        world.insert_resource(PassRange::default());
        world.insert_resource(Workload::new(4, 0, 1, 4));
        world.insert_resource(FilmResource::new(Film::new(2, 2)));
        world.insert_resource(RenderStats::default());
        let finished = |pixel, l: Vec3, first_bad| {
            let mut state = PathState::new(pixel, 7);
            state.status = PathStatus::Finished;
            (state.path.l, state.path.first_bad) = (l, first_bad);
            state
        };
        world.spawn(finished(0, Vec3::ONE, None));
        world.spawn(finished(1, Vec3::NAN, Some((Quantity::Throughput, 2))));
        world.spawn(finished(2, Vec3::INFINITY, Some((Quantity::Emission, 0))));
        world.run_system_once(splat_paths_to_film).unwrap();
        let stats = *world.resource::<RenderStats>();
        assert_eq!((stats.samples, stats.nan_samples), (3, 2));
        assert_eq!(
            stats.first_bad,
            Some(BadSample { pixel: 1, sample: 7, cause: Some((Quantity::Throughput, 2)) })
        );
        let image = world.resource::<FilmResource>().image();
        assert_eq!(image.pixels[..3], [Vec3::ONE, Vec3::ZERO, Vec3::ZERO]);
    }
}
