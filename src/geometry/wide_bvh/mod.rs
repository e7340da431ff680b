//! A four-wide BVH traversed one ray at a time, its four child boxes tested together in SIMD lanes.
//!
//! obvhs builds the binary tree (PLOC and reinsertion: [`build_bvh2`]); this module decides its leaves
//! by the surface area heuristic with the cost of a leaf counted in the packs of items it needs (a
//! pack of four triangles costs what one does), and flattens the rest into nodes of eight children,
//! opening the largest child first (Wald et al. 2008's collapse, as Embree's BVH8). The boxes stay uncompressed: a node test is six loads and a dozen
//! lane operations, where obvhs's compressed CWBVH spends most of its node test decoding bytes into
//! floats (measured on the Cornell box: 116 ns a ray through raw obvhs for 1.9 nodes and 2.8
//! triangles a ray). Leaves are ranges of up to [`MAX_LEAF_ITEMS`] items the caller defines and
//! tests (triangle packs, spheres): the traversal hands the range over and takes back the new
//! closest distance.
//!
//! `build.rs` builds the binary tree, chooses its leaves and flattens it; `traverse.rs` walks it;
//! this file holds the nodes and the box test.

mod build;
mod traverse;

pub use build::{LeafRule, build_bvh2};
pub use traverse::ClosestLeaf;

use super::offset::gamma;
use wide::f32x8;

/// A lane per child.
type Lanes = f32x8;

/// Children of a node.
pub const WIDTH: usize = 8;
/// Items a leaf may hold (three bits of a child code).
pub const MAX_LEAF_ITEMS: u32 = 8;

/// A child code's leaf bit; then three bits of item count − 1 and 28 of the first item.
const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 28;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;
/// Largest first item a leaf can name.
pub const MAX_ITEMS: u32 = FIRST_MASK;
/// Traversal stack entries held on the stack for shallow trees (the Cornell box's: 2 levels), and for
/// deep ones (a 2 M-triangle mesh: 11); a deeper tree traverses with a heap stack. The array is
/// zeroed for every ray, so it is no larger than the tree needs.
const SHALLOW_STACK: usize = 64 + WIDTH;
/// The stack of trees of one or two levels (the Cornell box's, a moving object's dynamic set): the
/// zeroing of a larger array is most of the traversal of such a tree (a dynamic set of two
/// triangles cost 2% of a 2 M-triangle scene's frame with the 64-entry stack).
const TINY_STACK: usize = 16 + WIDTH;
const DEEP_STACK: usize = 256 + WIDTH;
/// pbrt-v4's slack on a box's exit distance, so that rounding never culls a box the ray enters.
const EXIT_SLACK: f32 = 1.0 + 2.0 * gamma(3);

/// Eight child boxes, a lane each (`bounds[a]` the minimum on axis `a`, `bounds[3 + a]` the
/// maximum), their child codes, and for each octant of ray directions the order to visit them in.
/// An unused child has an empty box, which no ray enters. 256 bytes, four cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    bounds: [Lanes; 6],
    children: [u32; WIDTH],
    /// For rays in octant `q` (bit `a` set: direction ≥ 0 along axis `a`), the children farthest
    /// first: rank `r`'s child in bits `3r..3r + 3` (Fuetterling et al. 2017; tinybvh's `perm8`).
    /// Pushing the hit ones in this order leaves the nearest on top of the stack, with no sort.
    order: [u32; 8],
}

impl Node {
    const EMPTY: Node = Node {
        bounds: [
            Lanes::splat(f32::INFINITY),
            Lanes::splat(f32::INFINITY),
            Lanes::splat(f32::INFINITY),
            Lanes::splat(f32::NEG_INFINITY),
            Lanes::splat(f32::NEG_INFINITY),
            Lanes::splat(f32::NEG_INFINITY),
        ],
        children: [u32::MAX; WIDTH],
        order: [0; 8],
    };

    /// Ask for the node's four cache lines.
    #[inline(always)]
    fn prefetch(&self) {
        prefetch_line(&self.bounds[0]);
        prefetch_line(&self.bounds[2]);
        prefetch_line(&self.bounds[4]);
        prefetch_line(&self.children);
    }

    /// The box around all its children (empty lanes hold an empty box, which changes nothing).
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let min =
            std::array::from_fn(|a| self.bounds[a].to_array().into_iter().fold(f32::INFINITY, f32::min));
        let max = std::array::from_fn(|a| {
            self.bounds[3 + a].to_array().into_iter().fold(f32::NEG_INFINITY, f32::max)
        });
        (min, max)
    }

    /// Which children the ray enters before `t_max` (a bit each), and where.
    #[inline(always)]
    fn intersect(&self, ray: &BoxRay, t_max: f32) -> (u32, Lanes) {
        let slab = |a: usize, side: usize| (self.bounds[side] - ray.o[a]) * ray.inv[a];
        // maxps/minps return their second operand when either is NaN (a ray parallel to a slab
        // that starts on its plane): keeping the running bound second ignores that slab.
        let near = slab(2, ray.near[2])
            .fast_max(slab(1, ray.near[1]).fast_max(slab(0, ray.near[0]).fast_max(Lanes::ZERO)));
        let far = slab(2, ray.far[2])
            .fast_min(slab(1, ray.far[1]).fast_min(slab(0, ray.far[0]).fast_min(Lanes::splat(t_max))));
        let mask = near.simd_le(far * Lanes::splat(EXIT_SLACK)).to_bitmask();
        (mask, near)
    }
}

