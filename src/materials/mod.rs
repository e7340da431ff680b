//! BSDFs of the glTF metallic-roughness model as one per-hit mixture.
//!
//! `f = metallic · conductor + (1 - metallic) · [(1 - transmission) · plastic + transmission · dielectric]`
//! where every lobe shares the GGX roughness alpha = roughness² ([`microfacet::Ggx`]):
//!
//! | lobe | file | model |
//! |---|---|---|
//! | conductor | `conductor.rs` | GGX, Schlick F0 = base colour, delta mirror when alpha < 1e-3 |
//! | plastic (glTF dielectric base) | `plastic.rs` | GGX specular with KHR_materials_specular Schlick Fresnel over a Fresnel-coupled Lambertian |
//! | dielectric (transmission) | `dielectric.rs` | exact Fresnel, smooth (delta) or rough (Walter et al. 2007) |
//!
//! Conventions follow pbrt-v4: directions are in the local shading frame (z = shading normal), both point
//! away from the surface, `eval` excludes the cosine, and delta lobes are only reached through `sample`.

pub mod clearcoat;
pub mod conductor;
pub mod dielectric;
pub mod fresnel;
pub mod microfacet;
pub mod plastic;

pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use microfacet::Ggx;
pub use plastic::Plastic;

use crate::sampling::ONE_MINUS_EPSILON;
use crate::sampling::warp::cosine_hemisphere;
use fresnel::f0_from_ior;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Resolved parameters at a hit point (textures already looked up). glTF metallic-roughness semantics.
#[derive(Clone, Copy, Debug)]
pub struct ShadingParams {
    /// Linear RGB base colour: diffuse albedo, conductor F0 and transmission tint.
    pub base_color: Vec3,
    /// Conductor fraction in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]; GGX alpha = roughness².
    pub roughness: f32,
    /// Transmission fraction of the dielectric part in [0, 1] (KHR_materials_transmission).
    pub transmission: f32,
    /// Index of refraction of the inside (KHR_materials_ior, default 1.5); the outside is vacuum.
    pub ior: f32,
    /// Specular factor of the dielectric base (KHR_materials_specular); 0 gives a pure Lambertian base.
    pub specular: f32,
    /// Specular colour of the dielectric base (KHR_materials_specular).
    pub specular_color: Vec3,
    /// Clear coat weight in [0, 1] (KHR_materials_clearcoat).
    pub clearcoat: f32,
    /// Perceptual roughness of the coat.
    pub clearcoat_roughness: f32,
    /// Transmission through a thin-walled sheet (glTF: no KHR_materials_volume, or thickness 0)
    /// rather than into a solid.
    pub thin_walled: bool,
}

/// Which quantity a path carries; it matters only for refraction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera paths: transmitted radiance is scaled by 1 / eta² (pbrt-v4 `TransportMode::Radiance`).
    Radiance,
    /// Light paths (photons): no 1 / eta² scaling.
    Importance,
}

/// A direction drawn by [`Bsdf::sample`].
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction, local frame, unit length.
    pub wi: Vec3,
    /// BSDF value: the non-delta mixture for rough samples, the delta lobe's weight for specular ones.
    pub f: Vec3,
    /// Solid-angle mixture pdf for rough samples; the discrete probability for specular ones.
    pub pdf: f32,
    /// True when `wi` came from a Dirac delta lobe.
    pub is_specular: bool,
    /// True when `wi` is on the other side of the surface from `wo`.
    pub is_transmission: bool,
    /// Relative IOR crossed along `wi` (pbrt-v4 `etap`); 1 for reflection.
    pub eta: f32,
}

/// Number of lobes in the mixture: conductor, plastic, dielectric.
const LOBES: usize = 3;

/// The BSDF at one hit: small, `Copy`, built per hit without allocation. Most surfaces of most
/// scenes are plain Lambertian (glTF's dielectric base with no specular layer and no coat): they are
/// a variant of their own, built from the base colour alone and evaluated without the mixture (in a
/// diffuse Cornell box, building the mixture was 2.6% of a `pt` profile).
#[derive(Clone, Copy, Debug)]
pub struct Bsdf(Repr);

