//! Chi-square goodness-of-fit test of a direction sampler against the density it claims
//! (pbrt-v4 `Chi2Test` in `bsdfs_test.cpp`, Mitsuba 3 `chi2.py`).
//!
//! The sphere is cut into bins of equal solid angle over (cos θ, φ). Observed counts come from the
//! sampler; expected counts from integrating the density over each bin with adaptive 2D Simpson
//! quadrature. Bins expecting too few samples are pooled, and the statistic's p-value comes from the
//! regularized incomplete gamma function. Samplers may fail (return `None`) as often as the density
//! leaves probability mass off the sphere.

use glam::Vec3;
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

/// Probability that a χ² variable with `dof` degrees of freedom exceeds `statistic`.
pub fn chi_square_p_value(statistic: f64, dof: u32) -> f64 {
    regularized_gamma_q(0.5 * dof as f64, 0.5 * statistic)
}

/// Regularized lower incomplete gamma function P(a, x) = γ(a, x) / Γ(a).
pub fn regularized_gamma_p(a: f64, x: f64) -> f64 {
    1.0 - regularized_gamma_q(a, x)
}

/// Regularized upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a) (Press et al., Numerical
/// Recipes §6.2: series below x = a + 1, Lentz's continued fraction above, each where it converges fast).
pub fn regularized_gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^-x x^a / Γ(a) Σ x^n / (a (a+1) … (a+n)).
        let (mut ap, mut term) = (a, 1.0 / a);
        let mut sum = term;
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * log_prefactor.exp()
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        log_prefactor.exp() * h
    }
}

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, n = 9; ~15 significant digits).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula: Γ(x) Γ(1 - x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// An axis-aligned rectangle of the integration domain.
#[derive(Clone, Copy, Debug)]
struct Rect {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Rect {
    /// Quadrant `q` (0..4: x half = q / 2, y half = q % 2).
    fn quadrant(&self, q: usize) -> Rect {
        let (xm, ym) = (0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1));
        let (x0, x1) = if q / 2 == 0 { (self.x0, xm) } else { (xm, self.x1) };
        let (y0, y1) = if q.is_multiple_of(2) { (self.y0, ym) } else { (ym, self.y1) };
        Rect { x0, x1, y0, y1 }
    }

    /// The quadrant holding point `p` (points outside are clamped to the nearest).
    fn quadrant_of(&self, p: (f64, f64)) -> usize {
        let (xm, ym) = (0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1));
        2 * (p.0 >= xm) as usize + (p.1 >= ym) as usize
    }
}

/// Adaptive tensor Simpson quadrature on a quadtree (Lyness 1969, in 2D), guided by sample points.
struct Quadrature<'a> {
    f: &'a mut dyn FnMut(f64, f64) -> f64,
    /// Absolute error floor of a whole initial cell.
    eps: f64,
    /// Scale from probability to expected count, for the sample guide.
    n_samples: f64,
}

