//! A point on a triangle light for each lane (`Light::sample` of a still triangle): by the solid
//! angle the triangle subtends where it is large, warped by the receiver's cosine (Arvo 1995 in
//! pbrt-v4's form, `sampling::spherical`), by area where it is small — both computed in lanes and
//! each lane taking its own, the scalar code's operations in its order.

use super::ggx::{clamp, max};
use super::v3::{Mask, V3, select};
use super::{Lanes, WIDTH};
use crate::lights::{Light, LightShape};
use crate::sampling::spherical::{
    MAX_SPHERICAL_SOLID_ANGLE, MIN_SPHERICAL_SOLID_ANGLE, SPHERICAL_FROM_SOLID_ANGLE,
};
use glam::Vec3;
use std::f32::consts::PI;

/// Lanes of a group that may sample by solid angle up to which they are sampled one by one: the
/// spherical construction costs several times the area sample, and in lanes every lane pays it.
const SPHERICAL_ONE_BY_ONE: usize = super::WIDTH / 4;

/// The triangles the lanes chose, moved to the lanes' shutter times.
pub struct TriangleLanes {
    /// Vertices.
    pub v: [V3; 3],
    /// The unmoved vertices (area sampling moves its point instead).
    pub p: [V3; 3],
    /// Their displacement at the lanes' times.
    pub shift: V3,
    /// Unit front normal.
    pub n: V3,
    /// Area.
    pub area: Lanes,
    /// Emitted radiance.
    pub le: V3,
}

impl TriangleLanes {
    /// The triangles of `lights` (each a `LightShape::Triangle`) at shutter times `time`.
    #[inline(always)]
    pub fn new(lights: &[&Light; WIDTH], time: Lanes) -> Self {
        let (mut p, mut n, mut area) = ([[Vec3::ZERO; 3]; WIDTH], [Vec3::Z; WIDTH], [0.0; WIDTH]);
        for (i, light) in lights.iter().enumerate() {
            if let LightShape::Triangle { p: corners, n: normal, area: a } = light.shape {
                (p[i], n[i], area[i]) = (corners, normal, a);
            }
        }
        let shift = V3::gather(|i| lights[i].motion).scale(time);
        let p: [V3; 3] = std::array::from_fn(|k| V3::gather(|i| p[i][k]));
        Self {
            v: p.map(|q| q + shift),
            p,
            shift,
            n: V3::gather(|i| n[i]),
            area: Lanes::new(area),
            le: V3::gather(|i| lights[i].le),
        }
    }