#[derive(Clone, Copy, Debug)]
enum Repr {
    /// Albedo (base colour clamped to [0, 1]); reflects on both sides.
    Lambert(Vec3),
    /// Everything else.
    Mixture(Mixture),
}

/// The full mixture of conductor, plastic and dielectric lobes under an optional coat.
#[derive(Clone, Copy, Debug)]
struct Mixture {
    conductor: Conductor,
    plastic: Plastic,
    dielectric: Dielectric,
    /// Mixture coefficients of conductor, plastic and dielectric; they sum to one.
    weights: [f32; LOBES],
    /// Albedo when the whole BSDF is Lambertian (plastic without its specular layer), the common case
    /// in diffuse scenes: it skips the mixture's lobe selection and Fresnel coupling entirely.
    lambert: Option<Vec3>,
    /// A clear coat over all of it (`clearcoat.rs`).
    coat: Option<clearcoat::Coat>,
}

impl Bsdf {
    /// Build the BSDF from glTF parameters (clamped to their valid ranges; a non-positive or
    /// non-finite IOR falls back to 1.5).
    #[inline]
    pub fn new(p: &ShadingParams) -> Self {
        let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        let (metallic, transmission, specular) = (unit(p.metallic), unit(p.transmission), unit(p.specular));
        let coated = unit(p.clearcoat) > 0.0;
        if metallic == 0.0 && transmission == 0.0 && specular == 0.0 && !coated {
            return Self(Repr::Lambert(p.base_color.max(Vec3::ZERO).min(Vec3::ONE)));
        }
        Self(Repr::Mixture(Mixture::new(p)))
    }

    /// Give the clear coat its own shading normal `n` (unit, in this BSDF's local frame).
    pub fn set_coat_normal(&mut self, n: Vec3) {
        if let Repr::Mixture(m) = &mut self.0 {
            m.set_coat_normal(n);
        }
    }

    /// True when every lobe is a Dirac delta (perfect mirror, smooth glass): no light sampling there.
    #[inline]
    pub fn is_delta(&self) -> bool {
        match &self.0 {
            Repr::Lambert(_) => false,
            Repr::Mixture(m) => m.is_delta(),
        }
    }

    /// f(wo, wi) WITHOUT the cosine, local shading frame (z = shading normal), both vectors unit and
    /// pointing away from the surface. Delta lobes contribute 0 here.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match &self.0 {
            Repr::Lambert(albedo) => lambert_eval(*albedo, wo, wi),
            Repr::Mixture(m) => m.eval(wo, wi, mode),
        }
    }

    /// Solid-angle pdf of sample() producing wi (non-delta part only; delta lobes 0).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match &self.0 {
            Repr::Lambert(_) => lambert_pdf(wo, wi),
            Repr::Mixture(m) => m.pdf(wo, wi),
        }
    }

    /// Sample wi. u_lobe picks the lobe, u the direction. f is the full BSDF value (sum over non-delta
    /// lobes, or the delta lobe's weight for specular samples), pdf the full mixture pdf (for delta
    /// samples: the discrete probability of that lobe, pbrt-v4 convention so f·|cos|/pdf is the weight).
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        self.sample_with(wo, || u_lobe, u, mode)
    }

    /// [`Bsdf::sample`] drawing the lobe's number only when there is a lobe to choose (a Lambertian
    /// surface has one): a sampler's draw costs more than the Lambertian sample itself.
    #[inline]
    pub fn sample_with(
        &self,
        wo: Vec3,
        u_lobe: impl FnOnce() -> f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        match &self.0 {
            Repr::Lambert(albedo) => lambert_sample(*albedo, wo, u),
            Repr::Mixture(m) => m.sample(wo, u_lobe(), u, mode),
        }
    }

    /// The plain Lambertian BSDF of `albedo` (already in [0, 1]), as [`Bsdf::new`] makes it for a
    /// diffuse material: what a kept light vertex rebuilds from the albedo it keeps.
    #[inline]
    pub fn lambert(albedo: Vec3) -> Self {
        Self(Repr::Lambert(albedo))
    }

    /// The albedo of a plain Lambertian BSDF (what lanes of shading take), `None` for any other.
    #[inline]
    pub fn lambert_albedo(&self) -> Option<Vec3> {
        match &self.0 {
            Repr::Lambert(albedo) => Some(*albedo),
            Repr::Mixture(_) => None,
        }
    }

    /// Whether the BSDF is zero for every pair of directions (a black Lambertian): light arriving
    /// there is absorbed and lights nothing.
    #[inline]
    pub fn reflects_nothing(&self) -> bool {
        match &self.0 {
            Repr::Lambert(albedo) => *albedo == Vec3::ZERO,
            Repr::Mixture(m) => m.reflects_nothing(),
        }
    }

    /// Cheap hemispherical-albedo estimate per channel, independent of wo, for Russian roulette of
    /// photons (take its max component as the survival probability); see the mixture's for how each
    /// lobe is estimated.
    #[inline]
    pub fn albedo_hint(&self) -> Vec3 {
        match &self.0 {
            Repr::Lambert(albedo) => *albedo,
            Repr::Mixture(m) => m.albedo_hint(),
        }
    }
}

