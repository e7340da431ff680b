//! The BSDFs lanes evaluate, sample and give pdfs for: Lambert's, and glTF's metallic-roughness
//! mixture without transmission or coat (a GGX conductor weighted by metallic beside the plastic
//! lobe: GGX specular with KHR_materials_specular's Fresnel over a Fresnel-coupled Lambertian).
//! Each is `materials::Bsdf` for its kind, lane by lane, in the scalar code's order of operations
//! (`Mixture::{eval, pdf, sample}`, `Conductor`, `Plastic`, `lambert_*`).

use super::ggx::{Ggx, clamp, cosine_hemisphere, half_vector, max, reflect, schlick, schlick_scalar};
use super::v3::{Mask, V3, max_element, select};
use super::{Lanes, WIDTH};
use crate::materials::fresnel::f0_from_ior;
use crate::materials::microfacet::SMOOTH_ALPHA;
use crate::materials::{Bsdf, ShadingParams};
use crate::sampling::ONE_MINUS_EPSILON;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// A direction each lane's BSDF drew, in the local frame.
pub struct SampleLanes {
    /// The direction.
    pub wi: V3,
    /// The BSDF towards it (the whole mixture).
    pub f: V3,
    /// The mixture's pdf of it.
    pub pdf: Lanes,
    /// Lanes that drew one (`Bsdf::sample` returned `Some`).
    pub drawn: Mask,
}

/// A BSDF per lane.
pub trait LaneBsdf {
    /// `Bsdf::eval`: f(wo, wi) without the cosine.
    fn eval(&self, wo: V3, wi: V3) -> V3;
    /// `Bsdf::pdf`.
    fn pdf(&self, wo: V3, wi: V3) -> Lanes;
    /// `Bsdf::sample_with`: a direction from the lobe `u_lobe` picks and the point `u`.
    fn sample(&self, wo: V3, u_lobe: Lanes, u: [Lanes; 2]) -> SampleLanes;
    /// `Bsdf::albedo_hint` of lane `i` (the feature images' albedo).
    fn albedo_hint(&self, i: usize) -> Vec3;
}

/// Lambert's BSDF, an albedo per lane.
pub struct Lambert {
    /// The albedo (the base colour clamped to [0, 1]).
    pub albedo: V3,
}

impl LaneBsdf for Lambert {
    #[inline(always)]
    fn eval(&self, wo: V3, wi: V3) -> V3 {
        let same_side = (wo.z * wi.z).simd_gt(Lanes::ZERO);
        V3::select(same_side, self.albedo.scale(Lanes::splat(FRAC_1_PI)), V3::splat(0.0))
    }

    #[inline(always)]
    fn pdf(&self, wo: V3, wi: V3) -> Lanes {
        let same_side = (wo.z * wi.z).simd_gt(Lanes::ZERO);
        select(same_side, wi.z.abs() * Lanes::splat(FRAC_1_PI), Lanes::ZERO)
    }

    #[inline(always)]
    fn sample(&self, wo: V3, _u_lobe: Lanes, u: [Lanes; 2]) -> SampleLanes {
        let usable =
            !wo.z.simd_eq(Lanes::ZERO) & wo.is_finite() & max_element(self.albedo).simd_gt(Lanes::ZERO);
        let hemisphere = cosine_hemisphere(u);
        let wi = V3 { z: select(wo.z.simd_lt(Lanes::ZERO), -hemisphere.z, hemisphere.z), ..hemisphere };
        let pdf = wi.z.abs() * Lanes::splat(FRAC_1_PI);
        let f = self.albedo.scale(Lanes::splat(FRAC_1_PI));
        SampleLanes { wi, f, pdf, drawn: usable & pdf.simd_gt(Lanes::ZERO) }
    }

    #[inline(always)]
    fn albedo_hint(&self, i: usize) -> Vec3 {
        self.albedo.lanes()[i]
    }
}

/// The metallic-roughness mixture without transmission or coat: `Mixture` whose dielectric weight
/// is zero, its lobes rough. The constants are made lane by lane by the scalar code
/// ([`MetalRough::lane`]), the rest in lanes.
pub struct MetalRough {
    /// The conductor's weight (metallic) and the plastic's (1 − metallic).
    w_conductor: Lanes,
    w_plastic: Lanes,
    /// The base colour: the conductor's F0, the plastic's diffuse albedo.
    base: V3,
    /// Its largest channel.
    base_max: Lanes,
    /// The plastic's specular F0 (KHR_materials_specular) and its largest channel; its F90.
    f0: V3,
    f0_max: Lanes,
    f90: Lanes,
    /// Both lobes' roughness.
    ggx: Ggx,
    /// Each lane's parameters, for the feature images' albedo (`Bsdf::albedo_hint`).
    params: [ShadingParams; WIDTH],
}