    /// Each lane's point on its triangle seen from `p_ref` with normal `n_ref`, and its pdf per
    /// unit solid angle (the choice's probability not in it); lanes where `Light::sample` returns
    /// `None` are cleared from the mask.
    ///
    /// A lane that may sample by solid angle takes its longer way whatever the others do; where few
    /// lanes of a group do, `one_by_one` samples them (the scalar code, the same bits) and the lanes
    /// do the others by area, a choice of speed that leaves the image as it is.
    #[inline(always)]
    pub fn sample(
        &self,
        p_ref: V3,
        n_ref: V3,
        u: [Lanes; 2],
        one_by_one: impl Fn(usize) -> Option<(Vec3, f32)>,
    ) -> (V3, Lanes, Mask) {
        let (area_point, area_pdf, area_ok) = self.sample_area(p_ref, u);
        let large = self.large(p_ref);
        let count = large.to_bitmask().count_ones() as usize;
        if count == 0 {
            return (area_point, area_pdf, area_ok);
        }
        if count <= SPHERICAL_ONE_BY_ONE {
            let mut bits = large.to_bitmask();
            let (mut point, mut pdf, mut ok) = (area_point.lanes(), area_pdf.to_array(), area_ok.to_array());
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let sample = one_by_one(i);
                (point[i], pdf[i]) = sample.unwrap_or((point[i], pdf[i]));
                ok[i] = f32::from_bits(if sample.is_some() { u32::MAX } else { 0 });
            }
            return (V3::gather(|i| point[i]), Lanes::new(pdf), Lanes::new(ok));
        }
        let spherical = self.spherical(p_ref, large);
        let (point, pdf, ok) = spherical.sample(self, p_ref, n_ref, u);
        let wanted = spherical.wanted;
        (V3::select(wanted, point, area_point), select(wanted, pdf, area_pdf), select(wanted, ok, area_ok))
    }

    /// `Light::spherical`'s first tests: the lanes whose triangle faces them and may subtend a
    /// solid angle large enough to be sampled by it.
    #[inline(always)]
    fn large(&self, p_ref: V3) -> Mask {
        let [v0, v1, v2] = self.v;
        let to_ref = p_ref - (v0 + v1 + v2).scale_div(Lanes::splat(3.0));
        let cos_r = self.n.dot(to_ref);
        let front = !self.n.dot(p_ref - v0).simd_le(Lanes::ZERO) & !cos_r.simd_le(Lanes::ZERO);
        let r2 = to_ref.dot(to_ref);
        front & !(self.area * cos_r).simd_lt(Lanes::splat(SPHERICAL_FROM_SOLID_ANGLE) * r2 * r2.sqrt())
    }

    /// `SphericalTriangle::new` and `worth_sampling` for the lanes `large` holds: the corner
    /// directions and solid angle, and the lanes that sample by it.
    #[inline(always)]
    fn spherical(&self, p_ref: V3, large: Mask) -> Spherical {
        let corners = self.v.map(|q| (q - p_ref).normalize_or_zero());
        let [a, b, c] = corners;
        let y = a.dot(b.cross(c));
        let x = Lanes::ONE + a.dot(b) + a.dot(c) + b.dot(c);
        let solid_angle = (Lanes::splat(2.0) * y.atan2(x)).abs();
        let worth = solid_angle.simd_ge(Lanes::splat(MIN_SPHERICAL_SOLID_ANGLE))
            & solid_angle.simd_le(Lanes::splat(MAX_SPHERICAL_SOLID_ANGLE));
        Spherical { corners, solid_angle, wanted: large & worth }
    }

    /// Area sampling (`uniform_triangle`, the pdf by distance and cosine).
    #[inline(always)]
    fn sample_area(&self, p_ref: V3, u: [Lanes; 2]) -> (V3, Lanes, Mask) {
        let first = u[0].simd_lt(u[1]);
        let (b0, b1) = (u[0] / Lanes::splat(2.0), u[1] / Lanes::splat(2.0));
        let bx = select(first, b0, u[0] - b1);
        let by = select(first, u[1] - b0, b1);
        let [p0, p1, p2] = self.p;
        let point = p0.scale(Lanes::ONE - bx - by) + p1.scale(bx) + p2.scale(by) + self.shift;
        let to_ref = p_ref - point;
        let dist2 = to_ref.dot(to_ref);
        let cos_l = self.n.dot(to_ref) / dist2.sqrt();
        let ok = !(cos_l.simd_le(Lanes::ZERO) | dist2.simd_eq(Lanes::ZERO));
        (point, dist2 / (cos_l * self.area), ok)
    }
}

/// A spherical triangle per lane.
struct Spherical {
    corners: [V3; 3],
    solid_angle: Lanes,
    /// Lanes that sample by solid angle.
    wanted: Mask,
}

impl Spherical {
    /// `Light::sample`'s spherical branch: the cosine warp, `SphericalTriangle::sample`, the point.
    #[inline(always)]
    fn sample(&self, t: &TriangleLanes, p_ref: V3, n_ref: V3, u: [Lanes; 2]) -> (V3, Lanes, Mask) {
        let zero = Lanes::ZERO;
        let no_normal = n_ref.is_zero();
        // cosine_corners, sample_bilinear, bilinear_pdf.
        let cos = |q: V3| max(n_ref.dot(q).abs(), Lanes::splat(0.01));
        let c1 = cos(self.corners[1]);
        let w = [c1, c1, cos(self.corners[0]), cos(self.corners[2])];
        let y = sample_linear(u[1], w[0] + w[1], w[2] + w[3]);
        let x = sample_linear(u[0], w[0] + (w[2] - w[0]) * y, w[1] + (w[3] - w[1]) * y);
        let warped = [select(no_normal, u[0], x), select(no_normal, u[1], y)];
        let warp_pdf = select(no_normal, Lanes::ONE, bilinear_pdf([x, y], w));

        let (b, drawn) = self.barycentrics(t, p_ref, warped);
        let [v0, v1, v2] = t.v;
        let point = v0 + (v1 - v0).scale(b[0]) + (v2 - v0).scale(b[1]);
        let at_ref = point.x.simd_eq(p_ref.x) & point.y.simd_eq(p_ref.y) & point.z.simd_eq(p_ref.z);
        let ok = drawn & !at_ref & !warp_pdf.simd_le(zero);
        (point, warp_pdf / self.solid_angle, ok)
    }

