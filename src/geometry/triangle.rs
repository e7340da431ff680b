//! Watertight ray–triangle intersection (Woop, Benthin & Wald 2013, as in pbrt-v4 `IntersectTriangle`).
//!
//! The test shears the triangle into the ray's coordinate system and evaluates the edge functions
//! there, so a ray through a shared edge or vertex hits exactly one of the triangles that meet there:
//! no cracks between triangles, which obvhs's own (Möller–Trumbore) test does not promise.

use super::offset::gamma;
use glam::{Vec3, Vec3A, Vec3Swizzles};

/// Barycentric hit on a triangle: `p = b0·p0 + b1·p1 + b2·p2` at distance `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter.
    pub t: f32,
    /// Weight of p1.
    pub b1: f32,
    /// Weight of p2.
    pub b2: f32,
}

/// The per-ray part of the watertight test: the axis permutation and shear that map the ray direction
/// to +z. Computing it once per ray instead of once per triangle (as Woop et al. suggest) leaves only
/// the edge functions in the per-triangle loop.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    /// The axis of the largest |d| component; it becomes z. The cyclic permutation that moves it there
    /// is a swizzle chosen by a branch that is the same for every triangle of the ray (well predicted),
    /// not an indexed load per vertex.
    kz: u8,
    /// (Sx, Sy, 0): the shear that sends the permuted direction to +z.
    shear_xy: Vec3A,
    /// (1, 1, Sz): the scale of the sheared z.
    scale: Vec3A,
}

impl ShearedRay {
    /// Prepare direction `d` (need not be unit length).
    #[inline]
    pub fn new(d: Vec3) -> Self {
        let kz = d.abs().max_position() as u8;
        Self::with_scale(d, kz, 1.0 / d[kz as usize])
    }

    /// [`ShearedRay::new`] with the reciprocal of the direction's largest component given
    /// (`inverse[kz]` of the box test's reciprocal: the same division, done once).
    #[inline(always)]
    pub fn with_inverse(d: Vec3, inverse: Vec3) -> Self {
        let kz = d.abs().max_position() as u8;
        Self::with_scale(d, kz, inverse[kz as usize])
    }

    #[inline(always)]
    fn with_scale(d: Vec3, kz: u8, sz: f32) -> Self {
        let d = permute(Vec3A::from(d), kz);
        Self { kz, shear_xy: Vec3A::new(-d.x * sz, -d.y * sz, 0.0), scale: Vec3A::new(1.0, 1.0, sz) }
    }

    /// The world axis that becomes z of ray space.
    #[inline]
    pub fn axis(&self) -> usize {
        self.kz as usize
    }

    /// (Sx, Sy, Sz): x' = x + Sx·z, y' = y + Sy·z, z' = Sz·z in the permuted frame.
    #[inline]
    pub fn shear(&self) -> (f32, f32, f32) {
        (self.shear_xy.x, self.shear_xy.y, self.scale.z)
    }

    /// Vertex `p` relative to the origin, in ray space; SIMD lanes do the three coordinates at once.
    #[inline(always)]
    fn transform(&self, p: Vec3A) -> Vec3 {
        let p = permute(p, self.kz);
        Vec3::from((p + self.shear_xy * Vec3A::splat(p.z)) * self.scale)
    }
}

/// Cyclic permutation that puts axis `kz` last: (kx, ky, kz) = (kz + 1, kz + 2, kz) mod 3, which keeps
/// the handedness (and so the sign of the edge functions).
#[inline(always)]
fn permute(p: Vec3A, kz: u8) -> Vec3A {
    match kz {
        0 => p.yzx(),
        1 => p.zxy(),
        _ => p,
    }
}

