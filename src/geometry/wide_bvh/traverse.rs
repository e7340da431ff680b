//! The traversal: nearest hit and any hit, children visited nearest first from a stack sized to
//! the tree (an array on the stack for all but the deepest trees), their nodes prefetched as pushed.

use super::{
    BoxRay, Counts, DEEP_STACK, LEAF, Node, SHALLOW_STACK, StackSize, TINY_STACK, WIDTH, WideBvh, leaf_range,
};

impl WideBvh {
    /// The nearest hit before `t_max`: `leaf(first, count, t_max)` tests a leaf's items and returns
    /// the new closest distance (`t_max` when nothing nearer was hit). Returns the closest distance.
    #[inline(always)]
    pub fn closest(&self, ray: &BoxRay, t_max: f32, counts: &mut impl Counts, leaf: impl ClosestLeaf) -> f32 {
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
        counts: &mut impl Counts,
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

/// A leaf's test for the nearest hit: `nearest(first, count, t_max)` tests the leaf's items and
/// returns the new closest distance (`t_max` when nothing nearer was hit). A closure is one; a
/// type of its own whose `nearest` is `#[inline(always)]` is compiled into the traversal loop,
/// where a closure's body may be left a call that reloads its constants every leaf (the still
/// triangle packs' test: 6–10% of the Cornell box's closest-hit time). Any-hit leaves measured no
/// different either way and stay closures.
pub trait ClosestLeaf {
    /// The leaf's nearest hit before `t_max`.
    fn nearest(&mut self, first: u32, count: u32, t_max: f32) -> f32;
}

impl<F: FnMut(u32, u32, f32) -> f32> ClosestLeaf for F {
    #[inline(always)]
    fn nearest(&mut self, first: u32, count: u32, t_max: f32) -> f32 {
        self(first, count, t_max)
    }
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
    counts: &mut impl Counts,
    stack: &mut impl Stack,
    mut leaf: impl ClosestLeaf,
) -> f32 {
    let mut child = 0u32;
    loop {
        if child & LEAF == 0 {
            let node = &bvh.nodes[child as usize];
            counts.node();
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
            counts.leaf();
            let (first, count) = leaf_range(child);
            t_max = leaf.nearest(first, count, t_max);
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
    counts: &mut impl Counts,
    stack: &mut impl Stack,
    mut leaf: impl FnMut(u32, u32) -> bool,
) -> bool {
    let mut child = 0u32;
    loop {
        if child & LEAF == 0 {
            let node = &bvh.nodes[child as usize];
            counts.node();
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
            counts.leaf();
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
    use crate::geometry::wide_bvh::{BoxRay, LeafRule, MAX_LEAF_ITEMS, TraceCounts, WideBvh, build_bvh2};
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
