//! The mixture of the module's formula: conductor, plastic and dielectric lobes weighted by
//! metallic and transmission, under an optional clear coat. Every hit that is not plain Lambertian
//! gets one; sampling picks a lobe by its weight and reflectance, then scores the whole mixture.

use super::fresnel::f0_from_ior;
use super::{
    BsdfSample, Conductor, Dielectric, Ggx, Plastic, ShadingParams, TransportMode, clearcoat, lambert_eval,
    lambert_pdf, lambert_sample,
};
use crate::sampling::ONE_MINUS_EPSILON;
use glam::{Vec2, Vec3};

/// Number of lobes in the mixture: conductor, plastic, dielectric.
const LOBES: usize = 3;

/// The full mixture of conductor, plastic and dielectric lobes under an optional coat.
#[derive(Clone, Copy, Debug)]
pub(super) struct Mixture {
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

impl Mixture {
    /// Build the mixture from glTF parameters (clamped to their valid ranges; a non-positive or non-finite
    /// IOR falls back to 1.5).
    pub(super) fn new(p: &ShadingParams) -> Self {
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
            dielectric: if p.thin_walled() {
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

#[cfg(test)]
mod tests {
    use crate::materials::tests::{
        albedo, check_reciprocity, check_sampling, close, grazing_directions, params, well_conditioned,
    };
    use crate::materials::{Bsdf, ShadingParams, TransportMode};
    use crate::sampling::Sampler;
    use crate::sampling::warp::uniform_sphere;
    use glam::Vec3;
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
}
