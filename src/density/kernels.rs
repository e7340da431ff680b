//! Kernels for density estimation (Silverman 1986, table 3.1): 1-D on the real line and radially
//! symmetric on the unit disc, each normalized to integrate to one.
//!
//! The photon-map radiance estimate is L = Σ f · ΔΦ · K(d²/r²) / r²: with the uniform kernel,
//! K = 1/π, that is Jensen's Σ f ΔΦ / (π r²); the others weigh near photons more, which sharpens
//! caustic edges at the price of more noise (Silverman 1986, §4.3; Jensen 2001, §7.5).

use crate::choice::Choice;
use serde::Deserialize;
use std::f32::consts::PI;

/// A density kernel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kernel {
    /// Constant over the disc.
    Uniform,
    /// Linear fall-off, 1 − s (Jensen's cone filter with k = 1).
    Cone,
    /// 1 − s², the kernel of least asymptotic integrated squared error.
    #[default]
    Epanechnikov,
    /// (1 − s²)², Silverman's quartic.
    Biweight,
    /// Gaussian truncated at the disc's rim (Jensen's β = 1.953), renormalized.
    Gaussian,
}

impl Choice for Kernel {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Uniform, "uniform", "constant over the disc"),
        (Self::Cone, "cone", "linear fall-off, 1 - s"),
        (Self::Epanechnikov, "epanechnikov", "1 - s^2, least asymptotic integrated squared error"),
        (Self::Biweight, "biweight", "(1 - s^2)^2, Silverman's quartic"),
        (Self::Gaussian, "gaussian", "Gaussian truncated at the rim, renormalized"),
    ];
}

/// Jensen's Gaussian filter steepness.
const GAUSS_BETA: f32 = 1.953;
/// ∫_disc of the unnormalized truncated Gaussian, divided by π: 1 − (1 − (2/β)(1 − e^{−β/2})) / (1 − e^{−β}).
const GAUSS_MASS_OVER_PI: f32 = 0.578_602_8;

impl Kernel {
    /// The kernel at squared normalized distance `s2` = d²/r² (zero outside the disc).
    #[inline]
    pub fn k2(self, s2: f32) -> f32 {
        if !(0.0..=1.0).contains(&s2) {
            return 0.0;
        }
        match self {
            Kernel::Uniform => 1.0 / PI,
            Kernel::Cone => 3.0 / PI * (1.0 - s2.sqrt()),
            Kernel::Epanechnikov => 2.0 / PI * (1.0 - s2),
            Kernel::Biweight => 3.0 / PI * (1.0 - s2) * (1.0 - s2),
            Kernel::Gaussian => {
                let g = 1.0 - (1.0 - (-GAUSS_BETA * s2 / 2.0).exp()) / (1.0 - (-GAUSS_BETA).exp());
                g / (PI * GAUSS_MASS_OVER_PI)
            }
        }
    }

    /// The 1-D kernel at `t`, integrating to one over the real line (support [−1, 1] except Gaussian).
    #[inline]
    pub fn k1(self, t: f64) -> f64 {
        let a = t.abs();
        if self != Kernel::Gaussian && a >= 1.0 {
            return 0.0;
        }
        match self {
            Kernel::Uniform => 0.5,
            Kernel::Cone => 1.0 - a,
            Kernel::Epanechnikov => 0.75 * (1.0 - t * t),
            Kernel::Biweight => 15.0 / 16.0 * (1.0 - t * t).powi(2),
            Kernel::Gaussian => (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt(),
        }
    }

    /// Half-width of the 1-D support (infinite for the Gaussian).
    pub fn support(self) -> f64 {
        if self == Kernel::Gaussian { f64::INFINITY } else { 1.0 }
    }

    /// R(K) = ∫K²: the variance of a kernel estimate is f(x)·R(K)/(n h) to first order.
    pub fn roughness(self) -> f64 {
        match self {
            Kernel::Uniform => 0.5,
            Kernel::Cone => 2.0 / 3.0,
            Kernel::Epanechnikov => 0.6,
            Kernel::Biweight => 5.0 / 7.0,
            Kernel::Gaussian => 0.5 / std::f64::consts::PI.sqrt(),
        }
    }

    /// μ₂ = ∫t²K: the bias of a kernel estimate is h²/2 · μ₂ · f''(x) to first order.
    pub fn second_moment(self) -> f64 {
        match self {
            Kernel::Uniform => 1.0 / 3.0,
            Kernel::Cone => 1.0 / 6.0,
            Kernel::Epanechnikov => 0.2,
            Kernel::Biweight => 1.0 / 7.0,
            Kernel::Gaussian => 1.0,
        }
    }

    /// Canonical bandwidth (R(K)/μ₂²)^(1/5) (Marron & Nolan 1988): kernels estimate alike when their
    /// bandwidths are in the ratio of these, which carries a Gaussian bandwidth rule to any kernel.
    pub fn canonical_bandwidth(self) -> f64 {
        (self.roughness() / self.second_moment().powi(2)).powf(0.2)
    }

    /// Every kernel, for tests and comparisons.
    pub const ALL: [Kernel; 5] =
        [Kernel::Uniform, Kernel::Cone, Kernel::Epanechnikov, Kernel::Biweight, Kernel::Gaussian];
}

#[cfg(test)]
mod tests {
    #[test]
    fn command_line_names_are_the_run_file_names() {
        crate::choice::assert_names_match_serde::<super::Kernel>();
    }

    use super::*;

    #[test]
    fn every_line_kernel_integrates_to_one_with_its_stated_moments() {
        // Midpoint rule over [−8, 8] (the Gaussian's tail beyond is below 1e-14).
        let n = 400_000;
        let dt = 16.0 / n as f64;
        for kernel in Kernel::ALL {
            let (mut mass, mut mu2, mut r) = (0.0, 0.0, 0.0);
            for i in 0..n {
                let t = -8.0 + (i as f64 + 0.5) * dt;
                let k = kernel.k1(t);
                mass += k * dt;
                mu2 += t * t * k * dt;
                r += k * k * dt;
            }
            assert!((mass - 1.0).abs() < 1e-6, "{kernel:?}: mass {mass}");
            assert!((mu2 - kernel.second_moment()).abs() < 1e-5, "{kernel:?}: μ₂ {mu2}");
            assert!((r - kernel.roughness()).abs() < 1e-5, "{kernel:?}: R(K) {r}");
        }
    }

    #[test]
    fn every_disc_kernel_integrates_to_one() {
        // ∫_disc K(s²) dA = ∫_0^1 K(u) π du with u = s²; midpoint rule on a fine grid.
        let n = 200_000;
        for kernel in Kernel::ALL {
            let total: f64 = (0..n).map(|i| kernel.k2((i as f32 + 0.5) / n as f32) as f64).sum::<f64>()
                * std::f64::consts::PI
                / n as f64;
            assert!((total - 1.0).abs() < 1e-4, "{kernel:?} integrates to {total}");
            assert_eq!(kernel.k2(1.5), 0.0);
        }
    }
}
