//! Counter-based random numbers: a stateless hash of (seed, pixel, sample, dimension).
//!
//! Which dimension feeds what is `kernel::dimensions`.
//!
//! A counter-based generator needs no per-path state beyond the counters the path already carries, so a
//! path can be suspended, moved between threads or regenerated without changing its numbers.

use glam::Vec2;

/// An independent sampler: each call hashes its coordinates; nothing is stored between calls.
///
/// `Sampler` identifies one sample of one pixel; `get1d(dim)` returns the number for a dimension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    key: u64,
}

impl Sampler {
    /// The sampler for sample `sample` of pixel `pixel` under `seed`.
    #[inline]
    pub fn new(seed: u64, pixel: u32, sample: u32) -> Self {
        let key = mix64(seed ^ mix64(((pixel as u64) << 32) | sample as u64));
        Self { key }
    }

    /// A uniform number in [0, 1) for dimension `dim`.
    #[inline]
    pub fn get1d(&self, dim: u32) -> f32 {
        let bits = mix64(self.key.wrapping_add((dim as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)));
        // 24 high bits give every float in [0, 1) a spacing of 2^-24, so 1.0 is never returned.
        (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Two uniform numbers for dimensions `dim` and `dim + 1`.
    #[inline]
    pub fn get2d(&self, dim: u32) -> Vec2 {
        Vec2::new(self.get1d(dim), self.get1d(dim + 1))
    }
}

/// A 64-bit finaliser with full avalanche (Stafford's Mix13, as in SplitMix64).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_uniform_and_in_unit_interval() {
        let bins = 64;
        let n = 64_000;
        let mut counts = vec![0u32; bins];
        for i in 0..n {
            let u = Sampler::new(7, i, 3).get1d(11);
            assert!((0.0..1.0).contains(&u));
            counts[(u * bins as f32) as usize] += 1;
        }
        let expected = n as f64 / bins as f64;
        let chi2: f64 = counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum();
        // 63 degrees of freedom: the 0.999 quantile is about 103.4.
        assert!(chi2 < 103.4, "chi-square {chi2} over 64 bins");
    }

    #[test]
    fn dimensions_and_samples_are_decorrelated() {
        let s = Sampler::new(1, 5, 0);
        let t = Sampler::new(1, 5, 1);
        assert_ne!(s.get1d(0), s.get1d(1));
        assert_ne!(s.get1d(0), t.get1d(0));
        assert_eq!(s.get1d(4), Sampler::new(1, 5, 0).get1d(4));
    }
}
