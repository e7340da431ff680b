//! Eight triangles tested against one ray at once: the watertight test of `triangle.rs` (Woop, Benthin
//! & Wald 2013, pbrt-v4's `IntersectTriangle`) on SIMD lanes, one triangle a lane.
//!
//! A BVH leaf's triangles are stored as one or more packs, structure of arrays (each vertex
//! coordinate of the four triangles side by side), so the test loads them straight into lanes. Every
//! lane runs exactly the floating-point operations of the scalar test in the same order, so a lane
//! reports what [`super::triangle::intersect_triangle_sheared`] reports for its triangle, bit for
//! bit: the shared-edge watertightness is the scalar test's (its test holds here too). A lane whose
//! edge function is exactly zero takes the scalar test's f64 path, as pbrt-v4 does.

use super::offset::gamma;
use super::triangle::{ShearedRay, intersect_triangle_sheared};
use glam::Vec3;
use wide::f32x8;

/// A lane per triangle: eight, one AVX register (the machines we build for have it; without, `wide`
/// runs it as two SSE halves).
pub type PackLanes = f32x8;

/// Triangles of a pack.
pub const LANES: usize = 8;
/// Every lane's bit.
const ALL_LANES: u32 = (1 << LANES) - 1;

/// Eight triangles, structure of arrays: `v[k][a]` holds coordinate `a` of vertex `k` of each.
/// A pack with fewer triangles repeats its first one in the unused lanes (a duplicate hit is the same
/// triangle, so it changes nothing).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct TrianglePack {
    v: [[PackLanes; 3]; 3],
}

impl TrianglePack {
    /// A pack of up to [`LANES`] triangles (at least one).
    pub fn new(triangles: &[[Vec3; 3]]) -> Self {
        debug_assert!((1..=LANES).contains(&triangles.len()));
        let lane = |i: usize| triangles[if i < triangles.len() { i } else { 0 }];
        let v = std::array::from_fn(|k| {
            std::array::from_fn(|a| PackLanes::new(std::array::from_fn(|i| lane(i)[k][a])))
        });
        Self { v }
    }

    /// The vertices of lane `i`.
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        std::array::from_fn(|k| {
            Vec3::new(self.v[k][0].as_array()[i], self.v[k][1].as_array()[i], self.v[k][2].as_array()[i])
        })
    }
}

/// The per-ray part of the pack test: the ray's origin per lane (a moving pack's lanes each see the
/// ray moved back by their own displacement), its axis permutation and shear.
#[derive(Clone, Copy, Debug)]
pub struct PackRay {
    /// Origin, per world axis and lane.
    o: [PackLanes; 3],
    /// World axes that become x, y and z of ray space.
    k: [usize; 3],
    sx: PackLanes,
    sy: PackLanes,
    sz: PackLanes,
    /// The scalar form, for lanes that need the f64 fallback.
    sheared: ShearedRay,
    origin: Vec3,
}

impl PackRay {
    /// Prepare the ray `o + t·d`.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self::from_sheared(o, ShearedRay::new(d))
    }

    /// [`PackRay::new`] with the direction's reciprocal given (see [`ShearedRay::with_inverse`]).
    #[inline(always)]
    pub fn with_inverse(o: Vec3, d: Vec3, inverse: Vec3) -> Self {
        Self::from_sheared(o, ShearedRay::with_inverse(d, inverse))
    }

    #[inline(always)]
    fn from_sheared(o: Vec3, sheared: ShearedRay) -> Self {
        // The cyclic permutation that puts axis kz last, from a table (a remainder by 3 is a division).
        const PERMUTATIONS: [[usize; 3]; 3] = [[1, 2, 0], [2, 0, 1], [0, 1, 2]];
        let k = PERMUTATIONS[sheared.axis()];
        let (sx, sy, sz) = sheared.shear();
        Self {
            o: [PackLanes::splat(o.x), PackLanes::splat(o.y), PackLanes::splat(o.z)],
            k,
            sx: PackLanes::splat(sx),
            sy: PackLanes::splat(sy),
            sz: PackLanes::splat(sz),
            sheared,
            origin: o,
        }
    }

    /// The origin, the same in every lane.
    #[inline(always)]
    pub fn origin_lanes(&self) -> &[PackLanes; 3] {
        &self.o
    }

    /// The same ray seen by a pack whose triangles have moved by `shift` (per axis and lane).
    #[inline]
    pub fn shifted(&self, shift: &[PackLanes; 3]) -> ([PackLanes; 3], [Vec3; LANES]) {
        let o = [self.o[0] - shift[0], self.o[1] - shift[1], self.o[2] - shift[2]];
        let lanes =
            std::array::from_fn(|i| Vec3::new(o[0].as_array()[i], o[1].as_array()[i], o[2].as_array()[i]));
        (o, lanes)
    }
}

