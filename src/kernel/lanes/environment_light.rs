//! The environment light in lanes (`Environment::sample`): a constant sky by the cosine about each
//! lane's normal, a map by its luminance (the 2-D distribution's searches interleaved over the
//! lanes, `Distribution2D::sample_many`; the radiance read per lane), the direction and the point
//! beyond the scene in lanes, in the scalar code's order of operations.

use super::ggx::cosine_hemisphere;
use super::surface::Frame;
use super::v3::{Mask, V3, select};
use super::{Lanes, WIDTH};
use crate::lights::Environment;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// What the environment gives each lane: the end of the shadow ray (beyond the scene), the
/// radiance, the solid-angle density, and which lanes have a sample.
pub struct EnvironmentLanes {
    /// The point the shadow ray ends at.
    pub p: V3,
    /// The radiance from there.
    pub le: V3,
    /// The density of the direction.
    pub pdf: Lanes,
    /// Lanes with a sample.
    pub drawn: Mask,
}

/// Whether the lanes sample `environment` for shading normals `n_ref`: a map always, a constant
/// sky where the normal is not zero (there the scalar code samples the whole sphere).
#[inline(always)]
pub fn takes(environment: &Environment, n_ref: Vec3) -> bool {
    environment.constant_radiance().is_none() || n_ref != Vec3::ZERO
}

/// The environment's samples from the points `p_ref` with normals `n_ref`, random numbers `u`.
#[inline(always)]
pub fn sample_environment(
    environment: &Environment,
    p_ref: V3,
    n_ref: V3,
    u: [Vec2; WIDTH],
) -> EnvironmentLanes {
    let zero = Lanes::ZERO;
    let (wi, pdf, le) = match environment.constant_radiance() {
        Some(c) => {
            let local = cosine_hemisphere([Lanes::new(u.map(|u| u.x)), Lanes::new(u.map(|u| u.y))]);
            let wi = Frame::from_z(n_ref).to_world(local);
            (wi, local.z.max(zero) * Lanes::splat(FRAC_1_PI), V3::gather(|_| c))
        }
        None => {
            let sampled = environment.sample_map_many(&u).expect("a map");
            let (uv, pdf_uv) = (sampled.map(|s| s.0), Lanes::new(sampled.map(|s| s.1)));
            let (u_map, v_map) = (Lanes::new(uv.map(|uv| uv.x)), Lanes::new(uv.map(|uv| uv.y)));
            let (sin_theta, cos_theta) = (Lanes::splat(PI) * v_map).sin_cos();
            let (sin_phi, cos_phi) = (Lanes::splat(2.0 * PI) * u_map).sin_cos();
            let local = V3 { x: sin_theta * sin_phi, y: cos_theta, z: -sin_theta * cos_phi };
            let m = environment.to_world();
            let column = |c: Vec3| V3::gather(|_| c);
            let wi = column(m.x_axis).scale(local.x)
                + column(m.y_axis).scale(local.y)
                + column(m.z_axis).scale(local.z);
            let pdf = pdf_uv / (Lanes::splat(2.0 * PI * PI) * sin_theta);
            // The scalar code's `sin θ ≤ 0 || pdf_uv ≤ 0` refusal, as a mask (NaN passes, as there).
            let refused = sin_theta.simd_le(zero) | pdf_uv.simd_le(zero);
            let pdf = select(refused, zero, pdf);
            (wi, pdf, V3::gather(|i| sampled[i].2))
        }
    };
    let (center, radius) = environment.bounding_sphere();
    let to_center = p_ref - V3::gather(|_| center);
    let beyond = to_center.dot(to_center).sqrt() + Lanes::splat(2.0 * radius);
    EnvironmentLanes { p: p_ref + wi.scale(beyond), le, pdf, drawn: !pdf.simd_le(zero) }
}
