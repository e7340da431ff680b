//! The BSDF sample that continues a camera path, and the one Russian-roulette rule every integrator
//! uses.

use super::{CameraPath, Quantity, Vertex, VertexSampler};
use crate::geometry::Ray;
use crate::geometry::offset::offset_ray_origin;
use crate::materials::{BsdfSample, TransportMode};
use glam::Vec3;

/// Highest Russian-roulette survival probability: a path trapped by total internal reflection keeps
/// β = 1 forever, and without a cap below one it would never end (Mitsuba caps at 0.95 too).
pub const MAX_SURVIVAL: f32 = 0.95;

/// How long a path may get.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathLimits {
    /// Bounces after which the path ends (`u32::MAX`: only Russian roulette ends it).
    pub max_depth: u32,
    /// First depth at which Russian roulette may end it.
    pub rr_depth: u32,
}

/// Continue `path` from vertex `v` by sampling the BSDF, and decide by Russian roulette whether it
/// survives. Returns the next ray, or None when the path ends: at the maximum depth, when the BSDF
/// gives no sample or a zero one, or by roulette. A throughput that is no longer finite also ends the
/// path, and its radiance becomes NaN so that the film counts the sample as dropped rather than
/// silently losing it.
///
/// Russian roulette divides the throughput by the η-scale first, the product of squared relative IORs
/// crossed (pbrt-v4's `etaScale`): radiance is compressed inside a dense medium, and without that a
/// path refracted into glass would be killed for being bright only by that compression.
#[inline]
pub fn continue_path(
    path: &mut CameraPath,
    v: &Vertex,
    time: f32,
    u: &VertexSampler,
    limits: PathLimits,
) -> Option<Ray> {
    if path.depth >= limits.max_depth {
        return None;
    }
    let bs = v.bsdf.sample_with(v.wo, || u.bsdf_lobe(), u.bsdf_direction(), TransportMode::Radiance)?;
    continue_along(path, v, time, u, limits, bs)
}

/// [`continue_path`] past the choice of direction, for a path below the maximum depth: follow the
/// sample `bs` (whatever drew it: the BSDF, or path guiding's mixture, whose pdf it then carries),
/// then Russian roulette.
#[inline]
pub fn continue_along(
    path: &mut CameraPath,
    v: &Vertex,
    time: f32,
    u: &VertexSampler,
    limits: PathLimits,
    bs: BsdfSample,
) -> Option<Ray> {
    if bs.pdf <= 0.0 || bs.f.max_element() <= 0.0 {
        return None;
    }
    let si = &v.si;
    let wi_world = v.frame.to_world(bs.wi);
    // The same rule as light sampling's: a direction the shading frame calls reflection but the
    // geometric surface calls transmission (or the reverse) is not followed.
    if crosses_inconsistently(v, wi_world, bs.wi) {
        return None;
    }
    path.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
    path.prev_pdf = bs.pdf;
    path.specular_bounce = bs.is_specular;
    path.prev_p = si.p;
    path.prev_n = v.n_side();
    if bs.is_transmission {
        path.eta_scale *= bs.eta * bs.eta;
        if v.volume {
            path.media.cross_volume(si.material, wi_world.dot(si.ng) < 0.0);
        }
    }
    path.depth += 1;
    let ray = Ray {
        o: offset_ray_origin(si.p, si.p_error, si.ng, wi_world),
        d: wi_world,
        t_max: f32::INFINITY,
        time,
    };
    if path.depth >= limits.rr_depth {
        let survive = survival_probability(path.beta, path.eta_scale);
        if u.roulette() >= survive {
            return None;
        }
        path.beta /= survive;
    }
    if !path.beta.is_finite() {
        path.l = Vec3::NAN;
        path.mark_bad(Quantity::Throughput);
        return None;
    }
    // A path whose every channel carries nothing can add nothing more.
    if path.beta.max_element() <= 0.0 {
        return None;
    }
    Some(ray)
}

/// Russian roulette's survival probability for throughput `beta` and η-scale `eta_scale`.
#[inline]
pub fn survival_probability(beta: Vec3, eta_scale: f32) -> f32 {
    (beta * eta_scale).max_element().min(MAX_SURVIVAL)
}

/// Whether `wi` (world and shading-frame local) is on one side of the surface by the shading
/// normal and on the other by the geometric one, relative to where the path arrived: light
/// through an opaque surface (a leak) or a reflection into it. Mitsuba refuses both.
#[inline]
pub fn crosses_inconsistently(v: &Vertex, wi_world: Vec3, wi_local: Vec3) -> bool {
    let wo_world = v.frame.to_world(v.wo);
    wi_world.dot(v.si.ng) * wo_world.dot(v.si.ng) * wi_local.z * v.wo.z < 0.0
}
