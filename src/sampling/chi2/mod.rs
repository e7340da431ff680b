//! Chi-square goodness-of-fit test of a direction sampler against the density it claims
//! (pbrt-v4 `Chi2Test` in `bsdfs_test.cpp`, Mitsuba 3 `chi2.py`).
//!
//! The sphere is cut into bins of equal solid angle over (cos θ, φ). Observed counts come from the
//! sampler; expected counts from integrating the density over each bin with adaptive 2D Simpson
//! quadrature. Bins expecting too few samples are pooled, and the statistic's p-value comes from the
//! regularized incomplete gamma function. Samplers may fail (return `None`) as often as the density
//! leaves probability mass off the sphere.

mod gamma;
mod quadrature;

pub use gamma::{chi_square_p_value, ln_gamma, regularized_gamma_p, regularized_gamma_q};

use glam::Vec3;
use quadrature::{Quadrature, Rect};
use std::f64::consts::PI;

/// Settings of [`chi2_test`].
#[derive(Clone, Copy, Debug)]
pub struct Chi2Config {
    /// Bins in cos θ over [-1, 1].
    pub cos_theta_bins: u32,
    /// Bins in φ over [0, 2π).
    pub phi_bins: u32,
    /// Bins expecting fewer samples than this are pooled (the usual rule of thumb is 5).
    pub min_expected: f64,
    /// Family-wise significance level: the chance that a correct sampler fails one of `test_count` tests.
    pub significance: f64,
    /// How many tests share `significance` (Šidák correction).
    pub test_count: u32,
}

impl Default for Chi2Config {
    /// 24 × 48 bins, pooling below 5, 1% significance, one test.
    fn default() -> Self {
        Self { cos_theta_bins: 24, phi_bins: 48, min_expected: 5.0, significance: 0.01, test_count: 1 }
    }
}

/// Test that `sample(i)` for `i in 0..n_samples` draws directions with density `pdf` (per unit solid
/// angle, over the whole sphere).
///
/// `sample` may return `None` for a failed sample; directions need not be normalised. Returns the
/// p-value when the hypothesis "samples follow `pdf`" survives at the Šidák-corrected level
/// `1 - (1 - significance)^(1 / test_count)`, and a description of the failure otherwise.
pub fn chi2_test(
    mut sample: impl FnMut(u32) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
    n_samples: u32,
    config: &Chi2Config,
) -> Result<f64, String> {
    let mut directions = Vec::with_capacity(n_samples as usize);
    for i in 0..n_samples {
        if let Some(d) = sample(i) {
            direction_bin(d, config).ok_or_else(|| format!("sample {i} is {d}"))?;
            directions.push(d);
        }
    }
    let mut observed = vec![0.0; (config.cos_theta_bins * config.phi_bins) as usize];
    for &d in &directions {
        observed[direction_bin(d, config).unwrap_or(0)] += 1.0;
    }
    let expected = expected_frequencies(pdf, n_samples, config, &directions);
    let on_sphere: f64 = expected.iter().sum();
    if on_sphere > n_samples as f64 * 1.002 {
        return Err(format!("pdf integrates to {} > 1", on_sphere / n_samples as f64));
    }
    // Failed samples must match the mass the pdf leaves off the sphere. This is a separate, looser check
    // than a chi-square cell: the quadrature's 1e-4 relative error, summed over the sphere, is as large as
    // the Poisson noise of a small "no sample" count.
    let missing = (n_samples as usize - directions.len()) as f64;
    let missing_expected = (n_samples as f64 - on_sphere).max(0.0);
    if (missing - missing_expected).abs() > 5.0 * missing_expected.max(1.0).sqrt() + 2e-3 * n_samples as f64 {
        return Err(format!("{missing} samples failed where the pdf leaves room for {missing_expected:.1}"));
    }
    let (statistic, dof) = chi2_statistic(&observed, &expected, config.min_expected, n_samples)?;
    let p = chi_square_p_value(statistic, dof);
    let level = 1.0 - (1.0 - config.significance).powf(1.0 / config.test_count.max(1) as f64);
    if p.is_finite() && p >= level {
        Ok(p)
    } else {
        Err(format!("chi-square {statistic:.1} with {dof} degrees of freedom: p = {p:.3e} < {level:.3e}"))
    }
}

