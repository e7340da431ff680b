//! The SD-tree: a binary tree over a cube around the scene whose leaves hold directional distributions
//! (Müller et al. 2017, §5.1). The public face of the module: record, sample, pdf, refine.

use super::GuidingConfig;
use super::cylindrical::to_square;
use super::fixed_point::to_fixed;
use super::quadtree::DirectionalDistribution;
use super::recording::RecordingTree;
use super::selection::{PRIOR_SHARE, SelectionRecording};
use crate::sampling::ONE_MINUS_EPSILON;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// A spatial node is one `u32`: with this bit, the index of its leaf; without, the index of its first
/// child (the second follows it). The split axis is the depth modulo 3, so it need not be stored.
const LEAF: u32 = 1 << 31;

/// No spatial leaf deeper than this: 24 levels per axis exhaust an f32 coordinate in [0, 1).
const MAX_SPATIAL_DEPTH: u32 = 72;

/// What a spatial leaf holds.
#[derive(Debug)]
struct LeafData {
    /// What paths sample from during this iteration (the previous iteration's recording).
    distribution: DirectionalDistribution,
    /// What paths record into during this iteration.
    recording: RecordingTree,
    /// The BSDF's share of this iteration's samples ([`super::selection`]).
    bsdf_share: f32,
    /// What paths record towards the next share.
    selection: SelectionRecording,
    /// Splits above it: its extent along axis a is 2^−⌊(depth + 2 − a) / 3⌋ of the cube's.
    depth: u32,
}

/// The spatio-directional tree: where to send paths, learned from where light came from.
#[derive(Debug)]
pub struct SdTree {
    /// The cube's lowest corner.
    origin: Vec3,
    /// 1 / the cube's side.
    scale: f32,
    nodes: Vec<u32>,
    leaves: Vec<LeafData>,
    config: GuidingConfig,
}

/// Sizes of an [`SdTree`], for the memory budget and the logs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeCounts {
    /// Nodes of the spatial tree, leaves included.
    pub spatial: usize,
    /// Spatial leaves (each with two quadtrees).
    pub leaves: usize,
    /// Nodes of the quadtrees sampled from, over all leaves.
    pub sampling: usize,
    /// Nodes of the quadtrees recorded into, over all leaves.
    pub recording: usize,
    /// Leaves whose guide takes part: it learnt something and kept a share for it.
    pub guiding: usize,
}

/// A spatial leaf, found once per path vertex: sample, evaluate and record there without walking the
/// spatial tree again. It borrows the tree, so it cannot outlive a [`SdTree::refine`].
#[derive(Clone, Copy, Debug)]
pub struct Leaf<'a> {
    data: &'a LeafData,
    index: u32,
}

impl<'a> Leaf<'a> {
    /// Its index in the tree, valid until the next [`SdTree::refine`] ([`SdTree::leaf_at`]).
    pub fn index(&self) -> u32 {
        self.index
    }

    /// Its depth in the spatial tree (0 for the whole cube).
    pub fn depth(&self) -> u32 {
        self.data.depth
    }

    /// The distribution sampled from during this iteration.
    pub fn distribution(&self) -> &'a DirectionalDistribution {
        &self.data.distribution
    }

    /// A direction for the numbers `u` ∈ [0, 1)² and its density per steradian.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        self.data.distribution.sample(u)
    }

    /// The density per steradian of direction `d` (0 for a zero or non-finite vector).
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.data.distribution.pdf(d)
    }

    /// The BSDF's share of the samples here: the configured one, else what the leaf learnt (1 where
    /// guiding does not pay, [`super::selection::PRIOR_SHARE`] before it knows).
    #[inline]
    pub fn bsdf_share(&self) -> f32 {
        self.data.bsdf_share
    }

    /// Record, towards the leaf's next BSDF share, a sample towards `direction` drawn with the
    /// mixture's density `pdf`, whose BSDF density was `bsdf_pdf` and which brought the pixel
    /// `contribution` (luminance of everything the path gathered after the vertex). The guide's
    /// density is looked up here, and only for a sample that brought something: most bring nothing.
    #[inline]
    pub fn record_selection(&self, direction: Vec3, contribution: f32, pdf: f32, bsdf_pdf: f32) {
        if contribution > 0.0 {
            self.data.selection.record(contribution, pdf, bsdf_pdf, self.pdf(direction));
        }
    }

    /// Record the luminance of radiance arriving from `direction` (any non-zero length) divided by the
    /// density it was sampled with. Thread-safe, lock-free, order-independent. A sample of zero
    /// radiance counts towards the spatial split (the paper counts path vertices) but adds no energy;
    /// a NaN, negative or infinite radiance or a zero or non-finite direction is dropped whole, as a
    /// broken estimate that should not steer anything.
    #[inline]
    pub fn record(&self, direction: Vec3, radiance: f32) {
        if let (Some(s), Some(energy)) = (to_square(direction), to_fixed(radiance)) {
            self.data.recording.record(s, energy);
        }
    }
}

