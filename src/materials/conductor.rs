//! GGX microfacet conductor with Schlick Fresnel (glTF metallic = 1), or a perfect mirror when smooth.

use super::fresnel::{reflect, schlick};
use super::microfacet::Ggx;
use super::{BsdfSample, reflection_sample, to_upper};
use glam::{Vec2, Vec3};

/// Conductor lobe: Torrance–Sparrow with GGX, height-correlated Smith G2 and Schlick F (F0 = base colour,
/// F90 = 1), two-sided.
#[derive(Clone, Copy, Debug)]
pub struct Conductor {
    f0: Vec3,
    ggx: Ggx,
}

impl Conductor {
    /// A conductor with normal-incidence reflectance `f0` and roughness `ggx`.
    pub fn new(f0: Vec3, ggx: Ggx) -> Self {
        Self { f0, ggx }
    }

    /// True for the perfect mirror (alpha below [`super::microfacet::SMOOTH_ALPHA`]).
    pub fn is_delta(&self) -> bool {
        self.ggx.is_smooth()
    }

    /// Reflectance estimate used to pick this lobe: Schlick F at wo, floored because a black F0 still
    /// reflects off tilted microfacets and every lobe with f > 0 needs a non-zero probability.
    pub fn selection_weight(&self, wo: Vec3) -> f32 {
        schlick(self.f0, 1.0, wo.z).max_element().max(0.1)
    }

    /// Cosine-weighted hemispherical average of Schlick F: F0 + (1 - F0)/21.
    pub fn albedo_hint(&self) -> Vec3 {
        self.f0 + (Vec3::ONE - self.f0) / 21.0
    }

    /// BSDF value without the cosine; 0 for the mirror and across the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.is_delta() {
            return Vec3::ZERO;
        }
        let (wo, wi, _) = to_upper(wo, wi);
        match half_vector(wo, wi) {
            Some(wm) => self.microfacet_f(wo, wi, wm),
            None => Vec3::ZERO,
        }
    }

    /// Solid-angle pdf of [`Conductor::sample`]: D_wo(wm) / (4 wo·wm) (Heitz 2018, eq. 17 with the
    /// reflection Jacobian of Walter et al. 2007, eq. 14).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_delta() {
            return 0.0;
        }
        let (wo, wi, _) = to_upper(wo, wi);
        match half_vector(wo, wi) {
            Some(wm) => self.ggx.d_visible(wo, wm) / (4.0 * wo.dot(wm)),
            None => 0.0,
        }
    }

    /// Sample a reflected direction by visible normals; the mirror returns its delta weight F/|cos|.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let (wo, _, flipped) = to_upper(wo, Vec3::ZERO);
        if self.is_delta() {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = schlick(self.f0, 1.0, wo.z) / wi.z;
            return Some(reflection_sample(wi, f, 1.0, true, flipped));
        }
        let wm = self.ggx.sample_wm(wo, u);
        let wi = reflect(wo, wm);
        let cos_om = wo.dot(wm);
        if wi.z <= 0.0 || cos_om <= 0.0 {
            return None;
        }
        let pdf = self.ggx.d_visible(wo, wm) / (4.0 * cos_om);
        let f = self.microfacet_f(wo, wi, wm);
        Some(reflection_sample(wi, f, pdf, false, flipped))
    }

    /// D G F / (4 cos_o cos_i) (Walter et al. 2007, eq. 20), both vectors above the surface.
    fn microfacet_f(&self, wo: Vec3, wi: Vec3, wm: Vec3) -> Vec3 {
        let f = schlick(self.f0, 1.0, wo.dot(wm));
        f * (self.ggx.d(wm) * self.ggx.g(wo, wi) / (4.0 * wo.z * wi.z))
    }
}

