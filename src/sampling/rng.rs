//! Counter-based random numbers: each a pure function of (seed, pixel, sample, dimension), drawn
//! either independently (a hash) or from an Owen-scrambled Sobol sequence over the samples of a pixel
//! (`sobol`), which stratifies every dimension and every pair of them.
//!
//! Which dimension feeds what is `kernel::dimensions`.
//!
//! A counter-based generator needs no per-path state beyond the counters the path already carries, so a
//! path can be suspended, moved between threads or regenerated without changing its numbers.

use super::sobol::{owen_sobol_1d, owen_sobol_2d, owen_sobol_lanes};
use crate::choice::Choice;
use glam::Vec2;
use serde::Deserialize;
use wide::u32x8;

/// How the numbers of a pixel's samples are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SamplerKind {
    /// Each number a hash of its coordinates: independent uniform samples.
    Independent,
    /// Owen-scrambled Sobol points over the samples of a pixel, each dimension (or pair) with its own
    /// scramble (Burley 2020; pbrt-v4's `PaddedSobolSampler`): the first 2^k samples are stratified
    /// in every dimension and every 2-D projection, which lowers the error of smooth integrands
    /// faster than 1/N.
    #[default]
    Sobol,
}

impl Choice for SamplerKind {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Independent, "independent", "independent uniform numbers"),
        (Self::Sobol, "sobol", "Owen-scrambled Sobol: stratified in every dimension and pair"),
    ];
}

/// Golden-ratio increment that spreads dimension numbers over the hash's input.
const DIMENSION_STEP: u64 = 0x9E37_79B9_7F4A_7C15;

/// Dimensions come in groups of eight (a camera path's vertex draws one group): one 64-bit hash of
/// the sample's key and the group, then each lane's seeds by a cheap 32-bit hash of it, so that a
/// whole group is drawn in SIMD lanes at once ([`Sampler::group`]).
pub const GROUP: u32 = 8;

/// Lane keys of the shuffle and scramble seeds (hexadecimal digits of π: arbitrary, distinct).
const SHUFFLE_KEYS: [u32; 8] =
    [0x243f_6a88, 0x85a3_08d3, 0x1319_8a2e, 0x0370_7344, 0xa409_3822, 0x299f_31d0, 0x082e_fa98, 0xec4e_6c89];
const SCRAMBLE_KEYS: [u32; 8] =
    [0x4528_21e6, 0x38d0_1377, 0xbe54_66cf, 0x34e9_0c6c, 0xc0ac_29b7, 0xc97c_50dd, 0x3f84_d5b5, 0xb547_0917];

/// Which lanes of a group are the y of a 2-D pair whose x is the lane before: those lanes share
/// their pair's shuffle (a pair is one 2-D point of the sequence).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GroupLayout {
    /// Shuffle key of each lane (its pair's x lane's for a y lane).
    shuffle_keys: [u32; 8],
    /// All ones in the y lanes.
    second: [u32; 8],
}

impl GroupLayout {
    /// The layout whose 2-D pairs start at the lanes in `pairs` (bit `l`: lanes `l`, `l + 1`).
    pub const fn new(pairs: u8) -> Self {
        let mut shuffle_keys = SHUFFLE_KEYS;
        let mut second = [0; 8];
        let mut l = 0;
        while l < 7 {
            if pairs & (1 << l) != 0 {
                shuffle_keys[l + 1] = SHUFFLE_KEYS[l];
                second[l + 1] = u32::MAX;
            }
            l += 1;
        }
        Self { shuffle_keys, second }
    }
}

/// The numbers of one sample of one pixel (or one photon of one stream): `get1d(dim)` and
/// `get2d(dim)` return them by dimension, [`Sampler::group`] eight at once. Nothing is stored
/// between calls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    key: u64,
    index: u32,
    kind: SamplerKind,
}

impl Sampler {
    /// The independent sampler for sample `sample` of pixel `pixel` under `seed`.
    #[inline]
    pub fn new(seed: u64, pixel: u32, sample: u32) -> Self {
        Self::of(SamplerKind::Independent, seed, pixel, sample)
    }

