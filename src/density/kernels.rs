//! Radially symmetric kernels on the unit disc, each normalized so that ∫_disc K = 1.
//!
//! The photon-map radiance estimate is L = Σ f · ΔΦ · K(d²/r²) / r²: with the uniform kernel,
//! K = 1/π, that is Jensen's Σ f ΔΦ / (π r²); the others weigh near photons more, which sharpens
//! caustic edges at the price of more noise (Silverman 1986, §4.3; Jensen 2001, §7.5).

use clap::ValueEnum;
use serde::Deserialize;
use std::f32::consts::PI;

/// A density kernel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, ValueEnum)]
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

    /// Every kernel, for tests and comparisons.
    pub const ALL: [Kernel; 5] =
        [Kernel::Uniform, Kernel::Cone, Kernel::Epanechnikov, Kernel::Biweight, Kernel::Gaussian];
}

#[cfg(test)]
mod tests {
    use super::*;

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
