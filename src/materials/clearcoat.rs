//! KHR_materials_clearcoat: a clear GGX dielectric coat (IOR 1.5, F0 = 0.04) of weight `w` over
//! the whole material.
//!
//! `f = w · coat(wo, wi) + (1 − w·F(cos θo)) (1 − w·F(cos θi)) · base(wo, wi)`
//!
//! The coat is the extension's specular BRDF (GGX, height-correlated Smith, Schlick Fresnel at the
//! microfacet); light reaching the base crosses the coat twice, in and out, and loses its Fresnel
//! reflection each way. The extension's reference attenuates the base by `1 − w·F(n·V)` only, which
//! is not reciprocal; counting both crossings is, so photons (which evaluate the BSDF the other
//! way round) see the same material, and it conserves energy: the coat reflects at most F of what
//! arrives and passes at most 1 − F of it.

use super::BsdfSample;
use super::conductor::Conductor;
use super::fresnel::schlick_scalar;
use super::microfacet::Ggx;
use crate::sampling::warp::Frame;
use glam::{Vec2, Vec3};

/// Whether `wi` leaves on the other side of the base's surface than `wo` arrives.
#[inline]
fn crosses(wo: Vec3, wi: Vec3) -> bool {
    wo.z * wi.z <= 0.0
}

/// Normal-incidence reflectance of the coat (IOR 1.5).
pub(crate) const COAT_F0: f32 = 0.04;

/// The coat lobe.
#[derive(Clone, Copy, Debug)]
pub struct Coat {
    weight: f32,
    /// The coat's reflection: a GGX lobe with Schlick's Fresnel, F0 = 0.04 and F90 = 1, which is
    /// the conductor lobe of that F0.
    lobe: Conductor,
    /// The coat's own shading frame within the BSDF's (KHR_materials_clearcoat's
    /// `clearcoatNormalTexture`); none: the coat follows the base's normal.
    frame: Option<Frame>,
}

impl Coat {
    /// A coat of `weight` (clearcoatFactor × texture) and perceptual `roughness`; none at weight 0.
    pub fn new(weight: f32, roughness: f32) -> Option<Self> {
        let weight = if weight.is_nan() { 0.0 } else { weight.clamp(0.0, 1.0) };
        (weight > 0.0).then(|| Self {
            weight,
            lobe: Conductor::new(Vec3::splat(COAT_F0), Ggx::from_roughness(roughness)),
            frame: None,
        })
    }

    /// Give the coat its own normal `n` (unit, in the BSDF's local frame).
    pub fn set_normal(&mut self, n: Vec3) {
        self.frame = (n.is_finite() && n.z < 1.0 - 1e-6).then(|| Frame::from_z(n));
    }

    /// `w` in the coat's frame.
    #[inline]
    fn local(&self, w: Vec3) -> Vec3 {
        self.frame.map_or(w, |f| f.to_local(w))
    }

    /// Schlick's Fresnel of the coat at `cos`.
    #[inline]
    fn fresnel(cos: f32) -> f32 {
        schlick_scalar(COAT_F0, 1.0, cos.abs().min(1.0))
    }

    /// Whether the coat is a perfect mirror.
    pub fn is_delta(&self) -> bool {
        self.lobe.is_delta()
    }

    /// The share of light that crosses the coat down to the base and back out.
    #[inline]
    pub fn transmittance(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = (self.local(wo), self.local(wi));
        (1.0 - self.weight * Self::fresnel(wo.z)) * (1.0 - self.weight * Self::fresnel(wi.z))
    }

    /// Probability of sampling the coat rather than the base for `wo`: its reflectance there.
    #[inline]
    pub fn selection_probability(&self, wo: Vec3) -> f32 {
        (self.weight * Self::fresnel(self.local(wo).z)).clamp(0.02, 0.98)
    }

    /// Cosine-weighted hemispherical average of the coat's Fresnel, F0 + (1 − F0)/21, times its weight.
    pub fn albedo_hint(&self) -> f32 {
        self.weight * (COAT_F0 + (1.0 - COAT_F0) / 21.0)
    }

    /// The coat's BSDF without the cosine (zero for the mirror and across the surface).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        if crosses(wo, wi) {
            return 0.0;
        }
        self.weight * self.lobe.eval(self.local(wo), self.local(wi)).x
    }

    /// Solid-angle pdf of [`Coat::sample`] (visible normals).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if crosses(wo, wi) {
            return 0.0;
        }
        self.lobe.pdf(self.local(wo), self.local(wi))
    }

    /// A reflected direction by visible normals; the smooth coat returns its delta weight.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let mut s = self.lobe.sample(self.local(wo), u)?;
        s.f *= self.weight;
        if let Some(frame) = &self.frame {
            s.wi = frame.to_world(s.wi);
            // A coat tilted by its own normal map still only reflects: what its lobe sends
            // through the base's surface is lost, not transmitted (it would add energy).
            if crosses(wo, s.wi) {
                return None;
            }
        }
        Some(s)
    }
}

