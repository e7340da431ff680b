//! The directional distribution a spatial leaf samples from: a quadtree over the cylindrical square,
//! piecewise constant in each of its leaves (Müller et al. 2017, §5.2–5.3).
//!
//! Each node stores its four quadrants' shares of the node's own energy, not of the whole tree's, so a
//! deep node keeps full f32 precision however small its absolute share. Sampling walks down once,
//! choosing a quadrant per level and rescaling the same two random numbers into it (hierarchical
//! warping), so a sample costs one pass of at most `max_depth` levels, no allocation, and keeps the
//! stratification of the numbers it was given.

use super::cylindrical::{INV_FOUR_PI, from_square, to_square};
use crate::sampling::ONE_MINUS_EPSILON;
use glam::{Vec2, Vec3};

/// One node: quadrant `q` (bit 0: x ≥ ½, bit 1: y ≥ ½) holds `share[q]` of the node's energy and is
/// a leaf where `child[q]` is 0 (the root is never a child). 24 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SamplingNode {
    pub(crate) share: [f32; 4],
    pub(crate) child: [u16; 4],
}

/// A directional density over the sphere, piecewise constant on a quadtree of the cylindrical square.
/// With no nodes it is the uniform sphere: a leaf that recorded no energy guides nowhere in particular.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DirectionalDistribution {
    pub(crate) nodes: Vec<SamplingNode>,
    /// The recorded energy (sum of radiance / pdf) it was built from.
    energy: f64,
    /// How many samples it was built from, those that carried no energy included.
    samples: u64,
}

/// The quadrant of point `s` of a node's square, and `s` rescaled into that quadrant. Doubling and
/// subtracting one are exact in floating point, so the walk cuts `s` at exactly the cell boundaries.
#[inline]
pub(crate) fn quadrant(s: &mut Vec2) -> usize {
    *s *= 2.0;
    let (right, top) = (s.x >= 1.0, s.y >= 1.0);
    s.x -= right as u8 as f32;
    s.y -= top as u8 as f32;
    right as usize | (top as usize) << 1
}

/// Random numbers clamped into [0, 1)², NaN to 0: what the warp below may assume.
#[inline]
fn unit(u: Vec2) -> Vec2 {
    let clamp = |x: f32| if x >= 0.0 { x.min(ONE_MINUS_EPSILON) } else { 0.0 };
    Vec2::new(clamp(u.x), clamp(u.y))
}

/// Choose between two intervals of weights `a` and `b` (not both zero) with `u`, and rescale `u` into
/// the chosen one: measure preserving, so the numbers stay uniform for the next level. An interval
/// of weight zero is never chosen, even where `u · (a + b)` rounds up to `a + b`.
#[inline]
fn split(u: f32, a: f32, b: f32) -> (bool, f32) {
    let x = u * (a + b);
    let (second, v) = if x < a || b == 0.0 { (false, x / a) } else { (true, (x - a) / b) };
    (second, v.clamp(0.0, ONE_MINUS_EPSILON))
}

impl DirectionalDistribution {
    /// The distribution of a tree's finished sums: `sums[n][q]` is the energy of quadrant `q` of node
    /// `n` (a whole subtree's for an inner quadrant), `children` the tree's shape. Children come after
    /// their parents, as the recording tree builds them.
    pub(crate) fn from_sums(sums: &[[u128; 4]], children: &[[u16; 4]], samples: u64) -> Self {
        let total = |s: &[u128; 4]| s.iter().fold(0u128, |a, &b| a.saturating_add(b));
        let root = sums.first().map_or(0, total);
        if root == 0 {
            return Self { nodes: Vec::new(), energy: 0.0, samples };
        }
        let nodes = sums
            .iter()
            .zip(children)
            .map(|(s, &child)| {
                let t = total(s);
                // A node without energy is never reached (its quadrant has share zero); even shares
                // keep its arithmetic finite all the same.
                let share = if t == 0 { [0.25; 4] } else { s.map(|x| (x as f64 / t as f64) as f32) };
                SamplingNode { share, child }
            })
            .collect();
        Self { nodes, energy: super::fixed_point::from_fixed(root), samples }
    }