impl SdTree {
    /// A tree over the box from `bounds_min` to `bounds_max` with the paper's settings.
    pub fn new(bounds_min: Vec3, bounds_max: Vec3) -> Self {
        Self::with_config(bounds_min, bounds_max, GuidingConfig::default())
    }

    /// A tree over the box with the given settings ([`GuidingConfig::sanitized`]). The tree covers the
    /// cube of the box's longest side from its lowest corner, so that splits cycling x, y, z make
    /// cells of similar extent on every axis. A non-finite box becomes the unit cube; an empty one a
    /// cube of side 1 (points outside are clamped onto it anyway). Every leaf starts uniform.
    pub fn with_config(bounds_min: Vec3, bounds_max: Vec3, config: GuidingConfig) -> Self {
        let config = config.sanitized();
        let (lo, hi) = (bounds_min.min(bounds_max), bounds_min.max(bounds_max));
        let (origin, side) = if lo.is_finite() && hi.is_finite() {
            let side = (hi - lo).max_element();
            (lo, if side > 0.0 && side.is_finite() { side } else { 1.0 })
        } else {
            (Vec3::ZERO, 1.0)
        };
        let nothing = super::recording::Recorded { sums: vec![[0; 4]], children: vec![[0; 4]], samples: 0 };
        let shape = RecordingTree::refined_shape(&nothing, config.directional_threshold, config.max_depth);
        let leaf = LeafData {
            distribution: DirectionalDistribution::default(),
            recording: RecordingTree::with_shape(&shape),
            bsdf_share: config.fixed_bsdf_share.unwrap_or(PRIOR_SHARE),
            selection: SelectionRecording::default(),
            depth: 0,
        };
        Self { origin, scale: 1.0 / side, nodes: vec![LEAF], leaves: vec![leaf], config }
    }

    /// The settings it refines with.
    pub fn config(&self) -> &GuidingConfig {
        &self.config
    }