#[cfg(test)]
mod tests {
    use crate::materials::tests::{albedo, check_reciprocity, check_sampling, grazing_directions, params};
    use crate::materials::{Bsdf, ShadingParams, TransportMode};
    use glam::{Vec2, Vec3};

    fn coated(base: ShadingParams, weight: f32, roughness: f32) -> Bsdf {
        Bsdf::new(&ShadingParams { clearcoat: weight, clearcoat_roughness: roughness, ..base })
    }

    /// Bases: white Lambertian, rough plastic, rough gold-ish metal.
    fn bases() -> [ShadingParams; 3] {
        [
            params(Vec3::ONE, 0.0, 1.0, 0.0, 1.5, 0.0),
            params(Vec3::new(0.8, 0.2, 0.1), 0.0, 0.5, 0.0, 1.5, 1.0),
            params(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.4, 0.0, 1.5, 1.0),
        ]
    }

    const COATS: [(f32, f32); 3] = [(1.0, 0.1), (0.5, 0.3), (1.0, 0.8)];

    #[test]
    fn coated_samples_follow_the_mixture_pdf() {
        let wos = grazing_directions();
        let count = (bases().len() * COATS.len() * wos.len()) as u32;
        for (b, base) in bases().into_iter().enumerate() {
            for (weight, roughness) in COATS {
                let bsdf = coated(base, weight, roughness);
                for wo in wos {
                    let label = format!("base {b}, coat {weight} at roughness {roughness}");
                    check_sampling(&bsdf, wo, TransportMode::Radiance, count, &label);
                }
            }
        }
    }

    #[test]
    fn coated_materials_are_reciprocal() {
        for base in bases() {
            for (weight, roughness) in COATS {
                check_reciprocity(&coated(base, weight, roughness));
            }
        }
    }

    /// A coat conserves energy: over a white Lambertian base (albedo 1) the coated material reflects
    /// at most what it receives, and at most what the uncoated base did plus the coat's own share;
    /// a coat of weight 0 changes nothing.
    #[test]
    fn a_coat_over_white_never_reflects_more_than_it_receives() {
        let white = bases()[0];
        for (weight, roughness) in COATS.into_iter().chain([(1.0, 0.0)]) {
            let bsdf = coated(white, weight, roughness);
            for wo in grazing_directions() {
                let (mean, se) = albedo(&bsdf, wo, TransportMode::Radiance, 20_000);
                assert!(
                    mean.max_element() - 4.0 * se.max_element() <= 1.0,
                    "coat {weight}/{roughness}, wo {wo}: {mean}"
                );
                // The coat takes light from the base: less than the bare white base's 1 in any case.
                assert!(mean.max_element() < 1.0 + 4.0 * se.max_element());
            }
        }
        let wo = Vec3::new(0.3, 0.2, 0.9).normalize();
        let (bare, none) = (Bsdf::new(&white), coated(white, 0.0, 0.5));
        let wi = Vec3::new(-0.5, 0.1, 0.7).normalize();
        assert_eq!(bare.eval(wo, wi, TransportMode::Radiance), none.eval(wo, wi, TransportMode::Radiance));
    }

    /// A smooth coat is a mirror of reflectance w · F(cos θo) (Schlick, F0 = 0.04) over a base that
    /// keeps its own rough lobes: the mirror comes through `sample` with that weight.
    #[test]
    fn a_smooth_coat_mirrors_with_its_fresnel_weight() {
        let bsdf = coated(bases()[0], 1.0, 0.0);
        assert!(!bsdf.is_delta(), "the base is still rough");
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let mut mirrored = 0;
        for i in 0..200 {
            let u = (i as f32 + 0.5) / 200.0;
            let s = bsdf.sample(wo, u, Vec2::new(0.3, 0.7), TransportMode::Radiance).unwrap();
            if s.is_specular {
                mirrored += 1;
                let fresnel = 0.04 + 0.96 * (1.0f32 - 0.8).powi(5);
                assert!((s.f.x * s.wi.z - fresnel).abs() < 1e-5, "{} vs {fresnel}", s.f.x * s.wi.z);
            }
        }
        assert!(mirrored > 0);
    }

    /// A coat with its own normal (`clearcoatNormalTexture`), tilted 35° from the base's: still a
    /// density its samples follow, reciprocal, and energy-conserving over white.
    #[test]
    fn a_coat_with_its_own_normal_stays_consistent() {
        let tilt = 35f32.to_radians();
        let n = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        let wos = grazing_directions();
        for base in bases() {
            let mut bsdf = coated(base, 1.0, 0.3);
            bsdf.set_coat_normal(n);
            for wo in wos {
                check_sampling(&bsdf, wo, TransportMode::Radiance, (3 * wos.len()) as u32, "tilted coat");
            }
            check_reciprocity(&bsdf);
        }
        let mut white = coated(bases()[0], 1.0, 0.3);
        white.set_coat_normal(n);
        for wo in grazing_directions() {
            let (mean, se) = albedo(&white, wo, TransportMode::Radiance, 20_000);
            assert!(mean.max_element() - 4.0 * se.max_element() <= 1.0, "tilted coat, wo {wo}: {mean}");
        }
    }
}
