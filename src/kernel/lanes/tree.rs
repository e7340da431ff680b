//! The light tree's descent in lanes (`LightTree::sample`): every lane walks from the root to a
//! leaf, one level per step, the two children's bounds of each lane's node gathered into lanes and
//! their importances computed together. A scalar descent spends most of its time waiting on the
//! square roots and divisions of one importance after another (51% of `pt`'s time on veach-mis
//! with tree selection); in lanes eight of them share each instruction. Every lane runs the scalar
//! code's operations in its order, so it picks the light and probability the scalar descent does,
//! bit for bit (`tests.rs`).

use super::v3::{Mask, MaskBits, V3, select};
use super::{Lanes, WIDTH};
use crate::lights::tree::{Node, NodeBounds};
use crate::lights::visibility::{CLUSTER_DEPTH, DEFENSIVE, choose_cluster, mixture_pmf};
use crate::lights::{LightTree, Lights, VisibilityGrid};
use crate::sampling::ONE_MINUS_EPSILON;

/// A node's bounds in each lane.
struct BoundsLanes {
    center: V3,
    phi: Lanes,
    w: V3,
    cos_theta_o: Lanes,
    sin_theta_o: Lanes,
    cos_theta_e: Lanes,
    radius2: Lanes,
    min_d2: Lanes,
}

impl BoundsLanes {
    /// The bounds of node `index[i]` in lane `i`.
    #[inline(always)]
    fn gather(nodes: &[Node], index: &[u32; WIDTH]) -> Self {
        let b: [&NodeBounds; WIDTH] = std::array::from_fn(|i| &nodes[index[i] as usize].bounds);
        let lanes = |f: fn(&NodeBounds) -> f32| Lanes::new(std::array::from_fn(|i| f(b[i])));
        Self {
            center: V3::gather(|i| b[i].center),
            phi: lanes(|b| b.phi),
            w: V3::gather(|i| b[i].w),
            cos_theta_o: lanes(|b| b.cos_theta_o),
            sin_theta_o: lanes(|b| b.sin_theta_o),
            cos_theta_e: lanes(|b| b.cos_theta_e),
            radius2: lanes(|b| b.radius2),
            min_d2: lanes(|b| b.min_d2),
        }
    }

    /// `NodeBounds::importance` in lanes; `has_n` where the lane's `n` is not zero.
    #[inline(always)]
    fn importance(&self, p: V3, n: V3, has_n: Mask) -> Lanes {
        let (zero, one) = (Lanes::ZERO, Lanes::ONE);
        let safe_sqrt = |x: Lanes| x.max(zero).sqrt();
        // cos(a − b) and sin(a − b), clamped to 1 and 0 where a < b (cos a > cos b).
        let cos_sub = |sin_a: Lanes, cos_a: Lanes, sin_b: Lanes, cos_b: Lanes| {
            select(cos_a.simd_gt(cos_b), one, cos_a * cos_b + sin_a * sin_b)
        };
        let sin_sub = |sin_a: Lanes, cos_a: Lanes, sin_b: Lanes, cos_b: Lanes| {
            select(cos_a.simd_gt(cos_b), zero, sin_a * cos_b - cos_a * sin_b)
        };
        let d = p - self.center;
        let dist2 = d.dot(d);
        let wi = V3::select(dist2.simd_gt(zero), d.scale(one / dist2.sqrt()), V3::splat(0.0));
        let cos_w = self.w.dot(wi);
        let sin_w = safe_sqrt(one - cos_w * cos_w);
        let cos_b = select(dist2.simd_lt(self.radius2), -one, safe_sqrt(one - self.radius2 / dist2));
        let sin_b = safe_sqrt(one - cos_b * cos_b);
        let cos_x = cos_sub(sin_w, cos_w, self.sin_theta_o, self.cos_theta_o);
        let sin_x = sin_sub(sin_w, cos_w, self.sin_theta_o, self.cos_theta_o);
        let cos_p = cos_sub(sin_x, cos_x, sin_b, cos_b);
        let importance = self.phi * cos_p / dist2.max(self.min_d2).max(Lanes::splat(f32::MIN_POSITIVE));
        let cos_i = wi.dot(n).abs();
        let sin_i = safe_sqrt(one - cos_i * cos_i);
        let importance = select(has_n, importance * cos_sub(sin_i, cos_i, sin_b, cos_b), importance);
        select(cos_p.simd_le(self.cos_theta_e), zero, importance.max(zero))
    }
}

