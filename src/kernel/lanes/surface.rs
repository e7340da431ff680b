//! What every class of lanes computes of a vertex before its material: the point on the triangle
//! with its error bound, the geometric and interpolated normals, the shading frame, the direction
//! back; and the geometry after it: the offset origin of a ray leaving the surface and the test that
//! refuses a direction the shading and geometric normals disagree on. Each is the scalar kernel's
//! operations in its order (`Geometry::surface_hit`, `Vertex::new`, `offset::offset_ray_origin`,
//! `continuation::crosses_inconsistently`, `warp::Frame`).

use super::v3::{Mask, MaskBits, V3, select};
use super::{Bits, Lanes};
use crate::geometry::bvh::PlainTriangle;
use crate::geometry::offset::gamma;
use glam::Vec3;

/// A group's triangles, hit points and incoming directions, one lane each.
pub struct GroupHits<'a> {
    /// The triangles.
    pub triangles: &'a [PlainTriangle],
    /// Barycentric weight of vertex 1.
    pub b1: Lanes,
    /// Barycentric weight of vertex 2.
    pub b2: Lanes,
    /// The directions of the rays that found them.
    pub d: V3,
}

/// A vertex's surface, in lanes.
pub struct Surface {
    /// The point.
    pub p: V3,
    /// The bound on its error.
    pub p_error: V3,
    /// The geometric normal.
    pub ng: V3,
    /// The shading frame about the interpolated normal.
    pub frame: Frame,
    /// Towards where the ray came from, in the frame.
    pub wo: V3,
    /// The shading normal on the side the ray came from.
    pub n_side: V3,
}

impl Surface {
    /// The surface where each lane's ray met its triangle (`Geometry::surface_hit` then
    /// `Vertex::new`), its shading normal `mapped` where a normal map gave one.
    #[inline(always)]
    pub fn of(hits: &GroupHits, mapped: &[Option<Vec3>; super::WIDTH]) -> Self {
        let triangles = hits.triangles;
        let count = triangles.len();
        let lane = |i: usize| &triangles[if i < count { i } else { 0 }];
        // The triangle is still, so its vertices move by zero, which the scalar kernel adds too (it
        // turns a -0 coordinate into +0).
        let zero = V3::splat(0.0);
        let corner = |k: usize| V3::gather(|i| lane(i).p[k]) + zero;
        let (p0, p1, p2) = (corner(0), corner(1), corner(2));
        let (b1, b2) = (hits.b1, hits.b2);
        let b0 = Lanes::ONE - b1 - b2;
        let p = p0.scale(b0) + p1.scale(b1) + p2.scale(b2);
        let p_error =
            (p0.scale(b0).abs() + p1.scale(b1).abs() + p2.scale(b2).abs()).scale(Lanes::splat(gamma(7)));
        let ng = (p1 - p0).cross(p2 - p0).normalize();
        let has_normals = Mask::from_fn(|i| lane(i).normals.is_some());
        let ns = if has_normals.bits() == 0 {
            ng
        } else {
            let normal = |k: usize| V3::gather(|i| lane(i).normals.map_or(Vec3::ZERO, |n| n[k]));
            let interpolated =
                (normal(0).scale(b0) + normal(1).scale(b1) + normal(2).scale(b2)).normalize_or_zero();
            let flipped = interpolated.dot(ng).simd_lt(Lanes::ZERO);
            let ns = V3::select(interpolated.is_zero(), ng, V3::select(flipped, -interpolated, interpolated));
            V3::select(has_normals, ns, ng)
        };
        let is_mapped = Mask::from_fn(|i| mapped[i].is_some());
        let ns = if is_mapped.bits() == 0 {
            ns
        } else {
            V3::select(is_mapped, V3::gather(|i| mapped[i].unwrap_or(Vec3::ZERO)), ns)
        };
        let frame = Frame::from_z(ns);
        let wo = frame.to_local(-hits.d);
        let n_side = V3::select(wo.z.simd_ge(Lanes::ZERO), ns, -ns);
        Self { p, p_error, ng, frame, wo, n_side }
    }

