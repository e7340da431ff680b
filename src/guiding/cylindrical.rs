//! The cylindrical (Lambert equal-area) map between the unit sphere and the square [0, 1)²: cos θ =
//! 2x − 1, φ = 2πy. Equal areas on the square are equal solid angles on the sphere, so a density on
//! the square is a density per steradian times the constant 4π, and a quadtree over the square
//! splits the sphere into cells of equal solid angle at each depth (Müller et al. 2017, §5.2).

use crate::sampling::ONE_MINUS_EPSILON;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Solid angle per unit area of the square (the map's Jacobian): a density on the square times this
/// is a density per steradian.
pub const INV_FOUR_PI: f32 = 0.25 * FRAC_1_PI;

/// The point of the square of direction `d` (any non-zero length); `None` for a zero, infinite or
/// NaN vector. The result lies in [0, 1)², so that a quadtree's `x ≥ ½` tests never see 1.
#[inline]
pub fn to_square(d: Vec3) -> Option<Vec2> {
    let len = d.length();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let cos_theta = (d.z / len).clamp(-1.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let x = (cos_theta + 1.0) * 0.5;
    let y = phi * (0.5 * FRAC_1_PI);
    Some(Vec2::new(x, y).clamp(Vec2::ZERO, Vec2::splat(ONE_MINUS_EPSILON)))
}

/// The unit direction at point `s` of the square (inverse of [`to_square`]).
#[inline]
pub fn from_square(s: Vec2) -> Vec3 {
    let cos_theta = (2.0 * s.x - 1.0).clamp(-1.0, 1.0);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (sin_phi, cos_phi) = (2.0 * PI * s.y).sin_cos();
    Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[test]
    fn the_map_and_its_inverse_agree() {
        for i in 0..10_000 {
            let s = Sampler::new(3, i, 0).get2d(0);
            let d = from_square(s);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let back = to_square(d * 3.7).unwrap();
            // Near the poles φ is ill-conditioned; compare directions there.
            assert!((from_square(back) - d).length() < 1e-4, "{s} -> {d} -> {back}");
        }
        assert_eq!(to_square(Vec3::Z).unwrap().x, ONE_MINUS_EPSILON);
        assert_eq!(to_square(-Vec3::Z).unwrap().x, 0.0);
        for bad in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::new(0.0, f32::NAN, 1.0)]
        {
            assert_eq!(to_square(bad), None, "{bad}");
        }
    }
}
