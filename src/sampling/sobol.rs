//! Owen-scrambled Sobol points by hashing (Burley 2020, "Practical Hash-based Owen Scrambling"):
//! the first two dimensions of the Sobol sequence, whose every prefix of 2^k points is a (0, k, 2)-net,
//! with the sample index shuffled and each coordinate Owen-scrambled by hashes of a seed. A sampler
//! that draws each of its dimensions (or pairs) with its own seed gets a stratified sequence in every
//! dimension and every pair, decorrelated across them ("padding"), and across pixels: what pbrt-v4's
//! `PaddedSobolSampler` does with its `FastOwen` randomization.

use glam::Vec2;
use wide::{f32x8, i32x8, u32x8};

/// Sobol's second dimension of `index`: the XOR of the direction numbers of its set bits, whose
/// generator matrix is Pascal's triangle mod 2 (v₀ = 2³¹, vᵢ = vᵢ₋₁ ⊕ vᵢ₋₁ ≫ 1). The first is the
/// radical inverse, `index.reverse_bits()`.
///
/// By Lucas's theorem C(j, i) is odd exactly when the bits of i are a subset of those of j, so the
/// product is a superset-sum over bit positions, five XOR-shift steps instead of a loop over the bits.
#[inline]
pub fn sobol_second_dimension(index: u32) -> u32 {
    let mut x = index;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x.reverse_bits()
}

/// A hash in which each output bit depends only on input bits of equal or lower significance (a
/// Laine–Karras permutation, with the constants of Vegdahl's improved version of Burley's).
#[inline]
fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen scrambling of the bits of `x` read as a binary fraction (most significant first): each bit
/// is flipped by a hash of the bits above it, so a (0, k, 2)-net stays one.
#[inline]
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// 32 random bits to a float in [0, 1): the top 24, so that 1.0 is never returned.
#[inline]
fn unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Point `index` of a one-dimensional Owen-scrambled Sobol sequence (the radical inverse) under
/// `seeds` (shuffle, scramble).
#[inline]
pub fn owen_sobol_1d(index: u32, seeds: [u32; 2]) -> f32 {
    let shuffled = nested_uniform_scramble(index, seeds[0]);
    unit(nested_uniform_scramble(shuffled.reverse_bits(), seeds[1]))
}

/// Point `index` of a two-dimensional Owen-scrambled Sobol sequence under `seeds` (shuffle, x, y).
#[inline]
pub fn owen_sobol_2d(index: u32, seeds: [u32; 3]) -> Vec2 {
    let shuffled = nested_uniform_scramble(index, seeds[0]);
    Vec2::new(
        unit(nested_uniform_scramble(shuffled.reverse_bits(), seeds[1])),
        unit(nested_uniform_scramble(sobol_second_dimension(shuffled), seeds[2])),
    )
}

/// Eight lanes of Owen-scrambled Sobol points of one sample, at once: lane `l` is
/// `owen_sobol_1d(index, [shuffle[l], scramble[l]])`, or, where `second` has bit `l`, the y of
/// `owen_sobol_2d(index, [shuffle[l], scramble[l - 1], scramble[l]])` (a pair's y shares the pair's
/// shuffle, so the caller gives lane `l` lane `l − 1`'s shuffle seed). The same bits as those scalar
/// functions; a vertex's whole layout costs about what one scalar 2-D point did.
#[inline]
pub fn owen_sobol_lanes(index: u32, shuffle: u32x8, scramble: u32x8, second: u32x8) -> [f32; 8] {
    // nested_uniform_scramble(x, s) = rev(lk(rev(x), s)): the shuffle of the index, then the
    // radical inverse (a reversal that cancels the scramble's) or Sobol's second dimension (whose
    // own final reversal cancels likewise), then the coordinate's scramble.
    let shuffled = reverse_lanes(laine_karras_lanes(u32x8::splat(index.reverse_bits()), shuffle));
    let w = second.bitselect(second_dimension_unreversed(shuffled), shuffled);
    let bits = reverse_lanes(laine_karras_lanes(w, scramble));
    let top: i32x8 = bytemuck_cast(bits >> 8);
    (f32x8::from_i32x8(top) * f32x8::splat(1.0 / (1u32 << 24) as f32)).to_array()
}

/// The bits of a u32 lane as an i32 lane (the top 24 bits shifted down fit either way).
#[inline(always)]
fn bytemuck_cast(x: u32x8) -> i32x8 {
    i32x8::new(x.to_array().map(|v| v as i32))
}

#[inline(always)]
fn laine_karras_lanes(mut x: u32x8, seed: u32x8) -> u32x8 {
    x ^= x * u32x8::splat(0x3d20_adea);
    x += seed;
    x *= (seed >> 16) | u32x8::splat(1);
    x ^= x * u32x8::splat(0x0552_6c56);
    x ^= x * u32x8::splat(0x53a2_2864);
    x
}