    /// `continuation::crosses_inconsistently`: `wi` on one side of the surface by the shading frame
    /// and on the other by the geometric normal, relative to where the path arrived.
    #[inline(always)]
    pub fn crosses_inconsistently(&self, wi_world: V3, wi_local: V3) -> Mask {
        let wo_world = self.frame.to_world(self.wo);
        (wi_world.dot(self.ng) * wo_world.dot(self.ng) * wi_local.z * self.wo.z).simd_lt(Lanes::ZERO)
    }

    /// `offset::offset_ray_origin` for a ray leaving along `w`.
    #[inline(always)]
    pub fn ray_origin(&self, w: V3) -> V3 {
        offset_ray_origin(self.p, self.p_error, self.ng, w)
    }
}

/// The shading frame in lanes (`warp::Frame::from_z`, Duff et al. 2017).
pub struct Frame {
    /// Tangent.
    pub x: V3,
    /// Bitangent.
    pub y: V3,
    /// Normal.
    pub z: V3,
}

impl Frame {
    /// The frame about unit `n`.
    #[inline(always)]
    pub fn from_z(n: V3) -> Self {
        let sign = Lanes::ONE.copysign(n.z);
        let a = Lanes::splat(-1.0) / (sign + n.z);
        let b = n.x * n.y * a;
        let x = V3 { x: Lanes::ONE + sign * n.x * n.x * a, y: sign * b, z: -sign * n.x };
        let y = V3 { x: b, y: sign + n.y * n.y * a, z: -n.y };
        Self { x, y, z: n }
    }

    /// World to the frame.
    #[inline(always)]
    pub fn to_local(&self, v: V3) -> V3 {
        V3 { x: v.dot(self.x), y: v.dot(self.y), z: v.dot(self.z) }
    }

    /// The frame to world.
    #[inline(always)]
    pub fn to_world(&self, v: V3) -> V3 {
        self.x.scale(v.x) + self.y.scale(v.y) + self.z.scale(v.z)
    }
}

/// `offset::offset_ray_origin` in lanes.
#[inline(always)]
pub fn offset_ray_origin(p: V3, p_error: V3, n: V3, w: V3) -> V3 {
    let d = n.abs().dot(p_error);
    let offset = V3::select(w.dot(n).simd_lt(Lanes::ZERO), n.scale(-d), n.scale(d));
    let po = p + offset;
    let away = |po: Lanes, offset: Lanes| {
        select(
            offset.simd_gt(Lanes::ZERO),
            next_up(po),
            select(offset.simd_lt(Lanes::ZERO), next_down(po), po),
        )
    };
    V3 { x: away(po.x, offset.x), y: away(po.y, offset.y), z: away(po.z, offset.z) }
}

/// `f32::next_up` in lanes: the next float towards +∞ (±0 to the smallest subnormal; NaN and +∞
/// stay).
#[inline(always)]
fn next_up(x: Lanes) -> Lanes {
    let bits = x.to_bits();
    let abs = bits & Bits::splat(0x7fff_ffff);
    let one = Bits::splat(1);
    let stepped = bits.simd_eq(abs).select(bits + one, bits - one);
    let next = abs.simd_eq(Bits::splat(0)).select(one, stepped);
    let keep = x.is_nan() | x.simd_eq(Lanes::splat(f32::INFINITY));
    select(keep, x, Lanes::from_bits(next))
}

/// `f32::next_down` in lanes: the next float towards −∞.
#[inline(always)]
fn next_down(x: Lanes) -> Lanes {
    let bits = x.to_bits();
    let abs = bits & Bits::splat(0x7fff_ffff);
    let one = Bits::splat(1);
    let stepped = bits.simd_eq(abs).select(bits - one, bits + one);
    let next = abs.simd_eq(Bits::splat(0)).select(Bits::splat(0x8000_0001), stepped);
    let keep = x.is_nan() | x.simd_eq(Lanes::splat(f32::NEG_INFINITY));
    select(keep, x, Lanes::from_bits(next))
}