/// The (cos θ, φ) bin of direction `d`, row-major with φ fastest; `None` for a zero or non-finite vector.
pub fn direction_bin(d: Vec3, config: &Chi2Config) -> Option<usize> {
    let (theta, phi) = spherical(d)?;
    let (nc, np) = (config.cos_theta_bins as usize, config.phi_bins as usize);
    let c = ((theta.cos() + 1.0) * 0.5 * nc as f64) as usize;
    let p = (phi / (2.0 * PI) * np as f64) as usize;
    Some(c.min(nc - 1) * np + p.min(np - 1))
}

/// (θ, φ ∈ [0, 2π)) of a non-zero finite vector.
fn spherical(d: Vec3) -> Option<(f64, f64)> {
    let d = d.as_dvec3();
    let len = d.length();
    if !(len.is_finite() && len > 0.0) {
        return None;
    }
    let phi = d.y.atan2(d.x);
    Some(((d.z / len).clamp(-1.0, 1.0).acos(), if phi < 0.0 { phi + 2.0 * PI } else { phi }))
}

/// Expected counts per bin: `n_samples` × ∫ pdf over the bin, by adaptive 2D Simpson quadrature in
/// (θ, φ), accurate to 1e-4 relative or 0.01 samples in total, whichever is looser per cell.
///
/// `guide` holds the observed samples (may be empty). A cell whose estimate is more than 3σ from the
/// samples it holds is refined further even when its Simpson estimates agree: a lobe narrower than the
/// node spacing (a rough mirror at grazing incidence is ~1e-3 rad wide in φ) can slip between nodes.
/// At the depth limit the estimate stands, so a wrong pdf is still caught.
pub fn expected_frequencies(
    pdf: impl Fn(Vec3) -> f32,
    n_samples: u32,
    config: &Chi2Config,
    guide: &[Vec3],
) -> Vec<f64> {
    let (nc, np) = (config.cos_theta_bins as usize, config.phi_bins as usize);
    let (dc, dp) = (2.0 / nc as f64, 2.0 * PI / np as f64);
    let mut points: Vec<Vec<(f64, f64)>> = vec![Vec::new(); nc * np];
    for &d in guide {
        if let (Some(bin), Some(angles)) = (direction_bin(d, config), spherical(d)) {
            points[bin].push(angles);
        }
    }
    // Cells are also accepted at a relative error of 1e-4; this floor spends at most 0.01 samples in all.
    let eps = 1e-2 / (n_samples.max(1) as f64 * (nc * np) as f64);
    let mut expected = Vec::with_capacity(nc * np);
    for i in 0..nc {
        // Bins are equal in cos θ, but the quadrature runs over θ (dω = sin θ dθ dφ): a lobe of angular
        // width w centred on a pole is only w²/2 wide in cos θ, too narrow for the refinement to find.
        let (c0, c1) = (-1.0 + i as f64 * dc, -1.0 + (i + 1) as f64 * dc);
        let (theta0, theta1) = (c1.clamp(-1.0, 1.0).acos(), c0.clamp(-1.0, 1.0).acos());
        // Nodes on a bin edge are pulled a hair inside, so that a density discontinuous there (the
        // horizon) is evaluated on this bin's side: cos(acos(0)) = 6e-17 would count as "above".
        let inset = 1e-9 * dc;
        let mut integrand = |theta: f64, phi: f64| {
            let c = theta.cos().clamp(c0 + inset, c1 - inset);
            let s = (1.0 - c * c).max(0.0).sqrt();
            let d = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
            pdf(d) as f64 * theta.sin()
        };
        for j in 0..np {
            let (p0, p1) = (j as f64 * dp, (j + 1) as f64 * dp);
            let mut quadrature = Quadrature { f: &mut integrand, eps, n_samples: n_samples as f64 };
            let bin = Rect { x0: theta0, x1: theta1, y0: p0, y1: p1 };
            let points = &mut points[i * np + j];
            let mass = quadrature.integrate(bin, points, 4);
            expected.push(mass.max(0.0) * n_samples as f64);
        }
    }
    expected
}

