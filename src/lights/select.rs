//! Discrete light selection by a cumulative distribution (uniform or by power).

use crate::sampling::distribution::Distribution1D;

/// Picks index i with probability w_i / Σw by binary search over the CDF: O(log n) per sample.
#[derive(Clone, Debug, Default)]
pub struct LightSelector {
    /// `None` with no lights (a distribution always has at least one step).
    cdf: Option<Distribution1D>,
}

impl LightSelector {
    /// A selector over non-negative weights; all-zero weights fall back to uniform.
    pub fn new(weights: &[f32]) -> Self {
        Self { cdf: (!weights.is_empty()).then(|| Distribution1D::new(weights)) }
    }

    /// The index for `u` in [0, 1) and its probability; `None` with no lights.
    #[inline]
    pub fn sample(&self, u: f32) -> Option<(u32, f32)> {
        let (i, pmf) = self.cdf.as_ref()?.sample_discrete(u);
        Some((i as u32, pmf))
    }

    /// [`LightSelector::sample`] for `N` numbers at once (the searches interleaved), the same picks.
    #[inline]
    pub fn sample_many<const N: usize>(&self, u: &[f32; N]) -> [Option<(u32, f32)>; N] {
        match &self.cdf {
            None => [None; N],
            Some(cdf) => cdf.sample_discrete_many(u).map(|(i, pmf)| Some((i as u32, pmf))),
        }
    }

    /// Probability of index `i`.
    #[inline]
    pub fn pmf(&self, i: u32) -> f32 {
        self.cdf.as_ref().map_or(0.0, |d| d.step_probability(i as usize))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_frequencies_follow_the_weights() {
        let weights = [1.0, 0.0, 3.0, 6.0];
        let sel = LightSelector::new(&weights);
        let n = 100_000;
        let mut counts = [0u32; 4];
        for i in 0..n {
            let u = crate::sampling::Sampler::new(9, i, 0).get1d(0);
            let (k, p) = sel.sample(u).unwrap();
            assert_eq!(p, sel.pmf(k));
            counts[k as usize] += 1;
        }
        assert_eq!(counts[1], 0, "a zero-weight light was chosen");
        let mut chi2 = 0.0;
        for k in [0, 2, 3] {
            let expected = n as f64 * weights[k] as f64 / 10.0;
            chi2 += (counts[k] as f64 - expected).powi(2) / expected;
        }
        // 2 degrees of freedom: the 0.999 quantile is 13.8.
        assert!(chi2 < 13.8, "chi-square {chi2}, counts {counts:?}");
        let total: f32 = (0..4).map(|k| sel.pmf(k)).sum();
        assert!((total - 1.0).abs() < 1e-6);
    }
}