/// `LightTree::sample` for the lanes in `active`: each lane's light and its probability, `None`
/// where the scalar descent returns none (and for the lanes not in `active`).
pub fn sample_tree(
    tree: &LightTree,
    p: V3,
    n: V3,
    u: [f32; WIDTH],
    active: u32,
) -> [Option<(u32, f32)>; WIDTH] {
    descend(tree, p, n, u, Descent { active, root_checked: active, cluster: [0; WIDTH], depth: [0; WIDTH] })
}

/// Which lanes descend and how: the lanes in `root_checked` first ask whether the root reaches
/// their point (`LightTree::sample`); lane `i` takes the first `depth[i]` turns of `cluster[i]`'s
/// bits without choosing (`LightTree::sample_in_cluster`), its probability within the cluster.
struct Descent {
    active: u32,
    root_checked: u32,
    cluster: [u32; WIDTH],
    depth: [u32; WIDTH],
}

/// The children of each walking lane's node and the probability of its first:
/// `LightTree::split` in lanes, and the lanes where it has none (both children rule the point out
/// and hold no power).
#[inline(always)]
fn split(
    nodes: &[Node],
    node: &[u32; WIDTH],
    walking: u32,
    p: V3,
    n: V3,
    has_n: Mask,
) -> ([u32; WIDTH], [u32; WIDTH], Lanes, u32) {
    // Lanes that have stopped walk along with the first that has not (their results are kept).
    let lead = node[walking.trailing_zeros() as usize];
    let at: [u32; WIDTH] = std::array::from_fn(|i| if walking >> i & 1 == 1 { node[i] } else { lead });
    let first: [u32; WIDTH] = std::array::from_fn(|i| at[i] + 1);
    let second: [u32; WIDTH] = std::array::from_fn(|i| nodes[at[i] as usize].index);
    let (a, b) = (BoundsLanes::gather(nodes, &first), BoundsLanes::gather(nodes, &second));
    let (ia, ib) = (a.importance(p, n, has_n), b.importance(p, n, has_n));
    // By importance, by power where both children rule the point out.
    let total = ia + ib;
    let by_importance = total.simd_gt(Lanes::ZERO) & total.is_finite();
    let phi = a.phi + b.phi;
    let p_first = select(by_importance, ia / total, a.phi / phi);
    let no_split = (!by_importance & !phi.simd_gt(Lanes::ZERO)).bits();
    (first, second, p_first, no_split)
}

/// Each walking lane goes down to its first child where `first_turn` has its bit, else to its
/// second; a lane that reaches a leaf stops walking.
#[inline(always)]
fn step_down(
    nodes: &[Node],
    node: &mut [u32; WIDTH],
    walking: &mut u32,
    first_turn: u32,
    (first, second): ([u32; WIDTH], [u32; WIDTH]),
) {
    let mut still = *walking;
    while still != 0 {
        let i = still.trailing_zeros() as usize;
        still &= still - 1;
        node[i] = if first_turn >> i & 1 == 1 { first[i] } else { second[i] };
        if nodes[node[i] as usize].leaf {
            *walking &= !(1 << i);
        }
    }
}

/// The lanes whose bit `level` of `bits[i]` is clear (a first turn on a trail or cluster prefix).
#[inline(always)]
fn first_turns(bits: &[u64; WIDTH], level: u32) -> u32 {
    (0..WIDTH).fold(0u32, |turns, i| turns | ((bits[i] & (1 << level) == 0) as u32) << i)
}

