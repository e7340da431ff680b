//! Scatter for the camera pass of progressive photon mapping: follow each camera path through
//! specular bounces to its first non-specular hit and make that the pixel's hit point.
//!
//! Reads: `PathHit`, `SceneGeometry`, `RenderConfig`. Writes: `HitPoint` (visible point: position,
//! directions, β, material), `PathState` (emission seen through specular chains, status), `PathRay`,
//! `ShadowRay` (with `NEE`: one light sample at the hit point, Hachisuka & Jensen 2009 §4).
//! Glossy surfaces are gathered on, not bounced through: as the radius shrinks their estimate
//! converges too, only more slowly than a diffuse one.

use super::components::{HitPoint, PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::photon_estimate::{continue_path, direct_light};
use super::resources::{RenderConfig, SceneGeometry};
use crate::geometry::Ray;
use crate::geometry::bvh::{Hit, NO_LIGHT};
use crate::materials::{Bsdf, ShadingParams};
use crate::photon::record::{decode_octahedral, encode_octahedral};
use crate::sampling::Sampler;
use crate::sampling::warp::Frame;
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Advance every active camera path by one bounce, recording its hit point when it reaches one.
/// `NEE` adds a light sample there (`sppm`, `appm`, `cppm`); without it (`ppm`) direct light comes
/// from photons like the rest.
pub fn scatter_to_visible_points<const NEE: bool>(
    scene: Res<SceneGeometry>,
    config: Res<RenderConfig>,
    mut paths: Query<(&PathHit, &mut PathRay, &mut PathState, &mut ShadowRay, &mut HitPoint)>,
) {
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut shadow, mut hit_point)| {
            if state.status != PathStatus::Active {
                return;
            }
            state.rays += 1;
            if !advance::<NEE>(&scene, &config, &hit.0, &mut ray.0, &mut state, &mut shadow, &mut hit_point) {
                state.status = PathStatus::Finished;
            }
        },
    );
}

/// One bounce; false when the path is done (with or without a hit point).
fn advance<const NEE: bool>(
    scene: &SceneGeometry,
    config: &RenderConfig,
    hit: &Hit,
    ray: &mut Ray,
    state: &mut PathState,
    shadow: &mut ShadowRay,
    hit_point: &mut HitPoint,
) -> bool {
    if state.depth == 0 {
        // Until this pass finds a surface, the pixel gathers nothing.
        hit_point.beta = Vec3::ZERO;
    }
    // Emission (and the environment) seen directly or through specular bounces; photons carry every
    // other light.
    let seen_directly = state.depth == 0 || state.specular_bounce;
    if !hit.is_hit() {
        if seen_directly && let Some(env) = &scene.lights.environment {
            state.l += state.beta * env.le(ray.d);
        }
        return false;
    }
    let si = scene.geometry.surface_hit(ray, hit);
    let wo_world = -ray.d;
    if si.light != NO_LIGHT && si.ng.dot(wo_world) > 0.0 && seen_directly {
        state.l += state.beta * scene.materials[si.material as usize].emission;
    }
    let params = scene.shading_params(&si);
    let bsdf = Bsdf::new(&params);
    let frame = Frame::from_z(si.ns);
    let wo = frame.to_local(wo_world);
    if bsdf.is_delta() {
        return continue_path(config, &bsdf, &frame, &si, wo, ray, state);
    }
    if NEE {
        let sampler = Sampler::new(config.seed, state.pixel, state.sample);
        let base = Sampler::bounce_dimension(state.depth);
        direct_light(scene, &sampler, base, &si, &frame, &bsdf, wo, ray.time, state, shadow);
    }
    record(hit_point, si.p, wo_world, si.ns, state.beta, si.material, &params);
    false
}

/// Write the visible point into the hit point, keeping its statistics.
fn record(hp: &mut HitPoint, p: Vec3, wo: Vec3, ns: Vec3, beta: Vec3, material: u32, params: &ShadingParams) {
    let unorm = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u16;
    hp.p = p;
    hp.wo = encode_octahedral(wo, 16);
    hp.ns = encode_octahedral(ns, 16);
    hp.beta = beta;
    hp.material = material as u16;
    hp.base_color = params.base_color.to_array().map(unorm);
    hp.metallic_roughness = [unorm(params.metallic), unorm(params.roughness)];
}

/// The BSDF, shading frame and outgoing direction (local) stored in a hit point.
pub fn hit_point_bsdf(scene: &SceneGeometry, hp: &HitPoint) -> (Bsdf, Frame, Vec3) {
    let from_unorm = |x: u16| x as f32 / 65535.0;
    let m = &scene.materials[hp.material as usize];
    let params = ShadingParams {
        base_color: Vec3::from_array(hp.base_color.map(from_unorm)),
        metallic: from_unorm(hp.metallic_roughness[0]),
        roughness: from_unorm(hp.metallic_roughness[1]),
        transmission: m.transmission,
        ior: m.ior,
        specular: m.specular,
        specular_color: m.specular_color,
    };
    let frame = Frame::from_z(decode_octahedral(hp.ns, 16));
    let wo = frame.to_local(decode_octahedral(hp.wo, 16));
    (Bsdf::new(&params), frame, wo)
}
