//! A (0, m, 2)-net in base 2: the first two dimensions of the Sobol sequence (the radical inverse and
//! Sobol's second dimension), XOR-scrambled. Its 2^m points are stratified in every elementary
//! interval of area 2^−m — a 4 × 4 grid, and 16 rows, and 16 columns at once — so an axis-aligned
//! edge, which a jittered grid samples with only √N points, is crossed by the net as finely as by N
//! (Kollig & Keller 2002, "Efficient multidimensional sampling"). XOR with random bits keeps the net's
//! stratification (a random digit scrambling).

use super::sobol::sobol_second_dimension;
use glam::Vec2;

/// Point `index` of the net, scrambled by `scramble` (random bits per axis), in [0, 1)².
#[inline]
pub fn net_point(index: u32, scramble: [u32; 2]) -> Vec2 {
    let x = index.reverse_bits() ^ scramble[0];
    let y = sobol_second_dimension(index) ^ scramble[1];
    // 24 bits: every value below one, and exactly representable.
    Vec2::new((x >> 8) as f32, (y >> 8) as f32) * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every elementary interval of area 2^−m (2^a columns × 2^(m−a) rows, all a) holds exactly one
    /// of the first 2^m points, scrambled or not.
    #[test]
    fn the_first_two_to_the_m_points_are_a_zero_m_two_net() {
        for scramble in [[0, 0], [0x9e37_79b9, 0x7f4a_7c15]] {
            for m in 0..=8u32 {
                let n = 1u32 << m;
                let points: Vec<Vec2> = (0..n).map(|i| net_point(i, scramble)).collect();
                for a in 0..=m {
                    let (columns, rows) = (1u32 << a, 1u32 << (m - a));
                    let mut seen = vec![0u32; n as usize];
                    for p in &points {
                        assert!(p.cmpge(Vec2::ZERO).all() && p.cmplt(Vec2::ONE).all(), "{p}");
                        let cell = (p.y * rows as f32) as u32 * columns + (p.x * columns as f32) as u32;
                        seen[cell as usize] += 1;
                    }
                    assert!(seen.iter().all(|&c| c == 1), "m {m}, {columns}×{rows}: {seen:?}");
                }
            }
        }
    }
}
