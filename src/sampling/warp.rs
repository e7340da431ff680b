//! Warps from the unit square to disks, hemispheres, cones and triangles, with their densities.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4, PI};

/// Shirley–Chiu concentric map: low distortion, so stratification survives.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // θ = π/4 · y/x, or π/2 − π/4 · x/y in the other half, whose cosine and sine are the sine and
    // cosine of π/4 · x/y: either way an angle within ±π/4, where two short polynomials give both.
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// Sine and cosine of `x` in [−π/4, π/4], within 2 ulps of the exact values (Cephes `sinf`/`cosf`
/// minimax polynomials on that interval). The library's `sin_cos` reduces any argument and was
/// 2% of a `pt` profile as a call; these are a dozen multiply-adds, the same on every machine.
#[inline]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = x + x * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
    let cos = 1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
    (sin, cos)
}

/// Cosine-weighted direction about +z (Malley's method).
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] per unit solid angle.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;

/// Uniform direction in the cone about +z with half-angle `acos(cos_max)`.
#[inline]
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Density of [`uniform_cone`] per unit solid angle.
#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics (b0, b1) on a triangle; b2 = 1 - b0 - b1 (Heitz 2019, low distortion).
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    Vec2::new(b0, b1)
}

/// An orthonormal basis around a unit vector (Duff et al. 2017, branchless).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// First tangent.
    pub x: Vec3,
    /// Second tangent.
    pub y: Vec3,
    /// The unit vector the frame was built around.
    pub z: Vec3,
}

impl Frame {
    /// A frame whose +z is `n` (must be unit length).
    #[inline]
    pub fn from_z(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { x, y, z: n }
    }

    /// World to local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    /// Local to world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[test]
    fn quarter_sine_and_cosine_are_within_two_ulps() {
        for i in 0..=100_000 {
            let x = (i as f64 / 100_000.0 * 2.0 - 1.0) * std::f64::consts::FRAC_PI_4;
            let (s, c) = sin_cos_quarter(x as f32);
            let x = x as f32 as f64;
            let ulp =
                |v: f64| (v as f32).abs().max(f32::MIN_POSITIVE).next_up() as f64 - (v as f32).abs() as f64;
            assert!((s as f64 - x.sin()).abs() <= 2.0 * ulp(x.sin()), "sin({x}) = {s}, exact {}", x.sin());
            assert!((c as f64 - x.cos()).abs() <= 2.0 * ulp(x.cos()), "cos({x}) = {c}, exact {}", x.cos());
        }
    }

    #[test]
    fn frame_is_orthonormal_for_any_normal() {
        for i in 0..1000 {
            let s = Sampler::new(3, i, 0);
            let n = uniform_sphere(s.get2d(0));
            let f = Frame::from_z(n);
            for (a, b) in [(f.x, f.y), (f.y, f.z), (f.x, f.z)] {
                assert!(a.dot(b).abs() < 1e-5, "{n}: not orthogonal");
            }
            assert!((f.x.length() - 1.0).abs() < 1e-5 && (f.y.length() - 1.0).abs() < 1e-5);
            let v = Vec3::new(0.3, -0.2, 0.9);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn triangle_barycentrics_stay_inside() {
        for i in 0..10_000 {
            let b = uniform_triangle(Sampler::new(0, i, 0).get2d(0));
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }
}
