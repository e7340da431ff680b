//! The GGX distribution, Schlick's Fresnel and the warps they sample by, in lanes: each function is
//! its scalar namesake (`materials::microfacet::Ggx`, `materials::fresnel`, `sampling::warp`)
//! with the same operations in the same order, one lane per vertex, the lane's own alpha.

use super::v3::{Mask, V3, select};
use super::{Lanes, sin_cos_quarter};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};

/// `f32::max`: the larger, or the operand that is not NaN.
#[inline(always)]
pub fn max(a: Lanes, b: Lanes) -> Lanes {
    a.max(b)
}

/// `f32::clamp`: `min` below it, `max` above it, NaN kept.
#[inline(always)]
pub fn clamp(x: Lanes, min: Lanes, max: Lanes) -> Lanes {
    let x = select(x.simd_lt(min), min, x);
    select(x.simd_gt(max), max, x)
}

/// `f32::signum`: ±1 by the sign bit, NaN kept.
#[inline(always)]
pub fn signum(x: Lanes) -> Lanes {
    select(x.is_nan(), x, Lanes::ONE.copysign(x))
}

/// `fresnel::schlick_weight`: `(1 − |cos|)⁵`, the base clamped to [0, 1].
#[inline(always)]
pub fn schlick_weight(cos: Lanes) -> Lanes {
    let m = clamp(Lanes::ONE - cos.abs(), Lanes::ZERO, Lanes::ONE);
    let m2 = m * m;
    m2 * m2 * m
}

/// `fresnel::schlick`.
#[inline(always)]
pub fn schlick(f0: V3, f90: Lanes, cos: Lanes) -> V3 {
    f0 + (V3 { x: f90, y: f90, z: f90 } - f0).scale(schlick_weight(cos))
}

/// `fresnel::schlick_scalar`.
#[inline(always)]
pub fn schlick_scalar(f0: Lanes, f90: Lanes, cos: Lanes) -> Lanes {
    f0 + (f90 - f0) * schlick_weight(cos)
}

/// `fresnel::reflect`.
#[inline(always)]
pub fn reflect(wo: V3, n: V3) -> V3 {
    -wo + n.scale(Lanes::splat(2.0) * wo.dot(n))
}

/// `conductor::half_vector`: the half vector of a pair above the surface, and where it exists.
#[inline(always)]
pub fn half_vector(wo: V3, wi: V3) -> (V3, Mask) {
    let above = wo.z.simd_gt(Lanes::ZERO) & wi.z.simd_gt(Lanes::ZERO);
    let wm = wo + wi;
    let len2 = wm.dot(wm);
    (wm.scale_div(len2.sqrt()), above & len2.simd_gt(Lanes::ZERO))
}

/// `warp::concentric_disk`.
#[inline(always)]
pub fn concentric_disk(u: [Lanes; 2]) -> (Lanes, Lanes) {
    let two = Lanes::splat(2.0);
    let (ox, oy) = (two * u[0] - Lanes::ONE, two * u[1] - Lanes::ONE);
    let quarter = Lanes::splat(FRAC_PI_4);
    let (sin_x, cos_x) = sin_cos_quarter(quarter * (oy / ox));
    let (sin_y, cos_y) = sin_cos_quarter(quarter * (ox / oy));
    let wide_x = ox.abs().simd_gt(oy.abs());
    let centre = ox.simd_eq(Lanes::ZERO) & oy.simd_eq(Lanes::ZERO);
    let dx = select(centre, Lanes::ZERO, select(wide_x, ox * cos_x, oy * sin_y));
    let dy = select(centre, Lanes::ZERO, select(wide_x, ox * sin_x, oy * cos_y));
    (dx, dy)
}

/// `warp::cosine_hemisphere`.
#[inline(always)]
pub fn cosine_hemisphere(u: [Lanes; 2]) -> V3 {
    let (dx, dy) = concentric_disk(u);
    let z = (Lanes::ONE - (dx * dx + dy * dy)).fast_max(Lanes::ZERO).sqrt();
    V3 { x: dx, y: dy, z }
}