    /// Whether this is the uniform sphere (nothing recorded, or nothing but zero radiance).
    pub fn is_uniform(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The energy (sum of recorded radiance / pdf) it was built from.
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The samples it was built from, those of zero radiance included.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Quadtree nodes (0 for the uniform sphere).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of its nodes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<SamplingNode>()
    }

    /// A direction for the numbers `u` ∈ [0, 1)² and its density per steradian.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (s, density) = self.sample_square(u);
        (from_square(s), density * INV_FOUR_PI)
    }

    /// The density per steradian of direction `d` (any non-zero length; 0 for a zero or non-finite
    /// vector). The same products as [`Self::sample`]'s, so the two agree to the bit in the same cell.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        to_square(d).map_or(0.0, |s| self.pdf_square(s) * INV_FOUR_PI)
    }

    /// A point of the square and its density there (per unit area of the square).
    pub(crate) fn sample_square(&self, u: Vec2) -> (Vec2, f32) {
        let mut u = unit(u);
        if self.nodes.is_empty() {
            return (u, 1.0);
        }
        let (mut origin, mut size, mut density, mut node) = (Vec2::ZERO, 1.0f32, 1.0f32, 0usize);
        loop {
            let SamplingNode { share: [s0, s1, s2, s3], child } = self.nodes[node];
            // Column first (x), then the row within it: the two choices multiply to the quadrant's share.
            let (right, ux) = split(u.x, s0 + s2, s1 + s3);
            let (top, uy) = if right { split(u.y, s1, s3) } else { split(u.y, s0, s2) };
            let q = right as usize | (top as usize) << 1;
            density *= 4.0 * [s0, s1, s2, s3][q];
            size *= 0.5;
            origin += size * Vec2::new(right as u8 as f32, top as u8 as f32);
            u = Vec2::new(ux, uy);
            if child[q] == 0 {
                return (origin + size * u, density);
            }
            node = child[q] as usize;
        }
    }

    /// The density at point `s` ∈ [0, 1)² of the square.
    pub(crate) fn pdf_square(&self, mut s: Vec2) -> f32 {
        if self.nodes.is_empty() {
            return 1.0;
        }
        let (mut density, mut node) = (1.0f32, 0usize);
        loop {
            let n = &self.nodes[node];
            let q = quadrant(&mut s);
            density *= 4.0 * n.share[q];
            if n.child[q] == 0 || density == 0.0 {
                return density;
            }
            node = n.child[q] as usize;
        }
    }

    /// The density per steradian as a `width` × `height` image (row-major, top row first) for
    /// debugging: column x is φ = 2π(x + ½)/width, row y is cos θ = 1 − 2(y + ½)/height, so the top row
    /// looks along +z. Each pixel is the density at its centre.
    pub fn image(&self, width: u32, height: u32) -> Vec<f32> {
        let (w, h) = (width as f32, height as f32);
        let mut out = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                let s = Vec2::new(1.0 - (y as f32 + 0.5) / h, (x as f32 + 0.5) / w);
                out.push(self.pdf_square(s.min(Vec2::splat(ONE_MINUS_EPSILON))) * INV_FOUR_PI);
            }
        }
        out
    }

    /// Feed its exact contents to a hasher (for the determinism fingerprint).
    pub(crate) fn hash_into(&self, hasher: &mut xxhash_rust::xxh3::Xxh3) {
        hasher.update(&self.energy.to_bits().to_le_bytes());
        hasher.update(&self.samples.to_le_bytes());
        for n in &self.nodes {
            n.share.iter().for_each(|s| hasher.update(&s.to_bits().to_le_bytes()));
            n.child.iter().for_each(|c| hasher.update(&c.to_le_bytes()));
        }
    }
}
