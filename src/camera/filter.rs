//! The pixel reconstruction filters: their reach, their normalized densities (what a splat shares
//! out) and exact inverse-CDF sampling of those densities (where a camera sample lands), so that
//! every camera sample has weight one and a splat and a camera sample estimate the same pixel.

use crate::scene::FilterKind;
use glam::Vec2;

/// How far from a pixel's centre, in pixels, the filter reaches.
pub fn filter_radius(filter: FilterKind) -> f32 {
    match filter {
        FilterKind::Box => 0.5,
        FilterKind::Tent => 1.0,
        FilterKind::Gaussian => GAUSSIAN_RADIUS,
    }
}

/// The filter's normalized density at `offset` from a pixel's centre: what a point on the film
/// gives that pixel, the weight a splat shares out (the density [`sample_filter`] draws from, so a
/// splat and a camera sample estimate the same pixel). The box is half-open, as its samples are.
pub fn filter_weight(filter: FilterKind, offset: Vec2) -> f32 {
    match filter {
        FilterKind::Box => {
            let inside = |x: f32| (-0.5..0.5).contains(&x);
            if inside(offset.x) && inside(offset.y) { 1.0 } else { 0.0 }
        }
        FilterKind::Tent => (1.0 - offset.x.abs()).max(0.0) * (1.0 - offset.y.abs()).max(0.0),
        FilterKind::Gaussian => truncated_gaussian(offset.x) * truncated_gaussian(offset.y),
    }
}

/// The density of the normal distribution (σ = 0.5) truncated to ±1.5.
fn truncated_gaussian(x: f32) -> f32 {
    if x.abs() > GAUSSIAN_RADIUS {
        return 0.0;
    }
    let k = (GAUSSIAN_RADIUS / GAUSSIAN_SIGMA) as f64;
    let mass = 1.0 - 2.0 * normal_cdf(-k);
    let sigma = GAUSSIAN_SIGMA as f64;
    let z = x as f64 / sigma;
    ((-0.5 * z * z).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt() * mass)) as f32
}

/// Offset from the pixel centre, drawn with density equal to the normalized filter.
#[inline]
pub fn sample_filter(filter: FilterKind, u: Vec2) -> Vec2 {
    match filter {
        FilterKind::Box => u - Vec2::splat(0.5),
        FilterKind::Tent => Vec2::new(sample_tent(u.x), sample_tent(u.y)),
        FilterKind::Gaussian => Vec2::new(sample_truncated_gaussian(u.x), sample_truncated_gaussian(u.y)),
    }
}

/// Inverse CDF of the tent of radius 1.
#[inline]
fn sample_tent(u: f32) -> f32 {
    if u < 0.5 { -1.0 + (2.0 * u).sqrt() } else { 1.0 - (2.0 - 2.0 * u).sqrt() }
}

/// Gaussian filter standard deviation in pixels.
pub const GAUSSIAN_SIGMA: f32 = 0.5;
/// Gaussian filter radius in pixels (3 σ).
pub const GAUSSIAN_RADIUS: f32 = 1.5;

/// Inverse CDF of the normal distribution (σ = 0.5) truncated to ±1.5: exact, so weights stay one.
#[inline]
fn sample_truncated_gaussian(u: f32) -> f32 {
    let k = (GAUSSIAN_RADIUS / GAUSSIAN_SIGMA) as f64;
    let lo = normal_cdf(-k);
    let p = lo + (1.0 - 2.0 * lo) * u as f64;
    (inverse_normal_cdf(p) * GAUSSIAN_SIGMA as f64) as f32
}

/// Standard normal CDF (erfc via Numerical Recipes' Chebyshev fit, relative error < 1.2e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 { 1.0 - 0.5 * erfc } else { 0.5 * erfc }
}

/// Standard normal quantile (Acklam's rational approximation, relative error < 1.2e-9).
fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] =
        [7.784_695_709_041_462e-3, 3.224_671_290_700_398e-1, 2.445_134_137_142_996, 3.754_408_661_907_416];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn histogram_matches(filter: FilterKind, radius: f32, density: impl Fn(f32) -> f32) {
        let bins = 30;
        let n = 60_000u32;
        let mut counts = vec![0u32; bins];
        for i in 0..n {
            let x = sample_filter(filter, Sampler::new(1, i, 0).get2d(0)).x;
            assert!(x.abs() <= radius + 1e-5, "{filter:?} sample {x} outside radius {radius}");
            let b = (((x + radius) / (2.0 * radius)) * bins as f32) as usize;
            counts[b.min(bins - 1)] += 1;
        }
        let norm: f64 = (0..10_000)
            .map(|k| density(-radius + (k as f32 + 0.5) * 2.0 * radius / 10_000.0) as f64)
            .sum::<f64>()
            * (2.0 * radius as f64 / 10_000.0);
        let mut chi2 = 0.0;
        for (b, &c) in counts.iter().enumerate() {
            let (a, w) = (-radius + b as f32 * 2.0 * radius / bins as f32, 2.0 * radius / bins as f32);
            let mass: f64 = (0..100).map(|k| density(a + (k as f32 + 0.5) * w / 100.0) as f64).sum::<f64>()
                * (w as f64 / 100.0)
                / norm;
            let expected = mass * n as f64;
            chi2 += (c as f64 - expected).powi(2) / expected;
        }
        // 29 degrees of freedom: the 0.999 quantile is 58.3.
        assert!(chi2 < 58.3, "{filter:?}: chi-square {chi2}");
    }

    #[test]
    fn filter_samples_follow_the_filter_shapes() {
        histogram_matches(FilterKind::Box, 0.5, |_| 1.0);
        histogram_matches(FilterKind::Tent, 1.0, |x| 1.0 - x.abs());
        histogram_matches(FilterKind::Gaussian, GAUSSIAN_RADIUS, |x| {
            (-x * x / (2.0 * GAUSSIAN_SIGMA * GAUSSIAN_SIGMA)).exp()
        });
    }

    /// The weights a splat shares out are the densities the camera samples are drawn from: each
    /// integrates to one over its support.
    #[test]
    fn filter_weights_integrate_to_one() {
        for filter in [FilterKind::Box, FilterKind::Tent, FilterKind::Gaussian] {
            let r = filter_radius(filter);
            let k = 400;
            let step = 2.0 * r / k as f32;
            let mut sum = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    let o = Vec2::new(-r + (i as f32 + 0.5) * step, -r + (j as f32 + 0.5) * step);
                    sum += (filter_weight(filter, o) * step * step) as f64;
                }
            }
            assert!((sum - 1.0).abs() < 2e-3, "{filter:?}: {sum}");
        }
    }
}
