//! Visibility-aware light selection: a grid over the scene learns, from the shadow rays of the first
//! samples, which fraction of the rays from each cell to each cluster of lights (a light-tree node at
//! a fixed depth) got through. When learning ends, each cell gets a distribution over clusters in
//! proportion to their importance at the cell's centre times that learned visibility; later samples
//! pick a cluster from their cell's distribution (one short table lookup), then a light within it by
//! the tree's importance at the shading point.
//!
//! Visibility is estimated as (unoccluded + 1) / (traced + 2) (Laplace's rule), so a cluster the
//! learning samples never reached counts as half visible, not invisible. On top of that the learned
//! distribution is mixed with the plain tree's: with probability [`DEFENSIVE`] a sample comes from the
//! tree alone (Hesterberg's defensive mixture), so every light the tree can choose keeps at least that
//! share of its tree probability. No light with a real contribution gets probability zero, the
//! estimator stays unbiased, and where the learning was wrong the variance grows by at most
//! 1/DEFENSIVE.

use super::LightTree;
use crate::sampling::ONE_MINUS_EPSILON;
use glam::{UVec3, Vec3};
use std::sync::atomic::{AtomicU32, Ordering};

/// Share of samples drawn from the plain tree.
pub const DEFENSIVE: f32 = 0.25;
/// Tree depth of the clusters: up to 2⁴ = 16 per cell (each selection weighs all of them).
pub const CLUSTER_DEPTH: u32 = 4;
const CLUSTERS: usize = 1 << CLUSTER_DEPTH;
/// Cells along the scene's longest side.
const CELLS_LONGEST: f32 = 16.0;
/// Shadow rays a cell must have seen before its learned visibility is used.
const MIN_SAMPLES: u32 = 16;

/// The learned per-cell visibility of each light cluster.
#[derive(Debug)]
pub struct VisibilityGrid {
    min: Vec3,
    inv_cell: f32,
    dims: UVec3,
    /// Per (cell, cluster): shadow rays traced and unoccluded while learning. Counters, so that every
    /// worker records into the one grid and the counts do not depend on the order rays arrive in.
    traced: Vec<AtomicU32>,
    unoccluded: Vec<AtomicU32>,
    /// Per (cell, cluster) after learning: the cumulative distribution over clusters (all zero where
    /// the cell learned nothing).
    cdf: Vec<f32>,
    /// The tree node of each cluster id (`u32::MAX`: none).
    cluster_nodes: Vec<u32>,
    ready: bool,
}

impl Clone for VisibilityGrid {
    fn clone(&self) -> Self {
        let copy =
            |counts: &[AtomicU32]| counts.iter().map(|n| AtomicU32::new(n.load(Ordering::Relaxed))).collect();
        Self {
            min: self.min,
            inv_cell: self.inv_cell,
            dims: self.dims,
            traced: copy(&self.traced),
            unoccluded: copy(&self.unoccluded),
            cdf: self.cdf.clone(),
            cluster_nodes: self.cluster_nodes.clone(),
            ready: self.ready,
        }
    }
}

impl VisibilityGrid {
    /// An empty grid over the box `min`..`max` for the clusters of `tree`.
    pub fn new(min: Vec3, max: Vec3, tree: &LightTree) -> Self {
        let extent = (max - min).max(Vec3::splat(1e-6));
        let cell = extent.max_element() / CELLS_LONGEST;
        let dims = (extent / cell).ceil().as_uvec3().max(UVec3::ONE);
        let cells = (dims.x * dims.y * dims.z) as usize;
        Self {
            min,
            inv_cell: 1.0 / cell,
            dims,
            traced: (0..cells * CLUSTERS).map(|_| AtomicU32::new(0)).collect(),
            unoccluded: (0..cells * CLUSTERS).map(|_| AtomicU32::new(0)).collect(),
            cdf: Vec::new(),
            cluster_nodes: tree.cluster_nodes(CLUSTER_DEPTH),
            ready: false,
        }
    }

    /// Whether learning is over and selection uses the learned visibility.
    pub fn is_ready(&self) -> bool {
        self.ready
    }

    /// The cell of a shading point `p` whose normal `n` faces the side it is shaded from: the point
    /// is moved a quarter cell off the surface first, so the two sides of a wall, which see different
    /// lights, do not share a cell when the wall lies on a cell boundary.
    #[inline]
    fn cell(&self, p: Vec3, n: Vec3) -> usize {
        let p = p + n * (0.25 / self.inv_cell);
        let c = ((p - self.min) * self.inv_cell).max(Vec3::ZERO).as_uvec3().min(self.dims - 1);
        ((c.z * self.dims.y + c.y) * self.dims.x + c.x) as usize
    }

