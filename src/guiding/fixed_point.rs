//! Energy sums that many threads add to at once and that come out with the same bits whatever order
//! the additions arrive in.
//!
//! Floating-point addition is not associative, so a float sum built by racing threads depends on the
//! schedule, and so would every split the guide decides from it. Integers do not: a sample's value is
//! rounded once to a multiple of 2^−[`FRACTION_BITS`] and added in 96-bit unsigned fixed point (a `u64`
//! low word and a `u32` high word), which holds totals up to 2^64 ≈ 1.8e19.
//!
//! The high word saturates rather than wrapping: a saturating sum of non-negative terms is
//! min(total, limit) in any order, so even an absurd total stays deterministic (and merely reads as
//! the largest value), where a wrapped one would read as a tiny energy.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

/// Fractional bits: the quantum is 2^−32 ≈ 2.3e−10, so a value of 1e−7 keeps three significant
/// digits. Radiance over pdf below that is noise next to any direction that matters.
pub const FRACTION_BITS: i32 = 32;

/// The largest value one sample adds (2^48 ≈ 2.8e14); larger ones are clamped to it. A firefly keeps
/// its direction important without drowning a leaf's other directions for the rest of the render,
/// and the high word then moves by at most 2^16 per sample.
pub const MAX_SAMPLE: f32 = (1u64 << 48) as f32;

/// A sum's largest value: the high word saturated.
const SATURATED: u128 = ((u32::MAX as u128) << 64) | u64::MAX as u128;

/// The fixed-point value of one sample: `None` for NaN, negative or infinite values (a bad estimate,
/// not a bright one), values above [`MAX_SAMPLE`] clamped to it. Multiplying by a power of two is
/// exact, so the only rounding is the final one, half up.
#[inline]
pub fn to_fixed(value: f32) -> Option<u128> {
    if !(value >= 0.0 && value.is_finite()) {
        return None;
    }
    let scaled = value.min(MAX_SAMPLE) as f64 * (FRACTION_BITS as f64).exp2() + 0.5;
    // f64 → u128 is a library call; below 2^64 (all but the largest samples) u64 is one instruction
    // and the same integer.
    Some(if scaled < 18_446_744_073_709_551_616.0 { scaled as u64 as u128 } else { scaled as u128 })
}

/// A fixed-point sum as a float (rounded to the nearest f64; exact for sums below 2^53 quanta).
#[inline]
pub fn from_fixed(sum: u128) -> f64 {
    sum as f64 * (-FRACTION_BITS as f64).exp2()
}

/// `N` saturating 96-bit sums that threads add to without a lock (12·N bytes: a quadtree node's four
/// quadrants in 48). The low and high words live in separate arrays so that four sums pack without
/// padding.
#[derive(Debug)]
pub struct AtomicSums<const N: usize> {
    lo: [AtomicU64; N],
    hi: [AtomicU32; N],
}

impl<const N: usize> Default for AtomicSums<N> {
    fn default() -> Self {
        Self {
            lo: std::array::from_fn(|_| AtomicU64::new(0)),
            hi: std::array::from_fn(|_| AtomicU32::new(0)),
        }
    }
}

impl<const N: usize> AtomicSums<N> {
    /// Add `value` (from [`to_fixed`]) to sum `i`. One `fetch_add` in the common case; the high word
    /// is touched only on a carry out of the low word (once per 2^32 of summed value) or for a value
    /// of 2^32 or more.
    #[inline]
    pub fn add(&self, i: usize, value: u128) {
        let lo = value as u64;
        let old = self.lo[i].fetch_add(lo, Ordering::Relaxed);
        // The carry is decided by the value this add found, so each carry is counted exactly once,
        // whichever thread adds first.
        let carry = old.overflowing_add(lo).1 as u64;
        let hi = (value >> 64) as u64 + carry;
        if hi != 0 {
            let hi = u32::try_from(hi).unwrap_or(u32::MAX);
            // A compare-and-swap loop, not a lock: needed for saturation, and taken rarely enough
            // that its retries cost nothing.
            let _ =
                self.hi[i].fetch_update(Ordering::Relaxed, Ordering::Relaxed, |h| Some(h.saturating_add(hi)));
        }
    }

    /// Sum `i`. Once the high word has saturated the low word is meaningless (it kept wrapping), so a
    /// saturated sum reads as the largest value.
    pub fn get(&self, i: usize) -> u128 {
        let hi = self.hi[i].load(Ordering::Relaxed);
        if hi == u32::MAX {
            return SATURATED;
        }
        ((hi as u128) << 64) | self.lo[i].load(Ordering::Relaxed) as u128
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_are_refused_and_huge_ones_clamped() {
        for bad in [f32::NAN, -1.0, f32::INFINITY, f32::NEG_INFINITY, -0.0001] {
            assert_eq!(to_fixed(bad), None, "{bad}");
        }
        assert_eq!(to_fixed(0.0), Some(0));
        assert_eq!(to_fixed(1.0), Some(1 << 32));
        assert_eq!(to_fixed(1e30), to_fixed(MAX_SAMPLE));
        for v in [1e-7f32, 0.37, 1.0, 123.456, 7.5e9, MAX_SAMPLE] {
            let back = from_fixed(to_fixed(v).unwrap());
            assert!(((back - v as f64) / v as f64).abs() < 2e-3, "{v} -> {back}");
        }
    }

    #[test]
    fn carries_reach_the_high_word_in_any_order() {
        let values: Vec<u128> = (0..2000u128).map(|i| (i * 7919 % 1013) << 40 | (i * 31) << 62).collect();
        let exact: u128 = values.iter().sum();
        let sums = AtomicSums::<2>::default();
        values.iter().for_each(|&v| sums.add(0, v));
        values.iter().rev().for_each(|&v| sums.add(1, v));
        assert!(exact > 1 << 64, "the test must carry");
        assert_eq!((sums.get(0), sums.get(1)), (exact, exact));
    }

    #[test]
    fn threads_racing_give_the_exact_sum() {
        let sums = AtomicSums::<1>::default();
        let value = to_fixed(MAX_SAMPLE).unwrap() - 12345;
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| (0..1000).for_each(|_| sums.add(0, value)));
            }
        });
        assert_eq!(sums.get(0), 4000 * value);
    }

    #[test]
    fn an_overflowing_sum_saturates() {
        let sums = AtomicSums::<1>::default();
        let big = to_fixed(MAX_SAMPLE).unwrap();
        // 2^80 per add: 2^16 adds fill the high word.
        for _ in 0..(1 << 16) + 5 {
            sums.add(0, big);
        }
        assert_eq!(sums.get(0), SATURATED);
        sums.add(0, 1);
        assert_eq!(sums.get(0), SATURATED);
    }
}