/// A Lambertian surface's f, reflecting on both sides.
#[inline]
fn lambert_eval(albedo: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z * wi.z > 0.0 { albedo * FRAC_1_PI } else { Vec3::ZERO }
}

/// The cosine-weighted pdf of a Lambertian sample.
#[inline]
fn lambert_pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z * wi.z > 0.0 { wi.z.abs() * FRAC_1_PI } else { 0.0 }
}

/// A cosine-weighted direction on `wo`'s side.
#[inline]
fn lambert_sample(albedo: Vec3, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    if wo.z == 0.0 || !wo.is_finite() || albedo.max_element() <= 0.0 {
        return None;
    }
    let wi = cosine_hemisphere(u);
    let wi = if wo.z < 0.0 { flip_z(wi) } else { wi };
    let pdf = wi.z.abs() * FRAC_1_PI;
    (pdf > 0.0).then(|| reflection_sample(wi, albedo * FRAC_1_PI, pdf, false, false))
}

impl Mixture {
    /// Build the mixture from glTF parameters (clamped to their valid ranges; a non-positive or non-finite
    /// IOR falls back to 1.5).
    fn new(p: &ShadingParams) -> Self {
        let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        let (metallic, transmission, specular) = (unit(p.metallic), unit(p.transmission), unit(p.specular));
        let base = p.base_color.max(Vec3::ZERO).min(Vec3::ONE);
        let ior = if p.ior.is_finite() && p.ior > 0.0 { p.ior } else { 1.5 };
        let ggx = Ggx::from_roughness(p.roughness);
        // KHR_materials_specular: F0 = min(F0(ior) · specular_colour, 1) · specular, F90 = specular.
        let spec_f0 = (f0_from_ior(ior) * p.specular_color.max(Vec3::ZERO)).min(Vec3::ONE) * specular;
        let weights = [metallic, (1.0 - metallic) * (1.0 - transmission), (1.0 - metallic) * transmission];
        let lambert = (weights[1] == 1.0 && specular == 0.0).then_some(base);
        Self {
            conductor: Conductor::new(base, ggx),
            plastic: Plastic::new(base, spec_f0, specular, ggx),
            dielectric: if p.thin_walled {
                Dielectric::thin_walled(ior, base, ggx)
            } else {
                Dielectric::new(ior, base, ggx)
            },
            weights,
            lambert,
            coat: clearcoat::Coat::new(p.clearcoat, p.clearcoat_roughness),
        }
    }

    /// Give the clear coat its own shading normal `n` (unit, in this BSDF's local frame).
    pub fn set_coat_normal(&mut self, n: Vec3) {
        if let Some(coat) = &mut self.coat {
            coat.set_normal(n);
        }
    }