#[inline(always)]
fn reverse_lanes(x: u32x8) -> u32x8 {
    let swap = |x: u32x8, shift: u32, mask: u32| {
        let m = u32x8::splat(mask);
        ((x >> shift) & m) | ((x & m) << shift)
    };
    let x = swap(x, 1, 0x5555_5555);
    let x = swap(x, 2, 0x3333_3333);
    let x = swap(x, 4, 0x0f0f_0f0f);
    let x = swap(x, 8, 0x00ff_00ff);
    (x >> 16) | (x << 16)
}

/// [`sobol_second_dimension`] without its final reversal.
#[inline(always)]
fn second_dimension_unreversed(mut x: u32x8) -> u32x8 {
    x ^= (x >> 1) & u32x8::splat(0x5555_5555);
    x ^= (x >> 2) & u32x8::splat(0x3333_3333);
    x ^= (x >> 4) & u32x8::splat(0x0f0f_0f0f);
    x ^= (x >> 8) & u32x8::splat(0x00ff_00ff);
    x ^= (x >> 16) & u32x8::splat(0x0000_ffff);
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each elementary interval of area 2^−k (2^a columns × 2^(k−a) rows) holds exactly one point.
    fn is_net(points: &[Vec2]) -> bool {
        let n = points.len() as u32;
        let k = n.trailing_zeros();
        (0..=k).all(|a| {
            let (columns, rows) = (1u32 << a, 1u32 << (k - a));
            let mut seen = vec![0u32; n as usize];
            for p in points {
                seen[((p.y * rows as f32) as u32 * columns + (p.x * columns as f32) as u32) as usize] += 1;
            }
            seen.iter().all(|&c| c == 1)
        })
    }

    #[test]
    fn every_power_of_two_prefix_is_a_zero_k_two_net_and_one_d_strata_are_full() {
        for seeds in [[0, 0, 0], [1, 2, 3], [0xdead_beef, 0x1234_5678, 0x9e37_79b9]] {
            for k in 0..=9 {
                let n = 1u32 << k;
                let points: Vec<Vec2> = (0..n).map(|i| owen_sobol_2d(i, seeds)).collect();
                assert!(points.iter().all(|p| p.cmpge(Vec2::ZERO).all() && p.cmplt(Vec2::ONE).all()));
                assert!(is_net(&points), "seeds {seeds:?}, 2^{k} points");
                let mut strata = vec![0; n as usize];
                for i in 0..n {
                    strata[(owen_sobol_1d(i, [seeds[0], seeds[1]]) * n as f32) as usize] += 1;
                }
                assert!(strata.iter().all(|&c| c == 1), "1-D, seeds {seeds:?}, 2^{k}");
            }
        }
    }

    #[test]
    fn lanes_are_the_scalar_points() {
        for index in [0u32, 1, 2, 7, 63, 64, 1000, 0xdead_beef] {
            for k in 0..20u32 {
                let h = |x: u32| x.wrapping_mul(0x9e37_79b9).rotate_left(13) ^ k.wrapping_mul(0x85eb_ca77);
                let shuffle: [u32; 8] = std::array::from_fn(|l| h(l as u32 + 1));
                let scramble: [u32; 8] = std::array::from_fn(|l| h(l as u32 + 100));
                // Pairs in lanes (1, 2) and (4, 5): the y lane takes its pair's shuffle.
                let mut lane_shuffle = shuffle;
                (lane_shuffle[2], lane_shuffle[5]) = (shuffle[1], shuffle[4]);
                let second = u32x8::new([0, 0, u32::MAX, 0, 0, u32::MAX, 0, 0]);
                let lanes = owen_sobol_lanes(index, u32x8::new(lane_shuffle), u32x8::new(scramble), second);
                for l in [0usize, 3, 6, 7] {
                    assert_eq!(lanes[l], owen_sobol_1d(index, [shuffle[l], scramble[l]]), "lane {l}");
                }
                for l in [1usize, 4] {
                    let p = owen_sobol_2d(index, [shuffle[l], scramble[l], scramble[l + 1]]);
                    assert_eq!((lanes[l], lanes[l + 1]), (p.x, p.y), "pair {l}");
                }
            }
        }
    }

    #[test]
    fn the_second_dimension_is_the_direction_number_sum() {
        let by_loop = |mut index: u32| {
            let (mut v, mut result) = (1u32 << 31, 0u32);
            while index != 0 {
                if index & 1 != 0 {
                    result ^= v;
                }
                index >>= 1;
                v ^= v >> 1;
            }
            result
        };
        for index in (0..4096).chain([u32::MAX, 0x8000_0001, 0xdead_beef, 0x1234_5678]) {
            assert_eq!(sobol_second_dimension(index), by_loop(index), "{index:#x}");
        }
    }

    #[test]
    fn scrambling_keeps_the_order_of_the_bits_above() {
        // Two numbers that share their top bits keep sharing them: Owen scrambling permutes within
        // each elementary interval, never across.
        for seed in [1u32, 77, 0xffff_0000] {
            let (a, b) = (0b1011_0000u32 << 24, 0b1011_1111u32 << 24);
            let (sa, sb) = (nested_uniform_scramble(a, seed), nested_uniform_scramble(b, seed));
            assert_eq!(sa >> 28, sb >> 28, "seed {seed}: {sa:032b} {sb:032b}");
        }
    }
}