    /// Record one shadow ray from `p` (normal `n` on the shaded side) towards a light of `cluster`,
    /// and whether it got through. Ignored once learning is over.
    pub fn record(&self, p: Vec3, n: Vec3, cluster: u32, unoccluded: bool) {
        if self.ready || !p.is_finite() || !n.is_finite() {
            return;
        }
        let i = self.cell(p, n) * CLUSTERS + cluster as usize % CLUSTERS;
        self.traced[i].fetch_add(1, Ordering::Relaxed);
        if unoccluded {
            self.unoccluded[i].fetch_add(1, Ordering::Relaxed);
        }
    }

    /// End learning: weigh every cluster of every cell by its importance at the cell's centre times
    /// its estimated visibility, and keep the cumulative distribution. Cells with too few rays, or
    /// that no cluster can light, select by the tree alone.
    pub fn finish_learning(&mut self, tree: &LightTree) {
        if self.ready {
            return;
        }
        let cells = self.traced.len() / CLUSTERS;
        self.cdf = vec![0.0; self.traced.len()];
        for cell in 0..cells {
            let traced = &self.traced[cell * CLUSTERS..(cell + 1) * CLUSTERS];
            if traced.iter().map(|n| n.load(Ordering::Relaxed)).sum::<u32>() < MIN_SAMPLES {
                continue;
            }
            let (x, rest) = (cell as u32 % self.dims.x, cell as u32 / self.dims.x);
            let (y, z) = (rest % self.dims.y, rest / self.dims.y);
            let centre = self.min + (UVec3::new(x, y, z).as_vec3() + 0.5) / self.inv_cell;
            let mut acc = 0.0f64;
            let row = &mut self.cdf[cell * CLUSTERS..(cell + 1) * CLUSTERS];
            for (c, &node) in self.cluster_nodes.iter().enumerate() {
                if node != u32::MAX {
                    let i = cell * CLUSTERS + c;
                    let (unoccluded, traced) =
                        (self.unoccluded[i].load(Ordering::Relaxed), self.traced[i].load(Ordering::Relaxed));
                    let visibility = (unoccluded as f64 + 1.0) / (traced as f64 + 2.0);
                    acc += tree.node_importance(node, centre, Vec3::ZERO) as f64 * visibility;
                }
                row[c] = acc as f32;
            }
            if acc > 0.0 && acc.is_finite() {
                row.iter_mut().for_each(|w| *w = (*w as f64 / acc) as f32);
                row[CLUSTERS - 1] = 1.0;
            } else {
                row.fill(0.0);
            }
        }
        self.traced = Vec::new();
        self.unoccluded = Vec::new();
        self.ready = true;
    }

    /// The cluster distribution of the cell holding (p, n), if it learned one.
    #[inline]
    pub(crate) fn row(&self, p: Vec3, n: Vec3) -> Option<&[f32]> {
        if !self.ready || !p.is_finite() || !n.is_finite() {
            return None;
        }
        let cell = self.cell(p, n);
        let row = &self.cdf[cell * CLUSTERS..(cell + 1) * CLUSTERS];
        (row[CLUSTERS - 1] == 1.0).then_some(row)
    }

    /// Pick a light for (p, n): from the tree with probability [`DEFENSIVE`], else a cluster from the
    /// cell's learned distribution and a light in it by the tree. Returns the light and its pmf.
    #[inline]
    pub fn sample(&self, tree: &LightTree, p: Vec3, n: Vec3, u: f32) -> Option<(u32, f32)> {
        let Some(row) = self.row(p, n) else { return tree.sample(p, n, u) };
        let light = if u < DEFENSIVE {
            tree.sample(p, n, u / DEFENSIVE)?.0
        } else {
            let (cluster, u) = choose_cluster(row, u);
            tree.sample_in_cluster(cluster, CLUSTER_DEPTH, p, n, u)?.0
        };
        let pmf = self.pmf(tree, light, p, n);
        (pmf > 0.0).then_some((light, pmf))
    }

