//! Building a wide BVH: obvhs's binary tree (PLOC, reinsertion), the leaves chosen on it by the
//! surface area heuristic, and its flattening into nodes of eight children.

use super::{
    COUNT_SHIFT, DEEP_STACK, LEAF, MAX_ITEMS, MAX_LEAF_ITEMS, Node, SHALLOW_STACK, StackSize, TINY_STACK,
    WIDTH, WideBvh,
};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::ploc::PlocBuilder;

/// obvhs's binary tree over `aabbs`, each standing for primitive `indices[i]` (several boxes may
/// stand for one primitive when large triangles were split): PLOC, then reinsertion. Every leaf holds
/// one box, its `first_index` the primitive it stands for; [`WideBvh::from_bvh2`] chooses the leaves.
pub fn build_bvh2(aabbs: &[Aabb], indices: Vec<u32>, params: &BvhBuildParams) -> Bvh2 {
    // Not `with_capacity`: that sizes the Morton buffer for 128-bit codes, twice what U64 needs.
    let mut bvh2 = PlocBuilder::new().build(
        params.ploc_search_distance,
        aabbs,
        indices,
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    bvh2
}

/// How leaves are chosen: a subtree of at most `max_items` packs of `pack` primitives becomes a leaf
/// when testing its packs costs no more, by the surface area heuristic, than descending it, with a
/// node's box test costing `node_cost` packs.
#[derive(Clone, Copy, Debug)]
pub struct LeafRule {
    /// Primitives per item (4 for triangle packs, 1 for spheres).
    pub pack: u32,
    /// Most items in a leaf (at most [`MAX_LEAF_ITEMS`]).
    pub max_items: u32,
    /// What a node's box test costs, in item tests.
    pub node_cost: f32,
}

/// Which binary nodes become leaves: bottom-up SAH costs, then the highest subtrees that chose to be
/// leaves.
fn choose_leaves(bvh2: &Bvh2, rule: LeafRule) -> Vec<bool> {
    let n = bvh2.nodes.len();
    let (mut prims, mut cost, mut leaf) = (vec![0u32; n], vec![0f32; n], vec![false; n]);
    // Post-order without recursion: children before parents.
    let mut order = Vec::with_capacity(n);
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        order.push(i);
        if !bvh2.nodes[i].is_leaf() {
            let first = bvh2.nodes[i].first_index as usize;
            stack.extend([first, first + 1]);
        }
    }
    for &i in order.iter().rev() {
        let node = &bvh2.nodes[i];
        let area = node.aabb().half_area();
        if node.is_leaf() {
            (prims[i], cost[i], leaf[i]) = (1, area, true);
            continue;
        }
        let first = node.first_index as usize;
        prims[i] = prims[first] + prims[first + 1];
        let items = prims[i].div_ceil(rule.pack);
        let descend = rule.node_cost * area + cost[first] + cost[first + 1];
        let as_leaf = items as f32 * area;
        leaf[i] = items <= rule.max_items && as_leaf <= descend;
        cost[i] = if leaf[i] { as_leaf } else { descend };
    }
    leaf
}

/// The primitives of the binary subtree at `index`.
fn subtree_primitives(bvh2: &Bvh2, index: usize, out: &mut Vec<u32>) {
    out.clear();
    let mut stack = vec![index];
    while let Some(i) = stack.pop() {
        let node = &bvh2.nodes[i];
        if node.is_leaf() {
            out.push(node.first_index);
        } else {
            stack.extend([node.first_index as usize, node.first_index as usize + 1]);
        }
    }
    out.sort_unstable();
    out.dedup();
}