/// Intersect the ray `o + t·d`, `0 < t < t_max`, with triangle (p0, p1, p2).
#[inline]
pub fn intersect_triangle(o: Vec3, d: Vec3, t_max: f32, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<TriangleHit> {
    intersect_triangle_sheared(o, &ShearedRay::new(d), t_max, p0, p1, p2)
}

/// [`intersect_triangle`] with the per-ray work done once in `ray`.
#[inline(always)]
pub fn intersect_triangle_sheared(
    o: Vec3,
    ray: &ShearedRay,
    t_max: f32,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
    // Translate to the ray origin, permute so the ray runs along z, shear so it points along +z.
    let o = Vec3A::from(o);
    let p0t = ray.transform(Vec3A::from(p0) - o);
    let p1t = ray.transform(Vec3A::from(p1) - o);
    let p2t = ray.transform(Vec3A::from(p2) - o);
    // Edge functions; fall back to f64 when one is exactly zero (pbrt-v4 does the same).
    let mut e0 = p1t.x * p2t.y - p1t.y * p2t.x;
    let mut e1 = p2t.x * p0t.y - p2t.y * p0t.x;
    let mut e2 = p0t.x * p1t.y - p0t.y * p1t.x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        let f64e =
            |ax: f32, ay: f32, bx: f32, by: f32| (ax as f64 * by as f64 - ay as f64 * bx as f64) as f32;
        e0 = f64e(p1t.x, p1t.y, p2t.x, p2t.y);
        e1 = f64e(p2t.x, p2t.y, p0t.x, p0t.y);
        e2 = f64e(p0t.x, p0t.y, p1t.x, p1t.y);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }
    // Scaled hit distance, compared against the range before dividing.
    let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let b1 = e1 * inv_det;
    let b2 = e2 * inv_det;
    let t = t_scaled * inv_det;
    // Ensure t is conservatively greater than zero (pbrt-v4, eq. 6.33–6.38).
    let max_zt = Vec3::new(p0t.z, p1t.z, p2t.z).abs().max_element();
    let delta_z = gamma(3) * max_zt;
    let max_xt = Vec3::new(p0t.x, p1t.x, p2t.x).abs().max_element();
    let max_yt = Vec3::new(p0t.y, p1t.y, p2t.y).abs().max_element();
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = Vec3::new(e0, e1, e2).abs().max_element();
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some(TriangleHit { t, b1, b2 })
}

/// Conservative absolute error of the point `b0·p0 + b1·p1 + b2·p2` (pbrt-v4 eq. 6.23).
#[inline]
pub fn triangle_point_error(b0: f32, b1: f32, b2: f32, p0: Vec3, p1: Vec3, p2: Vec3) -> Vec3 {
    ((b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs()) * gamma(7)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No cracks: rays aimed at the diagonal two triangles share, and within a few ulps either side of
    /// it, hit at least one of them (on the edge itself the watertight test may report both, which a
    /// closest-hit query resolves); a little further off only the triangle on that side is hit.
    #[test]
    fn rays_at_a_shared_edge_never_slip_between_the_two_triangles() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        let dir = Vec3::new(0.0, 0.0, -1.0);
        let hits = |o: Vec3| {
            let h1 = intersect_triangle(o, dir, f32::INFINITY, a, b, c).is_some();
            let h2 = intersect_triangle(o, dir, f32::INFINITY, a, c, d).is_some();
            (h1, h2)
        };
        for i in 1..100 {
            let s = i as f32 / 100.0;
            for ulps in -4i32..=4 {
                // Step x by whole ulps across the diagonal x = y.
                let x = f32::from_bits((s.to_bits() as i32 + ulps) as u32);
                let (h1, h2) = hits(Vec3::new(x, s, 1.0));
                assert!(h1 || h2, "the ray at ({x}, {s}) slipped through the shared edge");
            }
            assert_eq!(hits(Vec3::new(s + 1e-3, s, 1.0)), (true, false), "below the diagonal at {s}");
            assert_eq!(hits(Vec3::new(s - 1e-3, s, 1.0)), (false, true), "above the diagonal at {s}");
        }
    }

    #[test]
    fn hit_reports_distance_and_barycentrics() {
        let h = intersect_triangle(
            Vec3::new(0.25, 0.25, 2.0),
            Vec3::new(0.0, 0.0, -1.0),
            10.0,
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
        )
        .unwrap();
        assert!((h.t - 2.0).abs() < 1e-6 && (h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.25).abs() < 1e-6);
        assert!(
            intersect_triangle(Vec3::new(0.25, 0.25, 2.0), Vec3::Z, 10.0, Vec3::ZERO, Vec3::X, Vec3::Y)
                .is_none()
        );
        assert!(
            intersect_triangle(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z, 1.5, Vec3::ZERO, Vec3::X, Vec3::Y)
                .is_none()
        );
    }
}
