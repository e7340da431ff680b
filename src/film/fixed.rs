//! Fixed-point pixel sums. Integer addition is associative, so a pixel's sum has the same bits whatever
//! order its samples arrive in: from any number of threads at once, and from partial renders merged
//! later. Floating-point sums have neither property.
//!
//! A sample's radiance is rounded to a multiple of 2^−`FRACTION_BITS` (about 9.1e−13: a relative
//! error below 1e−6 for radiance of 1e−6 and up) and summed in 96-bit two's complement, a `u64` low
//! word and a `u32` high word per channel. A pixel holds sums up to 2^55 ≈ 3.6e16 (radiance times
//! samples); one sample may carry up to `MAX_SAMPLE`, and a larger one is dropped as bad, like NaN.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

/// Fractional bits of a fixed-point sum.
pub const FRACTION_BITS: i32 = 40;
/// The largest radiance one sample may add to a channel (2^48 ≈ 2.8e14).
pub const MAX_SAMPLE: f32 = (1u64 << 48) as f32;

/// Whether a sample's radiance can go to the film: finite, and within ±`MAX_SAMPLE`.
#[inline]
pub fn accepts(l: glam::Vec3) -> bool {
    l.is_finite() && l.abs().max_element() <= MAX_SAMPLE
}

/// The fixed-point value of one accepted sample channel: an f32 times a power of two (exact), rounded
/// half away from zero. `f64::round` and the f64 → i128 conversion are library calls on baseline
/// x86-64; adding ±0.5 and truncating to i64 are single instructions, and every radiance below 2^22
/// takes that path.
#[inline]
pub fn to_fixed(v: f32) -> i128 {
    let scaled = v as f64 * (FRACTION_BITS as f64).exp2();
    let rounded = scaled + 0.5f64.copysign(scaled);
    if rounded.abs() < (1u64 << 62) as f64 { rounded as i64 as i128 } else { rounded as i128 }
}

/// A fixed-point sum as a float.
#[inline]
pub fn from_fixed(sum: i128) -> f64 {
    sum as f64 * (-FRACTION_BITS as f64).exp2()
}

/// One pixel's sums of `N` channels, added to from many threads at once (12·N + 4 bytes: 40 for
/// colour).
#[derive(Debug)]
pub struct PixelSums<const N: usize = 3> {
    lo: [AtomicU64; N],
    hi: [AtomicU32; N],
    count: AtomicU32,
}

/// Add every pixel of `from` to the pixel of `to` at the same index and leave `from` empty (a pass's
/// film folded into the render's).
pub fn take_all<const N: usize>(to: &[PixelSums<N>], from: &[PixelSums<N>]) {
    debug_assert_eq!(to.len(), from.len());
    to.iter().zip(from).for_each(|(to, from)| to.take_from(from));
}

/// Make every pixel of `pixels` empty.
pub fn clear_all<const N: usize>(pixels: &[PixelSums<N>]) {
    pixels.iter().for_each(PixelSums::clear);
}

/// `n` empty pixels, in one allocation asked for fallibly: an error naming `what` (the film), its
/// size and `budget` where the allocator has not got them (a film is the one allocation that grows
/// with the resolution alone).
pub fn try_pixels<const N: usize>(
    n: usize,
    what: impl FnOnce() -> String,
    budget: u64,
) -> crate::error::Result<Vec<PixelSums<N>>> {
    let mut pixels = Vec::new();
    pixels.try_reserve_exact(n).map_err(|_| crate::error::Error::OutOfMemory {
        what: what(),
        bytes: n as u64 * size_of::<PixelSums<N>>() as u64,
        budget,
    })?;
    pixels.extend((0..n).map(|_| PixelSums::default()));
    Ok(pixels)
}

impl<const N: usize> Default for PixelSums<N> {
    fn default() -> Self {
        Self {
            lo: std::array::from_fn(|_| AtomicU64::new(0)),
            hi: std::array::from_fn(|_| AtomicU32::new(0)),
            count: AtomicU32::new(0),
        }
    }
}