    /// True when every lobe is a Dirac delta (perfect mirror, smooth glass): no light sampling there.
    pub fn is_delta(&self) -> bool {
        if self.coat.is_some_and(|c| !c.is_delta()) {
            return false;
        }
        let delta = [self.conductor.is_delta(), self.plastic.is_delta(), self.dielectric.is_delta()];
        (0..LOBES).all(|k| self.weights[k] == 0.0 || delta[k])
    }

    /// f(wo, wi) WITHOUT the cosine, local shading frame (z = shading normal), both vectors unit and pointing
    /// away from the surface. Delta lobes contribute 0 here.
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match &self.coat {
            None => self.base_eval(wo, wi, mode),
            Some(c) => c.transmittance(wo, wi) * self.base_eval(wo, wi, mode) + Vec3::splat(c.eval(wo, wi)),
        }
    }

    /// Solid-angle pdf of sample() producing wi (non-delta part only; delta lobes 0).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match &self.coat {
            None => self.base_pdf(wo, wi),
            Some(c) => {
                let p = c.selection_probability(wo);
                p * c.pdf(wo, wi) + (1.0 - p) * self.base_pdf(wo, wi)
            }
        }
    }

    /// Sample wi. u_lobe picks the lobe, u the direction. f is the full BSDF value (sum over non-delta lobes, or
    /// the delta lobe's weight for specular samples), pdf the full mixture pdf (for delta samples: the discrete
    /// probability of that lobe, pbrt-v4 convention so f·|cos|/pdf is the weight).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let Some(c) = &self.coat else { return self.base_sample(wo, u_lobe, u, mode) };
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        let p = c.selection_probability(wo);
        let s = if u_lobe < p {
            let mut s = c.sample(wo, u)?;
            s.pdf *= p;
            if !s.is_specular {
                s.f += c.transmittance(wo, s.wi) * self.base_eval(wo, s.wi, mode);
                s.pdf += (1.0 - p) * self.base_pdf(wo, s.wi);
            }
            s
        } else {
            let u_base = ((u_lobe - p) / (1.0 - p)).clamp(0.0, ONE_MINUS_EPSILON);
            let mut s = self.base_sample(wo, u_base, u, mode)?;
            s.f *= c.transmittance(wo, s.wi);
            s.pdf *= 1.0 - p;
            if !s.is_specular {
                s.f += Vec3::splat(c.eval(wo, s.wi));
                s.pdf += p * c.pdf(wo, s.wi);
            }
            s
        };
        (s.pdf > 0.0 && s.pdf.is_finite() && s.f.is_finite()).then_some(s)
    }

    /// The base without the coat: [`Bsdf::eval`]'s mixture.
    fn base_eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        if let Some(albedo) = self.lambert {
            return lambert_eval(albedo, wo, wi);
        }
        (0..LOBES)
            .filter(|&k| self.weights[k] > 0.0)
            .map(|k| self.weights[k] * self.lobe_eval(k, wo, wi, mode))
            .sum()
    }

    fn base_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.lambert.is_some() {
            return lambert_pdf(wo, wi);
        }
        let p = self.lobe_probabilities(wo);
        (0..LOBES).filter(|&k| p[k] > 0.0).map(|k| p[k] * self.lobe_pdf(k, wo, wi)).sum()
    }

    fn base_sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        if let Some(albedo) = self.lambert {
            return lambert_sample(albedo, wo, u);
        }
        let p = self.lobe_probabilities(wo);
        // Pick the lobe and reuse the rest of u_lobe inside it (for glass: reflect or refract).
        let mut k = 0;
        let mut cdf = 0.0;
        while k + 1 < LOBES && (p[k] == 0.0 || u_lobe >= cdf + p[k]) {
            cdf += p[k];
            k += 1;
        }
        if p[k] == 0.0 {
            return None;
        }
        let uc = ((u_lobe - cdf) / p[k]).clamp(0.0, ONE_MINUS_EPSILON);
        let mut s = self.lobe_sample(k, wo, uc, u, mode)?;
        s.f *= self.weights[k];
        s.pdf *= p[k];
        if !s.is_specular {
            // The estimator f/pdf must see the whole mixture, not the picked lobe (Veach 1997, §9.2.4).
            for j in (0..LOBES).filter(|&j| j != k && p[j] > 0.0) {
                s.f += self.weights[j] * self.lobe_eval(j, wo, s.wi, mode);
                s.pdf += p[j] * self.lobe_pdf(j, wo, s.wi);
            }
        }
        (s.pdf > 0.0 && s.pdf.is_finite() && s.f.is_finite()).then_some(s)
    }

    /// Whether the BSDF is zero for every pair of directions (a black Lambertian): light arriving
    /// there is absorbed and lights nothing.
    pub fn reflects_nothing(&self) -> bool {
        self.lambert == Some(Vec3::ZERO) && self.coat.is_none()
    }

    /// Cheap hemispherical-albedo estimate per channel, independent of wo, for Russian roulette of photons
    /// (take its max component as the survival probability).
    ///
    /// Each lobe uses its Fresnel average over a cosine-weighted hemisphere, (F0 + (F90 - F0)/21) for
    /// Schlick; the plastic diffuse part is base · (1 - F̄)², and the dielectric is lossless (R + T·tint).
    /// Microfacet shadowing losses are ignored, so this slightly overestimates rough lobes.
    pub fn albedo_hint(&self) -> Vec3 {
        let albedo = self.weights[0] * self.conductor.albedo_hint()
            + self.weights[1] * self.plastic.albedo_hint()
            + self.weights[2] * self.dielectric.albedo_hint();
        let albedo = match &self.coat {
            None => albedo,
            Some(c) => albedo * (1.0 - c.albedo_hint()).powi(2) + Vec3::splat(c.albedo_hint()),
        };
        albedo.min(Vec3::ONE)
    }

    /// Probability of picking each lobe for `wo`: mixture weight × the lobe's reflectance estimate.
    fn lobe_probabilities(&self, wo: Vec3) -> [f32; LOBES] {
        let w = [
            self.weights[0] * self.conductor.selection_weight(wo),
            self.weights[1] * self.plastic.selection_weight(wo),
            self.weights[2] * self.dielectric.selection_weight(wo),
        ];
        let sum: f32 = w.iter().sum();
        if !(sum > 0.0 && sum.is_finite()) {
            return [0.0; LOBES];
        }
        w.map(|x| x / sum)
    }

    fn lobe_eval(&self, k: usize, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match k {
            0 => self.conductor.eval(wo, wi),
            1 => self.plastic.eval(wo, wi),
            _ => self.dielectric.eval(wo, wi, mode),
        }
    }

    fn lobe_pdf(&self, k: usize, wo: Vec3, wi: Vec3) -> f32 {
        match k {
            0 => self.conductor.pdf(wo, wi),
            1 => self.plastic.pdf(wo, wi),
            _ => self.dielectric.pdf(wo, wi),
        }
    }

    fn lobe_sample(&self, k: usize, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        match k {
            0 => self.conductor.sample(wo, u),
            1 => self.plastic.sample(wo, uc, u),
            _ => self.dielectric.sample(wo, uc, u, mode),
        }
    }
}