/// The per-ray part of the box test.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    o: [Lanes; 3],
    inv: [Lanes; 3],
    /// Which of `Node::bounds` the ray enters (and leaves) through, per axis.
    near: [usize; 3],
    far: [usize; 3],
    /// The octant of its direction (bit `a`: non-negative along axis `a`), which picks `Node::order`.
    octant: usize,
}

impl BoxRay {
    /// Prepare the ray `o + t·d`.
    #[inline]
    pub fn new(o: glam::Vec3, d: glam::Vec3) -> Self {
        Self::with_inverse(o, d, Self::inverse(d))
    }

    /// The direction's reciprocal as the box test takes it, three divisions in one instruction
    /// (for callers that share it: the triangle test's shear scale is one of its components).
    #[inline(always)]
    pub fn inverse(d: glam::Vec3) -> glam::Vec3 {
        // -0.0 + 0.0 = +0.0: a zero component must take the same side as its infinite inverse.
        (glam::Vec3A::ONE / (glam::Vec3A::from(d) + glam::Vec3A::ZERO)).into()
    }

    /// [`BoxRay::new`] with `inv` = [`BoxRay::inverse`]`(d)`.
    #[inline(always)]
    pub fn with_inverse(o: glam::Vec3, d: glam::Vec3, inv: glam::Vec3) -> Self {
        let d = d + glam::Vec3::ZERO;
        let side = |a: usize| if d[a] >= 0.0 { (a, 3 + a) } else { (3 + a, a) };
        let (n0, f0) = side(0);
        let (n1, f1) = side(1);
        let (n2, f2) = side(2);
        Self {
            o: [Lanes::splat(o.x), Lanes::splat(o.y), Lanes::splat(o.z)],
            inv: [Lanes::splat(inv.x), Lanes::splat(inv.y), Lanes::splat(inv.z)],
            near: [n0, n1, n2],
            far: [f0, f1, f2],
            octant: (d.x >= 0.0) as usize | ((d.y >= 0.0) as usize) << 1 | ((d.z >= 0.0) as usize) << 2,
        }
    }
}

/// What one traversal did: inner nodes whose boxes it tested and leaves it handed over.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraceCounts {
    /// Inner nodes visited.
    pub nodes: u32,
    /// Leaves visited.
    pub leaves: u32,
}

/// What a traversal counts as it goes: [`TraceCounts`] for the profile, [`Uncounted`] otherwise
/// (a render without `--profile` pays nothing for the counters).
pub trait Counts {
    /// An inner node's boxes were tested.
    fn node(&mut self);
    /// A leaf was handed over.
    fn leaf(&mut self);
}

impl Counts for TraceCounts {
    #[inline(always)]
    fn node(&mut self) {
        self.nodes += 1;
    }

    #[inline(always)]
    fn leaf(&mut self) {
        self.leaves += 1;
    }
}

/// Counts nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Uncounted;

impl Counts for Uncounted {
    #[inline(always)]
    fn node(&mut self) {}

    #[inline(always)]
    fn leaf(&mut self) {}
}

/// A four-wide BVH; its leaves are ranges of items the builder's caller made.
#[derive(Clone, Debug, Default)]
pub struct WideBvh {
    nodes: Vec<Node>,
    /// The traversal stack the tree's depth needs.
    stack: StackSize,
}

/// Which traversal stack a tree needs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum StackSize {
    Tiny,
    #[default]
    Shallow,
    Deep,
    Heap,
}

impl WideBvh {
    /// Inner nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes the nodes take.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * size_of::<Node>()
    }

    /// Recompute every box from the boxes of the leaves (`leaf_box(first, count)`, as min and max),
    /// the tree's shape kept: a refit after its items moved. Children come after their parent in
    /// the node table, so one pass from the end sees every child's box before its parent's.
    pub fn refit(&mut self, leaf_box: impl Fn(u32, u32) -> ([f32; 3], [f32; 3])) {
        for n in (0..self.nodes.len()).rev() {
            for lane in 0..WIDTH {
                let code = self.nodes[n].children[lane];
                if code == u32::MAX {
                    continue;
                }
                let (min, max) = if code & LEAF != 0 {
                    let (first, count) = leaf_range(code);
                    leaf_box(first, count)
                } else {
                    self.nodes[code as usize].bounds()
                };
                let node = &mut self.nodes[n];
                for a in 0..3 {
                    node.bounds[a].as_mut_array()[lane] = min[a];
                    node.bounds[3 + a].as_mut_array()[lane] = max[a];
                }
            }
            self.nodes[n].order = build::visit_orders(&self.nodes[n]);
        }
    }
}

/// Ask for the cache line holding `value` ahead of its use (a node the traversal has pushed): the
/// miss overlaps the work before it is visited. Nothing where the target has no such instruction.
#[inline(always)]
pub fn prefetch_line<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    safe_arch::prefetch_t0(value);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// A leaf code's first item and count.
#[inline(always)]
fn leaf_range(code: u32) -> (u32, u32) {
    (code & FIRST_MASK, ((code >> COUNT_SHIFT) & 7) + 1)
}
