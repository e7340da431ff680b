//! Gather: splat finished paths onto the film and hand their entity the next work item; for
//! progressive photon mapping, gather each pass's photons into the hit points.
//!
//! `splat_paths_to_film` reads finished `PathState`s; writes `Film`, `RenderStats`, `Workload`,
//! `PathState` (next pixel and sample). `build_pass_photon_map` turns `PhotonBuffer` into
//! `PassPhotons`; `gather_photons_into_*` read `PassPhotons` and write `HitPoint::m`/`phi` (and the
//! χ² cells or Laplacian of `cppm`/`appm`).
//!
//! `splat_paths_to_film` runs on one thread on purpose: visiting finished paths in entity order to
//! splat them and hand out work makes the image bit-identical whatever the thread count. The loop
//! does no more than an add per finished path, a small share of a bounce.

use super::components::{AdaptiveStats, Chi2Cells, HitPoint, PathState, PathStatus, ShadowRay};
use super::photon_estimate::NORMAL_COSINE;
use super::resources::{PhotonBuffer, RenderFilm, RenderStats, SceneGeometry, Workload};
use super::visible_points::hit_point_bsdf;
use crate::lights::area::luminance;
use crate::materials::TransportMode;
use crate::photon::progressive::{biweight_laplacian, chi2_cell};
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Splat finished paths, count rays and dropped samples, and advance each entity's work.
pub fn splat_paths_to_film(
    mut workload: ResMut<Workload>,
    mut film: ResMut<RenderFilm>,
    mut stats: ResMut<RenderStats>,
    mut paths: Query<&mut PathState>,
) {
    let mut active = 0;
    for mut state in &mut paths {
        match state.status {
            PathStatus::Idle => continue,
            PathStatus::Active | PathStatus::NeedsCamera => {
                active += 1;
                continue;
            }
            PathStatus::Finished => {}
        }
        let state = &mut *state;
        // NaN/Inf never reach the film: the sample counts, its radiance does not.
        let l = if state.l.is_finite() {
            state.l
        } else {
            stats.nan_samples += 1;
            Vec3::ZERO
        };
        film.add(state.pixel, l);
        stats.samples += 1;
        stats.rays += state.rays as u64;
        stats.shadow_rays += state.shadow_rays as u64;
        stats.lookups += state.lookups as u64;
        state.lookups = 0;
        state.rays = 0;
        state.shadow_rays = 0;
        match workload.take() {
            Some((pixel, sample)) => {
                state.pixel = pixel;
                state.sample = sample;
                state.status = PathStatus::NeedsCamera;
                active += 1;
            }
            None => state.status = PathStatus::Idle,
        }
    }
    stats.active_paths = active;
    stats.steps += 1;
}

/// The photons of the running progressive pass, as a kd-tree for the hit points' radius queries.
#[derive(Resource, Debug, Default)]
pub struct PassPhotons {
    /// This pass's photons.
    pub map: crate::photon::PhotonMap,
    /// Photon contributions that were NaN or infinite, dropped before they reached a hit point (all
    /// passes). Incremented only on that rare event, so the atomic costs nothing in the gather loop.
    pub dropped: std::sync::atomic::AtomicU64,
}

/// Arrange the pass's photon deposits into a kd-tree (parallel, deterministic) for gathering.
pub fn build_pass_photon_map(mut buffer: ResMut<PhotonBuffer>, mut pass: ResMut<PassPhotons>) {
    pass.map = crate::photon::PhotonMap::build(std::mem::take(&mut buffer.photons));
}

/// Visit every photon of `map` that counts for hit point `hp`: within its radius, on the side it is
/// seen from (a photon's normal faces where it came from, so one that arrived from behind the surface
/// is left out, unless the material transmits), and on a surface of about the same orientation.
/// `visit(tangent-plane offset, squared distance, β · f · ΔΦ)`.
#[inline]
fn for_each_gathered_photon(
    scene: &SceneGeometry,
    pass: &PassPhotons,
    hp: &HitPoint,
    mut visit: impl FnMut(glam::Vec2, f32, Vec3),
) {
    let mut dropped = 0u64;
    let (bsdf, frame, wo) = hit_point_bsdf(scene, hp);
    let transmits = scene.materials[hp.material as usize].transmission > 0.0;
    let side = if wo.z >= 0.0 { frame.z } else { -frame.z };
    pass.map.within(hp.p, hp.r2, |photon, d2| {
        let cos = photon.normal().dot(side);
        if cos < NORMAL_COSINE && !(transmits && -cos >= NORMAL_COSINE) {
            return;
        }
        let local = frame.to_local(photon.position() - hp.p);
        let f = bsdf.eval(wo, frame.to_local(photon.direction()), TransportMode::Radiance);
        let contribution = hp.beta * f * photon.power();
        if contribution.is_finite() {
            visit(local.truncate(), d2, contribution);
        } else {
            dropped += 1;
        }
    });
    if dropped > 0 {
        pass.dropped.fetch_add(dropped, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Gather: add every photon of the pass within a hit point's radius to its M and Φ_M
/// (Hachisuka, Ogaki & Jensen 2008, §4.1). One hit point per task, photons in kd-tree order, so the
/// sums do not depend on the thread count.
pub fn gather_photons_into_hit_points(
    scene: Res<SceneGeometry>,
    pass: Res<PassPhotons>,
    mut hit_points: Query<&mut HitPoint>,
) {
    hit_points.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(|mut hp| {
        if !hp.is_valid() || pass.map.is_empty() {
            return;
        }
        let (mut m, mut phi) = (0u32, Vec3::ZERO);
        for_each_gathered_photon(&scene, &pass, &hp, |_, _, contribution| {
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
    scene: Res<SceneGeometry>,
    pass: Res<PassPhotons>,
    mut hit_points: Query<(&mut HitPoint, &mut Chi2Cells)>,
) {
    hit_points.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut hp, mut cells)| {
            if !hp.is_valid() || pass.map.is_empty() {
                return;
            }
            let (mut m, mut phi, r2) = (0u32, Vec3::ZERO, hp.r2);
            for_each_gathered_photon(&scene, &pass, &hp, |offset, d2, contribution| {
                m += 1;
                phi += contribution;
                cells.counts[chi2_cell(offset, d2, r2)] += 1;
            });
            hp.m += m;
            hp.phi += phi;
        },
    );
}

/// Gather for `appm`: as [`gather_photons_into_hit_points`], and estimate the Laplacian of the
/// reflected radiance's luminance with the biweight kernel's Laplacian (Kaplanyan & Dachsbacher 2013).
pub fn gather_photons_with_laplacian(
    scene: Res<SceneGeometry>,
    pass: Res<PassPhotons>,
    mut hit_points: Query<(&mut HitPoint, &mut AdaptiveStats)>,
) {
    hit_points.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut hp, mut stats)| {
            if !hp.is_valid() || pass.map.is_empty() {
                return;
            }
            let (mut m, mut phi, mut laplacian, r2) = (0u32, Vec3::ZERO, 0.0f32, hp.r2);
            for_each_gathered_photon(&scene, &pass, &hp, |_, d2, contribution| {
                m += 1;
                phi += contribution;
                laplacian += luminance(contribution) * biweight_laplacian(d2, r2);
            });
            hp.m += m;
            hp.phi += phi;
            stats.laplacian += laplacian;
        },
    );
}

/// Visibility-aware light selection: learn from every shadow ray traced this step which light
/// clusters are visible from where (one thread, entity order: the learned grid does not depend on
/// the thread count).
pub fn learn_light_visibility(mut scene: ResMut<SceneGeometry>, mut shadows: Query<&mut ShadowRay>) {
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
