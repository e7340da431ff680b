//! Path guiding: a learned distribution of incident radiance to sample directions from (issue 49),
//! the SD-tree of Müller, Gross & Novák 2017, "Practical Path Guiding for Efficient Light-Transport
//! Simulation", with the details of Vorba et al. 2019 ("Path Guiding in Production", course notes).
//!
//! A binary tree over space (a cube around the scene, split at midpoints cycling x, y, z) whose leaves
//! each hold a quadtree over directions (the cylindrical square of the sphere). Training runs in
//! iterations of doubling sample counts: during an iteration, paths *sample* from the distribution the
//! previous iteration built and *record* what they found into a second quadtree per leaf; then
//! [`SdTree::refine`] makes the recorded energies the new distribution, splits spatial leaves that saw
//! more than c·√(2^k) samples, and reshapes each recording quadtree by where the energy went (splitting
//! quadrants above ρ of a leaf's energy, collapsing those below).
//!
//! Why it looks as it does:
//! - Determinism: everything recorded is an integer (fixed-point energies, sample counts) added
//!   atomically, and refining reads those integers in index order, so a trained tree has the same bits
//!   however many threads recorded and in whatever order ([`SdTree::fingerprint`]).
//! - No lock on the hot path: [`SdTree::record`] takes `&self` (one or two relaxed `fetch_add`s);
//!   sampling reads a tree nobody writes during the iteration.
//! - Speed: flat arrays with child indices (4 bytes a spatial node, 32 a sampling quadtree node),
//!   no allocation per sample, one walk per level. [`SdTree::leaf`] finds a vertex's leaf once, for
//!   its sample, pdf and record; a [`Leaf`] borrows the tree, so it cannot outlive a `refine`.
//!
//! Not here yet (the integrators' part): which vertices record and with what radiance, the
//! one-sample MIS between BSDF and guide, and the spatial box filter of recorded samples.

mod cylindrical;
mod fixed_point;
mod quadtree;
mod recording;
pub mod selection;
mod spatial;

#[cfg(test)]
mod tests;

pub use cylindrical::{INV_FOUR_PI, from_square, to_square};
pub use quadtree::DirectionalDistribution;
pub use selection::{CANDIDATE_SHARES, PRIOR_SHARE};
pub use spatial::{Leaf, NodeCounts, Refined, SdTree};

use quadtree::quadrant;

/// The deepest quadtree [`GuidingConfig::max_depth`] allows: a square coordinate in f32 has 24 bits.
pub const MAX_QUADTREE_DEPTH: u32 = 24;

/// How an [`SdTree`] refines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuidingConfig {
    /// c: a spatial leaf that recorded more than c·√(2^k) samples in iteration k is split (the paper's
    /// 12 000). The √ grows the threshold slower than the doubling sample count, so the tree keeps
    /// refining, but each leaf's quadtree still sees more samples every iteration.
    pub spatial_threshold: f64,
    /// ρ: a quadrant holding more than this share of its leaf's energy is split, one holding less
    /// collapsed (the paper's 0.01). At most 1/ρ quadrants per depth can exceed it, so a quadtree holds
    /// at most about `max_depth / ρ` nodes.
    pub directional_threshold: f64,
    /// Deepest quadtree node (the root's quadrants are at depth 1); at most [`MAX_QUADTREE_DEPTH`].
    pub max_depth: u32,
    /// The BSDF's share of a guided vertex's samples, the same everywhere; `None`: each leaf learns
    /// its own ([`selection`]).
    pub fixed_bsdf_share: Option<f32>,
}

impl Default for GuidingConfig {
    /// The paper's: c = 12 000, ρ = 0.01, depth 20; the BSDF's share learnt.
    fn default() -> Self {
        Self {
            spatial_threshold: 12_000.0,
            directional_threshold: 0.01,
            max_depth: 20,
            fixed_bsdf_share: None,
        }
    }
}

impl GuidingConfig {
    /// The settings made usable: a NaN or negative c becomes the default; ρ is kept in [1e-4, 1] (below,
    /// the node cap of a quadtree would cut the refinement short wherever it happened to be); the
    /// depth in 1..=[`MAX_QUADTREE_DEPTH`].
    pub fn sanitized(self) -> Self {
        let default = Self::default();
        let c =
            if self.spatial_threshold >= 0.0 { self.spatial_threshold } else { default.spatial_threshold };
        let rho = if self.directional_threshold.is_nan() {
            default.directional_threshold
        } else {
            self.directional_threshold.clamp(1e-4, 1.0)
        };
        Self {
            spatial_threshold: c,
            directional_threshold: rho,
            max_depth: self.max_depth.clamp(1, MAX_QUADTREE_DEPTH),
            // Never 0: the BSDF keeps every direction it can reach possible.
            fixed_bsdf_share: self.fixed_bsdf_share.map(|a| if a > 0.0 { a.min(1.0) } else { PRIOR_SHARE }),
        }
    }
}
