//! The isotropic GGX (Trowbridge–Reitz) microfacet distribution with height-correlated Smith masking and
//! visible-normal sampling.
//!
//! All directions are in the local shading frame (z = macro normal). Functions of a direction `w` use
//! `|w.z|`, so they serve both sides of a surface.

use crate::sampling::warp::concentric_disk;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Below this alpha a lobe is treated as perfectly smooth (a Dirac delta).
pub const SMOOTH_ALPHA: f32 = 1e-3;
/// Smallest alpha used by a rough lobe; keeps D finite in f32.
pub const MIN_ALPHA: f32 = 1e-4;

/// Isotropic GGX distribution of microfacet normals (Walter et al. 2007, eq. 33).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    /// The distribution for glTF perceptual roughness (alpha = roughness², Burley 2012).
    #[inline]
    pub fn from_roughness(roughness: f32) -> Self {
        let r = if roughness.is_nan() { 0.0 } else { roughness.clamp(0.0, 1.0) };
        Self { alpha: (r * r).max(MIN_ALPHA) }
    }

    /// The GGX width parameter.
    #[inline]
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// True when the surface is smooth enough to be sampled as a delta lobe.
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }

    /// Microfacet normal density D(wm) (projected-area normalised: ∫ D cos θm dωm = 1).
    #[inline]
    pub fn d(&self, wm: Vec3) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        // Walter et al. 2007 eq. 33 multiplied through by cos⁴: D = α² / (π (sin² + α² cos²)²) for unit wm.
        // sin² comes from x² + y², not 1 - cos², which would cancel catastrophically near the peak of a
        // narrow lobe (alpha = 0.01 lost three digits that way).
        let a2 = self.alpha * self.alpha;
        let t = wm.x * wm.x + wm.y * wm.y + a2 * wm.z * wm.z;
        a2 * FRAC_1_PI / (t * t)
    }

    /// Smith's auxiliary function Λ(w) for GGX (Heitz 2014, eq. 86).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 == 0.0 {
            return f32::INFINITY;
        }
        let tan2 = (w.x * w.x + w.y * w.y) / cos2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// Smith masking G1(w) = 1 / (1 + Λ(w)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2 = 1 / (1 + Λ(wo) + Λ(wi)) (Heitz 2014, eq. 99).
    ///
    /// Chosen over the separable G1·G1 because it is what real height fields give and it loses less
    /// energy at grazing angles; it is symmetric, so reciprocity holds.
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        // Sum the Λs first so that swapping wo and wi gives bit-identical results.
        1.0 / (1.0 + (self.lambda(wo) + self.lambda(wi)))
    }

    /// Density of visible normals seen from `w`: G1(w) max(0, w·wm) D(wm) / |cos θ| (Heitz 2018, eq. 1).
    ///
    /// For `w` below the surface the normals seen are those facing `-w` (pbrt-v4 convention), so the
    /// density is symmetric under `w → -w`.
    #[inline]
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let cos_m = w.dot(wm) * w.z.signum();
        if w.z == 0.0 || cos_m <= 0.0 {
            return 0.0;
        }
        self.g1(w) * cos_m * self.d(wm) / w.z.abs()
    }

    /// Sample a microfacet normal from [`Ggx::d_visible`] for `w` (Heitz 2018, "Sampling the GGX
    /// Distribution of Visible Normals", listing 1). The result always has wm.z > 0.
    #[inline]
    pub fn sample_wm(&self, w: Vec3, u: Vec2) -> Vec3 {
        // Stretch the view direction to the configuration where the distribution is a hemisphere.
        let mut wh = Vec3::new(self.alpha * w.x, self.alpha * w.y, w.z).normalize();
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 { Vec3::Z.cross(wh).normalize() } else { Vec3::X };
        let t2 = wh.cross(t1);
        // Any uniform disk sample works; the concentric map keeps stratification.
        let mut p = concentric_disk(u);
        // Warp the disk to the projected hemisphere's visible part (Heitz 2018, §4.2).
        let h = (1.0 - p.x * p.x).max(0.0).sqrt();
        let s = 0.5 * (1.0 + wh.z);
        p.y = (1.0 - s) * h + s * p.y;
        let pz = (1.0 - p.length_squared()).max(0.0).sqrt();
        let nh = p.x * t1 + p.y * t2 + pz * wh;
        // Unstretch back to the ellipsoid configuration.
        Vec3::new(self.alpha * nh.x, self.alpha * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::sampling::chi2::{Chi2Config, chi2_test};
    use crate::sampling::warp::uniform_sphere;

    /// ∫ f over the sphere by stratified uniform sampling.
    fn integrate_sphere(f: impl Fn(Vec3) -> f32) -> f32 {
        let n = 200_000u32;
        let mut sum = 0.0f64;
        for i in 0..n {
            sum += f(uniform_sphere(Sampler::new(9, i, 0).get2d(0))) as f64;
        }
        (sum * 4.0 * std::f64::consts::PI / n as f64) as f32
    }

    #[test]
    fn projected_normal_density_integrates_to_one() {
        for roughness in [0.3f32, 0.6, 1.0] {
            let ggx = Ggx::from_roughness(roughness);
            let total = integrate_sphere(|wm| ggx.d(wm) * wm.z.max(0.0));
            assert!((total - 1.0).abs() < 0.02, "roughness {roughness}: {total}");
        }
    }

    #[test]
    fn visible_normal_density_integrates_to_one() {
        for roughness in [0.5f32, 1.0] {
            let ggx = Ggx::from_roughness(roughness);
            for w in [Vec3::Z, Vec3::new(0.8, 0.0, 0.6), Vec3::new(0.0, -0.95, 0.312).normalize()] {
                let total = integrate_sphere(|wm| ggx.d_visible(w, wm));
                assert!((total - 1.0).abs() < 0.02, "roughness {roughness}, w {w}: {total}");
            }
        }
    }

    /// Smith's masking is defined by the microsurface's projected area: G1(ω) ∫ max(0, ω·ωm) D(ωm) dωm
    /// = cos θ (Heitz 2014, eq. 2). Integrating D numerically gives G1 independently of Λ.
    #[test]
    fn masking_makes_the_projected_microsurface_area_equal_the_macrosurface() {
        for roughness in [0.3f32, 0.7, 1.0] {
            let ggx = Ggx::from_roughness(roughness);
            for cos in [1.0f32, 0.8, 0.5, 0.2] {
                let w = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                let projected = integrate_sphere(|wm| w.dot(wm).max(0.0) * ggx.d(wm));
                let expected = cos / projected;
                assert!(
                    (ggx.g1(w) - expected).abs() < 0.02 * expected,
                    "α² {roughness}, cos {cos}: G1 {} vs {expected}",
                    ggx.g1(w)
                );
            }
        }
        assert_eq!(Ggx::from_roughness(0.7).g1(Vec3::X), 0.0, "nothing is seen at the horizon");
    }

    /// Height-correlated masking-shadowing lies strictly between the uncorrelated product G1·G1 and
    /// min(G1, G1) away from normal incidence (Heitz 2014, §6), and is symmetric.
    #[test]
    fn height_correlated_shadowing_lies_between_the_product_and_the_minimum() {
        let ggx = Ggx::from_roughness(0.7);
        for (a, b) in [
            (Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, 0.8, 0.6)),
            (Vec3::new(0.9, 0.0, 0.436), Vec3::new(-0.3, 0.0, 0.954)),
        ] {
            let (a, b) = (a.normalize(), b.normalize());
            let g = ggx.g(a, b);
            assert_eq!(g, ggx.g(b, a));
            assert!(g > ggx.g1(a) * ggx.g1(b) && g < ggx.g1(a).min(ggx.g1(b)), "{g}");
        }
    }

    #[test]
    fn sampled_visible_normals_follow_their_density() {
        let cases = [(0.2f32, 0.9f32), (0.5, 0.3), (1.0, 0.05), (0.5, -0.6)];
        let config = Chi2Config { test_count: cases.len() as u32, ..Default::default() };
        for (roughness, cos) in cases {
            let ggx = Ggx::from_roughness(roughness);
            let w = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
            let result = chi2_test(
                |i| Some(ggx.sample_wm(w, Sampler::new(4, i, 0).get2d(0))),
                |wm| ggx.d_visible(w, wm),
                100_000,
                &config,
            );
            assert!(result.is_ok(), "roughness {roughness}, cos {cos}: {result:?}");
        }
    }
}
