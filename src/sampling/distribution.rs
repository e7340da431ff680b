//! Piecewise-constant distributions over [0, 1) and [0, 1)², sampled by inverting their CDFs with a
//! binary search (pbrt-v4 `PiecewiseConstant1D` / `PiecewiseConstant2D`): O(log n) per sample, O(1) per
//! pdf lookup.

use super::ONE_MINUS_EPSILON;
use glam::Vec2;

/// A step function on [0, 1) with `n` equal steps, normalised into a density.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    /// Step heights (non-negative).
    func: Vec<f32>,
    /// CDF at the step boundaries: `cdf[0] = 0`, `cdf[n] = 1`.
    cdf: Vec<f32>,
    /// ∫ func over [0, 1).
    integral: f32,
}

impl Distribution1D {
    /// The distribution proportional to `func` (negative values count as 0). A function that is zero
    /// everywhere becomes uniform, so that sampling never fails where the caller has nothing better.
    pub fn new(func: &[f32]) -> Self {
        let n = func.len().max(1);
        let mut func: Vec<f32> = func.iter().map(|&f| if f > 0.0 { f } else { 0.0 }).collect();
        if func.is_empty() {
            func.push(0.0);
        }
        // Accumulate in f64: a 4096-wide row of tiny values next to a sun would otherwise lose the
        // small steps' mass to rounding.
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0f64);
        for &f in &func {
            acc += f as f64 / n as f64;
            cdf.push(acc);
        }
        let integral = acc;
        let cdf: Vec<f32> = if integral > 0.0 {
            cdf.iter().map(|&c| (c / integral) as f32).collect()
        } else {
            func.iter_mut().for_each(|f| *f = 1.0);
            (0..=n).map(|i| i as f32 / n as f32).collect()
        };
        let integral = if integral > 0.0 { integral as f32 } else { 1.0 };
        let mut cdf = cdf;
        cdf[n] = 1.0;
        Self { func, cdf, integral }
    }

    /// Number of steps.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Whether there are no steps (never: an empty function has one zero step).
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// ∫ func over [0, 1) (1 for a function that was zero everywhere).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// A point x in [0, 1) for `u` in [0, 1), its density and its step.
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // The last boundary whose CDF is ≤ u: the step that holds u. Steps of zero mass have equal
        // boundaries and are skipped over, so they are never chosen.
        let i = (self.cdf.partition_point(|&c| c <= u).max(1) - 1).min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let offset = if width > 0.0 { (u - self.cdf[i]) / width } else { 0.0 };
        let x = ((i as f32 + offset.clamp(0.0, 1.0)) / n as f32).min(ONE_MINUS_EPSILON);
        (x, self.step_density(i), i)
    }

    /// Density at x in [0, 1).
    #[inline]
    pub fn pdf(&self, x: f32) -> f32 {
        self.step_density(self.step(x))
    }

    /// Probability of step `i` (the density integrated over it).
    #[inline]
    pub fn step_probability(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// The density over step `i`, from the width of its CDF interval: what sampling actually does.
    /// `func / integral` would differ by the f32 rounding of the CDF, which for a dim step beside a
    /// bright one (a row of sky next to the sun) is a large relative error, and a step whose mass
    /// rounds away would claim a density it is never sampled with.
    #[inline]
    fn step_density(&self, i: usize) -> f32 {
        self.step_probability(i) * self.func.len() as f32
    }

    /// The step that holds x (clamped into range).
    #[inline]
    pub fn step(&self, x: f32) -> usize {
        let n = self.func.len();
        // NaN becomes 0 through the cast.
        ((x * n as f32) as usize).min(n - 1)
    }
}

/// A step function on [0, 1)² over a `width` × `height` grid (row 0 at v = 0), sampled by choosing
/// a row from the marginal and then a column from that row's conditional.
#[derive(Clone, Debug, Default)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// The distribution proportional to `func` (row-major, `width` × `height`).
    pub fn new(func: &[f32], width: usize, height: usize) -> Self {
        assert_eq!(func.len(), width * height, "function values must fill the grid");
        let rows: Vec<Distribution1D> = func.chunks(width).map(Distribution1D::new).collect();
        // A row that was all zero became uniform for its own sake; its marginal weight stays zero.
        let row_mass: Vec<f32> = func
            .chunks(width)
            .map(|row| (row.iter().map(|&f| f.max(0.0) as f64).sum::<f64>() / width as f64) as f32)
            .collect();
        let marginal = Distribution1D::new(&row_mass);
        Self { rows, marginal }
    }

    /// A point in [0, 1)² for `u` and its density.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pdf_v, row) = self.marginal.sample(u.y);
        let (x, pdf_u, _) = self.rows[row].sample(u.x);
        (Vec2::new(x, v), pdf_v * pdf_u)
    }

    /// Density at `p` in [0, 1)².
    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        let row = self.marginal.step(p.y);
        self.marginal.pdf(p.y) * self.rows[row].pdf(p.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[test]
    fn one_dimensional_sampling_follows_the_steps_and_skips_zero_ones() {
        let dist = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]);
        let n = 80_000;
        let mut counts = [0u32; 4];
        for i in 0..n {
            let (x, pdf, step) = dist.sample(Sampler::new(3, i, 0).get1d(0));
            assert_eq!(step, dist.step(x), "x {x} lies in the step it reports");
            assert_eq!(pdf, dist.pdf(x));
            counts[step] += 1;
        }
        assert_eq!(counts[1], 0, "a zero step was chosen");
        let pmf: Vec<f64> = (0..4).map(|i| dist.step_probability(i) as f64).collect();
        let p = crate::sampling::chi2::discrete_chi2_p_value(&counts, &pmf, n).unwrap();
        assert!(p > 1e-3, "p-value {p}, counts {counts:?}");
        assert!((dist.integral() - 2.0).abs() < 1e-6);
    }

    #[test]
    fn zero_function_becomes_uniform() {
        let dist = Distribution1D::new(&[0.0, 0.0]);
        assert_eq!(dist.pdf(0.3), 1.0);
        let (x, pdf, _) = dist.sample(0.75);
        assert!((x - 0.75).abs() < 1e-6 && pdf == 1.0);
    }

    #[test]
    fn two_dimensional_density_integrates_to_one_and_matches_samples() {
        let (w, h) = (5, 3);
        let func: Vec<f32> = (0..w * h).map(|i| ((i * 7) % 4) as f32).collect();
        let dist = Distribution2D::new(&func, w, h);
        let total: f32 = (0..w * h)
            .map(|i| {
                dist.pdf(Vec2::new(((i % w) as f32 + 0.5) / w as f32, ((i / w) as f32 + 0.5) / h as f32))
            })
            .sum::<f32>()
            / (w * h) as f32;
        assert!((total - 1.0).abs() < 1e-5, "∫ pdf = {total}");
        for i in 0..1000 {
            let s = Sampler::new(5, i, 0);
            let (p, pdf) = dist.sample(s.get2d(0));
            assert!(p.x < 1.0 && p.y < 1.0);
            assert!((pdf - dist.pdf(p)).abs() <= 1e-5 * pdf, "pdf {pdf} vs {}", dist.pdf(p));
            assert!(pdf > 0.0, "sampled a zero cell at {p}");
        }
    }
}