    /// The leaf holding point `p`: outside the cube, the nearest point of it (NaN coordinates read as
    /// the lowest). The point is scaled into [0, 1)³ once; then each level doubles one coordinate and
    /// drops its integer part, which is exact, so a point's leaf depends on its bits alone.
    #[inline]
    pub fn leaf(&self, p: Vec3) -> Leaf<'_> {
        let unit = |c: f32| if c >= 0.0 { c.min(ONE_MINUS_EPSILON) } else { 0.0 };
        let mut x = ((p - self.origin) * self.scale).to_array().map(unit);
        let (mut node, mut axis) = (0usize, 0usize);
        loop {
            let n = self.nodes[node];
            if n & LEAF != 0 {
                let index = n & !LEAF;
                return Leaf { data: &self.leaves[index as usize], index };
            }
            x[axis] *= 2.0;
            let upper = x[axis] >= 1.0;
            if upper {
                x[axis] -= 1.0;
            }
            node = n as usize + upper as usize;
            axis = if axis == 2 { 0 } else { axis + 1 };
        }
    }

    /// The leaf of a [`Leaf::index`] taken since the last refine; `None` if out of range.
    pub fn leaf_at(&self, index: u32) -> Option<Leaf<'_>> {
        self.leaves.get(index as usize).map(|data| Leaf { data, index })
    }

    /// Record at `p` (see [`Leaf::record`]).
    #[inline]
    pub fn record(&self, p: Vec3, direction: Vec3, radiance: f32) {
        self.leaf(p).record(direction, radiance);
    }

    /// A direction at `p` and its density per steradian (see [`Leaf::sample`]).
    #[inline]
    pub fn sample(&self, p: Vec3, u: Vec2) -> (Vec3, f32) {
        self.leaf(p).sample(u)
    }

    /// The density per steradian at `p` of direction `d` (see [`Leaf::pdf`]).
    #[inline]
    pub fn pdf(&self, p: Vec3, d: Vec3) -> f32 {
        self.leaf(p).pdf(d)
    }

    /// The spatial split threshold after iteration `iteration`: c·√(2^k), exact powers of two and one
    /// correctly rounded √2, so the same on every machine.
    pub fn spatial_threshold(&self, iteration: u32) -> f64 {
        let k = iteration.min(120);
        let odd = if k % 2 == 1 { std::f64::consts::SQRT_2 } else { 1.0 };
        self.config.spatial_threshold * (1u64 << (k / 2)) as f64 * odd
    }

    /// End training iteration `iteration` (0 for the first): what was recorded becomes what is
    /// sampled, spatial leaves that recorded more than [`Self::spatial_threshold`] samples are split
    /// (each half assumed to have seen half, recursively, as in the paper; both start from the
    /// parent's distribution), and every leaf's recording quadtree is reshaped by the energy it saw
    /// and emptied. A leaf that recorded no energy samples the uniform sphere next. Unless the share
    /// is fixed, each leaf chooses its BSDF share from what it recorded ([`super::selection`]).
    ///
    /// Leaves are finished in parallel, each from its own integers alone; the new tree is then built
    /// depth first in the old one's order, so the result does not depend on the thread count.
    pub fn refine(&mut self, iteration: u32) {
        self.refine_within(iteration, usize::MAX);
    }

    /// As [`Self::refine`] if the refined tree, with what refining holds beside it, fits in
    /// `max_bytes`. If it does not (or the allocator refuses its tables), training ends here: the
    /// recorded distributions are kept, no leaf is split, the recording quadtrees are dropped (the
    /// tree then needs less than before), and [`Refined::Capped`] says so. The bytes are counted
    /// before anything is allocated: a tree that would double past the budget is never built.
    pub fn refine_within(&mut self, iteration: u32, max_bytes: usize) -> Refined {
        let (rho, max_depth, fixed) =
            (self.config.directional_threshold, self.config.max_depth, self.config.fixed_bsdf_share);
        let shape_of =
            |leaf: &LeafData| RecordingTree::refined_shape(&leaf.recording.finish(), rho, max_depth);
        // The shapes' sizes first, each shape dropped once counted: a leaf's next recording quadtree
        // may be far larger than its last (a leaf that saw nothing gets a uniform tree as deep as
        // the threshold allows).
        let finished: Vec<Finished> = self
            .leaves
            .par_iter()
            .map(|leaf| {
                let recorded = leaf.recording.finish();
                Finished {
                    distribution: DirectionalDistribution::from_sums(
                        &recorded.sums,
                        &recorded.children,
                        recorded.samples,
                    ),
                    shape_nodes: RecordingTree::refined_shape(&recorded, rho, max_depth).len(),
                    samples: recorded.samples,
                    bsdf_share: fixed
                        .unwrap_or_else(|| leaf.selection.choose(leaf.distribution.is_uniform())),
                }
            })
            .collect();
        let threshold = self.spatial_threshold(iteration);
        let grown = Self::grown_size(&self.nodes, &finished, threshold);
        // Refining holds the finished leaves and the shapes beside the old tree, then beside the
        // new one (the old leaves go before it is built).
        let beside = finished.iter().map(Finished::memory_bytes).sum::<usize>() as f64;
        let peak = beside + grown.bytes.max(self.memory_bytes() as f64);
        let shapes: Option<Vec<Vec<[u16; 4]>>> =
            (peak <= max_bytes as f64).then(|| self.leaves.par_iter().map(shape_of).collect());
        self.leaves = Vec::new();
        let built = shapes
            .as_deref()
            .and_then(|shapes| Rebuild::new(&self.nodes, &finished, threshold, grown, Some(shapes)));
        let (outcome, build) = match built {
            Some(build) => (Refined::Grown, build),
            None => {
                let same = Self::grown_size(&self.nodes, &finished, f64::INFINITY);
                let build = Rebuild::new(&self.nodes, &finished, f64::INFINITY, same, None)
                    .expect("a tree of the old shape without its recordings is smaller than the old one");
                (Refined::Capped, build)
            }
        };
        (self.nodes, self.leaves) = build.run();
        outcome
    }

    /// Nodes, leaves and bytes of the tree `refine` builds from `nodes` and `finished` splitting
    /// above `threshold`: each leaf as often as its samples halve past it (as f64: 72 levels of
    /// splits overflow any integer).
    fn grown_size(nodes: &[u32], finished: &[Finished], threshold: f64) -> GrownSize {
        let mut size = GrownSize { nodes: 0.0, leaves: 0.0, bytes: 0.0 };
        let mut stack = vec![(0usize, 0u32)];
        while let Some((node, depth)) = stack.pop() {
            let n = nodes[node];
            if n & LEAF == 0 {
                size.nodes += 1.0;
                stack.extend([(n as usize, depth + 1), (n as usize + 1, depth + 1)]);
                continue;
            }
            let f = &finished[(n & !LEAF) as usize];
            let mut splits = 0;
            let mut samples = f.samples as f64;
            while samples > threshold && depth + splits < MAX_SPATIAL_DEPTH {
                samples = (samples as u64 / 2) as f64;
                splits += 1;
            }
            let leaves = (splits as f64).exp2();
            size.nodes += 2.0 * leaves - 1.0;
            size.leaves += leaves;
            size.bytes += leaves * f.leaf_bytes() as f64;
        }
        size.bytes += size.nodes * size_of::<u32>() as f64;
        size
    }

    /// Node counts of the spatial tree and of the quadtrees.
    pub fn node_counts(&self) -> NodeCounts {
        NodeCounts {
            spatial: self.nodes.len(),
            leaves: self.leaves.len(),
            sampling: self.leaves.iter().map(|l| l.distribution.node_count()).sum(),
            recording: self.leaves.iter().map(|l| l.recording.node_count()).sum(),
            guiding: self
                .leaves
                .iter()
                .filter(|l| l.bsdf_share < 1.0 && !l.distribution.is_uniform())
                .count(),
        }
    }

    /// Bytes the tree holds: spatial nodes, leaves, and both quadtrees of each (4 bytes a spatial node,
    /// 32 a sampling and 56 a recording quadtree node, 152 a leaf's own fields).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<u32>()
            + self.leaves.len() * size_of::<LeafData>()
            + self
                .leaves
                .iter()
                .map(|l| l.distribution.memory_bytes() + l.recording.memory_bytes())
                .sum::<usize>()
    }

    /// The smallest box around every region whose guide takes part in sampling (it learnt something
    /// and kept a share for it), grown by a millionth of the cube's side so that a point on a face
    /// tests inside; `None` if no region guides. Outside it, a vertex need not find its region.
    pub fn guiding_bounds(&self) -> Option<(Vec3, Vec3)> {
        let side = 1.0 / self.scale;
        let mut bounds: Option<(Vec3, Vec3)> = None;
        // Depth first: (node, its cell's lowest corner and size in units of the cube, depth).
        let mut stack = vec![(0usize, Vec3::ZERO, Vec3::ONE, 0u32)];
        while let Some((node, lo, size, depth)) = stack.pop() {
            let n = self.nodes[node];
            if n & LEAF != 0 {
                let leaf = &self.leaves[(n & !LEAF) as usize];
                if leaf.bsdf_share < 1.0 && !leaf.distribution.is_uniform() {
                    let (a, b) = (self.origin + lo * side, self.origin + (lo + size) * side);
                    bounds = Some(bounds.map_or((a, b), |(l, h)| (l.min(a), h.max(b))));
                }
                continue;
            }
            let axis = (depth % 3) as usize;
            let mut half = size;
            half[axis] *= 0.5;
            let mut upper = lo;
            upper[axis] += half[axis];
            stack.push((n as usize, lo, half, depth + 1));
            stack.push((n as usize + 1, upper, half, depth + 1));
        }
        let margin = Vec3::splat(side * 1e-6);
        bounds.map(|(l, h)| (l - margin, h + margin))
    }

    /// The sampled density per steradian at `p` as an image (see [`DirectionalDistribution::image`]).
    pub fn directional_image(&self, p: Vec3, width: u32, height: u32) -> Vec<f32> {
        self.leaf(p).distribution().image(width, height)
    }

    /// A hash of everything the tree holds (cube, shape, distributions, recorded integers): equal
    /// fingerprints mean the same trees, for the determinism tests across thread counts and orders.
    pub fn fingerprint(&self) -> u64 {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        self.origin.to_array().iter().for_each(|c| h.update(&c.to_bits().to_le_bytes()));
        h.update(&self.scale.to_bits().to_le_bytes());
        self.nodes.iter().for_each(|n| h.update(&n.to_le_bytes()));
        for leaf in &self.leaves {
            h.update(&leaf.depth.to_le_bytes());
            leaf.distribution.hash_into(&mut h);
            h.update(&leaf.bsdf_share.to_bits().to_le_bytes());
            leaf.selection.hash_into(&mut h);
            let recorded = leaf.recording.finish();
            h.update(&recorded.samples.to_le_bytes());
            recorded.sums.iter().flatten().for_each(|s| h.update(&s.to_le_bytes()));
            recorded.children.iter().flatten().for_each(|c| h.update(&c.to_le_bytes()));
        }
        h.digest()
    }
}