/// One lane's constants of [`MetalRough`].
#[derive(Clone, Copy)]
pub struct MetalRoughLane {
    w_conductor: f32,
    w_plastic: f32,
    base: Vec3,
    f0: Vec3,
    f90: f32,
    alpha: f32,
    params: ShadingParams,
}

impl MetalRoughLane {
    /// A placeholder for an unused lane.
    pub const EMPTY: Self = Self {
        w_conductor: 0.0,
        w_plastic: 1.0,
        base: Vec3::ZERO,
        f0: Vec3::ZERO,
        f90: 1.0,
        alpha: 1.0,
        params: PLACEHOLDER_PARAMS,
    };
}

/// The parameters of an unused lane (any whose constants are finite will do).
pub const PLACEHOLDER_PARAMS: ShadingParams = ShadingParams { metallic: 0.0, ..ShadingParams::GLTF_DEFAULT };

impl MetalRough {
    /// Lane constants from a hit's parameters, as `Mixture::new` makes them; `None` where the scalar
    /// kernel must shade the vertex: a lobe smooth enough to be a delta (mirror reflection), or
    /// parameters for which `Bsdf::new` makes a Lambertian (metallic and specular both zero), or
    /// transmission or a coat after textures.
    pub fn lane(p: &ShadingParams) -> Option<MetalRoughLane> {
        let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        if unit(p.clearcoat) > 0.0 {
            return None;
        }
        Self::lane_under_coat(p)
    }

    /// [`MetalRough::lane`] for the base below a coat (`coat.rs`), whatever the coat's weight.
    pub fn lane_under_coat(p: &ShadingParams) -> Option<MetalRoughLane> {
        let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        let (metallic, transmission, specular) = (unit(p.metallic), unit(p.transmission), unit(p.specular));
        if transmission != 0.0 || (metallic == 0.0 && specular == 0.0) {
            return None;
        }
        let ggx = crate::materials::Ggx::from_roughness(p.roughness);
        if ggx.alpha() < SMOOTH_ALPHA {
            return None;
        }
        let ior = if p.ior.is_finite() && p.ior > 0.0 { p.ior } else { 1.5 };
        let f0 = (f0_from_ior(ior) * p.specular_color.max(Vec3::ZERO)).min(Vec3::ONE) * specular;
        Some(MetalRoughLane {
            w_conductor: metallic,
            w_plastic: (1.0 - metallic) * (1.0 - transmission),
            base: p.base_color.max(Vec3::ZERO).min(Vec3::ONE),
            f0,
            f90: specular,
            alpha: ggx.alpha(),
            params: *p,
        })
    }

    /// The mixtures of a group's lanes.
    pub fn new(lanes: &[MetalRoughLane; WIDTH]) -> Self {
        let f = |g: &dyn Fn(&MetalRoughLane) -> f32| Lanes::new(std::array::from_fn(|i| g(&lanes[i])));
        let base = V3::gather(|i| lanes[i].base);
        let f0 = V3::gather(|i| lanes[i].f0);
        Self {
            w_conductor: f(&|l| l.w_conductor),
            w_plastic: f(&|l| l.w_plastic),
            base_max: max_element(base),
            base,
            f0_max: max_element(f0),
            f0,
            f90: f(&|l| l.f90),
            ggx: Ggx { alpha: f(&|l| l.alpha) },
            params: std::array::from_fn(|i| lanes[i].params),
        }
    }

    /// `Conductor::selection_weight`.
    #[inline(always)]
    fn conductor_weight(&self, wo: V3) -> Lanes {
        max(max_element(schlick(self.base, Lanes::ONE, wo.z)), Lanes::splat(0.1))
    }

    /// `Plastic::lobe_weights` for |cos θo| = `cos_o`.
    #[inline(always)]
    fn plastic_weights(&self, cos_o: Lanes) -> (Lanes, Lanes) {
        let f = schlick_scalar(self.f0_max, self.f90, cos_o);
        let ws = select(self.f90.simd_gt(Lanes::ZERO), max(f, Lanes::splat(0.05) * self.f90), Lanes::ZERO);
        (ws, (Lanes::ONE - f) * self.base_max)
    }