/// Which lanes hit, where, and with which barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct PackHits {
    /// Bit `i` set: lane `i` hits within the ray's range.
    pub mask: u32,
    /// Distances.
    pub t: [f32; LANES],
    /// Weights of vertex 1.
    pub b1: [f32; LANES],
    /// Weights of vertex 2.
    pub b2: [f32; LANES],
}

impl PackHits {
    /// No lane hits.
    pub const NONE: PackHits = PackHits { mask: 0, t: [0.0; LANES], b1: [0.0; LANES], b2: [0.0; LANES] };

    /// The lane of the nearest hit (the lowest lane among equals), if any.
    #[inline]
    pub fn nearest(&self) -> Option<usize> {
        let mut mask = self.mask;
        let mut best: Option<usize> = None;
        while mask != 0 {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if best.is_none_or(|b| self.t[i] < self.t[b]) {
                best = Some(i);
            }
        }
        best
    }
}

/// What the lanes of a pack test have computed once the cheap tests are done: the ray-space
/// vertices, the edge functions, the determinant and the scaled distance of every lane. The
/// division and the error bound that a hit needs are left to [`PackTest::finish_lanes`] (every
/// lane at once, for closest hits) or [`PackTest::finish`] (one candidate lane, for shadow rays,
/// which stop at the first).
struct PackTest {
    /// Ray-space vertices: `p[k][a]`, coordinate `a` of vertex `k`.
    p: [[PackLanes; 3]; 3],
    e: [PackLanes; 3],
    det: PackLanes,
    t_scaled: PackLanes,
}