/// What [`SdTree::refine_within`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refined {
    /// The tree was refined as the paper's.
    Grown,
    /// The refined tree would not fit: the distributions were kept, nothing split, training ends.
    Capped,
}

/// A leaf after its iteration: its new distribution, its next recording shape, its sample count,
/// its next BSDF share.
struct Finished {
    distribution: DirectionalDistribution,
    /// Nodes of its next recording quadtree's shape.
    shape_nodes: usize,
    samples: u64,
    bsdf_share: f32,
}

impl Finished {
    /// Bytes it and its shape hold while the new tree is built.
    fn memory_bytes(&self) -> usize {
        size_of::<Self>()
            + self.distribution.memory_bytes()
            + size_of::<Vec<[u16; 4]>>()
            + self.shape_nodes * size_of::<[u16; 4]>()
    }

    /// Bytes a leaf made from it holds in the new tree: its fields, its distribution, and the
    /// recording quadtree of its shape.
    fn leaf_bytes(&self) -> usize {
        size_of::<LeafData>()
            + self.distribution.memory_bytes()
            + RecordingTree::bytes_of_shape(self.shape_nodes)
    }
}

/// The size of a tree [`SdTree::refine_within`] may build.
#[derive(Clone, Copy)]
struct GrownSize {
    nodes: f64,
    leaves: f64,
    bytes: f64,
}

