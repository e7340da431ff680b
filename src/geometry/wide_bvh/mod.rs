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
//! `build.rs` builds the binary tree, chooses its leaves and flattens it; this file holds the nodes
//! and the traversal.

mod build;

pub use build::{LeafRule, build_bvh2};

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
        // -0.0 + 0.0 = +0.0: a zero component must take the same side as its infinite inverse.
        let d = d + glam::Vec3::ZERO;
        let side = |a: usize| if d[a] >= 0.0 { (a, 3 + a) } else { (3 + a, a) };
        let (n0, f0) = side(0);
        let (n1, f1) = side(1);
        let (n2, f2) = side(2);
        Self {
            o: [Lanes::splat(o.x), Lanes::splat(o.y), Lanes::splat(o.z)],
            inv: [Lanes::splat(1.0 / d.x), Lanes::splat(1.0 / d.y), Lanes::splat(1.0 / d.z)],
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

    /// The nearest hit before `t_max`: `leaf(first, count, t_max)` tests a leaf's items and returns
    /// the new closest distance (`t_max` when nothing nearer was hit). Returns the closest distance.
    #[inline(always)]
    pub fn closest(
        &self,
        ray: &BoxRay,
        t_max: f32,
        counts: &mut TraceCounts,
        leaf: impl FnMut(u32, u32, f32) -> f32,
    ) -> f32 {
        if self.nodes.is_empty() {
            return t_max;
        }
        match self.stack {
            StackSize::Tiny => {
                closest_with(self, ray, t_max, counts, &mut ArrayStack::<TINY_STACK>::new(), leaf)
            }
            StackSize::Shallow => {
                closest_with(self, ray, t_max, counts, &mut ArrayStack::<SHALLOW_STACK>::new(), leaf)
            }
            StackSize::Deep => {
                closest_with(self, ray, t_max, counts, &mut ArrayStack::<DEEP_STACK>::new(), leaf)
            }
            StackSize::Heap => closest_with(self, ray, t_max, counts, &mut HeapStack(Vec::new()), leaf),
        }
    }

    /// Whether any leaf item blocks the ray before `t_max`: `leaf(first, count)` says whether one of
    /// its items does.
    #[inline(always)]
    pub fn any(
        &self,
        ray: &BoxRay,
        t_max: f32,
        counts: &mut TraceCounts,
        leaf: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        match self.stack {
            StackSize::Tiny => any_with(self, ray, t_max, counts, &mut ArrayStack::<TINY_STACK>::new(), leaf),
            StackSize::Shallow => {
                any_with(self, ray, t_max, counts, &mut ArrayStack::<SHALLOW_STACK>::new(), leaf)
            }
            StackSize::Deep => any_with(self, ray, t_max, counts, &mut ArrayStack::<DEEP_STACK>::new(), leaf),
            StackSize::Heap => any_with(self, ray, t_max, counts, &mut HeapStack(Vec::new()), leaf),
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

/// Where traversal keeps the children it will visit later, with their entry distances.
trait Stack {
    fn push(&mut self, child: u32, t: f32);
    /// Push when `keep`, without a branch where the stack can: the entry is written either way and
    /// kept by moving the top.
    fn push_if(&mut self, child: u32, t: f32, keep: bool);
    fn pop(&mut self) -> Option<(u32, f32)>;
}

/// A stack in an array with room for a node's children past its deepest need (`push_if` writes
/// before it knows whether it keeps).
struct ArrayStack<const N: usize> {
    entries: [(u32, f32); N],
    len: usize,
}

impl<const N: usize> ArrayStack<N> {
    #[inline(always)]
    fn new() -> Self {
        Self { entries: [(0, 0.0); N], len: 0 }
    }
}

impl<const N: usize> Stack for ArrayStack<N> {
    #[inline(always)]
    fn push(&mut self, child: u32, t: f32) {
        self.entries[self.len] = (child, t);
        self.len += 1;
    }

    #[inline(always)]
    fn push_if(&mut self, child: u32, t: f32, keep: bool) {
        self.entries[self.len] = (child, t);
        self.len += keep as usize;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.entries[self.len])
    }
}

struct HeapStack(Vec<(u32, f32)>);

impl Stack for HeapStack {
    fn push(&mut self, child: u32, t: f32) {
        self.0.push((child, t));
    }

    fn push_if(&mut self, child: u32, t: f32, keep: bool) {
        if keep {
            self.0.push((child, t));
        }
    }

    fn pop(&mut self) -> Option<(u32, f32)> {
        self.0.pop()
    }
}

/// Prefetch the inner nodes among `node`'s children in `mask`.
#[inline(always)]
fn prefetch_children(bvh: &WideBvh, node: &Node, mut mask: u32) {
    while mask != 0 {
        let code = node.children[mask.trailing_zeros() as usize];
        mask &= mask - 1;
        if code & LEAF == 0 {
            bvh.nodes[code as usize].prefetch();
        }
    }
}

#[inline(always)]
fn closest_with(
    bvh: &WideBvh,
    ray: &BoxRay,
    mut t_max: f32,
    counts: &mut TraceCounts,
    stack: &mut impl Stack,
    mut leaf: impl FnMut(u32, u32, f32) -> f32,
) -> f32 {
    let mut child = 0u32;
    loop {
        if child & LEAF == 0 {
            let node = &bvh.nodes[child as usize];
            counts.nodes += 1;
            let (mask, near) = node.intersect(ray, t_max);
            if mask != 0 {
                if mask & (mask - 1) == 0 {
                    child = node.children[mask.trailing_zeros() as usize];
                    continue;
                }
                // The hit children, farthest first by the octant's order: the nearest ends on top
                // and is visited next, the others wait (Fuetterling et al. 2017; no sort).
                let near = near.to_array();
                let mut order = node.order[ray.octant];
                for _ in 0..WIDTH {
                    let slot = (order & 7) as usize;
                    order >>= 3;
                    stack.push_if(node.children[slot], near[slot], mask >> slot & 1 != 0);
                }
                prefetch_children(bvh, node, mask);
                child = stack.pop().map_or(0, |(c, _)| c);
                continue;
            }
        } else {
            counts.leaves += 1;
            let (first, count) = leaf_range(child);
            t_max = leaf(first, count, t_max);
        }
        loop {
            match stack.pop() {
                None => return t_max,
                Some((c, t)) if t <= t_max => {
                    child = c;
                    break;
                }
                Some(_) => {}
            }
        }
    }
}

#[inline(always)]
fn any_with(
    bvh: &WideBvh,
    ray: &BoxRay,
    t_max: f32,
    counts: &mut TraceCounts,
    stack: &mut impl Stack,
    mut leaf: impl FnMut(u32, u32) -> bool,
) -> bool {
    let mut child = 0u32;
    loop {
        if child & LEAF == 0 {
            let node = &bvh.nodes[child as usize];
            counts.nodes += 1;
            let (mut mask, _) = node.intersect(ray, t_max);
            if mask != 0 {
                prefetch_children(bvh, node, mask);
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack.push(node.children[i], 0.0);
                }
                child = node.children[first];
                continue;
            }
        } else {
            counts.leaves += 1;
            let (first, count) = leaf_range(child);
            if leaf(first, count) {
                return true;
            }
        }
        match stack.pop() {
            None => return false,
            Some((c, _)) => child = c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec3A};
    use obvhs::BvhBuildParams;
    use obvhs::aabb::Aabb;

    /// Boxes on a grid; every ray's closest box by brute force equals the traversal's, and the
    /// traversal visits far fewer leaves than there are boxes.
    #[test]
    fn closest_and_any_agree_with_brute_force() {
        let mut boxes = Vec::new();
        for x in 0..12 {
            for y in 0..9 {
                for z in 0..7 {
                    let min = Vec3A::new(x as f32, y as f32 * 1.3, z as f32 * 0.7);
                    boxes.push(Aabb::new(min, min + Vec3A::splat(0.4)));
                }
            }
        }
        let indices = (0..boxes.len() as u32).collect();
        let bvh2 = build_bvh2(&boxes, indices, &BvhBuildParams::medium_build());
        let mut leaves: Vec<u32> = Vec::new();
        let rule = LeafRule { pack: 1, max_items: MAX_LEAF_ITEMS, node_cost: 1.0 };
        let bvh = WideBvh::from_bvh2(&bvh2, rule, |prims| {
            let first = leaves.len() as u32;
            leaves.extend_from_slice(prims);
            (first, prims.len() as u32)
        });
        let hit_box = |b: &Aabb, o: Vec3, d: Vec3| {
            let (t0, t1) = ((Vec3::from(b.min) - o) / d, (Vec3::from(b.max) - o) / d);
            let (near, far) = (t0.min(t1).max_element().max(0.0), t0.max(t1).min_element());
            (near <= far).then_some(near)
        };
        let mut visited = 0;
        for i in 0..2000 {
            let s = crate::sampling::Sampler::new(3, i, 0);
            let o = Vec3::new(s.get1d(0) * 14.0 - 1.0, s.get1d(1) * 13.0 - 1.0, s.get1d(2) * 6.0 - 1.0);
            let d = crate::sampling::warp::uniform_sphere(s.get2d(3));
            let expected = boxes.iter().filter_map(|b| hit_box(b, o, d)).fold(f32::INFINITY, f32::min);
            let mut counts = TraceCounts::default();
            let found = bvh.closest(&BoxRay::new(o, d), f32::INFINITY, &mut counts, |first, count, t_max| {
                leaves[first as usize..(first + count) as usize]
                    .iter()
                    .filter_map(|&p| hit_box(&boxes[p as usize], o, d))
                    .fold(t_max, f32::min)
            });
            assert!(
                found == expected || (found - expected).abs() <= 1e-4 * expected,
                "ray {i}: {found} vs {expected}"
            );
            visited += counts.leaves;
            let any = bvh.any(&BoxRay::new(o, d), f32::INFINITY, &mut counts, |first, count| {
                leaves[first as usize..(first + count) as usize]
                    .iter()
                    .any(|&p| hit_box(&boxes[p as usize], o, d).is_some())
            });
            assert_eq!(any, expected.is_finite(), "ray {i}");
        }
        assert!(visited < 2000 * boxes.len() as u32 / 10, "{visited} leaves visited");
    }
}
