//! The quadtree a spatial leaf records into during an iteration, and how its shape for the next
//! iteration follows from what it recorded (Müller et al. 2017, §5.3 and their `DTree::reset`).
//!
//! Its shape is fixed for the whole iteration; only the sums in its leaves change, by atomic integer
//! additions, so recording needs `&self` and no lock, and the result does not depend on the order of
//! the samples (`fixed_point`). Refining it then reads those integers in index order.

use super::fixed_point::AtomicSums;
use super::quadrant;
use glam::Vec2;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};

/// One node: the energy recorded in each quadrant that is a leaf (`child[q] == 0`), and the children.
/// 56 bytes.
#[derive(Debug, Default)]
struct RecordingNode {
    sums: AtomicSums<4>,
    child: [u16; 4],
}

/// A recording quadtree: shape fixed, sums atomic.
#[derive(Debug)]
pub(crate) struct RecordingTree {
    nodes: Vec<RecordingNode>,
    /// Samples recorded, those of zero radiance included: the spatial tree splits on this.
    samples: AtomicU64,
}

/// What a recording tree finished with: its energies per quadrant (an inner quadrant's is its
/// subtree's), its shape, and its sample count.
pub(crate) struct Recorded {
    pub(crate) sums: Vec<[u128; 4]>,
    pub(crate) children: Vec<[u16; 4]>,
    pub(crate) samples: u64,
}

/// Where a node of the refined tree takes its quadrants' energies from: a node of the recorded tree,
/// or a recorded leaf quadrant being subdivided, whose energy is assumed spread evenly over it.
#[derive(Clone, Copy)]
enum Source {
    Node(usize),
    Even(u128),
}

impl RecordingTree {
    /// An empty tree of the given shape (children after their parents, root at 0).
    pub(crate) fn with_shape(children: &[[u16; 4]]) -> Self {
        let nodes = children.iter().map(|&child| RecordingNode { child, ..Default::default() }).collect();
        Self { nodes, samples: AtomicU64::new(0) }
    }

    /// Quadtree nodes.
    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of its nodes.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<RecordingNode>()
    }

    /// Bytes of the nodes of a tree of a shape of `nodes` nodes.
    pub(crate) fn bytes_of_shape(nodes: usize) -> usize {
        nodes * size_of::<RecordingNode>()
    }

    /// Count one sample, and add `energy` (fixed point; 0 adds nothing) to the quadrant holding point
    /// `s` ∈ [0, 1)² of the square.
    #[inline]
    pub(crate) fn record(&self, mut s: Vec2, energy: u128) {
        self.samples.fetch_add(1, Ordering::Relaxed);
        // No nodes: training has ended (`SdTree::refine_within`), and nothing is recorded.
        if energy == 0 || self.nodes.is_empty() {
            return;
        }
        let mut node = 0;
        loop {
            let n = &self.nodes[node];
            let q = quadrant(&mut s);
            if n.child[q] == 0 {
                n.sums.add(q, energy);
                return;
            }
            node = n.child[q] as usize;
        }
    }

    /// The sums with every inner quadrant's filled in from its subtree, children before parents
    /// (children have larger indices), so the result is a fixed function of the recorded integers.
    pub(crate) fn finish(&self) -> Recorded {
        let samples = self.samples.load(Ordering::Relaxed);
        if self.nodes.is_empty() {
            return Recorded { sums: vec![[0; 4]], children: vec![[0; 4]], samples };
        }
        let mut sums = vec![[0u128; 4]; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let n = &self.nodes[i];
            for q in 0..4 {
                sums[i][q] = match n.child[q] {
                    0 => n.sums.get(q),
                    c => sums[c as usize].iter().fold(0u128, |a, &b| a.saturating_add(b)),
                };
            }
        }
        let children = self.nodes.iter().map(|n| n.child).collect();
        Recorded { sums, children, samples }
    }

    /// The fixed shape of the next iteration's tree: a quadrant holding more than `threshold` of the
    /// whole tree's energy is split, recursively (a recorded leaf quadrant as if its energy were spread
    /// evenly, so one bright cell is cut as finely as its energy warrants in one step, as in the
    /// paper), and a node whose quadrant holds less is dropped with its subtree: its quadrant becomes
    /// a leaf. No node deeper than `max_depth` (the root's quadrants are at depth 1), no more than
    /// 2^16 nodes (children are `u16` indices; at the cap the deepest splits are the ones left out).
    /// With no energy at all, every quadrant holds its area's share (a uniform tree as deep as
    /// `threshold` allows).
    ///
    /// Breadth first, so the nodes near the root, visited by every sample, sit together in memory.
    pub(crate) fn refined_shape(recorded: &Recorded, threshold: f64, max_depth: u32) -> Vec<[u16; 4]> {
        let total = recorded.sums.first().map_or(0, |s| s.iter().fold(0u128, |a, &b| a.saturating_add(b)));
        let mut children = vec![[0u16; 4]];
        let mut queue = VecDeque::from([(0usize, Source::Node(0), 1u32)]);
        while let Some((node, source, depth)) = queue.pop_front() {
            let energies = match source {
                Source::Node(i) => recorded.sums[i],
                Source::Even(e) => [e; 4],
            };
            for q in 0..4 {
                let fraction =
                    if total > 0 { energies[q] as f64 / total as f64 } else { 0.25f64.powi(depth as i32) };
                if depth >= max_depth || fraction <= threshold || children.len() > u16::MAX as usize {
                    continue;
                }
                let below = match source {
                    Source::Node(i) if recorded.children[i][q] != 0 => {
                        Source::Node(recorded.children[i][q] as usize)
                    }
                    _ => Source::Even(energies[q] / 4),
                };
                children[node][q] = children.len() as u16;
                children.push([0; 4]);
                queue.push_back((children.len() - 1, below, depth + 1));
            }
        }
        children
    }
}