/// Mirror a direction through the tangent plane (z → -z).
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

/// Map (wo, wi) so that wo is in the upper hemisphere: opaque lobes are two-sided (pbrt-v4), and mirroring
/// both vectors keeps every isotropic quantity unchanged. Returns whether a flip happened.
#[inline]
fn to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
    if wo.z < 0.0 { (flip_z(wo), flip_z(wi), true) } else { (wo, wi, false) }
}

/// A reflection sample in the upper frame, mapped back to wo's side.
#[inline]
fn reflection_sample(wi: Vec3, f: Vec3, pdf: f32, is_specular: bool, flipped: bool) -> BsdfSample {
    let wi = if flipped { flip_z(wi) } else { wi };
    BsdfSample { wi, f, pdf, is_specular, is_transmission: false, eta: 1.0 }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::sampling::chi2::{Chi2Config, chi2_test};
    use crate::sampling::warp::uniform_sphere;
    use glam::DVec3;

    /// Samples per chi-square test.
    const CHI2_SAMPLES: u32 = 100_000;

    /// Shading parameters with a white specular colour.
    pub(crate) fn params(
        base_color: Vec3,
        metallic: f32,
        roughness: f32,
        transmission: f32,
        ior: f32,
        specular: f32,
    ) -> ShadingParams {
        ShadingParams {
            base_color,
            metallic,
            roughness,
            transmission,
            ior,
            specular,
            specular_color: Vec3::ONE,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            thin_walled: false,
        }
    }

    /// Outgoing directions from normal to grazing incidence, on both sides of the surface.
    pub(crate) fn grazing_directions() -> [Vec3; 6] {
        let at = |cos: f32, phi: f32| {
            let sin = (1.0 - cos * cos).sqrt();
            Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
        };
        [at(1.0, 0.0), at(0.8, 0.3), at(0.3, 2.0), at(0.05, 4.0), at(-0.5, 1.0), at(-0.05, 5.5)]
    }

    fn close(a: Vec3, b: Vec3, relative: f32) -> bool {
        (a - b).abs().max_element() <= relative * a.abs().max_element().max(b.abs().max_element()) + 1e-12
    }

    /// Chi-square test of `sample` against `pdf` for `wo`, plus: the sample's f and pdf equal eval and pdf,
    /// directions are unit, and the transmission flag matches the side of wi.
    pub(crate) fn check_sampling(bsdf: &Bsdf, wo: Vec3, mode: TransportMode, test_count: u32, label: &str) {
        assert!(!bsdf.is_delta(), "{label}: delta BSDFs have no density to test");
        let config = Chi2Config { test_count, ..Default::default() };
        let draw = |i: u32| {
            let s = Sampler::new(17, i, 0);
            bsdf.sample(wo, s.get1d(0), s.get2d(1), mode)
        };
        for i in 0..2_000 {
            let Some(s) = draw(i) else { continue };
            assert!(!s.is_specular, "{label}, wo {wo}: specular sample from a rough BSDF");
            assert!((s.wi.length() - 1.0).abs() < 1e-4, "{label}, wo {wo}: |wi| = {}", s.wi.length());
            assert_eq!(s.is_transmission, s.wi.z * wo.z < 0.0, "{label}, wo {wo}, wi {}", s.wi);
            let pdf = bsdf.pdf(wo, s.wi);
            let f = bsdf.eval(wo, s.wi, mode);
            assert!(
                close(Vec3::splat(s.pdf), Vec3::splat(pdf), 2e-3),
                "{label}, wo {wo}: pdf {} vs {pdf}",
                s.pdf
            );
            assert!(close(s.f, f, 2e-3), "{label}, wo {wo}, wi {}: f {} vs {f}", s.wi, s.f);
        }
        let result = chi2_test(|i| draw(i).map(|s| s.wi), |wi| bsdf.pdf(wo, wi), CHI2_SAMPLES, &config);
        assert!(result.is_ok(), "{label}, wo {wo}: {}", result.unwrap_err());
    }

    /// False for refraction pairs whose microfacet is within ~3° of grazing on either side: near the
    /// critical angle the transmitted cosine is so ill-conditioned in f32 that swapping the arguments
    /// changes 1 - F by more than the reciprocity tests' 1e-4 (the error grows as 1e-7 / cos²).
    pub(crate) fn well_conditioned(wo: Vec3, wi: Vec3, ior: f32) -> bool {
        if wo.z * wi.z >= 0.0 {
            return true;
        }
        let etap = if wo.z > 0.0 { ior } else { 1.0 / ior };
        let wm = (wi * etap + wo).normalize();
        wo.dot(wm).abs() > 0.05 && wi.dot(wm).abs() > 0.05
    }

    /// eval(wo, wi) = eval(wi, wo) for random pairs on one side of the surface (relative 1e-4).
    pub(crate) fn check_reciprocity(bsdf: &Bsdf) {
        for i in 0..2_000 {
            let s = Sampler::new(19, i, 0);
            let (wo, mut wi) = (uniform_sphere(s.get2d(0)), uniform_sphere(s.get2d(2)));
            if wi.z * wo.z < 0.0 {
                wi.z = -wi.z;
            }
            let (a, b) =
                (bsdf.eval(wo, wi, TransportMode::Radiance), bsdf.eval(wi, wo, TransportMode::Radiance));
            assert!(close(a, b, 1e-4), "{bsdf:?}: f({wo}, {wi}) = {a} but f({wi}, {wo}) = {b}");
        }
    }

    /// Monte Carlo hemispherical albedo ∫ f |cos θi| dωi with its standard error, per channel.
    pub(crate) fn albedo(bsdf: &Bsdf, wo: Vec3, mode: TransportMode, n: u32) -> (Vec3, Vec3) {
        // Accumulate in f64: an f32 sum of thousands of terms drifts by more than the tests' tolerance.
        let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..n {
            let s = Sampler::new(23, i, 0);
            if let Some(bs) = bsdf.sample(wo, s.get1d(0), s.get2d(1), mode) {
                let w = (bs.f * bs.wi.z.abs() / bs.pdf).as_dvec3();
                sum += w;
                sum2 += w * w;
            }
        }
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean).max(DVec3::ZERO);
        (mean.as_vec3(), (var / n as f64).powf(0.5).as_vec3())
    }

    /// Rough mixtures of every lobe kind; all non-delta.
    fn mixtures() -> [(&'static str, ShadingParams); 4] {
        let base = Vec3::new(0.8, 0.5, 0.2);
        [
            ("half metal, rough 0.3", params(base, 0.5, 0.3, 0.0, 1.5, 1.0)),
            ("half metal, rough 0.7", params(base, 0.5, 0.7, 0.0, 1.5, 0.5)),
            ("metal, glass, plastic", params(base, 0.3, 0.5, 0.5, 1.5, 1.0)),
            ("half glass, lambert", params(base, 0.0, 0.4, 0.5, 1.33, 0.0)),
        ]
    }

    #[test]
    fn mixed_materials_samples_follow_their_pdf() {
        let wos = grazing_directions();
        let count = (mixtures().len() * wos.len()) as u32;
        for (label, p) in mixtures() {
            for wo in wos {
                check_sampling(&Bsdf::new(&p), wo, TransportMode::Radiance, count, label);
            }
        }
    }

    #[test]
    fn opaque_mixtures_are_reciprocal() {
        for (_, p) in mixtures().into_iter().filter(|(_, p)| p.transmission == 0.0) {
            check_reciprocity(&Bsdf::new(&p));
        }
    }

    #[test]
    fn mixtures_obey_generalized_reciprocity() {
        for (label, p) in mixtures() {
            let bsdf = Bsdf::new(&p);
            for i in 0..1_000 {
                let s = Sampler::new(29, i, 0);
                let (wo, wi) = (uniform_sphere(s.get2d(0)), uniform_sphere(s.get2d(2)));
                if !well_conditioned(wo, wi, p.ior) {
                    continue;
                }
                let a = bsdf.eval(wo, wi, TransportMode::Radiance);
                let b = bsdf.eval(wi, wo, TransportMode::Importance);
                assert!(close(a, b, 1e-4), "{label}: {a} vs {b} for {wo}, {wi}");
            }
        }
    }

    #[test]
    fn white_mixtures_never_scatter_more_than_they_receive() {
        for (label, mut p) in mixtures() {
            p.base_color = Vec3::ONE;
            for roughness in [0.0, 0.1, 0.5, 1.0] {
                p.roughness = roughness;
                let bsdf = Bsdf::new(&p);
                for wo in grazing_directions() {
                    let (mean, se) = albedo(&bsdf, wo, TransportMode::Importance, 10_000);
                    let bound = mean.max_element() - 4.0 * se.max_element();
                    assert!(bound <= 1.0, "{label}, roughness {roughness}, wo {wo}: {mean} ± {se}");
                }
            }
        }
    }

    #[test]
    fn only_all_delta_mixtures_are_delta() {
        let base = Vec3::splat(0.5);
        assert!(Bsdf::new(&params(base, 1.0, 0.0, 0.0, 1.5, 1.0)).is_delta(), "mirror");
        assert!(Bsdf::new(&params(base, 0.0, 0.0, 1.0, 1.5, 1.0)).is_delta(), "glass");
        assert!(Bsdf::new(&params(base, 0.5, 0.01, 1.0, 1.5, 1.0)).is_delta(), "mirror and glass");
        assert!(!Bsdf::new(&params(base, 0.5, 0.0, 0.0, 1.5, 1.0)).is_delta(), "mirror and plastic");
        assert!(!Bsdf::new(&params(base, 1.0, 0.1, 0.0, 1.5, 1.0)).is_delta(), "rough metal");
        assert!(!Bsdf::new(&params(base, 0.0, 0.2, 1.0, 1.5, 1.0)).is_delta(), "rough glass");
    }

    #[test]
    fn samples_are_finite_or_none_for_any_parameters() {
        for i in 0..20_000 {
            let s = Sampler::new(31, i, 0);
            let p = ShadingParams {
                base_color: Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)),
                metallic: (s.get1d(3) * 3.0).floor() / 2.0,
                roughness: [0.0, 0.001, 0.05, 0.3, 1.0][(s.get1d(4) * 5.0) as usize],
                transmission: (s.get1d(5) * 3.0).floor() / 2.0,
                ior: [1.0, 1.5, 2.5, 0.8][(s.get1d(6) * 4.0) as usize],
                specular: (s.get1d(7) * 3.0).floor() / 2.0,
                specular_color: Vec3::ONE,
                clearcoat: 0.0,
                clearcoat_roughness: 0.0,
                thin_walled: false,
            };
            let bsdf = Bsdf::new(&p);
            let mut wo = uniform_sphere(s.get2d(8));
            if i % 7 == 0 {
                wo = Vec3::new(wo.x, wo.y, 1e-7).normalize();
            }
            let mode = if i % 2 == 0 { TransportMode::Radiance } else { TransportMode::Importance };
            if let Some(bs) = bsdf.sample(wo, s.get1d(10), s.get2d(11), mode) {
                assert!(bs.f.is_finite() && bs.f.min_element() >= 0.0, "{p:?}, {wo}: {bs:?}");
                assert!(bs.pdf.is_finite() && bs.pdf > 0.0 && bs.wi.is_finite(), "{p:?}, {wo}: {bs:?}");
                assert!(bs.eta.is_finite() && bs.eta > 0.0);
            }
            let wi = uniform_sphere(s.get2d(13));
            assert!(bsdf.eval(wo, wi, mode).is_finite() && bsdf.pdf(wo, wi).is_finite());
        }
        let bsdf = Bsdf::new(&params(Vec3::ONE, 0.5, 0.5, 0.5, 1.5, 1.0));
        assert!(bsdf.sample(Vec3::X, 0.5, Vec2::splat(0.5), TransportMode::Radiance).is_none());
    }

    #[test]
    fn albedo_hint_matches_simple_cases() {
        let base = Vec3::new(0.8, 0.4, 0.1);
        let lambert = Bsdf::new(&params(base, 0.0, 1.0, 0.0, 1.5, 0.0));
        assert!((lambert.albedo_hint() - base).abs().max_element() < 1e-6);
        let glass = Bsdf::new(&params(Vec3::ONE, 0.0, 0.0, 1.0, 1.5, 1.0));
        assert!((glass.albedo_hint() - Vec3::ONE).abs().max_element() < 1e-6);
        let black = Bsdf::new(&params(Vec3::ZERO, 0.0, 1.0, 0.0, 1.5, 0.0));
        assert_eq!(black.albedo_hint(), Vec3::ZERO);
        assert!(black.sample(Vec3::Z, 0.5, Vec2::splat(0.5), TransportMode::Radiance).is_none());
    }
}