fn descend(tree: &LightTree, p: V3, n: V3, u: [f32; WIDTH], how: Descent) -> [Option<(u32, f32)>; WIDTH] {
    let nodes = tree.nodes();
    let mut chosen = [None; WIDTH];
    if nodes.is_empty() || how.active == 0 {
        return chosen;
    }
    let has_n = !n.is_zero();
    let mut reached = how.active;
    if how.root_checked != 0 {
        let root = BoundsLanes::gather(nodes, &[0; WIDTH]).importance(p, n, has_n);
        reached &= !(root.simd_le(Lanes::ZERO).bits() & how.root_checked);
    }
    let mut node = [0u32; WIDTH];
    let cluster = how.cluster.map(u64::from);
    // Every walking lane is as deep as the others: all start at the root and go down together.
    let mut level = 0u32;
    let mut u = Lanes::new(u);
    let mut pmf = Lanes::ONE;
    let mut walking = if nodes[0].leaf { 0 } else { reached };
    let mut lost = 0u32;
    while walking != 0 {
        let (first, second, p_first, no_split) = split(nodes, &node, walking, p, n, has_n);
        // Lanes still within their forced prefix turn as their cluster says and choose nothing.
        let forced = (0..WIDTH).fold(0u32, |bits, i| bits | ((level < how.depth[i]) as u32) << i) & walking;
        let no_split = no_split & walking & !forced;
        let go_first = u.simd_lt(p_first);
        let one_minus_epsilon = Lanes::splat(ONE_MINUS_EPSILON);
        let u_next = select(
            go_first,
            (u / p_first).min(one_minus_epsilon),
            ((u - p_first) / (Lanes::ONE - p_first)).min(one_minus_epsilon),
        );
        let choosing = walking & !forced;
        let moving = Mask::from_fn(|i| choosing >> i & 1 == 1);
        u = select(moving, u_next, u);
        pmf = select(moving, pmf * select(go_first, p_first, Lanes::ONE - p_first), pmf);
        lost |= no_split;
        walking &= !no_split;
        let first_turn = (forced & first_turns(&cluster, level)) | (!forced & go_first.bits());
        step_down(nodes, &mut node, &mut walking, first_turn, (first, second));
        level += 1;
    }
    let pmf = pmf.to_array();
    let mut found = reached & !lost;
    while found != 0 {
        let i = found.trailing_zeros() as usize;
        found &= found - 1;
        chosen[i] = (pmf[i] > 0.0).then_some((nodes[node[i] as usize].index, pmf[i]));
    }
    chosen
}

/// `LightTree::pmf_and_in_cluster(light[i], depth, p, n)` for the lanes in `active`: each lane
/// walks its light's trail from the root, the splits on the way computed in lanes.
fn pmf_along_trails(
    tree: &LightTree,
    light: [u32; WIDTH],
    depth: u32,
    p: V3,
    n: V3,
    active: u32,
) -> [(f32, f32); WIDTH] {
    let nodes = tree.nodes();
    let mut out = [(0.0, 0.0); WIDTH];
    if nodes.is_empty() {
        return out;
    }
    let trail: [u64; WIDTH] = std::array::from_fn(|i| tree.trail(light[i]).unwrap_or(0));
    let known = (0..WIDTH).fold(0u32, |bits, i| bits | (tree.trail(light[i]).is_some() as u32) << i);
    let active = active & known;
    if active == 0 {
        return out;
    }
    let has_n = !n.is_zero();
    let root = BoundsLanes::gather(nodes, &[0; WIDTH]).importance(p, n, has_n);
    let root = root.simd_gt(Lanes::ZERO).bits();
    let (mut above, mut below) = (Lanes::ONE, Lanes::ONE);
    let mut node = [0u32; WIDTH];
    let mut level = 0u32;
    let mut walking = if nodes[0].leaf { 0 } else { active };
    let mut dead = 0u32;
    while walking != 0 {
        let (first, second, p_first, no_split) = split(nodes, &node, walking, p, n, has_n);
        let first_turn = first_turns(&trail, level);
        let turn_first = Mask::from_fn(|i| first_turn >> i & 1 == 1);
        let p_turn = select(turn_first, p_first, Lanes::ONE - p_first);
        let moving = Mask::from_fn(|i| walking >> i & 1 == 1);
        if level < depth {
            let none = Mask::from_fn(|i| no_split >> i & 1 == 1);
            above = select(moving, above * select(none, Lanes::ZERO, p_turn), above);
        } else {
            dead |= no_split & walking;
            walking &= !no_split;
            below = select(moving, below * p_turn, below);
        }
        step_down(nodes, &mut node, &mut walking, first_turn, (first, second));
        level += 1;
    }
    let (above, below) = (above.to_array(), below.to_array());
    let mut found = active & !dead;
    while found != 0 {
        let i = found.trailing_zeros() as usize;
        found &= found - 1;
        if nodes[node[i] as usize].index == light[i] {
            out[i] = (if root >> i & 1 == 1 { above[i] * below[i] } else { 0.0 }, below[i]);
        }
    }
    out
}

