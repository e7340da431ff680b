//! KHR_materials_clearcoat in lanes: `Mixture`'s coat (`materials::clearcoat`) over a lane BSDF, a
//! rough GGX dielectric reflection of F0 = 0.04 weighted by the coat's factor, the base below it
//! attenuated by the coat's Fresnel on the way in and out. `Mixture::{eval, pdf, sample}` with a
//! coat, lane by lane in their order of operations: both branches of the sample (coat or base) run
//! in every lane and each lane keeps the one its `u_lobe` picked. A smooth coat (a delta lobe) or a
//! coat with a normal map of its own stays with the scalar kernel.

use super::bsdf::{LaneBsdf, SampleLanes, to_upper};
use super::ggx::{Ggx, clamp, half_vector, reflect, schlick, schlick_scalar};
use super::v3::{V3, select};
use super::{Lanes, WIDTH};
use crate::materials::clearcoat::COAT_F0;
use crate::materials::microfacet::SMOOTH_ALPHA;
use crate::materials::{Bsdf, ShadingParams};
use crate::sampling::ONE_MINUS_EPSILON;
use glam::Vec3;

/// One lane's coat: its weight and GGX width.
#[derive(Clone, Copy)]
pub struct CoatLane {
    weight: f32,
    alpha: f32,
}

impl CoatLane {
    /// A placeholder for an unused lane.
    pub const EMPTY: Self = Self { weight: 1.0, alpha: 1.0 };

    /// `Coat::new` for a hit's parameters, `None` where the hit has no coat (its texture made the
    /// weight zero: `Bsdf::new` then makes no coat) or a mirror-smooth one (a delta lobe).
    pub fn new(p: &ShadingParams) -> Option<Self> {
        let weight = if p.clearcoat.is_nan() { 0.0 } else { p.clearcoat.clamp(0.0, 1.0) };
        let alpha = crate::materials::Ggx::from_roughness(p.clearcoat_roughness).alpha();
        (weight > 0.0 && alpha >= SMOOTH_ALPHA).then_some(Self { weight, alpha })
    }
}

/// A coat over `B`, a weight and a width per lane.
pub struct Coated<B> {
    base: B,
    weight: Lanes,
    ggx: Ggx,
    /// Each lane's parameters, for the feature images' albedo (`Bsdf::albedo_hint`).
    params: [ShadingParams; WIDTH],
}

impl<B: LaneBsdf> Coated<B> {
    /// The coats of a group over its base BSDF.
    pub fn new(base: B, coats: &[CoatLane; WIDTH], params: [ShadingParams; WIDTH]) -> Self {
        let lanes = |f: fn(&CoatLane) -> f32| Lanes::new(std::array::from_fn(|i| f(&coats[i])));
        Self { base, weight: lanes(|c| c.weight), ggx: Ggx { alpha: lanes(|c| c.alpha) }, params }
    }

    /// `Coat::fresnel`.
    #[inline(always)]
    fn fresnel(cos: Lanes) -> Lanes {
        schlick_scalar(Lanes::splat(COAT_F0), Lanes::ONE, cos.abs().min(Lanes::ONE))
    }

    /// `Coat::transmittance`.
    #[inline(always)]
    fn transmittance(&self, wo: V3, wi: V3) -> Lanes {
        (Lanes::ONE - self.weight * Self::fresnel(wo.z)) * (Lanes::ONE - self.weight * Self::fresnel(wi.z))
    }

    /// `Coat::selection_probability`.
    #[inline(always)]
    fn selection_probability(&self, wo: V3) -> Lanes {
        clamp(self.weight * Self::fresnel(wo.z), Lanes::splat(0.02), Lanes::splat(0.98))
    }

    /// `Conductor::microfacet_f` of the coat's lobe (F0 = 0.04, F90 = 1), one channel.
    #[inline(always)]
    fn lobe_f(&self, wo: V3, wi: V3, wm: V3) -> Lanes {
        let f = schlick(V3::splat(COAT_F0), Lanes::ONE, wo.dot(wm)).x;
        f * (self.ggx.d(wm) * self.ggx.g(wo, wi) / (Lanes::splat(4.0) * wo.z * wi.z))
    }