impl<const N: usize> PixelSums<N> {
    /// Add fixed-point values to the channels and `count` to the sample count.
    #[inline]
    pub fn add(&self, values: [i128; N], count: u32) {
        for (c, v) in values.into_iter().enumerate() {
            let bits = v as u128;
            let lo = bits as u64;
            let old = self.lo[c].fetch_add(lo, Ordering::Relaxed);
            // The carry out of the low word is decided by the value this add found, so every carry
            // is counted exactly once, whichever thread adds first.
            let hi = ((bits >> 64) as u32).wrapping_add(old.overflowing_add(lo).1 as u32);
            if hi != 0 {
                self.hi[c].fetch_add(hi, Ordering::Relaxed);
            }
        }
        self.count.fetch_add(count, Ordering::Relaxed);
    }

    /// Back to no sums and no samples.
    pub fn clear(&self) {
        for c in 0..N {
            self.lo[c].store(0, Ordering::Relaxed);
            self.hi[c].store(0, Ordering::Relaxed);
        }
        self.count.store(0, Ordering::Relaxed);
    }

    /// Add another pixel's sums and count, and leave it empty (folding a pass's film into the
    /// render's: integer sums, so the bits are those of adding every sample to the one film).
    pub fn take_from(&self, other: &Self) {
        let (sums, count) = other.get();
        self.add(sums, count);
        other.clear();
    }

    /// The channel sums (sign-extended from 96 bits) and the sample count.
    pub fn get(&self) -> ([i128; N], u32) {
        let channel = |c: usize| {
            let bits = ((self.hi[c].load(Ordering::Relaxed) as u128) << 64)
                | self.lo[c].load(Ordering::Relaxed) as u128;
            ((bits << 32) as i128) >> 32
        };
        (std::array::from_fn(channel), self.count.load(Ordering::Relaxed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_carry_into_the_high_word_and_keep_their_sign() {
        let sums = PixelSums::<3>::default();
        let big = (u64::MAX as i128) - 5;
        sums.add([big, -3, 7], 1);
        sums.add([big, -3, -10], 1);
        sums.add([11, 1 << 80, 0], 1);
        assert_eq!(sums.get(), ([2 * big + 11, (1 << 80) - 6, -3], 3));
    }

    #[test]
    fn the_order_of_additions_does_not_change_the_bits() {
        let values: Vec<f32> = (0..1000)
            .map(|i| ((i * 7919) % 1013) as f32 * 1.37e-3 + 1e5 * (i % 17 == 0) as u8 as f32)
            .collect();
        let forward = PixelSums::<3>::default();
        let backward = PixelSums::<3>::default();
        for &v in &values {
            forward.add([to_fixed(v); 3], 1);
        }
        for &v in values.iter().rev() {
            backward.add([to_fixed(v); 3], 1);
        }
        assert_eq!(forward.get(), backward.get());
        // And the sum is the exact one, to half a unit of the last place per sample.
        let exact: f64 = values.iter().map(|&v| v as f64).sum();
        assert!(
            (from_fixed(forward.get().0[0]) - exact).abs()
                <= 500.0 * (-FRACTION_BITS as f64).exp2() + exact * 1e-15
        );
    }

    #[test]
    fn rounding_keeps_a_relative_error_below_a_millionth_from_1e_minus_6() {
        for v in [1e-6f32, 3.3e-5, 0.7, 1.0, 123.456, 2.0e9, MAX_SAMPLE] {
            let back = from_fixed(to_fixed(v));
            assert!(((back - v as f64) / v as f64).abs() < 1e-6, "{v} -> {back}");
        }
        assert!(
            accepts(glam::Vec3::splat(MAX_SAMPLE)) && !accepts(glam::Vec3::new(0.0, 2.0 * MAX_SAMPLE, 0.0))
        );
    }
}