/// `VisibilityGrid::sample` for the lanes in `active`: where a lane's cell has learned, the
/// defensive share descends the tree and the rest a cluster the cell picks (its first turns
/// forced); each picked light's probability under the mixture is then walked along its trail in
/// lanes. Where the cell has not learned, the tree alone.
fn sample_visible(
    tree: &LightTree,
    grid: &VisibilityGrid,
    p: V3,
    n: V3,
    u: [f32; WIDTH],
    active: u32,
) -> [Option<(u32, f32)>; WIDTH] {
    let (ps, ns) = (p.lanes(), n.lanes());
    let rows: [Option<&[f32]>; WIDTH] =
        std::array::from_fn(|i| if active >> i & 1 == 1 { grid.row(ps[i], ns[i]) } else { None });
    let (mut u_tree, mut root_checked, mut cluster, mut depth) = (u, active, [0u32; WIDTH], [0u32; WIDTH]);
    for i in 0..WIDTH {
        let Some(row) = rows[i] else { continue };
        if u[i] < DEFENSIVE {
            u_tree[i] = u[i] / DEFENSIVE;
        } else {
            (cluster[i], u_tree[i]) = choose_cluster(row, u[i]);
            depth[i] = CLUSTER_DEPTH;
            root_checked &= !(1 << i);
        }
    }
    let descended = descend(tree, p, n, u_tree, Descent { active, root_checked, cluster, depth });
    let learned = (0..WIDTH).fold(0u32, |bits, i| bits | (rows[i].is_some() as u32) << i);
    let picked = (0..WIDTH).fold(0u32, |bits, i| bits | (descended[i].is_some() as u32) << i);
    let light = descended.map(|c| c.map_or(0, |(light, _)| light));
    let mixture = learned & picked;
    let pmfs = if mixture != 0 {
        pmf_along_trails(tree, light, CLUSTER_DEPTH, p, n, mixture)
    } else {
        [(0.0, 0.0); WIDTH]
    };
    std::array::from_fn(|i| {
        // A cell that has not learned keeps the tree's own pick and probability.
        let Some(row) = rows[i] else { return descended[i] };
        let picked = descended[i]?.0;
        let (tree_pmf, in_cluster) = pmfs[i];
        let pmf = mixture_pmf(row, tree.cluster(picked, CLUSTER_DEPTH), tree_pmf, in_cluster);
        (pmf > 0.0).then_some((picked, pmf))
    })
}

/// `Lights::select` for the first `count` lanes: by the tree in lanes (visibility-aware or not),
/// else `Lights::select_many` (the selector's searches interleaved).
#[inline(never)]
pub fn select_lights(
    lights: &Lights,
    p: V3,
    n: V3,
    u_select: [f32; WIDTH],
    count: usize,
) -> [Option<(u32, f32)>; WIDTH] {
    if let Some((tree, tree_share)) = lights.tree_alone() {
        by_tree(lights, u_select, count, tree_share, |u, descend| sample_tree(tree, p, n, u, descend))
    } else if let Some((tree, grid, tree_share)) = lights.tree_and_visibility() {
        by_tree(lights, u_select, count, tree_share, |u, descend| {
            sample_visible(tree, grid, p, n, u, descend)
        })
    } else {
        lights.select_many(&p.lanes(), &n.lanes(), &u_select, count)
    }
}

/// The tree's share of the selections (the infinite lights' chosen apart, `Lights::split_tree_share`),
/// its lanes descended by `sample(u, lanes)`.
#[inline(always)]
fn by_tree(
    lights: &Lights,
    u_select: [f32; WIDTH],
    count: usize,
    tree_share: f32,
    sample: impl FnOnce([f32; WIDTH], u32) -> [Option<(u32, f32)>; WIDTH],
) -> [Option<(u32, f32)>; WIDTH] {
    let mut chosen = [None; WIDTH];
    let mut u = [0.0; WIDTH];
    let mut descend = 0u32;
    for i in 0..count {
        match lights.split_tree_share(u_select[i]) {
            Err(infinite) => chosen[i] = infinite,
            Ok(u_tree) => (u[i], descend) = (u_tree, descend | 1 << i),
        }
    }
    let in_tree = sample(u, descend);
    for i in 0..count {
        if descend >> i & 1 == 1 {
            chosen[i] = in_tree[i].map(|(index, pmf)| (index, pmf * tree_share));
        }
    }
    chosen
}
