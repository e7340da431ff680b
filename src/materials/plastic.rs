//! glTF's dielectric base: a GGX specular layer (KHR_materials_specular Fresnel) over a Lambertian whose
//! weight is coupled to that Fresnel so the sum is reciprocal and energy conserving.
//!
//! Diffuse coupling: `f_d = base/π · (1 - F̂(cos θo)) · (1 - F̂(cos θi))` with `F̂` the scalar Schlick
//! Fresnel of the largest F0 channel (the product form of Shirley et al. 1997 and Ashikhmin & Shirley
//! 2000, without their 28/23 renormalisation). Why this form:
//! - it is symmetric in (wo, wi), so the sum stays reciprocal, which glTF's `mix(diffuse, specular, F(wo))`
//!   is not;
//! - with `specular = 0` both F0 and F90 are 0, so `F̂ ≡ 0` and the lobe is exactly `base/π` (Lambertian
//!   walls of the test scenes);
//! - the light entering the diffuse layer is at most `1 - F̂(cos θo)` and leaves through `1 - F̂(cos θi)`,
//!   so the diffuse albedo is at most `(1 - F̂(cos θo))(1 - F̄)` and the total never exceeds 1 (checked
//!   numerically by the tests over roughness, IOR, specular and grazing wo).
//!
//! Using the largest channel keeps one scalar per direction and can only lower the diffuse part of the
//! other channels, never push them above 1.

use super::conductor::half_vector;
use super::fresnel::{reflect, schlick, schlick_scalar};
use super::microfacet::Ggx;
use super::{BsdfSample, reflection_sample, to_upper};
use crate::sampling::warp::cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The glTF dielectric base: rough (or smooth, delta) specular plus a Fresnel-coupled Lambertian, two-sided.
#[derive(Clone, Copy, Debug)]
pub struct Plastic {
    base: Vec3,
    f0: Vec3,
    f0_max: f32,
    f90: f32,
    ggx: Ggx,
}

impl Plastic {
    /// Diffuse albedo `base`, specular Schlick `f0` and `f90` (glTF: `min(F0(ior)·specular_colour, 1)·specular`
    /// and `specular`), roughness `ggx`.
    pub fn new(base: Vec3, f0: Vec3, f90: f32, ggx: Ggx) -> Self {
        Self { base, f0, f0_max: f0.max_element(), f90, ggx }
    }

    /// True when the specular layer is smooth and there is no diffuse part.
    pub fn is_delta(&self) -> bool {
        self.ggx.is_smooth() && self.base.max_element() == 0.0
    }

    /// Reflectance estimate used to pick this lobe against the others.
    pub fn selection_weight(&self, wo: Vec3) -> f32 {
        let (ws, wd) = self.lobe_weights(wo.z.abs());
        ws + wd
    }

    /// Hemispherical average: specular F̄ plus the diffuse base · (1 - F̄)² (exact for a cosine-weighted wo).
    pub fn albedo_hint(&self) -> Vec3 {
        let spec = self.f0 + (Vec3::splat(self.f90) - self.f0) / 21.0;
        let f_avg = self.f0_max + (self.f90 - self.f0_max) / 21.0;
        spec + self.base * (1.0 - f_avg) * (1.0 - f_avg)
    }

