//! The sampler's dimension layout: which random number feeds which decision, for camera paths and
//! for photons. Every integrator draws through these, so two integrators that make the same decision
//! at the same vertex use the same number.

use crate::sampling::rng::{GROUP, GroupLayout};
use crate::sampling::{Sampler, SamplerKind};
use glam::Vec2;

/// The camera's 5-D sample: pixel filter (2), lens (2), shutter time (1), the sampler's first group
/// of dimensions.
pub mod camera {
    /// Position within the pixel filter (2-D).
    pub const FILTER: u32 = 0;
    /// Position on the lens (2-D).
    pub const LENS: u32 = 2;
    /// Shutter time.
    pub const TIME: u32 = 4;
    /// Dimensions the camera uses; the first bounce starts at the next group.
    pub const DIMENSIONS: u32 = 5;
    /// The camera's pairs, as the sampler draws its group at once.
    pub const LAYOUT: crate::sampling::rng::GroupLayout =
        crate::sampling::rng::GroupLayout::new(1 << FILTER | 1 << LENS);
}

/// Dimensions of one camera-path vertex, from [`bounce_dimension`] on: one group of the sampler's,
/// drawn at once when the vertex starts.
pub mod bounce {
    /// Which light next-event estimation picks.
    pub const LIGHT_SELECT: u32 = 0;
    /// The point on that light (2-D).
    pub const LIGHT_POINT: u32 = 1;
    /// Which BSDF lobe continues the path.
    pub const BSDF_LOBE: u32 = 3;
    /// The direction within the lobe (2-D).
    pub const BSDF_DIRECTION: u32 = 4;
    /// Russian roulette.
    pub const ROULETTE: u32 = 6;
    /// Dimensions per vertex (one spare): a group of the sampler's.
    pub const DIMENSIONS: u32 = super::GROUP;
    /// The vertex's pairs.
    pub const LAYOUT: super::GroupLayout = super::GroupLayout::new(1 << LIGHT_POINT | 1 << BSDF_DIRECTION);
}

/// The first dimension of the vertex at `depth` bounces (the camera's group comes first).
#[inline]
pub fn bounce_dimension(depth: u32) -> u32 {
    (depth + 1) * GROUP
}

/// The random numbers of one camera-path vertex, its group drawn at once (in SIMD lanes: cheaper
/// than drawing the five it may need one by one).
#[derive(Clone, Copy, Debug)]
pub struct VertexSampler {
    u: [f32; 8],
}

impl VertexSampler {
    /// The numbers of the vertex at `depth` of the path that `sampler` (its pixel and sample) drives.
    #[inline]
    pub fn new(sampler: Sampler, depth: u32) -> Self {
        Self { u: sampler.group(bounce_dimension(depth) / GROUP, &bounce::LAYOUT) }
    }

    #[inline(always)]
    fn pair(&self, dim: u32) -> Vec2 {
        Vec2::new(self.u[dim as usize], self.u[dim as usize + 1])
    }

    /// Light selection.
    #[inline]
    pub fn light_select(&self) -> f32 {
        self.u[bounce::LIGHT_SELECT as usize]
    }

    /// The point on the selected light.
    #[inline]
    pub fn light_point(&self) -> Vec2 {
        self.pair(bounce::LIGHT_POINT)
    }

    /// The BSDF lobe.
    #[inline]
    pub fn bsdf_lobe(&self) -> f32 {
        self.u[bounce::BSDF_LOBE as usize]
    }

    /// The direction within the lobe.
    #[inline]
    pub fn bsdf_direction(&self) -> Vec2 {
        self.pair(bounce::BSDF_DIRECTION)
    }

    /// Russian roulette.
    #[inline]
    pub fn roulette(&self) -> f32 {
        self.u[bounce::ROULETTE as usize]
    }
}

/// A photon's dimensions: six at emission, then four per bounce.
pub mod photon {
    /// Shutter time, when the pass does not fix one.
    pub const TIME: u32 = 0;
    /// Which light emits.
    pub const LIGHT: u32 = 1;
    /// The point on the light (2-D).
    pub const POSITION: u32 = 2;
    /// The emitted direction (2-D).
    pub const DIRECTION: u32 = 4;
    /// The first bounce's dimensions start here.
    pub const FIRST_BOUNCE: u32 = 6;
    /// Dimensions per bounce.
    pub const PER_BOUNCE: u32 = 4;
    /// Within a bounce: the BSDF lobe.
    pub const LOBE: u32 = 0;
    /// Within a bounce: the direction in the lobe (2-D).
    pub const BSDF: u32 = 1;
    /// Within a bounce: Russian roulette.
    pub const ROULETTE: u32 = 3;
}

/// The sampler of photon `index` of progressive pass `pass` in a map of kind number `map`: the map
/// keeps a caustic and a global pass independent of each other, the pass number successive passes.
/// With a Sobol sampler a pass's photons are the points of one sequence, stratified over the lights'
/// area and directions (pbrt-v4's SPPM uses Halton points for its photons).
#[inline]
pub fn photon_sampler(kind: SamplerKind, seed: u64, pass: u32, map: u32, index: u32) -> Sampler {
    match kind {
        SamplerKind::Independent => Sampler::new(seed ^ ((pass as u64) << 32), index, (map + 1) << 16),
        SamplerKind::Sobol => Sampler::of(kind, seed ^ ((pass as u64) << 32), u32::MAX - 1 - map, index),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertices_use_disjoint_dimensions_after_the_camera() {
        assert!(bounce_dimension(0) >= camera::DIMENSIONS && bounce_dimension(0).is_multiple_of(GROUP));
        let used =
            [bounce::LIGHT_SELECT, bounce::LIGHT_POINT + 1, bounce::BSDF_DIRECTION + 1, bounce::ROULETTE];
        assert!(
            used.iter().all(|&d| d < bounce::DIMENSIONS),
            "a vertex stays within its {} dimensions",
            bounce::DIMENSIONS
        );
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let v = VertexSampler::new(Sampler::of(kind, 3, 7, 2), 1);
            let s = Sampler::of(kind, 3, 7, 2);
            assert_eq!(v.roulette(), s.get1d(bounce_dimension(1) + bounce::ROULETTE));
            assert_eq!(v.light_select(), s.get1d(bounce_dimension(1) + bounce::LIGHT_SELECT));
            assert_eq!(v.bsdf_lobe(), s.get1d(bounce_dimension(1) + bounce::BSDF_LOBE));
            assert_eq!(v.light_point(), s.get2d(bounce_dimension(1) + bounce::LIGHT_POINT));
            assert_eq!(v.bsdf_direction(), s.get2d(bounce_dimension(1) + bounce::BSDF_DIRECTION));
        }
    }
}