/// The new spatial tree being built from the old one and its finished leaves.
struct Rebuild<'a> {
    old: &'a [u32],
    finished: &'a [Finished],
    threshold: f64,
    /// Each finished leaf's recording shape (training goes on), or none (it ends: nothing records).
    shapes: Option<&'a [Vec<[u16; 4]>]>,
    nodes: Vec<u32>,
    leaves: Vec<LeafData>,
}

impl<'a> Rebuild<'a> {
    /// A build with its tables reserved for `size`; `None` if the allocator has not got them.
    fn new(
        old: &'a [u32],
        finished: &'a [Finished],
        threshold: f64,
        size: GrownSize,
        shapes: Option<&'a [Vec<[u16; 4]>]>,
    ) -> Option<Self> {
        let (mut nodes, mut leaves) = (Vec::new(), Vec::new());
        nodes.try_reserve_exact(size.nodes.min(usize::MAX as f64) as usize).ok()?;
        leaves.try_reserve_exact(size.leaves.min(usize::MAX as f64) as usize).ok()?;
        nodes.push(0);
        Some(Self { old, finished, threshold, shapes, nodes, leaves })
    }

    /// The new tree's nodes and leaves.
    fn run(mut self) -> (Vec<u32>, Vec<LeafData>) {
        self.copy(0, 0, 0);
        (self.nodes, self.leaves)
    }

    /// Copy old node `old` (at `depth`) into new node `new`.
    fn copy(&mut self, old: usize, new: usize, depth: u32) {
        let n = self.old[old];
        if n & LEAF != 0 {
            let leaf = (n & !LEAF) as usize;
            self.split(leaf, self.finished[leaf].samples, new, depth);
        } else {
            let first = self.children_of(new);
            self.copy(n as usize, first, depth + 1);
            self.copy(n as usize + 1, first + 1, depth + 1);
        }
    }

    /// Make new node `new` a leaf of finished leaf `leaf`, or, above the threshold, split it and give
    /// each half half the samples.
    fn split(&mut self, leaf: usize, samples: u64, new: usize, depth: u32) {
        if samples as f64 > self.threshold && depth < MAX_SPATIAL_DEPTH {
            let first = self.children_of(new);
            self.split(leaf, samples / 2, first, depth + 1);
            self.split(leaf, samples / 2, first + 1, depth + 1);
        } else {
            let f = &self.finished[leaf];
            self.nodes[new] = LEAF | self.leaves.len() as u32;
            let recording = match self.shapes {
                Some(shapes) => RecordingTree::with_shape(&shapes[leaf]),
                None => RecordingTree::with_shape(&[]),
            };
            self.leaves.push(LeafData {
                distribution: f.distribution.clone(),
                recording,
                bsdf_share: f.bsdf_share,
                selection: SelectionRecording::default(),
                depth,
            });
        }
    }

    /// Two new nodes as the children of `new`; the first's index.
    fn children_of(&mut self, new: usize) -> usize {
        let first = self.nodes.len();
        self.nodes.extend([0, 0]);
        self.nodes[new] = first as u32;
        first
    }
}