    /// The sampler of `kind` for sample `sample` of pixel `pixel` under `seed`.
    #[inline]
    pub fn of(kind: SamplerKind, seed: u64, pixel: u32, sample: u32) -> Self {
        let key = match kind {
            SamplerKind::Independent => mix64(seed ^ mix64(((pixel as u64) << 32) | sample as u64)),
            // One scramble per pixel: its samples are the points of one sequence.
            SamplerKind::Sobol => mix64(seed ^ mix64(pixel as u64 ^ 0x50b0_1000_0000_0000)),
        };
        Self { key, index: sample, kind }
    }

    /// The hash of this sampler's key and dimension `dim` (the independent sampler's number).
    #[inline]
    fn dimension_hash(&self, dim: u32) -> u64 {
        mix64(self.key.wrapping_add((dim as u64).wrapping_mul(DIMENSION_STEP)))
    }

    /// The shuffle and scramble seeds of dimension `dim` (Sobol).
    #[inline]
    fn seeds(&self, dim: u32) -> (u32, u32) {
        let group = self.dimension_hash(dim / GROUP);
        let lane = (dim % GROUP) as usize;
        (hash32(group as u32 ^ SHUFFLE_KEYS[lane]), hash32((group >> 32) as u32 ^ SCRAMBLE_KEYS[lane]))
    }

    /// A uniform number in [0, 1) for dimension `dim`.
    #[inline]
    pub fn get1d(&self, dim: u32) -> f32 {
        match self.kind {
            // 24 high bits give every float in [0, 1) a spacing of 2^-24, so 1.0 is never returned.
            SamplerKind::Independent => (self.dimension_hash(dim) >> 40) as f32 * (1.0 / (1u64 << 24) as f32),
            SamplerKind::Sobol => {
                let (shuffle, scramble) = self.seeds(dim);
                owen_sobol_1d(self.index, [shuffle, scramble])
            }
        }
    }

    /// Two uniform numbers for dimensions `dim` and `dim + 1` (one 2-D point of the sequence).
    #[inline]
    pub fn get2d(&self, dim: u32) -> Vec2 {
        match self.kind {
            SamplerKind::Independent => Vec2::new(self.get1d(dim), self.get1d(dim + 1)),
            SamplerKind::Sobol => {
                let (shuffle, scramble_x) = self.seeds(dim);
                let (_, scramble_y) = self.seeds(dim + 1);
                owen_sobol_2d(self.index, [shuffle, scramble_x, scramble_y])
            }
        }
    }

    /// The eight numbers of dimensions `GROUP · group ..`, the lanes `layout` pairs drawn as
    /// [`Sampler::get2d`] draws them and the others as [`Sampler::get1d`] does (the same bits),
    /// in SIMD lanes.
    #[inline]
    pub fn group(&self, group: u32, layout: &GroupLayout) -> [f32; 8] {
        match self.kind {
            SamplerKind::Independent => std::array::from_fn(|l| self.get1d(GROUP * group + l as u32)),
            SamplerKind::Sobol => {
                let hash = self.dimension_hash(group);
                let shuffle = hash32_lanes(u32x8::splat(hash as u32) ^ u32x8::new(layout.shuffle_keys));
                let scramble = hash32_lanes(u32x8::splat((hash >> 32) as u32) ^ u32x8::new(SCRAMBLE_KEYS));
                owen_sobol_lanes(self.index, shuffle, scramble, u32x8::new(layout.second))
            }
        }
    }
}

