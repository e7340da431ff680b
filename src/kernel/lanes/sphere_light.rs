//! Spherical lamps in lanes (`Light::sample`'s sphere: the cone the sphere subtends sampled
//! uniformly, pbrt-v4's `Sphere::Sample`), each lane's sphere and its point in the scalar code's
//! order of operations, so a lane gives the scalar sample bit for bit.

use super::surface::Frame;
use super::v3::{Mask, V3, select};
use super::{Lanes, WIDTH};
use crate::lights::light::{MIN_SIN2_SUBTENDED, SMALL_CONE_SIN2};
use crate::lights::{Light, LightShape};
use std::f32::consts::PI;

/// What a lane's sphere gives: the point on it, its radiance, the solid-angle density, and which
/// lanes have a sample (none from inside a sphere, nor from a sphere too small to subtend a float).
pub struct SphereLanes {
    /// The point on the sphere.
    pub p: V3,
    /// The radiance it sends.
    pub le: V3,
    /// The density of the direction to it.
    pub pdf: Lanes,
    /// Lanes with a sample.
    pub drawn: Mask,
}

/// Whether `light` is one these lanes take.
#[inline(always)]
pub fn is_sphere(light: &Light) -> bool {
    matches!(light.shape, LightShape::Sphere { .. })
}

/// The samples of `lights` (each lane's a sphere, unused lanes repeating one) from the points
/// `p_ref` at times `time`, with random numbers `u`.
#[inline(always)]
pub fn sample_spheres(lights: &[&Light; WIDTH], p_ref: V3, time: Lanes, u: [Lanes; 2]) -> SphereLanes {
    let (zero, one) = (Lanes::ZERO, Lanes::ONE);
    let mut radius = [0.0; WIDTH];
    for (i, light) in lights.iter().enumerate() {
        if let LightShape::Sphere { radius: r, .. } = light.shape {
            radius[i] = r;
        }
    }
    let center = V3::gather(|i| match lights[i].shape {
        LightShape::Sphere { center, .. } => center,
        _ => glam::Vec3::ZERO,
    });
    let radius = Lanes::new(radius);
    let c = center + V3::gather(|i| lights[i].motion).scale(time);
    let to_ref = p_ref - c;
    let dc2 = to_ref.dot(to_ref);
    let r2 = radius * radius;
    let sin2_max = r2 / dc2;
    let drawn = !dc2.simd_le(r2) & !sin2_max.simd_lt(Lanes::splat(MIN_SIN2_SUBTENDED));
    let sin_max = sin2_max.sqrt();
    let cos_max = (one - sin2_max).max(zero).sqrt();
    let [ux, uy] = u;
    // Small cones: 1 − cos loses all precision; its Taylor expansion instead (as the scalar code).
    let small = sin2_max.simd_lt(Lanes::splat(SMALL_CONE_SIN2));
    let wide_cos_theta = (cos_max - one) * ux + one;
    let small_sin2_theta = sin2_max * ux;
    let sin2_theta = select(small, small_sin2_theta, one - wide_cos_theta * wide_cos_theta);
    let cos_theta = select(small, (one - small_sin2_theta).sqrt(), wide_cos_theta);
    let one_minus_cos_max = select(small, sin2_max / Lanes::splat(2.0), one - cos_max);
    // The angle at the sphere's centre between the direction to p_ref and the sampled point.
    let cos_alpha = sin2_theta / sin_max + cos_theta * (one - sin2_theta / sin2_max).max(zero).sqrt();
    let sin_alpha = (one - cos_alpha * cos_alpha).max(zero).sqrt();
    let phi = uy * Lanes::splat(2.0) * Lanes::splat(PI);
    let (sin_phi, cos_phi) = phi.sin_cos();
    let frame = Frame::from_z((c - p_ref).normalize());
    let w = V3 { x: sin_alpha * cos_phi, y: sin_alpha * sin_phi, z: cos_alpha };
    let n = frame.to_world(-w);
    SphereLanes {
        p: c + n.scale(radius),
        le: V3::gather(|i| lights[i].le),
        pdf: one / (Lanes::splat(2.0 * PI) * one_minus_cos_max),
        drawn,
    }
}
