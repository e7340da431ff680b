//! Owen-scrambled Sobol points by hashing (Burley 2020, "Practical Hash-based Owen Scrambling"):
//! the first two dimensions of the Sobol sequence, whose every prefix of 2^k points is a (0, k, 2)-net,
//! with the sample index shuffled and each coordinate Owen-scrambled by hashes of a seed. A sampler
//! that draws each of its dimensions (or pairs) with its own seed gets a stratified sequence in every
//! dimension and every pair, decorrelated across them ("padding"), and across pixels: what pbrt-v4's
//! `PaddedSobolSampler` does with its `FastOwen` randomization.

use glam::Vec2;

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
