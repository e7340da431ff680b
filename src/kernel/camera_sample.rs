//! The numbers a camera sample starts from: its sampler, its point over the pixel filter (stratified
//! across a pass's hit points with the independent sampler), and a progressive pass's shutter time.

use super::dimensions::camera as dim;
use crate::sampling::net::net_point;
use crate::sampling::rng::mix64;
use crate::sampling::{Sampler, SamplerKind};
use glam::Vec2;

/// The sampler of camera sample `sample` of pixel `pixel`.
#[inline]
pub fn camera_sampler(kind: SamplerKind, seed: u64, pixel: u32, sample: u32) -> Sampler {
    Sampler::of(kind, seed, pixel, sample)
}

/// The point over the pixel filter of camera sample `sample` of `pixel`, drawn by `sampler`, when
/// `strata` samples of a pixel share a pass (a progressive mapper's hit points).
#[inline]
pub fn filter_sample(
    sampler: &Sampler,
    kind: SamplerKind,
    seed: u64,
    pixel: u32,
    sample: u32,
    strata: u32,
) -> Vec2 {
    match kind {
        // The sequence itself is a (0, m, 2)-net over any 2^m consecutive samples.
        SamplerKind::Sobol => sampler.get2d(dim::FILTER),
        SamplerKind::Independent => stratified(sampler.get2d(dim::FILTER), seed, pixel, sample, strata),
    }
}

/// The shutter time every camera path and photon of progressive pass `pass` shares (Hachisuka &
/// Jensen 2009, §5): a function of the pass's number in the whole render, so a split render gives
/// each pass the time it has in one run.
#[inline]
pub fn pass_time(kind: SamplerKind, seed: u64, pass: u32) -> f32 {
    Sampler::of(kind, seed, u32::MAX, pass).get1d(0)
}

/// The filter sample of camera sample `sample` of the independent sampler when `strata` samples of a
/// pixel share a pass: point `sample mod strata` of a (0, m, 2)-net scrambled per pixel, so that they
/// cover the pixel evenly in every direction; `u` itself when there is one.
#[inline]
fn stratified(u: Vec2, seed: u64, pixel: u32, sample: u32, strata: u32) -> Vec2 {
    if strata <= 1 {
        return u;
    }
    let bits = mix64(seed ^ mix64(pixel as u64 ^ 0x6e65_7473));
    net_point(sample % strata, [bits as u32, (bits >> 32) as u32])
}

#[cfg(test)]
mod tests {
    use super::stratified;
    use glam::Vec2;

    #[test]
    fn a_pixels_strata_cover_it_in_rows_and_columns() {
        for strata in [4u32, 16, 64] {
            let mut rows = vec![0u32; strata as usize];
            for sample in 0..strata {
                let u = stratified(Vec2::splat(0.5), 7, 3, sample + 5 * strata, strata);
                rows[(u.y * strata as f32) as usize] += 1;
            }
            assert!(rows.iter().all(|&n| n == 1), "{strata}: {rows:?}");
        }
        assert_eq!(stratified(Vec2::new(0.3, 0.7), 7, 3, 5, 1), Vec2::new(0.3, 0.7));
    }
}