/// Pearson's statistic over the cells with pooling of sparse cells (pbrt-v4 `Chi2Test`).
///
/// Returns the statistic and its degrees of freedom, or an error when samples land where nothing is
/// expected or too few cells remain.
pub fn chi2_statistic(
    observed: &[f64],
    expected: &[f64],
    min_expected: f64,
    n_samples: u32,
) -> Result<(f64, u32), String> {
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    let (mut statistic, mut cells) = (0.0, 0u32);
    for k in order {
        let (obs, exp) = (observed[k], expected[k]);
        if exp == 0.0 {
            // A tolerance, as in pbrt, for quadrature that misses a vanishing tail.
            if obs > n_samples as f64 * 1e-5 {
                return Err(format!("{obs} samples in cell {k}, where the pdf integrates to 0"));
            }
        } else if exp < min_expected || (pooled_exp > 0.0 && pooled_exp < min_expected) {
            // Pool sparse cells (sorted, so the pool fills before the large cells start).
            pooled_obs += obs;
            pooled_exp += exp;
        } else {
            statistic += (obs - exp) * (obs - exp) / exp;
            cells += 1;
        }
    }
    if pooled_exp > 0.0 {
        statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        cells += 1;
    }
    if cells < 2 {
        return Err(format!("only {cells} cell(s) after pooling: use more samples"));
    }
    Ok((statistic, cells - 1))
}

/// p-value of Pearson's test that `counts` (of `draws` samples over discrete outcomes) follow the
/// probabilities `pmf`, sparse cells pooled as in [`chi2_statistic`]: the test of a discrete sampler
/// (light selection) against the pmf it reports.
pub fn discrete_chi2_p_value(counts: &[u32], pmf: &[f64], draws: u32) -> Result<f64, String> {
    let observed: Vec<f64> = counts.iter().map(|&c| c as f64).collect();
    let expected: Vec<f64> = pmf.iter().map(|&p| p * draws as f64).collect();
    let (statistic, dof) = chi2_statistic(&observed, &expected, 5.0, draws)?;
    Ok(chi_square_p_value(statistic, dof))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf, uniform_cone, uniform_cone_pdf};
    use std::f32::consts::FRAC_1_PI;

    #[test]
    fn cosine_hemisphere_samples_pass_against_their_pdf() {
        let p = chi2_test(
            |i| Some(cosine_hemisphere(Sampler::new(1, i, 0).get2d(0))),
            |d| cosine_hemisphere_pdf(d.z),
            100_000,
            &Chi2Config { test_count: 2, ..Default::default() },
        );
        assert!(p.is_ok(), "{p:?}");
    }

    #[test]
    fn uniform_cone_samples_pass_against_their_pdf() {
        let cos_max = 0.8;
        let p = chi2_test(
            |i| Some(uniform_cone(Sampler::new(2, i, 0).get2d(0), cos_max)),
            |d| {
                if d.z >= cos_max { uniform_cone_pdf(cos_max) } else { 0.0 }
            },
            100_000,
            &Chi2Config { test_count: 2, ..Default::default() },
        );
        assert!(p.is_ok(), "{p:?}");
    }

    #[test]
    fn cosine_samples_are_rejected_against_a_uniform_hemisphere_pdf() {
        let p = chi2_test(
            |i| Some(cosine_hemisphere(Sampler::new(3, i, 0).get2d(0))),
            |d| if d.z > 0.0 { 0.5 * FRAC_1_PI } else { 0.0 },
            100_000,
            &Chi2Config::default(),
        );
        assert!(p.is_err(), "wrong pdf accepted with p = {p:?}");
    }

    #[test]
    fn failed_samples_must_match_the_missing_probability_mass() {
        // Half the samples fail, and the pdf integrates to one half: consistent.
        let sample = |i: u32| {
            let s = Sampler::new(4, i, 0);
            (s.get1d(2) < 0.5).then(|| cosine_hemisphere(s.get2d(0)))
        };
        let config = Chi2Config::default();
        assert!(chi2_test(sample, |d| 0.5 * cosine_hemisphere_pdf(d.z), 100_000, &config).is_ok());
        // Claiming the full pdf while half the samples fail is rejected.
        assert!(chi2_test(sample, |d| cosine_hemisphere_pdf(d.z), 100_000, &config).is_err());
    }
}