impl Quadrature<'_> {
    /// Quadtree levels below an initial cell.
    const MAX_DEPTH: u32 = 6;
    /// Levels within which disagreement with the samples alone forces refinement; deeper, only the
    /// Simpson error does (so a wrong pdf, which disagrees everywhere, costs no more than 4³ per cell).
    const GUIDED_DEPTH: u32 = 3;

    /// ∫∫ f over `rect`: `pieces` × `pieces` equal cells, each refined up to `MAX_DEPTH` quadtree levels.
    /// The initial split makes narrow peaks visible to the first estimates; a quadtree refines only
    /// around features, unlike nested 1D rules that refine whole lines.
    fn integrate(&mut self, rect: Rect, points: &mut [(f64, f64)], pieces: u32) -> f64 {
        let (hx, hy) = ((rect.x1 - rect.x0) / pieces as f64, (rect.y1 - rect.y0) / pieces as f64);
        let cell_of = |p: &(f64, f64)| {
            let a = (((p.0 - rect.x0) / hx) as i64).clamp(0, pieces as i64 - 1);
            let b = (((p.1 - rect.y0) / hy) as i64).clamp(0, pieces as i64 - 1);
            (a * pieces as i64 + b) as usize
        };
        points.sort_unstable_by_key(cell_of);
        let eps = self.eps / (pieces * pieces) as f64;
        let mut total = 0.0;
        let mut rest = points;
        for a in 0..pieces {
            for b in 0..pieces {
                let index = (a * pieces + b) as usize;
                let count = rest.iter().take_while(|p| cell_of(p) == index).count();
                let (inside, tail) = rest.split_at_mut(count);
                rest = tail;
                let (x0, y0) = (rect.x0 + a as f64 * hx, rect.y0 + b as f64 * hy);
                let mut v = [[0.0; 3]; 3];
                for (k, row) in v.iter_mut().enumerate() {
                    for (l, value) in row.iter_mut().enumerate() {
                        *value = (self.f)(x0 + 0.5 * hx * k as f64, y0 + 0.5 * hy * l as f64);
                    }
                }
                let cell = Rect { x0, x1: x0 + hx, y0, y1: y0 + hy };
                total += self.refine(cell, &v, inside, eps, 0);
            }
        }
        total
    }

    /// Compare the cell's Simpson estimate with the sum over its four children; recurse where they
    /// disagree or where the cell holds far more samples than estimated, else Richardson-extrapolate.
    fn refine(
        &mut self,
        rect: Rect,
        v: &[[f64; 3]; 3],
        points: &mut [(f64, f64)],
        eps: f64,
        level: u32,
    ) -> f64 {
        let (hx, hy) = (0.25 * (rect.x1 - rect.x0), 0.25 * (rect.y1 - rect.y0));
        // 5 × 5 nodes: the even ones are the parent's.
        let mut g = [[0.0; 5]; 5];
        for (k, row) in g.iter_mut().enumerate() {
            for (l, value) in row.iter_mut().enumerate() {
                *value = if k % 2 == 0 && l % 2 == 0 {
                    v[k / 2][l / 2]
                } else {
                    (self.f)(rect.x0 + hx * k as f64, rect.y0 + hy * l as f64)
                };
            }
        }
        let coarse = simpson_3x3(rect, v);
        let mut values = [[[0.0; 3]; 3]; 4];
        let mut fine = 0.0;
        for (q, child) in values.iter_mut().enumerate() {
            let (a, b) = (2 * (q / 2), 2 * (q % 2));
            for k in 0..3 {
                for l in 0..3 {
                    child[k][l] = g[a + k][b + l];
                }
            }
            fine += simpson_3x3(rect.quadrant(q), child);
        }
        let delta = fine - coarse;
        // Relative accuracy of 1e-4 is far below the Poisson noise of any count the test can draw.
        let converged = delta.abs() <= 15.0 * eps.max(1e-4 * fine.abs());
        // A count more than 3σ from the estimate hints that the nodes missed a feature. Refining only
        // makes the integral more exact, so chasing the samples cannot make a wrong pdf pass.
        let expected = fine * self.n_samples;
        let consistent = (points.len() as f64 - expected).powi(2) <= 9.0 * (expected + 1.0);
        if level == Self::MAX_DEPTH || (converged && (consistent || level >= Self::GUIDED_DEPTH)) {
            return fine + delta / 15.0;
        }
        points.sort_unstable_by_key(|p| rect.quadrant_of(*p));
        let mut rest = points;
        let mut total = 0.0;
        for (q, child) in values.iter().enumerate() {
            let count = rest.iter().take_while(|p| rect.quadrant_of(**p) == q).count();
            let (inside, tail) = rest.split_at_mut(count);
            rest = tail;
            total += self.refine(rect.quadrant(q), child, inside, 0.25 * eps, level + 1);
        }
        total
    }
}

/// Tensor Simpson rule on a cell from its 3 × 3 node values.
fn simpson_3x3(rect: Rect, v: &[[f64; 3]; 3]) -> f64 {
    const W: [f64; 3] = [1.0, 4.0, 1.0];
    let mut sum = 0.0;
    for k in 0..3 {
        for l in 0..3 {
            sum += W[k] * W[l] * v[k][l];
        }
    }
    sum * (rect.x1 - rect.x0) * (rect.y1 - rect.y0) / 36.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf, uniform_cone, uniform_cone_pdf};
    use std::f32::consts::FRAC_1_PI;

    #[test]
    fn incomplete_gamma_matches_closed_forms() {
        for x in [0.1f64, 1.0, 3.0, 10.0, 40.0] {
            // P(1, x) = 1 - e^-x, and χ² with 2 degrees of freedom is exponential.
            assert!((regularized_gamma_p(1.0, x) - (1.0 - (-x).exp())).abs() < 1e-12, "x {x}");
            assert!((chi_square_p_value(x, 2) - (-x / 2.0).exp()).abs() < 1e-12, "x {x}");
        }
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        // Tabulated χ² quantile: 63 degrees of freedom, upper tail 0.001 at 103.44.
        assert!((chi_square_p_value(103.44, 63) - 0.001).abs() < 5e-5);
    }

    #[test]
    fn adaptive_simpson_integrates_a_narrow_peak() {
        // A normalised Gaussian of σ = 0.01 off the grid nodes.
        let var = 1e-4;
        let mut f = |x: f64, y: f64| {
            let r2 = (x - 0.3123).powi(2) + (y - 0.6789).powi(2);
            (-r2 / (2.0 * var)).exp() / (2.0 * PI * var)
        };
        let rect = Rect { x0: 0.0, x1: 1.0, y0: 0.0, y1: 1.0 };
        let mut quadrature = Quadrature { f: &mut f, eps: 1e-7, n_samples: 1.0 };
        let total = quadrature.integrate(rect, &mut [], 4);
        assert!((total - 1.0).abs() < 1e-6, "{total}");
    }

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