    /// `Coat::eval` and `Coat::pdf`.
    #[inline(always)]
    fn coat(&self, wo: V3, wi: V3) -> (Lanes, Lanes) {
        let crosses = (wo.z * wi.z).simd_le(Lanes::ZERO);
        let (wo, wi) = to_upper(wo, wi);
        let (wm, exists) = half_vector(wo, wi);
        let f = select(exists, self.lobe_f(wo, wi, wm), Lanes::ZERO);
        let pdf = select(exists, self.ggx.d_visible(wo, wm) / (Lanes::splat(4.0) * wo.dot(wm)), Lanes::ZERO);
        (select(crosses, Lanes::ZERO, self.weight * f), select(crosses, Lanes::ZERO, pdf))
    }
}

impl<B: LaneBsdf> LaneBsdf for Coated<B> {
    #[inline(always)]
    fn eval(&self, wo: V3, wi: V3) -> V3 {
        let (coat, _) = self.coat(wo, wi);
        self.base.eval(wo, wi).scale(self.transmittance(wo, wi)) + V3 { x: coat, y: coat, z: coat }
    }

    #[inline(always)]
    fn pdf(&self, wo: V3, wi: V3) -> Lanes {
        let p = self.selection_probability(wo);
        let (_, coat) = self.coat(wo, wi);
        p * coat + (Lanes::ONE - p) * self.base.pdf(wo, wi)
    }

    #[inline(always)]
    fn sample(&self, wo: V3, u_lobe: Lanes, u: [Lanes; 2]) -> SampleLanes {
        let zero = Lanes::ZERO;
        let usable = !wo.z.simd_eq(zero) & wo.is_finite();
        let p = self.selection_probability(wo);
        let pick_coat = u_lobe.simd_lt(p);

        // The coat's sample (`Conductor::sample` of its lobe, times its weight), then the base added.
        let below = wo.z.simd_lt(zero);
        let (up, _) = to_upper(wo, V3::splat(0.0));
        let wm = self.ggx.sample_wm(up, u);
        let wi_up = reflect(up, wm);
        let cos_om = up.dot(wm);
        let coat_drawn = !wi_up.z.simd_le(zero) & !cos_om.simd_le(zero);
        let coat_pdf = self.ggx.d_visible(up, wm) / (Lanes::splat(4.0) * cos_om) * p;
        let coat_f = self.lobe_f(up, wi_up, wm) * self.weight;
        let coat_wi = V3 { z: select(below, -wi_up.z, wi_up.z), ..wi_up };
        let coat_f = V3 { x: coat_f, y: coat_f, z: coat_f }
            + self.base.eval(wo, coat_wi).scale(self.transmittance(wo, coat_wi));
        let coat_pdf = coat_pdf + (Lanes::ONE - p) * self.base.pdf(wo, coat_wi);

        // The base's sample, dimmed by the coat, then the coat added.
        let u_base = clamp((u_lobe - p) / (Lanes::ONE - p), zero, Lanes::splat(ONE_MINUS_EPSILON));
        let base = self.base.sample(wo, u_base, u);
        let (coat_at_base, coat_pdf_at_base) = self.coat(wo, base.wi);
        let base_f = base.f.scale(self.transmittance(wo, base.wi))
            + V3 { x: coat_at_base, y: coat_at_base, z: coat_at_base };
        let base_pdf = base.pdf * (Lanes::ONE - p) + p * coat_pdf_at_base;

        let wi = V3::select(pick_coat, coat_wi, base.wi);
        let f = V3::select(pick_coat, coat_f, base_f);
        let pdf = select(pick_coat, coat_pdf, base_pdf);
        let lobe_drawn = select(pick_coat, coat_drawn, base.drawn).simd_ne(zero);
        let finite = pdf.simd_gt(zero) & pdf.is_finite() & f.is_finite();
        SampleLanes { wi, f, pdf, drawn: usable & lobe_drawn & finite }
    }

    fn albedo_hint(&self, i: usize) -> Vec3 {
        Bsdf::new(&self.params[i]).albedo_hint()
    }
}