/// Normalised half vector of a reflection pair in the upper hemisphere, or `None` when either vector is
/// not strictly above the surface.
#[inline]
pub(super) fn half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return None;
    }
    let wm = wo + wi;
    let len2 = wm.length_squared();
    (len2 > 0.0).then(|| wm / len2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::tests::{albedo, check_reciprocity, check_sampling, grazing_directions, params};
    use crate::materials::{Bsdf, TransportMode};

    const ROUGHNESSES: [f32; 4] = [0.1, 0.3, 0.7, 1.0];

    #[test]
    fn rough_conductor_samples_follow_its_pdf() {
        let wos = grazing_directions();
        let count = (ROUGHNESSES.len() * wos.len()) as u32;
        for roughness in ROUGHNESSES {
            let bsdf = Bsdf::new(&params(Vec3::new(0.9, 0.6, 0.3), 1.0, roughness, 0.0, 1.5, 1.0));
            for wo in wos {
                check_sampling(&bsdf, wo, TransportMode::Radiance, count, &format!("roughness {roughness}"));
            }
        }
    }

    #[test]
    fn rough_conductor_is_reciprocal() {
        for roughness in ROUGHNESSES {
            check_reciprocity(&Bsdf::new(&params(Vec3::new(0.9, 0.6, 0.3), 1.0, roughness, 0.0, 1.5, 1.0)));
        }
    }

    #[test]
    fn white_conductor_never_reflects_more_than_it_receives() {
        for roughness in [0.0, 0.05, 0.1, 0.3, 0.5, 0.7, 1.0] {
            let bsdf = Bsdf::new(&params(Vec3::ONE, 1.0, roughness, 0.0, 1.5, 1.0));
            for wo in grazing_directions() {
                let (mean, se) = albedo(&bsdf, wo, TransportMode::Radiance, 20_000);
                assert!(
                    mean.max_element() - 4.0 * se.max_element() <= 1.0,
                    "roughness {roughness}, wo {wo}: {mean}"
                );
            }
        }
    }

    #[test]
    fn smooth_mirror_weight_equals_fresnel_and_white_is_one() {
        let base = Vec3::new(0.9, 0.5, 0.2);
        let wo = Vec3::new(0.6, 0.0, 0.8);
        for (color, expected) in [(base, schlick(base, 1.0, 0.8)), (Vec3::ONE, Vec3::ONE)] {
            let bsdf = Bsdf::new(&params(color, 1.0, 0.0, 0.0, 1.5, 1.0));
            assert!(bsdf.is_delta());
            for flip in [1.0, -1.0] {
                let wo = Vec3::new(wo.x, wo.y, flip * wo.z);
                let s = bsdf.sample(wo, 0.5, Vec2::new(0.3, 0.7), TransportMode::Radiance).unwrap();
                assert!(s.is_specular && !s.is_transmission && s.eta == 1.0);
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                let weight = s.f * s.wi.z.abs() / s.pdf;
                assert!((weight - expected).abs().max_element() < 1e-5, "{weight} vs {expected}");
                assert_eq!(bsdf.eval(wo, s.wi, TransportMode::Radiance), Vec3::ZERO);
                assert_eq!(bsdf.pdf(wo, s.wi), 0.0);
            }
        }
        // At normal incidence the mirror reflects exactly its base colour.
        let bsdf = Bsdf::new(&params(base, 1.0, 0.0, 0.0, 1.5, 1.0));
        let s = bsdf.sample(Vec3::Z, 0.5, Vec2::ZERO, TransportMode::Radiance).unwrap();
        assert!((s.f * s.wi.z / s.pdf - base).abs().max_element() < 1e-6);
    }

    /// glTF's metal Fresnel (the spec's Appendix B): F = f0 + (1 − f0)(1 − |V·H|)⁵ per channel, at the
    /// angle between the view and the microfacet normal H. D and G are the same for every channel, so
    /// a ratio of two channels of f is the ratio of the two channels of F alone, written out here.
    /// (F taken at normal incidence instead would give f0.x / f0.y = 0.22 where 0.54 is due at 80°.)
    #[test]
    fn rough_metal_fresnel_follows_the_angle_to_the_microfacet_normal() {
        let base = Vec3::new(0.2, 0.9, 0.5);
        let bsdf = Bsdf::new(&params(base, 1.0, 0.4, 0.0, 1.5, 1.0));
        let direction = |degrees: f32, phi: f32| {
            let (s, c) = degrees.to_radians().sin_cos();
            Vec3::new(s * phi.cos(), s * phi.sin(), c)
        };
        for (theta_o, theta_i, phi_i) in
            [(80.0, 80.0, std::f32::consts::PI), (75.0, 40.0, 2.5), (60.0, 10.0, 1.0)]
        {
            let (wo, wi) = (direction(theta_o, 0.0), direction(theta_i, phi_i));
            let f = bsdf.eval(wo, wi, TransportMode::Radiance);
            let c = wo.dot((wo + wi).normalize());
            let spec = base + (Vec3::ONE - base) * (1.0 - c).powi(5);
            let (got, due) = (f.x / f.y, spec.x / spec.y);
            assert!(
                (got / due - 1.0).abs() < 1e-4,
                "wo {theta_o}°, wi {theta_i}°: F ratio {got}, spec {due}"
            );
        }
    }

    #[test]
    fn conductor_reflects_nothing_across_the_surface() {
        let bsdf = Bsdf::new(&params(Vec3::ONE, 1.0, 0.5, 0.0, 1.5, 1.0));
        let (wo, wi) = (Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.6, 0.0, -0.8));
        assert_eq!(bsdf.eval(wo, wi, TransportMode::Radiance), Vec3::ZERO);
        assert_eq!(bsdf.pdf(wo, wi), 0.0);
        assert!(
            bsdf.sample(Vec3::new(1.0, 0.0, 0.0), 0.5, Vec2::splat(0.5), TransportMode::Radiance).is_none()
        );
    }
}