    /// BSDF value without the cosine: rough specular (if any) plus the coupled diffuse.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (wo, wi, _) = to_upper(wo, wi);
        match half_vector(wo, wi) {
            Some(wm) => self.specular_f(wo, wi, wm) + self.diffuse_f(wo, wi),
            None => Vec3::ZERO,
        }
    }

    /// Solid-angle pdf of [`Plastic::sample`] (the delta specular contributes 0).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi, _) = to_upper(wo, wi);
        match half_vector(wo, wi) {
            Some(wm) => self.mixture_pdf(wo, wi, wm),
            None => 0.0,
        }
    }

    /// Pick specular or diffuse with `uc`, then sample the direction with `u`.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let (wo, _, flipped) = to_upper(wo, Vec3::ZERO);
        let (ws, wd) = self.lobe_weights(wo.z);
        if ws + wd <= 0.0 {
            return None;
        }
        let wi = if uc * (ws + wd) < ws {
            if self.ggx.is_smooth() {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let f = schlick(self.f0, self.f90, wo.z) / wi.z;
                return Some(reflection_sample(wi, f, ws / (ws + wd), true, flipped));
            }
            reflect(wo, self.ggx.sample_wm(wo, u))
        } else {
            cosine_hemisphere(u)
        };
        let wm = half_vector(wo, wi)?;
        let f = self.specular_f(wo, wi, wm) + self.diffuse_f(wo, wi);
        let pdf = self.mixture_pdf(wo, wi, wm);
        (pdf > 0.0).then(|| reflection_sample(wi, f, pdf, false, flipped))
    }

    /// Unnormalised probabilities of specular and diffuse for |cos θo| = `cos_o`.
    ///
    /// The specular weight is floored at 5% of F90 because rough microfacets reflect with F(wo·wm) > F(wo)
    /// even when F0 = 0; it is exactly 0 only when the specular layer is off (F90 = 0).
    fn lobe_weights(&self, cos_o: f32) -> (f32, f32) {
        let f = schlick_scalar(self.f0_max, self.f90, cos_o);
        let ws = if self.f90 > 0.0 { f.max(0.05 * self.f90) } else { 0.0 };
        (ws, (1.0 - f) * self.base.max_element())
    }

    /// Diffuse part, both vectors above the surface.
    fn diffuse_f(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let couple = |cos: f32| 1.0 - schlick_scalar(self.f0_max, self.f90, cos);
        self.base * (FRAC_1_PI * couple(wo.z) * couple(wi.z))
    }

    /// Rough specular D G F / (4 cos_o cos_i) (Walter et al. 2007, eq. 20); 0 when smooth or switched off.
    fn specular_f(&self, wo: Vec3, wi: Vec3, wm: Vec3) -> Vec3 {
        if self.ggx.is_smooth() || self.f90 == 0.0 {
            return Vec3::ZERO;
        }
        let f = schlick(self.f0, self.f90, wo.dot(wm));
        f * (self.ggx.d(wm) * self.ggx.g(wo, wi) / (4.0 * wo.z * wi.z))
    }

    /// Mixture of the visible-normal pdf (Heitz 2018, eq. 17) and the cosine pdf.
    fn mixture_pdf(&self, wo: Vec3, wi: Vec3, wm: Vec3) -> f32 {
        let (ws, wd) = self.lobe_weights(wo.z);
        let total = ws + wd;
        if total <= 0.0 {
            return 0.0;
        }
        let spec = if self.ggx.is_smooth() { 0.0 } else { self.ggx.d_visible(wo, wm) / (4.0 * wo.dot(wm)) };
        (ws * spec + wd * wi.z * FRAC_1_PI) / total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::tests::{albedo, check_reciprocity, check_sampling, grazing_directions, params};
    use crate::materials::{Bsdf, TransportMode};
    use crate::sampling::Sampler;
    use crate::sampling::warp::uniform_sphere;

    #[test]
    fn lambert_samples_follow_its_pdf() {
        let bsdf = Bsdf::new(&params(Vec3::new(0.7, 0.5, 0.3), 0.0, 1.0, 0.0, 1.5, 0.0));
        let wos = grazing_directions();
        for wo in wos {
            check_sampling(&bsdf, wo, TransportMode::Radiance, wos.len() as u32, "lambert");
        }
    }

    #[test]
    fn plastic_samples_follow_its_pdf() {
        let roughnesses = [0.2f32, 0.5, 1.0];
        let wos = grazing_directions();
        let count = (roughnesses.len() * wos.len()) as u32;
        for roughness in roughnesses {
            let bsdf = Bsdf::new(&params(Vec3::new(0.7, 0.5, 0.3), 0.0, roughness, 0.0, 1.5, 1.0));
            for wo in wos {
                check_sampling(&bsdf, wo, TransportMode::Radiance, count, &format!("roughness {roughness}"));
            }
        }
    }

    #[test]
    fn zero_specular_is_exactly_lambertian() {
        let base = Vec3::new(0.8, 0.4, 0.1);
        for roughness in [0.0, 0.3, 1.0] {
            let bsdf = Bsdf::new(&params(base, 0.0, roughness, 0.0, 1.5, 0.0));
            assert!(!bsdf.is_delta());
            for i in 0..200 {
                let s = Sampler::new(11, i, 0);
                let (wo, wi) = (uniform_sphere(s.get2d(0)), uniform_sphere(s.get2d(2)));
                let f = bsdf.eval(wo, wi, TransportMode::Radiance);
                let expected = if wo.z * wi.z > 0.0 { base * FRAC_1_PI } else { Vec3::ZERO };
                assert_eq!(f, expected, "wo {wo}, wi {wi}");
                let pdf = bsdf.pdf(wo, wi);
                assert!((pdf - (wo.z * wi.z > 0.0) as u8 as f32 * wi.z.abs() * FRAC_1_PI).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn lambert_albedo_equals_base_color() {
        let base = Vec3::new(0.8, 0.4, 0.1);
        let bsdf = Bsdf::new(&params(base, 0.0, 0.5, 0.0, 1.5, 0.0));
        for wo in grazing_directions() {
            let (mean, se) = albedo(&bsdf, wo, TransportMode::Radiance, 4_000);
            // Cosine sampling makes every sample weigh exactly base.
            assert!((mean - base).abs().max_element() < 1e-5 && se.max_element() < 1e-5, "wo {wo}: {mean}");
        }
    }

    #[test]
    fn plastic_is_reciprocal() {
        for roughness in [0.0, 0.2, 0.5, 1.0] {
            for specular in [0.0, 0.5, 1.0] {
                check_reciprocity(&Bsdf::new(&params(
                    Vec3::new(0.7, 0.5, 0.3),
                    0.0,
                    roughness,
                    0.0,
                    1.5,
                    specular,
                )));
            }
        }
    }

    #[test]
    fn white_plastic_never_reflects_more_than_it_receives() {
        for roughness in [0.0f32, 0.1, 0.2, 0.5, 0.7, 1.0] {
            for ior in [1.0f32, 1.33, 1.5, 2.0, 3.0] {
                for specular in [0.5f32, 1.0] {
                    let bsdf = Bsdf::new(&params(Vec3::ONE, 0.0, roughness, 0.0, ior, specular));
                    for wo in grazing_directions() {
                        let (mean, se) = albedo(&bsdf, wo, TransportMode::Radiance, 8_000);
                        assert!(
                            mean.max_element() - 4.0 * se.max_element() <= 1.0,
                            "roughness {roughness}, ior {ior}, specular {specular}, wo {wo}: {mean} ± {se}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn smooth_plastic_mirror_weight_is_the_specular_fresnel() {
        let bsdf = Bsdf::new(&params(Vec3::splat(0.5), 0.0, 0.0, 0.0, 1.5, 1.0));
        assert!(!bsdf.is_delta());
        let wo = Vec3::new(0.0, 0.8, 0.6);
        // A lobe number of 0 picks the specular part first.
        let s = bsdf.sample(wo, 0.0, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
        assert!(s.is_specular);
        let expected = schlick(Vec3::splat(0.04), 1.0, 0.6).x;
        let probability = s.pdf;
        assert!((s.f.x * s.wi.z - expected).abs() < 1e-6 && probability > 0.0 && probability < 1.0);
    }
}