impl WideBvh {
    /// Flatten `bvh2` (made by [`build_bvh2`]), its leaves chosen by `rule`. `make_leaf` receives
    /// the primitives of each leaf (duplicates from split boxes removed) and returns the range of
    /// items it stored for them: its first item and how many (1 to [`MAX_LEAF_ITEMS`], the first at
    /// most [`MAX_ITEMS`]).
    pub fn from_bvh2(bvh2: &Bvh2, rule: LeafRule, mut make_leaf: impl FnMut(&[u32]) -> (u32, u32)) -> Self {
        if bvh2.nodes.is_empty() {
            return Self::default();
        }
        let is_leaf = choose_leaves(bvh2, rule);
        let mut nodes = vec![Node::EMPTY];
        let mut prims = Vec::new();
        let mut leaf_code = |index: usize, prims: &mut Vec<u32>| {
            subtree_primitives(bvh2, index, prims);
            let (item, count) = make_leaf(prims);
            assert!(
                (1..=MAX_LEAF_ITEMS).contains(&count) && item <= MAX_ITEMS,
                "a leaf of {count} items from {item}"
            );
            LEAF | (count - 1) << COUNT_SHIFT | item
        };
        // (binary node, depth, wide node and lane to fill); the root fills node 0.
        let mut work = vec![(0usize, 1u32, 0usize, usize::MAX)];
        let mut max_depth = 1;
        while let Some((index, depth, parent, lane)) = work.pop() {
            if lane != usize::MAX && is_leaf[index] {
                nodes[parent].children[lane] = leaf_code(index, &mut prims);
                continue;
            }
            // A root that is a leaf becomes node 0 with one child.
            let kids = if is_leaf[index] { vec![index] } else { open_children(bvh2, &is_leaf, index) };
            let slot = if lane == usize::MAX {
                0
            } else {
                nodes.push(Node::EMPTY);
                nodes[parent].children[lane] = (nodes.len() - 1) as u32;
                nodes.len() - 1
            };
            max_depth = max_depth.max(depth);
            for (j, &kid) in kids.iter().enumerate() {
                let aabb = bvh2.nodes[kid].aabb();
                let (min, max) = (aabb.min.to_array(), aabb.max.to_array());
                for a in 0..3 {
                    nodes[slot].bounds[a].as_mut_array()[j] = min[a];
                    nodes[slot].bounds[3 + a].as_mut_array()[j] = max[a];
                }
                if kid == index {
                    nodes[slot].children[j] = leaf_code(index, &mut prims);
                } else {
                    work.push((kid, depth + 1, slot, j));
                }
            }
        }
        for node in &mut nodes {
            node.order = visit_orders(node);
        }
        // A node pushes at most WIDTH − 1 children, and the path down holds one node per level;
        // `push_if` writes one entry past the top before it knows whether it keeps it.
        let needed = (max_depth as usize) * (WIDTH - 1) + 1 + WIDTH;
        let stack = if needed <= TINY_STACK {
            StackSize::Tiny
        } else if needed <= SHALLOW_STACK {
            StackSize::Shallow
        } else if needed <= DEEP_STACK {
            StackSize::Deep
        } else {
            tracing::warn!(
                "the BVH is {max_depth} levels deep (degenerate geometry?): tracing with a slower heap stack"
            );
            StackSize::Heap
        };
        Self { nodes, stack }
    }
}

/// For each octant of ray directions, the node's children farthest first: sorted by how far along
/// the octant's diagonal the corner a ray of that octant enters them by lies (Fuetterling et al.
/// 2017). Empty lanes sort last, behind everything: no ray enters them, so they are never pushed.
pub(super) fn visit_orders(node: &Node) -> [u32; 8] {
    std::array::from_fn(|octant| {
        let key = |lane: usize| {
            if node.children[lane] == u32::MAX {
                return f32::NEG_INFINITY;
            }
            (0..3)
                .map(|a| {
                    let positive = octant >> a & 1 == 1;
                    let corner = node.bounds[if positive { a } else { 3 + a }].as_array()[lane];
                    if positive { corner } else { -corner }
                })
                .sum::<f32>()
        };
        let mut lanes: [usize; WIDTH] = std::array::from_fn(|i| i);
        lanes.sort_by(|&a, &b| key(b).total_cmp(&key(a)).then(a.cmp(&b)));
        lanes.iter().enumerate().fold(0, |order, (rank, &lane)| order | (lane as u32) << (3 * rank))
    })
}

/// The binary node's children, opened (a child replaced by its own two) largest surface first
/// until there are [`WIDTH`] or only leaves remain.
fn open_children(bvh2: &Bvh2, is_leaf: &[bool], index: usize) -> Vec<usize> {
    let first = bvh2.nodes[index].first_index as usize;
    let mut kids = vec![first, first + 1];
    while kids.len() < WIDTH {
        let widest = kids
            .iter()
            .enumerate()
            .filter(|&(_, &k)| !is_leaf[k])
            .max_by(|a, b| {
                bvh2.nodes[*a.1].aabb().half_area().total_cmp(&bvh2.nodes[*b.1].aabb().half_area())
            })
            .map(|(i, _)| i);
        let Some(i) = widest else { break };
        let opened = bvh2.nodes[kids[i]].first_index as usize;
        kids[i] = opened;
        kids.push(opened + 1);
    }
    kids
}