/// A 32-bit finaliser with low bias (Wellons' `lowbias32`), for the lanes' seeds.
#[inline]
fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// [`hash32`] in eight lanes.
#[inline]
fn hash32_lanes(mut x: u32x8) -> u32x8 {
    x ^= x >> 16;
    x *= u32x8::splat(0x7feb_352d);
    x ^= x >> 15;
    x *= u32x8::splat(0x846c_a68b);
    x ^ (x >> 16)
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
    #[test]
    fn command_line_names_are_the_run_file_names() {
        crate::choice::assert_names_match_serde::<super::SamplerKind>();
    }

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
    fn dimensions_samples_and_pixels_are_decorrelated() {
        // Pearson's r of 20 000 pairs: 4 standard errors of an uncorrelated pair is 4/√n = 0.028.
        let n = 20_000u32;
        let bound = 4.0 / (n as f64).sqrt();
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            type Pair = fn(SamplerKind, u32) -> (f32, f32);
            let pairs: [(&str, Pair); 3] = [
                ("dimensions", |k, i| (Sampler::of(k, 1, i, 0).get1d(0), Sampler::of(k, 1, i, 0).get1d(1))),
                ("samples", |k, i| (Sampler::of(k, 1, i, 0).get1d(3), Sampler::of(k, 1, i, 1).get1d(3))),
                ("pixels", |k, i| {
                    (Sampler::of(k, 1, 2 * i, 7).get1d(5), Sampler::of(k, 1, 2 * i + 1, 7).get1d(5))
                }),
            ];
            for (what, pair) in pairs {
                // A Sobol sequence's consecutive samples are anti-correlated on purpose: stratified.
                if kind == SamplerKind::Sobol && what == "samples" {
                    continue;
                }
                let values: Vec<(f64, f64)> =
                    (0..n).map(|i| pair(kind, i)).map(|(a, b)| (a as f64, b as f64)).collect();
                let mean = |f: fn(&(f64, f64)) -> f64| values.iter().map(f).sum::<f64>() / n as f64;
                let (ma, mb) = (mean(|v| v.0), mean(|v| v.1));
                let cov = values.iter().map(|v| (v.0 - ma) * (v.1 - mb)).sum::<f64>() / n as f64;
                let var = |m: f64, f: fn(&(f64, f64)) -> f64| {
                    values.iter().map(|v| (f(v) - m).powi(2)).sum::<f64>() / n as f64
                };
                let r = cov / (var(ma, |v| v.0) * var(mb, |v| v.1)).sqrt();
                assert!(r.abs() < bound, "{kind:?}: {what} correlate, r = {r}");
            }
        }
        assert_eq!(Sampler::new(1, 5, 0).get1d(4), Sampler::new(1, 5, 0).get1d(4), "a pure function");
    }

    /// A group's lanes are the numbers `get1d` and `get2d` give for the same dimensions.
    #[test]
    fn a_group_is_its_dimensions_drawn_one_by_one() {
        let layout = GroupLayout::new(0b0001_0010);
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            for (pixel, sample, group) in [(0, 0, 0), (5, 3, 1), (77, 1000, 9), (123_456, 7, 40)] {
                let s = Sampler::of(kind, 42, pixel, sample);
                let lanes = s.group(group, &layout);
                let d = |l: u32| GROUP * group + l;
                for l in [0, 3, 6, 7] {
                    assert_eq!(lanes[l as usize], s.get1d(d(l)), "{kind:?} lane {l}");
                }
                for l in [1, 4] {
                    let p = s.get2d(d(l));
                    assert_eq!((lanes[l as usize], lanes[l as usize + 1]), (p.x, p.y), "{kind:?} pair {l}");
                }
            }
        }
    }

    /// On a smooth integrand, ∫∫ exp(−x)·cos(y) over [0, 1]², the mean squared error over 512 pixels
    /// (independent scrambles) falls from 16 to 256 samples by far more than the 16× of independent
    /// sampling (Owen-scrambled nets converge as N^−3 on smooth functions), and the mean estimate is
    /// unbiased within four standard errors.
    #[test]
    fn sobol_error_on_a_smooth_integrand_falls_faster_than_one_over_n() {
        let f = |p: Vec2| (-p.x).exp() * p.y.cos();
        let exact = (1.0 - (-1.0f64).exp()) * 1f64.sin();
        let mse = |kind: SamplerKind, n: u32| {
            let (mut sum_sq, mut sum) = (0.0f64, 0.0f64);
            for pixel in 0..512 {
                let estimate =
                    (0..n).map(|i| f(Sampler::of(kind, 9, pixel, i).get2d(3)) as f64).sum::<f64>() / n as f64;
                sum_sq += (estimate - exact).powi(2);
                sum += estimate - exact;
            }
            (sum_sq / 512.0, sum / 512.0)
        };
        let (sobol_16, bias_16) = mse(SamplerKind::Sobol, 16);
        let (sobol_256, _) = mse(SamplerKind::Sobol, 256);
        let (independent_256, _) = mse(SamplerKind::Independent, 256);
        assert!(sobol_256 < sobol_16 / 64.0, "MSE {sobol_16} at 16, {sobol_256} at 256");
        assert!(sobol_256 < independent_256 / 100.0, "Sobol {sobol_256}, independent {independent_256}");
        assert!(bias_16.abs() < 4.0 * (sobol_16 / 512.0).sqrt(), "mean error {bias_16}");
    }
}