    /// `Mixture::lobe_probabilities` (the dielectric's is zero): the conductor's and the plastic's.
    #[inline(always)]
    fn probabilities(&self, wo: V3) -> (Lanes, Lanes) {
        let (ws, wd) = self.plastic_weights(wo.z.abs());
        let w0 = self.w_conductor * self.conductor_weight(wo);
        let w1 = self.w_plastic * (ws + wd);
        // The dielectric's weight is 0 · 1.
        let sum = Lanes::ZERO + w0 + w1 + Lanes::ZERO;
        let usable = sum.simd_gt(Lanes::ZERO) & sum.is_finite();
        (select(usable, w0 / sum, Lanes::ZERO), select(usable, w1 / sum, Lanes::ZERO))
    }

    /// `Conductor::eval` past its delta test, for a pair already above the surface.
    #[inline(always)]
    fn conductor_f(&self, wo: V3, wi: V3, wm: V3) -> V3 {
        let f = schlick(self.base, Lanes::ONE, wo.dot(wm));
        f.scale(self.ggx.d(wm) * self.ggx.g(wo, wi) / (Lanes::splat(4.0) * wo.z * wi.z))
    }

    /// `Plastic::specular_f` of a rough lobe.
    #[inline(always)]
    fn specular_f(&self, wo: V3, wi: V3, wm: V3) -> V3 {
        let f = schlick(self.f0, self.f90, wo.dot(wm));
        let specular = f.scale(self.ggx.d(wm) * self.ggx.g(wo, wi) / (Lanes::splat(4.0) * wo.z * wi.z));
        V3::select(self.f90.simd_eq(Lanes::ZERO), V3::splat(0.0), specular)
    }

    /// `Plastic::diffuse_f`.
    #[inline(always)]
    fn diffuse_f(&self, wo: V3, wi: V3) -> V3 {
        let couple = |cos: Lanes| Lanes::ONE - schlick_scalar(self.f0_max, self.f90, cos);
        self.base.scale(Lanes::splat(FRAC_1_PI) * couple(wo.z) * couple(wi.z))
    }

    /// `Plastic::mixture_pdf` of a rough lobe.
    #[inline(always)]
    fn plastic_pdf(&self, wo: V3, wi: V3, wm: V3) -> Lanes {
        let (ws, wd) = self.plastic_weights(wo.z);
        let total = ws + wd;
        let spec = self.ggx.d_visible(wo, wm) / (Lanes::splat(4.0) * wo.dot(wm));
        let pdf = (ws * spec + wd * wi.z * Lanes::splat(FRAC_1_PI)) / total;
        select(total.simd_le(Lanes::ZERO), Lanes::ZERO, pdf)
    }

    /// Each lobe's f and pdf at (wo, wi) in the caller's frame (`to_upper` applied here).
    #[inline(always)]
    fn lobes(&self, wo: V3, wi: V3) -> [(V3, Lanes); 2] {
        let (wo, wi) = to_upper(wo, wi);
        let (wm, exists) = half_vector(wo, wi);
        let conductor_f = V3::select(exists, self.conductor_f(wo, wi, wm), V3::splat(0.0));
        let conductor_pdf =
            select(exists, self.ggx.d_visible(wo, wm) / (Lanes::splat(4.0) * wo.dot(wm)), Lanes::ZERO);
        let plastic_f =
            V3::select(exists, self.specular_f(wo, wi, wm) + self.diffuse_f(wo, wi), V3::splat(0.0));
        let plastic_pdf = select(exists, self.plastic_pdf(wo, wi, wm), Lanes::ZERO);
        [(conductor_f, conductor_pdf), (plastic_f, plastic_pdf)]
    }
}

/// `materials::to_upper`: both directions mirrored through the surface where `wo` is below it.
#[inline(always)]
pub(super) fn to_upper(wo: V3, wi: V3) -> (V3, V3) {
    let below = wo.z.simd_lt(Lanes::ZERO);
    let flip = |v: V3| V3 { z: select(below, -v.z, v.z), ..v };
    (flip(wo), flip(wi))
}

/// `acc + term` where `keep`, else `acc` (a lobe the mixture skips adds nothing, not even −0).
#[inline(always)]
fn add_if(keep: Mask, acc: V3, term: V3) -> V3 {
    V3::select(keep, acc + term, acc)
}

impl LaneBsdf for MetalRough {
    #[inline(always)]
    fn eval(&self, wo: V3, wi: V3) -> V3 {
        let [(conductor, _), (plastic, _)] = self.lobes(wo, wi);
        let zero = Lanes::ZERO;
        let f = add_if(self.w_conductor.simd_gt(zero), V3::splat(0.0), conductor.scale(self.w_conductor));
        add_if(self.w_plastic.simd_gt(zero), f, plastic.scale(self.w_plastic))
    }