    /// `SphericalTriangle::sample`: the barycentrics of the direction `u` picks, and where it picks
    /// one.
    #[inline(always)]
    fn barycentrics(&self, t: &TriangleLanes, p_ref: V3, u: [Lanes; 2]) -> ([Lanes; 2], Mask) {
        let zero = Lanes::ZERO;
        let one = Lanes::ONE;
        let [a, b, c] = self.corners;
        let (n_ab, n_bc, n_ca) = (a.cross(b), b.cross(c), c.cross(a));
        let degenerate =
            n_ab.dot(n_ab).simd_eq(zero) | n_bc.dot(n_bc).simd_eq(zero) | n_ca.dot(n_ca).simd_eq(zero);
        let (n_ab, n_bc, n_ca) = (n_ab.normalize(), n_bc.normalize(), n_ca.normalize());
        let alpha = angle_between(n_ab, -n_ca);
        let beta = angle_between(n_bc, -n_ab);
        let gamma = angle_between(n_ca, -n_bc);
        let pi = Lanes::splat(PI);
        let sub_area_pi = pi + u[0] * (alpha + beta + gamma - pi);
        let (sin_alpha, cos_alpha) = alpha.sin_cos();
        let (sin_ap, cos_ap) = sub_area_pi.sin_cos();
        let sin_phi = sin_ap * cos_alpha - cos_ap * sin_alpha;
        let cos_phi = cos_ap * cos_alpha + sin_ap * sin_alpha;
        let k1 = cos_phi + cos_alpha;
        let k2 = sin_phi - sin_alpha * a.dot(b);
        let cos_bp =
            (k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha);
        let finite = cos_bp.is_finite();
        let cos_bp = clamp(cos_bp, -one, one);
        let sin_bp = max(one - cos_bp * cos_bp, zero).sqrt();
        let cp = a.scale(cos_bp) + orthogonal(c, a).scale(sin_bp);
        let cos_theta = one - u[1] * (one - cp.dot(b));
        let sin_theta = max(one - cos_theta * cos_theta, zero).sqrt();
        let w = b.scale(cos_theta) + orthogonal(cp, b).scale(sin_theta);
        let [v0, v1, v2] = t.v;
        let (e1, e2) = (v1 - v0, v2 - v0);
        let s1 = w.cross(e2);
        let divisor = s1.dot(e1);
        let s = p_ref - v0;
        let b1 = clamp(s.dot(s1) / divisor, zero, one);
        let b2 = clamp(w.dot(s.cross(e1)) / divisor, zero, one);
        let sum = b1 + b2;
        let over = sum.simd_gt(one);
        let b = [select(over, b1 / sum, b1), select(over, b2 / sum, b2)];
        (b, !degenerate & finite & !divisor.simd_eq(zero))
    }
}

/// `spherical::angle_between`.
#[inline(always)]
fn angle_between(a: V3, b: V3) -> Lanes {
    let two = Lanes::splat(2.0);
    let obtuse = a.dot(b).simd_lt(Lanes::ZERO);
    select(obtuse, Lanes::splat(PI) - two * min1(a + b).asin(), two * min1(b - a).asin())
}

/// `(v.length() / 2).min(1)`.
#[inline(always)]
fn min1(v: V3) -> Lanes {
    (v.dot(v).sqrt() / Lanes::splat(2.0)).min(Lanes::ONE)
}

/// `spherical::orthogonal`.
#[inline(always)]
fn orthogonal(v: V3, w: V3) -> V3 {
    (v - w.scale(v.dot(w))).normalize_or_zero()
}

/// `spherical::sample_linear`.
#[inline(always)]
fn sample_linear(u: Lanes, a: Lanes, b: Lanes) -> Lanes {
    let x = u * (a + b) / (a + max(a * a + u * (b * b - a * a), Lanes::ZERO).sqrt());
    let x = x.min(Lanes::splat(1.0 - f32::EPSILON / 2.0));
    select(u.simd_eq(Lanes::ZERO) & a.simd_eq(Lanes::ZERO), Lanes::ZERO, x)
}

/// `spherical::bilinear_pdf`.
#[inline(always)]
fn bilinear_pdf(p: [Lanes; 2], w: [Lanes; 4]) -> Lanes {
    let (zero, one) = (Lanes::ZERO, Lanes::ONE);
    let inside = |x: Lanes| x.simd_ge(zero) & x.simd_le(one);
    let sum = w[0] + w[1] + w[2] + w[3];
    let [x, y] = p;
    let pdf = Lanes::splat(4.0)
        * ((one - x) * (one - y) * w[0] + x * (one - y) * w[1] + (one - x) * y * w[2] + x * y * w[3])
        / sum;
    select(inside(x) & inside(y), select(sum.simd_eq(zero), one, pdf), zero)
}
