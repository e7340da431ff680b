//! The cylindrical (Lambert equal-area) map between the unit sphere and the square [0, 1)²: cos θ =
//! 2x − 1, φ = 2πy. Equal areas on the square are equal solid angles on the sphere, so a density on
//! the square is a density per steradian times the constant 4π, and a quadtree over the square
//! splits the sphere into cells of equal solid angle at each depth (Müller et al. 2017, §5.2).
//!
//! The angle φ goes through short polynomials rather than the library's `atan2` and `sin_cos`: which
//! cell a direction falls in decides what the tree records, so its bits must not depend on the
//! machine's libm, and the polynomials are several times faster too.

use crate::sampling::ONE_MINUS_EPSILON;
use crate::sampling::warp::sin_cos_quarter;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

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
    let x = (cos_theta + 1.0) * 0.5;
    let y = angle(d.x, d.y) * (0.5 * FRAC_1_PI);
    Some(Vec2::new(x, y).clamp(Vec2::ZERO, Vec2::splat(ONE_MINUS_EPSILON)))
}

/// The angle of (x, y) in [0, 2π] (0 for the origin), within an ulp of the result (5e−7 near 2π):
/// atan of the smaller coordinate over the larger, in [0, π/4], then reflected into its octant.
#[inline]
fn angle(x: f32, y: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    if hi == 0.0 || hi.is_nan() {
        return 0.0;
    }
    let mut a = atan_unit(lo / hi);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 { 2.0 * PI - a } else { a }
}

/// atan t for t ∈ [0, 1]: Cephes `atanf`'s reduction (above tan π/8, π/4 + atan((t − 1)/(t + 1)))
/// and its minimax polynomial on [−tan π/8, tan π/8].
#[inline]
fn atan_unit(t: f32) -> f32 {
    let (offset, x) = if t > 0.414_213_57 { (FRAC_PI_4, (t - 1.0) / (t + 1.0)) } else { (0.0, t) };
    let z = x * x;
    let p = ((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1;
    offset + (p * z * x + x)
}

/// The unit direction at point `s` of the square (inverse of [`to_square`]).
#[inline]
pub fn from_square(s: Vec2) -> Vec3 {
    let cos_theta = (2.0 * s.x - 1.0).clamp(-1.0, 1.0);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (cos_phi, sin_phi) = turn(s.y);
    Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

/// (cos, sin) of 2π`y` for `y` ∈ [0, 1]: the nearest quarter turn k exactly (4y − k is exact), the
/// remaining ±π/4 by polynomial, then rotated by k quarter turns.
#[inline]
fn turn(y: f32) -> (f32, f32) {
    let t = 4.0 * y;
    let k = (t + 0.5).floor();
    let (s, c) = sin_cos_quarter((t - k) * FRAC_PI_2);
    match k as i32 & 3 {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
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

    /// The polynomials against the library's functions in f64, around the whole circle.
    #[test]
    fn angles_match_the_library() {
        use std::f64::consts::PI as PI64;
        for i in 0..=100_000 {
            let y = i as f32 / 100_000.0;
            let (c, s) = turn(y);
            let (ls, lc) = (2.0 * PI64 * y as f64).sin_cos();
            assert!((c as f64 - lc).abs() < 2e-7 && (s as f64 - ls).abs() < 2e-7, "{y}: {c} {s}, {lc} {ls}");
            let (x, y) = (c, s);
            let phi = (y as f64).atan2(x as f64).rem_euclid(2.0 * PI64);
            let a = angle(x, y) as f64;
            // At the seam 0 and 2π are the same direction.
            let diff = (a - phi).abs().min(2.0 * PI64 - (a - phi).abs());
            assert!(diff < 6e-7, "({x}, {y}): {a} against {phi}");
        }
        for (x, y, expected) in
            [(1.0, 0.0, 0.0), (0.0, 1.0, FRAC_PI_2), (-1.0, 0.0, PI), (0.0, -1.0, 1.5 * PI), (1.0, -0.0, 0.0)]
        {
            assert_eq!(angle(x, y), expected, "({x}, {y})");
        }
        assert_eq!(angle(0.0, 0.0), 0.0);
    }
}
