//! Sine and cosine, arcsine and two-argument arctangent as lanes compute them (Agner Fog's vector
//! class library through `wide`), for the scalar code that lanes are held to bit for bit: the C
//! library's `sinf`, `asinf` and `atan2f` round differently from any vector code, so a scalar kernel
//! that called them could not be matched by its lanes. Each function here runs the one-lane case of
//! the vector routine (a 4-lane register, lane 0); `wide` builds its 4-, 8- and 16-lane routines
//! from the same operations, so every width gives the same bits (`tests` holds them to it). Within
//! 2 ulps of the exact values on the ranges the samplers use.

use wide::f32x4;

/// `(sin x, cos x)`.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let (s, c) = f32x4::splat(x).sin_cos();
    (s.to_array()[0], c.to_array()[0])
}

/// `asin x` for x in [−1, 1].
#[inline]
pub fn asin(x: f32) -> f32 {
    f32x4::splat(x).asin().to_array()[0]
}

/// `atan2(y, x)`.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    f32x4::splat(y).atan2(f32x4::splat(x)).to_array()[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::lanes::{Lanes, WIDTH};
    use crate::sampling::Sampler;

    /// The lanes' routines (whatever their width) give every lane the one-lane bits, and both are
    /// within 2 ulps (or 2e-7 absolute near zero) of the C library's f64 results.
    #[test]
    fn every_width_gives_the_same_bits_and_the_right_values() {
        let close = |got: f32, exact: f64| (got as f64 - exact).abs() <= 2.5e-7_f64.max(exact.abs() * 2.5e-7);
        for i in 0..20_000u32 {
            let s = Sampler::new(17, i, 0);
            let angle: [f32; WIDTH] = std::array::from_fn(|k| (s.get1d(k as u32) - 0.25) * 8.0);
            let unit: [f32; WIDTH] = std::array::from_fn(|k| s.get1d(20 + k as u32) * 2.0 - 1.0);
            let other: [f32; WIDTH] = std::array::from_fn(|k| s.get1d(40 + k as u32) * 4.0 - 2.0);
            let (sin, cos) = Lanes::new(angle).sin_cos();
            let asin_lanes = Lanes::new(unit).asin();
            let atan2_lanes = Lanes::new(unit).atan2(Lanes::new(other));
            for k in 0..WIDTH {
                let (a, u, o) = (angle[k], unit[k], other[k]);
                let (s1, c1) = sin_cos(a);
                assert_eq!(
                    (s1.to_bits(), c1.to_bits()),
                    (sin.to_array()[k].to_bits(), cos.to_array()[k].to_bits())
                );
                assert_eq!(asin(u).to_bits(), asin_lanes.to_array()[k].to_bits());
                assert_eq!(atan2(u, o).to_bits(), atan2_lanes.to_array()[k].to_bits());
                assert!(close(s1, (a as f64).sin()) && close(c1, (a as f64).cos()), "sin_cos({a})");
                assert!(close(asin(u), (u as f64).asin()), "asin({u}): {}", asin(u));
                assert!(close(atan2(u, o), (u as f64).atan2(o as f64)), "atan2({u}, {o})");
            }
        }
        assert_eq!(atan2(0.0, -1.0), std::f32::consts::PI);
        assert_eq!(asin(1.0), std::f32::consts::FRAC_PI_2);
    }
}
