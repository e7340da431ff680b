//! The camera side of photon mapping (`pm`): shade camera hits with photon-map radiance estimates.
//!
//! Reads: `PathHit`, `SceneGeometry`, `PhotonMaps`, `RenderConfig`. Writes: `PathRay`, `PathState`,
//! `ShadowRay`. A camera path follows specular bounces to its first non-specular hit. There, direct
//! light comes from next-event estimation, caustics from the caustic map, and indirect light either
//! from the indirect map or, with final gathering, from the global map at the end of one more
//! BSDF-sampled bounce (Jensen 2001, §9).

use super::components::{PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::resources::{PhotonMaps, RenderConfig, SceneGeometry};
use crate::density::kernels::Kernel;
use crate::geometry::bvh::{Hit, NO_LIGHT};
use crate::geometry::offset::{SHADOW_EPSILON, offset_ray_origin};
use crate::geometry::{Ray, SurfaceHit};
use crate::materials::{Bsdf, TransportMode};
use crate::photon::{Neighbors, PhotonMap};
use crate::sampling::Sampler;
use crate::sampling::warp::Frame;
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Photons whose surface normal is further than this cosine from the query's are from another surface
/// (the other side of a thin wall, a nearby face at a corner) and are left out of the estimate.
pub(super) const NORMAL_COSINE: f32 = 0.9;

/// Sampler dimensions within one bounce (same layout as `scatter`).
mod dim {
    pub const LIGHT_SELECT: u32 = 0;
    pub const LIGHT_POINT: u32 = 1;
    pub const BSDF_LOBE: u32 = 3;
    pub const BSDF_DIRECTION: u32 = 4;
    pub const ROULETTE: u32 = 6;
}

/// Radiance reflected towards `wo` by the photons near `si`: Σ f · ΔΦ · K(d²/r²) / r², with r the
/// distance to the k-th nearest photon (or the maximum radius when fewer are that close).
#[allow(clippy::too_many_arguments)]
pub fn radiance_estimate(
    map: &PhotonMap,
    si: &SurfaceHit,
    frame: &Frame,
    bsdf: &Bsdf,
    wo: Vec3,
    k: usize,
    max_radius2: f32,
    kernel: Kernel,
    neighbors: &mut Neighbors,
) -> Vec3 {
    map.knn(si.p, k, max_radius2, neighbors);
    if neighbors.is_empty() {
        return Vec3::ZERO;
    }
    let r2 = if neighbors.len() < k { max_radius2 } else { neighbors.max_dist2() };
    if r2 <= 0.0 {
        return Vec3::ZERO;
    }
    let n_query = if frame.to_world(wo).dot(si.ng) >= 0.0 { si.ng } else { -si.ng };
    let mut sum = Vec3::ZERO;
    for (photon, d2) in neighbors.iter(map) {
        if photon.normal().dot(n_query) < NORMAL_COSINE {
            continue;
        }
        let wi = frame.to_local(photon.direction());
        sum += bsdf.eval(wo, wi, TransportMode::Radiance) * photon.power() * kernel.k2(d2 / r2);
    }
    sum / r2
}

/// Shade every active camera path with the photon maps.
pub fn scatter_photon_mapped(
    scene: Res<SceneGeometry>,
    config: Res<RenderConfig>,
    maps: Res<PhotonMaps>,
    mut paths: Query<(&PathHit, &mut PathRay, &mut PathState, &mut ShadowRay)>,
) {
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each_init(
        || Neighbors::with_capacity(maps.k),
        |neighbors, (hit, mut ray, mut state, mut shadow)| {
            if state.status != PathStatus::Active {
                return;
            }
            state.rays += 1;
            shade(&scene, &config, &maps, neighbors, &hit.0, &mut ray.0, &mut state, &mut shadow);
        },
    );
}

#[allow(clippy::too_many_arguments)]
fn shade(
    scene: &SceneGeometry,
    config: &RenderConfig,
    maps: &PhotonMaps,
    neighbors: &mut Neighbors,
    hit: &Hit,
    ray: &mut Ray,
    state: &mut PathState,
    shadow: &mut ShadowRay,
) {
    // Emission (and the environment) seen directly or through specular bounces; elsewhere NEE and
    // the maps account for it.
    let seen_directly = state.depth == 0 || state.specular_bounce;
    if !hit.is_hit() {
        if seen_directly
            && !state.gathering
            && let Some(env) = &scene.lights.environment
        {
            state.l += state.beta * env.le(ray.d);
        }
        state.status = PathStatus::Finished;
        return;
    }
    let si = scene.geometry.surface_hit(ray, hit);
    let wo_world = -ray.d;
    if si.light != NO_LIGHT && si.ng.dot(wo_world) > 0.0 && seen_directly && !state.gathering {
        state.l += state.beta * scene.materials[si.material as usize].emission;
    }
    let bsdf = Bsdf::new(&scene.shading_params(&si));
    let frame = Frame::from_z(si.ns);
    let wo = frame.to_local(wo_world);
    let estimate = |map: &PhotonMap, neighbors: &mut Neighbors, lookups: &mut u32| {
        *lookups += 1;
        radiance_estimate(map, &si, &frame, &bsdf, wo, maps.k, maps.max_radius2, maps.kernel, neighbors)
    };

    if !bsdf.is_delta() {
        if state.gathering {
            // The end of a final-gather ray: everything the global map knows.
            if let Some(global) = &maps.global {
                state.l += state.beta * estimate(global, neighbors, &mut state.lookups);
            }
            state.status = PathStatus::Finished;
            return;
        }
        let sampler = Sampler::new(config.seed, state.pixel, state.sample);
        let base = Sampler::bounce_dimension(state.depth);
        direct_light(scene, &sampler, base, &si, &frame, &bsdf, wo, ray.time, state, shadow);
        if let Some(caustic) = &maps.caustic {
            state.l += state.beta * estimate(caustic, neighbors, &mut state.lookups);
        }
        match (&maps.indirect, maps.final_gather) {
            (Some(indirect), false) => {
                state.l += state.beta * estimate(indirect, neighbors, &mut state.lookups);
                state.status = PathStatus::Finished;
                return;
            }
            (_, true) => state.gathering = true,
            (None, false) => {
                state.status = PathStatus::Finished;
                return;
            }
        }
    }

    if !continue_path(config, &bsdf, &frame, &si, wo, ray, state) {
        state.status = PathStatus::Finished;
    }
}

/// Continue a camera path by sampling its BSDF, with Russian roulette from `rr_depth`. Returns false
/// when the path ends (maximum depth, no sample, roulette, or a throughput that is no longer finite).
pub(super) fn continue_path(
    config: &RenderConfig,
    bsdf: &Bsdf,
    frame: &Frame,
    si: &SurfaceHit,
    wo: Vec3,
    ray: &mut Ray,
    state: &mut PathState,
) -> bool {
    if state.depth >= config.max_depth {
        return false;
    }
    let sampler = Sampler::new(config.seed, state.pixel, state.sample);
    let base = Sampler::bounce_dimension(state.depth);
    let Some(bs) = bsdf.sample(
        wo,
        sampler.get1d(base + dim::BSDF_LOBE),
        sampler.get2d(base + dim::BSDF_DIRECTION),
        TransportMode::Radiance,
    ) else {
        return false;
    };
    state.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
    state.specular_bounce = bs.is_specular;
    state.depth += 1;
    if state.depth >= config.rr_depth {
        let survive = state.beta.max_element().min(0.95);
        if sampler.get1d(base + dim::ROULETTE) >= survive {
            return false;
        }
        state.beta /= survive;
    }
    if !state.beta.is_finite() || state.beta.max_element() <= 0.0 {
        return false;
    }
    let wi_world = frame.to_world(bs.wi);
    *ray = Ray {
        o: offset_ray_origin(si.p, si.p_error, si.ng, wi_world),
        d: wi_world,
        t_max: f32::INFINITY,
        time: ray.time,
    };
    true
}

/// One light sample, unweighted: at the first diffuse vertex light sampling is the only way direct
/// light is counted (emission reached by BSDF sampling is not added there).
#[allow(clippy::too_many_arguments)]
pub(super) fn direct_light(
    scene: &SceneGeometry,
    sampler: &Sampler,
    base: u32,
    si: &SurfaceHit,
    frame: &Frame,
    bsdf: &Bsdf,
    wo: Vec3,
    time: f32,
    state: &PathState,
    shadow: &mut ShadowRay,
) {
    let u_select = sampler.get1d(base + dim::LIGHT_SELECT);
    let u_light = sampler.get2d(base + dim::LIGHT_POINT);
    let n_side = if wo.z >= 0.0 { si.ns } else { -si.ns };
    let Some((_, ls)) = scene.lights.sample(si.p, n_side, time, u_select, u_light) else {
        return;
    };
    let wi_world = (ls.p - si.p).normalize();
    let f =
        bsdf.eval(wo, frame.to_local(wi_world), TransportMode::Radiance) * frame.to_local(wi_world).z.abs();
    if f.max_element() <= 0.0 || ls.pdf <= 0.0 {
        return;
    }
    let origin = offset_ray_origin(si.p, si.p_error, si.ng, wi_world);
    shadow.ray = Ray { o: origin, d: ls.p - origin, t_max: 1.0 - SHADOW_EPSILON, time };
    shadow.contribution = state.beta * f * ls.le / ls.pdf;
    shadow.pending = true;
}
