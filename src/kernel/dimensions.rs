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
    /// Numbers that are all zero (a placeholder for an unused lane).
    pub const EMPTY: Self = Self { u: [0.0; 8] };

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

/// The first dimension of a photon's bounce after `depth` earlier bounces (emission's come first).
#[inline]
pub fn photon_bounce_dimension(depth: u32) -> u32 {
    photon::FIRST_BOUNCE + depth * photon::PER_BOUNCE
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

    /// Vertices checked: far past any path the tests render, and past Russian roulette's start.
    const DEPTHS: u32 = 64;

    /// The decisions of a camera-path vertex: name, first dimension within the vertex, width.
    const VERTEX_DECISIONS: [(&str, u32, u32); 5] = [
        ("light select", bounce::LIGHT_SELECT, 1),
        ("light point", bounce::LIGHT_POINT, 2),
        ("BSDF lobe", bounce::BSDF_LOBE, 1),
        ("BSDF direction", bounce::BSDF_DIRECTION, 2),
        ("roulette", bounce::ROULETTE, 1),
    ];

    /// Record that `what` reads dimension `dim`, failing if another decision already does.
    fn claim(owners: &mut std::collections::HashMap<u32, String>, dim: u32, what: String) {
        if let Some(other) = owners.insert(dim, what.clone()) {
            panic!("dimension {dim} is read by both {other} and {what}");
        }
    }

    /// The layout as numbers: every decision a camera path makes, camera first, then the vertices at
    /// depths 0..64, reads dimensions no other decision reads, and a vertex's stay inside its own
    /// group (the one `VertexSampler::new` draws). Giving the BSDF the light sample's dimensions,
    /// or every vertex the first one's, makes two decisions claim one dimension.
    #[test]
    fn no_two_decisions_of_a_camera_path_share_a_dimension() {
        let mut owners = std::collections::HashMap::new();
        for (name, first, width) in
            [("filter", camera::FILTER, 2), ("lens", camera::LENS, 2), ("time", camera::TIME, 1)]
        {
            for k in 0..width {
                assert!(
                    first + k < camera::DIMENSIONS,
                    "camera {name} reads {} ≥ {}",
                    first + k,
                    camera::DIMENSIONS
                );
                claim(&mut owners, first + k, format!("the camera's {name}"));
            }
        }
        assert!(camera::DIMENSIONS <= bounce_dimension(0), "the camera's group runs into the first vertex's");
        for depth in 0..DEPTHS {
            let base = bounce_dimension(depth);
            assert!(base.is_multiple_of(GROUP), "depth {depth} starts at {base}, not at a group");
            for (name, first, width) in VERTEX_DECISIONS {
                for k in 0..width {
                    let dim = base + first + k;
                    // `VertexSampler::new` draws the group's GROUP lanes, and nothing else.
                    assert!(
                        (base..base + GROUP).contains(&dim),
                        "depth {depth}: {name} reads {dim}, outside its vertex's group {base}..{}",
                        base + GROUP
                    );
                    claim(&mut owners, dim, format!("depth {depth}'s {name}"));
                }
            }
        }
    }

    /// The same for a photon: emission's six dimensions, then four per bounce.
    #[test]
    fn no_two_decisions_of_a_photon_share_a_dimension() {
        let mut owners = std::collections::HashMap::new();
        let emission = [
            ("time", photon::TIME, 1),
            ("light", photon::LIGHT, 1),
            ("position", photon::POSITION, 2),
            ("direction", photon::DIRECTION, 2),
        ];
        for (name, first, width) in emission {
            for k in 0..width {
                assert!(
                    first + k < photon::FIRST_BOUNCE,
                    "emission's {name} reads {} ≥ {}",
                    first + k,
                    photon::FIRST_BOUNCE
                );
                claim(&mut owners, first + k, format!("emission's {name}"));
            }
        }
        let bounce = [
            ("lobe", photon::LOBE, 1),
            ("BSDF direction", photon::BSDF, 2),
            ("roulette", photon::ROULETTE, 1),
        ];
        for depth in 0..DEPTHS {
            let base = photon_bounce_dimension(depth);
            for (name, first, width) in bounce {
                for k in 0..width {
                    let dim = base + first + k;
                    assert!(
                        (base..base + photon::PER_BOUNCE).contains(&dim),
                        "photon bounce {depth}: {name} reads {dim}, outside {base}..{}",
                        base + photon::PER_BOUNCE
                    );
                    claim(&mut owners, dim, format!("photon bounce {depth}'s {name}"));
                }
            }
        }
    }

    /// Columns of numbers, one a path: fails if any two correlate. Pearson's r of n independent
    /// uniform pairs has standard deviation 1/√n; 5/√n is a two-sided p of 6e-7 a pair, so about
    /// 1e-3 over the one to three thousand pairs a test compares (Bonferroni). A shared dimension
    /// gives r = 1.
    fn assert_uncorrelated(what: &str, columns: &[(String, Vec<f64>)]) {
        let n = columns[0].1.len() as f64;
        let bound = 5.0 / n.sqrt();
        let standardised: Vec<Vec<f64>> = columns
            .iter()
            .map(|(_, c)| {
                let mean = c.iter().sum::<f64>() / n;
                let sd = (c.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
                c.iter().map(|v| (v - mean) / sd).collect()
            })
            .collect();
        for a in 0..columns.len() {
            for b in a + 1..columns.len() {
                let r = standardised[a].iter().zip(&standardised[b]).map(|(x, y)| x * y).sum::<f64>() / n;
                assert!(
                    r.abs() < bound,
                    "{what}: {} and {} correlate, r = {r:.3} (bound {bound:.3})",
                    columns[a].0,
                    columns[b].0
                );
            }
        }
    }

    /// The numbers the kernel actually gets: the camera's (drawn as `emit_camera_paths` draws them)
    /// and those `VertexSampler`'s accessors return at depths 0 to 4, over 4096 (pixel, sample)
    /// paths, are pairwise uncorrelated, and no two decisions ever get the same number. This catches
    /// a collision anywhere between the layout and the kernel: an accessor reading another's lanes,
    /// `VertexSampler::new` ignoring the depth, a wrong `bounce_dimension`.
    #[test]
    fn every_decision_of_a_camera_path_gets_its_own_numbers() {
        let n = 4096u32;
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
            let mut column = |name: String, f: &dyn Fn(Sampler) -> f32| {
                let c = (0..n).map(|i| f(Sampler::of(kind, 17, 3 * i + 1, i % 13)) as f64).collect();
                columns.push((name, c));
            };
            column("camera filter x".into(), &|s| s.get2d(camera::FILTER).x);
            column("camera filter y".into(), &|s| s.get2d(camera::FILTER).y);
            column("camera lens x".into(), &|s| s.get2d(camera::LENS).x);
            column("camera lens y".into(), &|s| s.get2d(camera::LENS).y);
            column("camera time".into(), &|s| s.get1d(camera::TIME));
            for depth in 0..5 {
                let vertex = move |s: Sampler| VertexSampler::new(s, depth);
                column(format!("depth {depth} light select"), &|s| vertex(s).light_select());
                column(format!("depth {depth} light point x"), &|s| vertex(s).light_point().x);
                column(format!("depth {depth} light point y"), &|s| vertex(s).light_point().y);
                column(format!("depth {depth} BSDF lobe"), &|s| vertex(s).bsdf_lobe());
                column(format!("depth {depth} BSDF direction x"), &|s| vertex(s).bsdf_direction().x);
                column(format!("depth {depth} BSDF direction y"), &|s| vertex(s).bsdf_direction().y);
                column(format!("depth {depth} roulette"), &|s| vertex(s).roulette());
            }
            // Equal numbers for two decisions of one path: a 24-bit draw repeats by chance with
            // probability 2^-24 a pair, so about 0.2 times in these 4096 × 780 pairs; allow 4.
            let (mut repeats, mut worst) = (0, (0, "", ""));
            for a in 0..columns.len() {
                for b in a + 1..columns.len() {
                    let equal = columns[a].1.iter().zip(&columns[b].1).filter(|(x, y)| x == y).count();
                    repeats += equal;
                    if equal > worst.0 {
                        worst = (equal, &columns[a].0, &columns[b].0);
                    }
                }
            }
            assert!(
                repeats <= 4,
                "{kind:?}: two decisions of one path got the same number {repeats} times, {} and {} \
                 in {} of {n} paths",
                worst.1,
                worst.2,
                worst.0
            );
            assert_uncorrelated(&format!("{kind:?}"), &columns);
        }
    }

    /// A photon's numbers: emission's and its first three bounces', as `emit_photon` and
    /// `scatter_photon` draw them from `photon_sampler`, in two passes of one map and in two maps of
    /// one pass (which must not share numbers either).
    #[test]
    fn every_decision_of_a_photon_gets_its_own_numbers() {
        let n = 4096u32;
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
            for (pass, map) in [(0, 0), (1, 0), (0, 1)] {
                let mut column = |name: String, f: &dyn Fn(Sampler) -> f32| {
                    let c = (0..n).map(|i| f(photon_sampler(kind, 23, pass, map, i)) as f64).collect();
                    columns.push((format!("pass {pass} map {map} {name}"), c));
                };
                column("time".into(), &|s| s.get1d(photon::TIME));
                column("light".into(), &|s| s.get1d(photon::LIGHT));
                column("position x".into(), &|s| s.get2d(photon::POSITION).x);
                column("position y".into(), &|s| s.get2d(photon::POSITION).y);
                column("direction x".into(), &|s| s.get2d(photon::DIRECTION).x);
                column("direction y".into(), &|s| s.get2d(photon::DIRECTION).y);
                for depth in 0..3 {
                    let base = photon_bounce_dimension(depth);
                    column(format!("bounce {depth} lobe"), &|s| s.get1d(base + photon::LOBE));
                    column(format!("bounce {depth} BSDF x"), &|s| s.get2d(base + photon::BSDF).x);
                    column(format!("bounce {depth} BSDF y"), &|s| s.get2d(base + photon::BSDF).y);
                    column(format!("bounce {depth} roulette"), &|s| s.get1d(base + photon::ROULETTE));
                }
            }
            assert_uncorrelated(&format!("{kind:?} photons"), &columns);
        }
    }

    /// Every dimension the kernel draws, as it draws it (this file): the first 2^k samples
    /// of a pixel are stratified in each 1-D dimension and are a (0, k, 2)-net in each 2-D pair.
    #[test]
    fn sobol_samples_of_a_pixel_are_stratified_in_every_dimension_the_kernel_uses() {
        use crate::sampling::{Sampler, SamplerKind};
        let mut pairs = vec![camera::FILTER, camera::LENS];
        let mut singles = vec![camera::TIME];
        for depth in 0..3 {
            let base = bounce_dimension(depth);
            pairs.extend([base + bounce::LIGHT_POINT, base + bounce::BSDF_DIRECTION]);
            singles.extend([base + bounce::LIGHT_SELECT, base + bounce::BSDF_LOBE, base + bounce::ROULETTE]);
        }
        for (pixel, k) in [(0u32, 4u32), (12_345, 6), (7, 8)] {
            let n = 1u32 << k;
            let sampler = |i| Sampler::of(SamplerKind::Sobol, 42, pixel, i);
            for &dim in &singles {
                let mut strata = vec![0; n as usize];
                (0..n).for_each(|i| strata[(sampler(i).get1d(dim) * n as f32) as usize] += 1);
                assert!(strata.iter().all(|&c| c == 1), "pixel {pixel}, dimension {dim}, 2^{k}");
            }
            for &dim in &pairs {
                for a in 0..=k {
                    let (columns, rows) = (1u32 << a, 1u32 << (k - a));
                    let mut cells = vec![0; n as usize];
                    for i in 0..n {
                        let p = sampler(i).get2d(dim);
                        cells[((p.y * rows as f32) as u32 * columns + (p.x * columns as f32) as u32)
                            as usize] += 1;
                    }
                    assert!(cells.iter().all(|&c| c == 1), "pixel {pixel}, pair {dim}, {columns}×{rows}");
                }
            }
        }
    }
}