impl PackTest {
    /// Every candidate lane's hit: its distance beyond the error bound and before `t_max`.
    #[inline(always)]
    fn finish_lanes(&self, candidates: u32, t_max: f32) -> PackHits {
        let [e0, e1, e2] = self.e;
        let [[p0x, p0y, p0z], [p1x, p1y, p1z], [p2x, p2y, p2z]] = self.p;
        let inv_det = PackLanes::ONE / self.det;
        let b1 = e1 * inv_det;
        let b2 = e2 * inv_det;
        let t = self.t_scaled * inv_det;
        // Ensure t is conservatively greater than zero (pbrt-v4, eq. 6.33–6.38).
        let max3 = |a: PackLanes, b: PackLanes, c: PackLanes| a.abs().fast_max(b.abs().fast_max(c.abs()));
        let max_zt = max3(p0z, p1z, p2z);
        let delta_z = PackLanes::splat(gamma(3)) * max_zt;
        let max_xt = max3(p0x, p1x, p2x);
        let max_yt = max3(p0y, p1y, p2y);
        let delta_x = PackLanes::splat(gamma(5)) * (max_xt + max_zt);
        let delta_y = PackLanes::splat(gamma(5)) * (max_yt + max_zt);
        let delta_e = PackLanes::splat(2.0)
            * (PackLanes::splat(gamma(2)) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = max3(e0, e1, e2);
        let delta_t = PackLanes::splat(3.0)
            * (PackLanes::splat(gamma(3)) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
            * inv_det.abs();
        let miss = t.simd_le(delta_t) | !t.simd_lt(PackLanes::splat(t_max));
        PackHits {
            mask: candidates & !miss.to_bitmask(),
            t: t.to_array(),
            b1: b1.to_array(),
            b2: b2.to_array(),
        }
    }

    /// The nearest candidate lane's hit, if any: [`PackTest::finish_lanes`] then
    /// [`PackHits::nearest`], without storing every lane's distance and barycentrics.
    #[inline(always)]
    fn finish_nearest(&self, candidates: u32, t_max: f32) -> Option<(usize, f32, f32, f32)> {
        let [e0, e1, e2] = self.e;
        let [[p0x, p0y, p0z], [p1x, p1y, p1z], [p2x, p2y, p2z]] = self.p;
        let inv_det = PackLanes::ONE / self.det;
        let t = self.t_scaled * inv_det;
        let max3 = |a: PackLanes, b: PackLanes, c: PackLanes| a.abs().fast_max(b.abs().fast_max(c.abs()));
        let max_zt = max3(p0z, p1z, p2z);
        let delta_z = PackLanes::splat(gamma(3)) * max_zt;
        let max_xt = max3(p0x, p1x, p2x);
        let max_yt = max3(p0y, p1y, p2y);
        let delta_x = PackLanes::splat(gamma(5)) * (max_xt + max_zt);
        let delta_y = PackLanes::splat(gamma(5)) * (max_yt + max_zt);
        let delta_e = PackLanes::splat(2.0)
            * (PackLanes::splat(gamma(2)) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = max3(e0, e1, e2);
        let delta_t = PackLanes::splat(3.0)
            * (PackLanes::splat(gamma(3)) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
            * inv_det.abs();
        let miss = t.simd_le(delta_t) | !t.simd_lt(PackLanes::splat(t_max));
        let hits = candidates & !miss.to_bitmask();
        if hits == 0 {
            return None;
        }
        let ts = t.as_array();
        // The nearest, the lowest lane among equals (as `PackHits::nearest`).
        let lane = if hits & (hits - 1) == 0 {
            hits.trailing_zeros() as usize
        } else {
            let mut rest = hits & (hits - 1);
            let mut best = hits.trailing_zeros() as usize;
            while rest != 0 {
                let i = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if ts[i] < ts[best] {
                    best = i;
                }
            }
            best
        };
        let inv = inv_det.as_array()[lane];
        Some((lane, ts[lane], e1.as_array()[lane] * inv, e2.as_array()[lane] * inv))
    }

    /// Whether lane `i` hits: [`PackTest::finish_lanes`] for one lane, in the scalar test's order of
    /// operations, so that it decides as the lanes do.
    #[inline(always)]
    fn finish(&self, i: usize, t_max: f32) -> bool {
        let lane = |v: PackLanes| v.as_array()[i];
        let [e0, e1, e2] = self.e.map(lane);
        let inv_det = 1.0 / lane(self.det);
        let t = lane(self.t_scaled) * inv_det;
        let max3 = |a: f32, b: f32, c: f32| a.abs().max(b.abs().max(c.abs()));
        let coordinate = |a: usize| max3(lane(self.p[0][a]), lane(self.p[1][a]), lane(self.p[2][a]));
        let (max_xt, max_yt, max_zt) = (coordinate(0), coordinate(1), coordinate(2));
        let delta_z = gamma(3) * max_zt;
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = max3(e0, e1, e2);
        let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
        t > delta_t && t < t_max
    }
}

/// The cheap part of the test of `pack` against `ray` with origin `o` (per lane), accepting hits
/// with `t < t_max`: the lanes still candidates (inside the edges, in range, not degenerate), the
/// lanes whose edge function is exactly zero (for the scalar test's f64 path), and what the
/// finishing reads. `None` when no lane is either: most packs a ray reaches.
#[inline(always)]
fn test_pack(
    pack: &TrianglePack,
    ray: &PackRay,
    o: &[PackLanes; 3],
    t_max: f32,
) -> Option<(u32, u32, PackTest)> {
    let [kx, ky, kz] = ray.k;
    // Translate to the ray origin, permute so the ray runs along z, shear so it points along +z:
    // the scalar test's `ShearedRay::transform`, lane-wise.
    let vertex = |k: usize| {
        let (px, py, pz) = (pack.v[k][kx] - o[kx], pack.v[k][ky] - o[ky], pack.v[k][kz] - o[kz]);
        [px + ray.sx * pz, py + ray.sy * pz, pz * ray.sz]
    };
    let p = [vertex(0), vertex(1), vertex(2)];
    let [[p0x, p0y, p0z], [p1x, p1y, p1z], [p2x, p2y, p2z]] = p;
    let e0 = p1x * p2y - p1y * p2x;
    let e1 = p2x * p0y - p2y * p0x;
    let e2 = p0x * p1y - p0y * p1x;
    let zero = PackLanes::ZERO;
    // Lanes with an edge function exactly zero are redone by the scalar test (its f64 path).
    let fallback = (e0.simd_eq(zero) | e1.simd_eq(zero) | e2.simd_eq(zero)).to_bitmask();
    let negative = e0.simd_lt(zero) | e1.simd_lt(zero) | e2.simd_lt(zero);
    let positive = e0.simd_gt(zero) | e1.simd_gt(zero) | e2.simd_gt(zero);
    let outside = negative & positive;
    if outside.to_bitmask() == ALL_LANES && fallback == 0 {
        return None;
    }
    let det = e0 + e1 + e2;
    let t_scaled = e0 * p0z + e1 * p1z + e2 * p2z;
    let t_max_det = PackLanes::splat(t_max) * det;
    let behind_or_beyond = (det.simd_lt(zero) & (t_scaled.simd_ge(zero) | t_scaled.simd_lt(t_max_det)))
        | (det.simd_gt(zero) & (t_scaled.simd_le(zero) | t_scaled.simd_gt(t_max_det)));
    let miss = outside | det.simd_eq(zero) | behind_or_beyond;
    let candidates = !miss.to_bitmask() & ALL_LANES & !fallback;
    if candidates == 0 && fallback == 0 {
        return None;
    }
    Some((candidates, fallback, PackTest { p, e: [e0, e1, e2], det, t_scaled }))
}

/// Test the triangles of `pack` against `ray` with origin `o` (per lane), accepting hits with
/// `t < t_max`. `origins` gives the same origin per lane for the f64 fallback.
#[inline(always)]
pub fn intersect_pack(
    pack: &TrianglePack,
    ray: &PackRay,
    o: &[PackLanes; 3],
    origins: Option<&[Vec3; LANES]>,
    t_max: f32,
) -> PackHits {
    let Some((candidates, fallback, test)) = test_pack(pack, ray, o, t_max) else {
        return PackHits::NONE;
    };
    let mut hits = if candidates != 0 { test.finish_lanes(candidates, t_max) } else { PackHits::NONE };
    if fallback != 0 {
        redo_in_scalar(pack, ray, origins, t_max, fallback, &mut hits);
    }
    hits
}

/// The nearest hit among the triangles of a still `pack` (the ray's own origin in every lane)
/// before `t_max`: its lane, distance and barycentrics; what [`intersect_pack`] then
/// [`PackHits::nearest`] report, without their arrays.
#[inline(always)]
pub fn nearest_in_pack(pack: &TrianglePack, ray: &PackRay, t_max: f32) -> Option<(usize, f32, f32, f32)> {
    let (candidates, fallback, test) = test_pack(pack, ray, &ray.o, t_max)?;
    if fallback != 0 {
        let mut hits = if candidates != 0 { test.finish_lanes(candidates, t_max) } else { PackHits::NONE };
        redo_in_scalar(pack, ray, None, t_max, fallback, &mut hits);
        return hits.nearest().map(|i| (i, hits.t[i], hits.b1[i], hits.b2[i]));
    }
    if candidates == 0 {
        return None;
    }
    test.finish_nearest(candidates, t_max)
}

/// Whether any triangle of `pack` blocks `ray` (origin `o` per lane) before `t_max`, for shadow
/// rays: no barycentrics, and the first lane found ends the test.
#[inline(always)]
pub fn pack_blocks(
    pack: &TrianglePack,
    ray: &PackRay,
    o: &[PackLanes; 3],
    origins: Option<&[Vec3; LANES]>,
    t_max: f32,
) -> bool {
    let Some((mut candidates, fallback, test)) = test_pack(pack, ray, o, t_max) else {
        return false;
    };
    while candidates != 0 {
        let i = candidates.trailing_zeros() as usize;
        candidates &= candidates - 1;
        if test.finish(i, t_max) {
            return true;
        }
    }
    if fallback != 0 {
        let mut hits = PackHits::NONE;
        redo_in_scalar(pack, ray, origins, t_max, fallback, &mut hits);
        return hits.mask != 0;
    }
    false
}

/// The scalar test (with its f64 path) for the lanes in `lanes`.
#[cold]
#[inline(never)]
fn redo_in_scalar(
    pack: &TrianglePack,
    ray: &PackRay,
    origins: Option<&[Vec3; LANES]>,
    t_max: f32,
    mut lanes: u32,
    hits: &mut PackHits,
) {
    while lanes != 0 {
        let i = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        let o = origins.map_or(ray.origin, |o| o[i]);
        let [p0, p1, p2] = pack.triangle(i);
        hits.mask &= !(1 << i);
        if let Some(h) =
            intersect_triangle_sheared(o, &ray.sheared, t_max, p0, p1, p2).filter(|h| h.t < t_max)
        {
            hits.mask |= 1 << i;
            (hits.t[i], hits.b1[i], hits.b2[i]) = (h.t, h.b1, h.b2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle::intersect_triangle;
    use crate::sampling::Sampler;
    use crate::sampling::warp::uniform_sphere;

    /// Every lane reports exactly what the scalar test reports for its triangle: random triangles
    /// and rays, including rays aimed at shared edges and vertices (where the f64 path runs).
    #[test]
    fn lanes_agree_with_the_scalar_test_bit_for_bit() {
        let mut checked = 0;
        for i in 0..20_000u32 {
            let s = Sampler::new(5, i, 0);
            let point = |d: u32| (Vec3::new(s.get1d(d), s.get1d(d + 1), s.get1d(d + 2)) - 0.5) * 4.0;
            let tris: Vec<[Vec3; 3]> =
                (0..LANES as u32).map(|k| [point(10 * k), point(10 * k + 3), point(10 * k + 6)]).collect();
            let o = point(100);
            // Half the rays aim at a vertex or edge midpoint of the first triangle.
            let d = match i % 4 {
                0 => tris[0][1] - o,
                1 => (tris[0][0] + tris[0][2]) * 0.5 - o,
                _ => uniform_sphere(s.get2d(110)),
            };
            let t_max = if i % 3 == 0 { 1.5 } else { f32::INFINITY };
            let pack = TrianglePack::new(&tris);
            let ray = PackRay::new(o, d);
            let hits = intersect_pack(&pack, &ray, &ray.o, None, t_max);
            assert_eq!(
                pack_blocks(&pack, &ray, &ray.o, None, t_max),
                hits.mask != 0,
                "ray {i}: any-hit test"
            );
            for (k, tri) in tris.iter().enumerate() {
                let scalar = intersect_triangle(o, d, t_max, tri[0], tri[1], tri[2]).filter(|h| h.t < t_max);
                let lane = (hits.mask >> k & 1 == 1).then(|| (hits.t[k], hits.b1[k], hits.b2[k]));
                let scalar = scalar.map(|h| (h.t, h.b1, h.b2));
                assert_eq!(
                    lane.map(|(t, a, b)| (t.to_bits(), a.to_bits(), b.to_bits())),
                    scalar.map(|(t, a, b)| (t.to_bits(), a.to_bits(), b.to_bits())),
                    "ray {i}, triangle {k}"
                );
                checked += scalar.is_some() as u32;
            }
        }
        assert!(checked > 1000, "only {checked} hits compared");
    }

    /// The shared-edge test of `triangle.rs`, through packs: rays within a few ulps of the diagonal
    /// two triangles share hit at least one of them.
    #[test]
    fn rays_at_a_shared_edge_never_slip_between_the_two_lanes() {
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        let pack = TrianglePack::new(&[[a, b, c], [a, c, d]]);
        let dir = Vec3::new(0.0, 0.0, -1.0);
        for i in 1..100 {
            let s = i as f32 / 100.0;
            for ulps in -4i32..=4 {
                let x = f32::from_bits((s.to_bits() as i32 + ulps) as u32);
                let ray = PackRay::new(Vec3::new(x, s, 1.0), dir);
                let hits = intersect_pack(&pack, &ray, &ray.o, None, f32::INFINITY);
                assert!(hits.mask & 0b11 != 0, "the ray at ({x}, {s}) slipped through the shared edge");
            }
        }
    }
}