    #[inline(always)]
    fn pdf(&self, wo: V3, wi: V3) -> Lanes {
        let [(_, conductor), (_, plastic)] = self.lobes(wo, wi);
        let (p0, p1) = self.probabilities(wo);
        let zero = Lanes::ZERO;
        let pdf = select(p0.simd_gt(zero), zero + p0 * conductor, zero);
        select(p1.simd_gt(zero), pdf + p1 * plastic, pdf)
    }

    #[inline(always)]
    fn sample(&self, wo: V3, u_lobe: Lanes, u: [Lanes; 2]) -> SampleLanes {
        let zero = Lanes::ZERO;
        let usable = !wo.z.simd_eq(zero) & wo.is_finite();
        let (p0, p1) = self.probabilities(wo);
        // The lobe: the conductor where its probability covers u_lobe, else the plastic (the
        // dielectric's is zero, so nothing is drawn past both).
        let conductor = !p0.simd_eq(zero) & u_lobe.simd_lt(zero + p0);
        let cdf = select(conductor, zero, zero + p0);
        let plastic = !conductor & !p1.simd_eq(zero) & u_lobe.simd_lt(cdf + p1);
        let p = select(conductor, p0, p1);
        let uc = clamp((u_lobe - cdf) / p, zero, Lanes::splat(ONE_MINUS_EPSILON));

        // Either lobe's sample in the upper frame.
        let below = wo.z.simd_lt(zero);
        let (up, _) = to_upper(wo, V3::splat(0.0));
        let (ws, wd) = self.plastic_weights(up.z);
        let specular = conductor | (uc * (ws + wd)).simd_lt(ws);
        let sampled_wm = self.ggx.sample_wm(up, u);
        let wi_up = V3::select(specular, reflect(up, sampled_wm), cosine_hemisphere(u));
        // The conductor's: its checks, pdf and f at the normal it drew.
        let cos_om = up.dot(sampled_wm);
        let conductor_ok = !wi_up.z.simd_le(zero) & !cos_om.simd_le(zero);
        let conductor_pdf = self.ggx.d_visible(up, sampled_wm) / (Lanes::splat(4.0) * cos_om);
        let conductor_f = self.conductor_f(up, wi_up, sampled_wm);
        // The plastic's: the whole lobe's f and pdf at the half vector.
        let (wm, exists) = half_vector(up, wi_up);
        let plastic_ok = !(ws + wd).simd_le(zero) & exists;
        let plastic_pdf = self.plastic_pdf(up, wi_up, wm);
        let plastic_f = self.specular_f(up, wi_up, wm) + self.diffuse_f(up, wi_up);
        let plastic_ok = plastic_ok & plastic_pdf.simd_gt(zero);
        let wi = V3 { z: select(below, -wi_up.z, wi_up.z), ..wi_up };

        // The picked lobe weighed, then the other lobe added (Mixture::base_sample).
        let f = V3::select(conductor, conductor_f.scale(self.w_conductor), plastic_f.scale(self.w_plastic));
        let pdf = select(conductor, conductor_pdf, plastic_pdf) * p;
        let [(other_conductor, other_conductor_pdf), (other_plastic, other_plastic_pdf)] = self.lobes(wo, wi);
        let add_plastic = conductor & p1.simd_gt(zero);
        let add_conductor = !conductor & p0.simd_gt(zero);
        let f = add_if(add_plastic, f, other_plastic.scale(self.w_plastic));
        let f = add_if(add_conductor, f, other_conductor.scale(self.w_conductor));
        let pdf = select(add_plastic, pdf + p1 * other_plastic_pdf, pdf);
        let pdf = select(add_conductor, pdf + p0 * other_conductor_pdf, pdf);

        let lobe_ok = select(conductor, conductor_ok.to_lanes(), plastic_ok.to_lanes()).simd_ne(zero);
        let finite = pdf.simd_gt(zero) & pdf.is_finite() & f.is_finite();
        let drawn = usable & (conductor | plastic) & lobe_ok & finite;
        SampleLanes { wi, f, pdf, drawn }
    }

    fn albedo_hint(&self, i: usize) -> Vec3 {
        Bsdf::new(&self.params[i]).albedo_hint()
    }
}

/// A mask as lanes (all bits set where true), to select between masks.
trait ToLanes {
    fn to_lanes(self) -> Lanes;
}

impl ToLanes for Mask {
    #[inline(always)]
    fn to_lanes(self) -> Lanes {
        self
    }
}
