//! Scatter: shade each hit, add emission, sample a light (NEE), sample the BSDF, Russian roulette.
//!
//! Reads: `PathHit`, `SceneGeometry`, `RenderConfig`. Writes: `PathRay` (the continuation),
//! `PathState` (β, L, depth, status), `ShadowRay` (NEE segment and its contribution).
//! Follows pbrt-v4's `PathIntegrator::Li`: emission found by BSDF sampling and light found by NEE are
//! combined with the power heuristic (Veach & Guibas 1995), so each is weighted where it is better.

use super::components::{PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::resources::{RenderConfig, SceneGeometry};
use crate::geometry::bvh::{Hit, NO_LIGHT};
use crate::geometry::offset::{SHADOW_EPSILON, offset_ray_origin};
use crate::geometry::{Ray, SurfaceHit};
use crate::materials::{Bsdf, TransportMode};
use crate::sampling::Sampler;
use crate::sampling::warp::Frame;
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Sampler dimensions within one bounce (see `sampling::rng`).
mod dim {
    pub const LIGHT_SELECT: u32 = 0;
    pub const LIGHT_POINT: u32 = 1;
    pub const BSDF_LOBE: u32 = 3;
    pub const BSDF_DIRECTION: u32 = 4;
    pub const ROULETTE: u32 = 6;
}

/// Highest Russian-roulette survival probability: bounds the expected length of any path.
const MAX_SURVIVAL: f32 = 0.95;

/// The power heuristic with β = 2 for one sample from each of two strategies.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a.is_infinite() {
        1.0
    } else if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

/// Scatter every active path. `NEE` selects `pt` (light sampling + MIS) over `pt-naive`.
pub fn scatter_paths<const NEE: bool>(
    scene: Res<SceneGeometry>,
    config: Res<RenderConfig>,
    mut paths: Query<(&PathHit, &mut PathRay, &mut PathState, &mut ShadowRay)>,
) {
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut shadow)| {
            if state.status != PathStatus::Active {
                return;
            }
            state.rays += 1;
            scatter_one::<NEE>(&scene, &config, &hit.0, &mut ray.0, &mut state, &mut shadow);
        },
    );
}

#[inline]
fn scatter_one<const NEE: bool>(
    scene: &SceneGeometry,
    config: &RenderConfig,
    hit: &Hit,
    ray: &mut Ray,
    state: &mut PathState,
    shadow: &mut ShadowRay,
) {
    // A path that leaves the scene brings back the environment, weighted against light sampling as
    // emission found on a surface is.
    if !hit.is_hit() {
        if let Some((le, light_pdf)) = scene.lights.escaped(ray.d, state.prev_p, state.prev_n) {
            let weight = if !NEE || state.depth == 0 || state.specular_bounce {
                1.0
            } else {
                power_heuristic(state.prev_pdf, light_pdf)
            };
            state.l += state.beta * le * weight;
        }
        state.status = PathStatus::Finished;
        return;
    }
    let si: SurfaceHit = scene.geometry.surface_hit(ray, hit);
    let wo_world = -ray.d;

    // Add emission where the path hits a light's front side, weighted against light sampling.
    if si.light != NO_LIGHT && si.ng.dot(wo_world) > 0.0 {
        let le = scene.materials[si.material as usize].emission;
        let weight = if !NEE || state.depth == 0 || state.specular_bounce {
            1.0
        } else {
            let light_pdf = scene.lights.pdf(si.light, state.prev_p, state.prev_n, si.p, si.ng, ray.time);
            power_heuristic(state.prev_pdf, light_pdf)
        };
        state.l += state.beta * le * weight;
    }

    // End the path at the maximum depth (pbrt-v4 counts emission at that vertex first).
    if state.depth >= config.max_depth {
        state.status = PathStatus::Finished;
        return;
    }

    let bsdf = Bsdf::new(&scene.shading_params(&si));
    let frame = Frame::from_z(si.ns);
    let wo = frame.to_local(wo_world);
    // The shading normal on the side the path arrived from: light selection's view of this point.
    let n_side = if wo.z >= 0.0 { si.ns } else { -si.ns };
    let sampler = Sampler::new(config.seed, state.pixel, state.sample);
    let base = Sampler::bounce_dimension(state.depth);

    // Sample a light (next-event estimation) unless every lobe is a delta.
    if NEE && !bsdf.is_delta() {
        let u_select = sampler.get1d(base + dim::LIGHT_SELECT);
        let u_light = sampler.get2d(base + dim::LIGHT_POINT);
        if let Some((light, ls)) = scene.lights.sample(si.p, n_side, ray.time, u_select, u_light) {
            let to_light = ls.p - si.p;
            let wi_world = to_light.normalize();
            let wi = frame.to_local(wi_world);
            let f = bsdf.eval(wo, wi, TransportMode::Radiance) * wi.z.abs();
            if f.max_element() > 0.0 && ls.pdf > 0.0 {
                let bsdf_pdf = bsdf.pdf(wo, wi);
                let weight = power_heuristic(ls.pdf, bsdf_pdf);
                let origin = offset_ray_origin(si.p, si.p_error, si.ng, wi_world);
                shadow.ray = Ray { o: origin, d: ls.p - origin, t_max: 1.0 - SHADOW_EPSILON, time: ray.time };
                shadow.contribution = state.beta * f * ls.le * (weight / ls.pdf);
                shadow.pending = true;
                shadow.light = light;
                shadow.normal = n_side;
            }
        }
    }

    // Sample the BSDF for the continuation.
    let u_lobe = sampler.get1d(base + dim::BSDF_LOBE);
    let u_dir = sampler.get2d(base + dim::BSDF_DIRECTION);
    let Some(bs) = bsdf.sample(wo, u_lobe, u_dir, TransportMode::Radiance) else {
        state.status = PathStatus::Finished;
        return;
    };
    if bs.pdf <= 0.0 || bs.f.max_element() <= 0.0 {
        state.status = PathStatus::Finished;
        return;
    }
    let wi_world = frame.to_world(bs.wi);
    state.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
    state.prev_pdf = bs.pdf;
    state.specular_bounce = bs.is_specular;
    state.prev_p = si.p;
    state.prev_n = n_side;
    if bs.is_transmission {
        state.eta_scale *= bs.eta * bs.eta;
    }
    state.depth += 1;
    *ray = Ray {
        o: offset_ray_origin(si.p, si.p_error, si.ng, wi_world),
        d: wi_world,
        t_max: f32::INFINITY,
        time: ray.time,
    };

    // Russian roulette. The throughput is divided by the squared relative IOR first so that light
    // refracted into a dense medium is not killed for being "bright" only because radiance is
    // compressed there (pbrt-v4 `etaScale`). Survival is capped at 0.95 (as Mitsuba does): a path
    // trapped by total internal reflection keeps β = 1 forever, and without the cap it would never end.
    if state.depth >= config.rr_depth {
        let survive = (state.beta * state.eta_scale).max_element().min(MAX_SURVIVAL);
        if sampler.get1d(base + dim::ROULETTE) >= survive {
            state.status = PathStatus::Finished;
            return;
        }
        state.beta /= survive;
    }
    if !state.beta.is_finite() {
        // Keep the broken path's radiance so far; gather counts and drops non-finite samples.
        state.l = Vec3::NAN;
        state.status = PathStatus::Finished;
    }
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
    }
}