    /// The probability that [`VisibilityGrid::sample`] picks `light` at (p, n).
    #[inline]
    pub fn pmf(&self, tree: &LightTree, light: u32, p: Vec3, n: Vec3) -> f32 {
        let Some(row) = self.row(p, n) else { return tree.pmf(light, p, n) };
        let (tree_pmf, in_cluster) = tree.pmf_and_in_cluster(light, CLUSTER_DEPTH, p, n);
        mixture_pmf(row, tree.cluster(light, CLUSTER_DEPTH), tree_pmf, in_cluster)
    }
}

/// The cluster a cell's learned `row` picks for `u` in [0, 1) past the defensive share (`u` is the
/// whole selection number, ≥ [`DEFENSIVE`]), and the number that descends within it.
#[inline]
pub(crate) fn choose_cluster(row: &[f32], u: f32) -> (u32, f32) {
    let u = ((u - DEFENSIVE) / (1.0 - DEFENSIVE)).min(ONE_MINUS_EPSILON);
    let cluster = row.partition_point(|&c| c <= u).min(CLUSTERS - 1);
    let lo = if cluster == 0 { 0.0 } else { row[cluster - 1] };
    (cluster as u32, ((u - lo) / (row[cluster] - lo)).clamp(0.0, ONE_MINUS_EPSILON))
}

/// The mixture's probability of a light in `cluster` whose probability is `tree_pmf` by the tree
/// and `in_cluster` within its cluster, where the cell learned `row`.
#[inline]
pub(crate) fn mixture_pmf(row: &[f32], cluster: u32, tree_pmf: f32, in_cluster: f32) -> f32 {
    let cluster = cluster as usize;
    let p_cluster = row[cluster] - if cluster == 0 { 0.0 } else { row[cluster - 1] };
    DEFENSIVE * tree_pmf + (1.0 - DEFENSIVE) * p_cluster * in_cluster
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::Light;
    use crate::sampling::Sampler;

    fn lights(n: u32) -> Vec<Light> {
        crate::test_scenes::scattered_lights(n, 10.0)
    }

    /// A grid that learned arbitrary weights: every cluster in every cell gets a random share.
    fn learned(tree: &LightTree, lights: &[Light]) -> VisibilityGrid {
        let mut grid = VisibilityGrid::new(Vec3::ZERO, Vec3::splat(10.0), tree);
        for i in 0..200_000u32 {
            let s = Sampler::new(8, i, 0);
            let p = Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) * 10.0;
            let light = (s.get1d(3) * lights.len() as f32) as u32;
            // Occlusion-like: a third of the (cell, light) pairs deliver nothing.
            let lit = s.get1d(4) > 0.33;
            grid.record(p, Vec3::Y, tree.cluster(light, CLUSTER_DEPTH), lit);
        }
        grid.finish_learning(tree);
        grid
    }

    #[test]
    fn mixture_probabilities_sum_to_one_and_match_the_sampling_frequencies() {
        let lights = lights(200);
        let tree = LightTree::build(&lights);
        let grid = learned(&tree, &lights);
        for i in 0..6u32 {
            let s = Sampler::new(13, i, 0);
            let p = Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) * 10.0;
            let n = crate::sampling::warp::uniform_sphere(s.get2d(3));
            assert!(grid.row(p, n).is_some(), "the cell at {p} learned nothing");
            let pmfs: Vec<f64> = (0..lights.len() as u32).map(|l| grid.pmf(&tree, l, p, n) as f64).collect();
            let total: f64 = pmfs.iter().sum();
            assert!((total - 1.0).abs() < 1e-4, "Σ pmf = {total} at {p}");
            let draws = 200_000u32;
            let mut counts = vec![0u32; lights.len()];
            for k in 0..draws {
                let (light, pmf) = grid.sample(&tree, p, n, Sampler::new(21, k, i).get1d(0)).unwrap();
                assert!((pmf / grid.pmf(&tree, light, p, n) - 1.0).abs() < 1e-5);
                counts[light as usize] += 1;
            }
            let p_value = crate::sampling::chi2::discrete_chi2_p_value(&counts, &pmfs, draws).unwrap();
            assert!(p_value > 1e-3, "χ² p-value {p_value} at {p}");
        }
    }

    #[test]
    fn every_light_the_tree_can_choose_keeps_the_defensive_share() {
        let lights = lights(100);
        let tree = LightTree::build(&lights);
        let grid = learned(&tree, &lights);
        let (p, n) = (Vec3::splat(5.0), Vec3::Y);
        for l in 0..lights.len() as u32 {
            assert!(grid.pmf(&tree, l, p, n) >= DEFENSIVE * tree.pmf(l, p, n) * (1.0 - 1e-5));
        }
    }
}
