//! Scatter: what each integrator does where a ray landed, as thin queries over the kernel
//! (`caustica_core::kernel`).
//!
//! | system | integrator | reads | writes |
//! |---|---|---|---|
//! | `scatter_photon_mapped` | `pm` | `PathHit`, `SceneResource`, `RenderConfig`, `PhotonMaps` | `PathRay`, `PathState`, `ShadowRay` |
//! | `scatter_to_visible_points::<NEE>` | `ppm`, `sppm`, `appm`, `cppm` | `PathHit`, `SceneResource`, `RenderConfig` | `HitPoint`, `PathRay`, `PathState`, `ShadowRay` |
//!
//! `pt` (its vertex in `caustica_core::kernel::path_vertex`, its system in `camera_paths/`) follows
//! pbrt-v4's `PathIntegrator::Li`: emission found by BSDF sampling and light found by
//! NEE are combined with the power heuristic (Veach & Guibas 1995). The photon mappers count only
//! emission seen directly or through specular bounces; light sampling (unweighted) and photons carry
//! the rest.
//!
//! Every camera-path scatter also records the path's feature images (`PathAov`, when the render
//! asks for them) at its first non-specular vertex, from the vertex it builds anyway.

use super::components::{HitPoint, PathAov, PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::resources::{PhotonMaps, RenderConfig, SceneResource, wavefront_batching};
use bevy_ecs::prelude::*;
use caustica_core::geometry::Ray;
use caustica_core::geometry::bvh::Hit;
use caustica_core::kernel::aov::FirstSurface;
use caustica_core::kernel::{Arrival, EmissionWeight, Quantity, continue_path, sample_light};
use caustica_core::photon::estimate::radiance_estimate;
use caustica_core::photon::{Neighbors, PhotonMap};
use caustica_core::render_scene::RenderScene;

/// Run `vertex` on an active camera path, counting its ray, and finish the path when it says so.
#[inline(always)]
fn advance(state: &mut PathState, vertex: impl FnOnce(&mut PathState) -> bool) {
    if state.status != PathStatus::Active {
        return;
    }
    state.rays += 1;
    if !vertex(state) {
        state.status = PathStatus::Finished;
    }
}

/// Store the continuation's ray; false when there is none.
#[inline]
fn continue_from(ray: &mut Ray, next: Option<Ray>) -> bool {
    match next {
        Some(next) => {
            *ray = next;
            true
        }
        None => false,
    }
}

/// Shade every active camera path with the photon maps (`pm`, Jensen 2001 §9): at the first
/// non-specular hit, direct light by NEE, caustics from the caustic map, and indirect light from the
/// indirect map or, with final gathering, from the global map one BSDF-sampled bounce further.
pub fn scatter_photon_mapped(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    maps: Res<PhotonMaps>,
    mut paths: Query<(&PathHit, &mut PathRay, &mut PathState, &mut ShadowRay, Option<&mut PathAov>)>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each_init(
        || Neighbors::with_capacity(maps.neighbors_room()),
        |neighbors, (hit, mut ray, mut state, mut shadow, mut aov)| {
            let aov = aov.as_deref_mut().map(|a| &mut a.0);
            advance(&mut state, |state| {
                photon_mapped_vertex(
                    &scene,
                    &config,
                    &maps,
                    neighbors,
                    &hit.0,
                    &mut ray.0,
                    state,
                    &mut shadow,
                    aov,
                )
            });
        },
    );
}

/// One vertex of a `pm` camera path; false when the path ends.
#[allow(clippy::too_many_arguments)]
#[inline]
fn photon_mapped_vertex(
    scene: &RenderScene,
    config: &RenderConfig,
    maps: &PhotonMaps,
    neighbors: &mut Neighbors,
    hit: &Hit,
    ray: &mut Ray,
    state: &mut PathState,
    shadow: &mut ShadowRay,
    aov: Option<&mut FirstSurface>,
) -> bool {
    // A final-gather ray only reads the global map: light it reaches is in there already.
    let emission = (!state.gathering).then_some(EmissionWeight::SeenDirectly);
    let arrival = Arrival { emission, last_depth: u32::MAX };
    let (gathering, lookups) = (&mut state.gathering, &mut state.lookups);
    arrival.arrive(scene, ray, hit, &mut state.path, state.sampler, aov, |path, ray, v, u| {
        let mut estimate = |map: &PhotonMap| {
            *lookups += 1;
            radiance_estimate(
                map,
                &v.si,
                &v.frame,
                &v.bsdf,
                v.wo,
                maps.k,
                maps.max_radius2,
                maps.kernel,
                neighbors,
            )
        };
        if !v.bsdf.is_delta() {
            if *gathering {
                // The end of a final-gather ray: everything the global map knows.
                if let Some(global) = &maps.global {
                    let l = path.beta * estimate(global);
                    path.add(l, Quantity::PhotonEstimate);
                }
                return false;
            }
            if let Some(sample) = sample_light(scene, v, path, ray.time, u, false) {
                shadow.queue(sample);
            }
            if let Some(caustic) = &maps.caustic {
                let l = path.beta * estimate(caustic);
                path.add(l, Quantity::PhotonEstimate);
            }
            match (&maps.indirect, maps.final_gather) {
                (Some(indirect), false) => {
                    let l = path.beta * estimate(indirect);
                    path.add(l, Quantity::PhotonEstimate);
                    return false;
                }
                (_, true) => *gathering = true,
                (None, false) => return false,
            }
        }
        continue_from(ray, continue_path(path, v, ray.time, u, config.limits))
    })
}

/// What a progressive camera path's scatter reads and writes.
type VisiblePointPath = (
    &'static PathHit,
    &'static mut PathRay,
    &'static mut PathState,
    &'static mut ShadowRay,
    &'static mut HitPoint,
    Option<&'static mut PathAov>,
);

/// Advance every active camera path of a progressive pass by one bounce, recording its hit point at
/// the first non-specular surface. `NEE` adds a light sample there (`sppm`, `appm`, `cppm`,
/// Hachisuka & Jensen 2009 §4); without it (`ppm`) direct light comes from photons like the rest.
/// Glossy surfaces are gathered on, not bounced through: as the radius shrinks their estimate
/// converges too, only more slowly than a diffuse one.
pub fn scatter_to_visible_points<const NEE: bool>(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    mut paths: Query<VisiblePointPath>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut shadow, mut hit_point, mut aov)| {
            let aov = aov.as_deref_mut().map(|a| &mut a.0);
            advance(&mut state, |state| {
                visible_point_vertex::<NEE>(
                    &scene,
                    &config,
                    &hit.0,
                    &mut ray.0,
                    state,
                    &mut shadow,
                    &mut hit_point,
                    aov,
                )
            });
        },
    );
}

/// One bounce of a progressive camera path; false when the path is done (with or without a hit point).
#[allow(clippy::too_many_arguments)]
#[inline]
fn visible_point_vertex<const NEE: bool>(
    scene: &RenderScene,
    config: &RenderConfig,
    hit: &Hit,
    ray: &mut Ray,
    state: &mut PathState,
    shadow: &mut ShadowRay,
    hit_point: &mut HitPoint,
    aov: Option<&mut FirstSurface>,
) -> bool {
    if state.path.depth == 0 {
        // Until this pass finds a surface, the hit point gathers nothing.
        hit_point.beta = glam::Vec3::ZERO;
    }
    let arrival = Arrival { emission: Some(EmissionWeight::SeenDirectly), last_depth: u32::MAX };
    arrival.arrive(scene, ray, hit, &mut state.path, state.sampler, aov, |path, ray, v, u| {
        if v.bsdf.is_delta() {
            return continue_from(ray, continue_path(path, v, ray.time, u, config.limits));
        }
        if NEE && let Some(sample) = sample_light(scene, v, path, ray.time, u, false) {
            shadow.queue(sample);
        }
        hit_point.record(v, -ray.d, path.beta);
        false
    })
}