/// `microfacet::Ggx`, a width per lane.
#[derive(Clone, Copy)]
pub struct Ggx {
    /// The GGX width.
    pub alpha: Lanes,
}

impl Ggx {
    /// `Ggx::d`.
    #[inline(always)]
    pub fn d(&self, wm: V3) -> Lanes {
        let a2 = self.alpha * self.alpha;
        let t = wm.x * wm.x + wm.y * wm.y + a2 * wm.z * wm.z;
        select(wm.z.simd_le(Lanes::ZERO), Lanes::ZERO, a2 * Lanes::splat(FRAC_1_PI) / (t * t))
    }

    /// `Ggx::lambda`.
    #[inline(always)]
    pub fn lambda(&self, w: V3) -> Lanes {
        let cos2 = w.z * w.z;
        let tan2 = (w.x * w.x + w.y * w.y) / cos2;
        let lambda = Lanes::splat(0.5) * ((Lanes::ONE + self.alpha * self.alpha * tan2).sqrt() - Lanes::ONE);
        select(cos2.simd_eq(Lanes::ZERO), Lanes::splat(f32::INFINITY), lambda)
    }

    /// `Ggx::g1`.
    #[inline(always)]
    pub fn g1(&self, w: V3) -> Lanes {
        Lanes::ONE / (Lanes::ONE + self.lambda(w))
    }

    /// `Ggx::g`.
    #[inline(always)]
    pub fn g(&self, wo: V3, wi: V3) -> Lanes {
        Lanes::ONE / (Lanes::ONE + (self.lambda(wo) + self.lambda(wi)))
    }

    /// `Ggx::d_visible`.
    #[inline(always)]
    pub fn d_visible(&self, w: V3, wm: V3) -> Lanes {
        let cos_m = w.dot(wm) * signum(w.z);
        let none = w.z.simd_eq(Lanes::ZERO) | cos_m.simd_le(Lanes::ZERO);
        select(none, Lanes::ZERO, self.g1(w) * cos_m * self.d(wm) / w.z.abs())
    }

    /// `Ggx::sample_wm` (Heitz 2018, listing 1).
    #[inline(always)]
    pub fn sample_wm(&self, w: V3, u: [Lanes; 2]) -> V3 {
        let stretched = V3 { x: self.alpha * w.x, y: self.alpha * w.y, z: w.z }.normalize();
        let wh = V3::select(stretched.z.simd_lt(Lanes::ZERO), -stretched, stretched);
        // Vec3::Z.cross(wh) is (−wh.y, wh.x, 0) computed as glam does: 0·wh.z − wh.y·1 and so on.
        let zero = Lanes::ZERO;
        let z_cross = V3 {
            x: zero * wh.z - wh.y * Lanes::ONE,
            y: Lanes::ONE * wh.x - wh.z * zero,
            z: zero * wh.y - wh.x * zero,
        };
        let t1 = V3::select(
            wh.z.simd_lt(Lanes::splat(0.99999)),
            z_cross.normalize(),
            V3 { x: Lanes::ONE, y: zero, z: zero },
        );
        let t2 = wh.cross(t1);
        let (px, py) = concentric_disk(u);
        let h = max(Lanes::ONE - px * px, zero).sqrt();
        let s = Lanes::splat(0.5) * (Lanes::ONE + wh.z);
        let py = (Lanes::ONE - s) * h + s * py;
        let pz = max(Lanes::ONE - (px * px + py * py), zero).sqrt();
        let nh = t1.scale(px) + t2.scale(py) + wh.scale(pz);
        V3 { x: self.alpha * nh.x, y: self.alpha * nh.y, z: max(nh.z, Lanes::splat(1e-6)) }.normalize()
    }
}
