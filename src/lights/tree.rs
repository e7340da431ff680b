//! A light tree: a bounding-volume hierarchy over the emitters whose nodes carry power, spatial bounds
//! and an orientation cone, descended by an importance that accounts for power, distance and
//! orientation towards the shading point (Conty Estevez & Kulla 2018, as pbrt-v4's BVHLightSampler).
//!
//! Nodes are stored flat in depth-first order (a node's first child follows it, the second is at
//! `second`), and every light keeps the bit trail of its path from the root, so its probability at a
//! shading point is recomputed exactly by walking that path: MIS with BSDF sampling stays unbiased.

use super::{Light, LightShape};
use crate::sampling::ONE_MINUS_EPSILON;
use glam::{Quat, Vec3};
use std::f32::consts::PI;

/// What a node knows about the lights below it.
#[derive(Clone, Copy, Debug)]
pub struct LightBounds {
    /// Spatial bounds over the shutter (moving lights included).
    pub min: Vec3,
    /// Spatial bounds, upper corner.
    pub max: Vec3,
    /// Emitted power (luminance).
    pub phi: f32,
    /// Axis of the cone of surface normals.
    pub w: Vec3,
    /// Cosine of the half-angle of that cone (−1: any direction).
    pub cos_theta_o: f32,
    /// Cosine of the spread of emission around each normal (0: a hemisphere, Lambertian emitters).
    pub cos_theta_e: f32,
}

impl LightBounds {
    /// The bounds of one light.
    pub fn of(light: &Light) -> Self {
        // cos θe: the spread of emission about each normal (a hemisphere for surfaces, none beyond
        // the cone for a spot, whose θo + θe is its outer angle, as pbrt-v4's SpotLight::Bounds).
        let (min, max, w, cos_theta_o, cos_theta_e) = match light.shape {
            LightShape::Triangle { p, n, .. } => {
                let min = p[0].min(p[1]).min(p[2]);
                let max = p[0].max(p[1]).max(p[2]);
                (min, max, n, 1.0, 0.0)
            }
            LightShape::Sphere { center, radius } => (center - radius, center + radius, Vec3::Z, -1.0, 0.0),
            LightShape::Point { position, spot: None } => (position, position, Vec3::Z, -1.0, 0.0),
            LightShape::Point { position, spot: Some(s) } => {
                let spread = s.cos_outer.clamp(-1.0, 1.0).acos() - s.cos_inner.clamp(-1.0, 1.0).acos();
                (position, position, s.axis, s.cos_inner, spread.cos())
            }
            // Infinitely far: no power in the tree (it is selected beside it, as the environment).
            LightShape::Sun { .. } => {
                return Self {
                    min: Vec3::ZERO,
                    max: Vec3::ZERO,
                    phi: 0.0,
                    w: Vec3::Z,
                    cos_theta_o: -1.0,
                    cos_theta_e: 0.0,
                };
            }
        };
        let (min, max) = (min.min(min + light.motion), max.max(max + light.motion));
        Self { min, max, phi: light.power(), w, cos_theta_o, cos_theta_e }
    }

    /// The bounds of two groups of lights (pbrt-v4 `Union(LightBounds, LightBounds)`).
    pub fn union(&self, other: &Self) -> Self {
        if self.phi == 0.0 {
            return *other;
        }
        if other.phi == 0.0 {
            return *self;
        }
        let (w, cos_theta_o) = cone_union(self.w, self.cos_theta_o, other.w, other.cos_theta_o);
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
            phi: self.phi + other.phi,
            w,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(other.cos_theta_e),
        }
    }

    /// How much light these lights may send to a point `p` with normal `n` (zero `n`: no surface),
    /// an upper bound up to a constant: power × the best-case cosine at the lights / the squared
    /// distance × the best-case cosine at `p` (pbrt-v4 `LightBounds::Importance`).
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        NodeBounds::new(*self).importance(p, n)
    }
}

/// [`LightBounds`] with what every importance evaluation needs precomputed: the tree's descent
/// evaluates two of these per level for every light sample.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeBounds {
    pub(crate) center: Vec3,
    pub(crate) phi: f32,
    pub(crate) w: Vec3,
    pub(crate) cos_theta_o: f32,
    pub(crate) sin_theta_o: f32,
    pub(crate) cos_theta_e: f32,
    /// Squared radius of the bounding sphere of the box.
    pub(crate) radius2: f32,
    /// pbrt's floor on the squared distance, half the box diagonal (keeps near points finite).
    pub(crate) min_d2: f32,
}

impl NodeBounds {
    fn new(b: LightBounds) -> Self {
        let diagonal = b.max - b.min;
        Self {
            center: 0.5 * (b.min + b.max),
            phi: b.phi,
            w: b.w,
            cos_theta_o: b.cos_theta_o,
            sin_theta_o: (1.0 - b.cos_theta_o * b.cos_theta_o).max(0.0).sqrt(),
            cos_theta_e: b.cos_theta_e,
            radius2: 0.25 * diagonal.length_squared(),
            min_d2: 0.5 * diagonal.length(),
        }
    }

    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let cos_sub = |sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32| {
            if cos_a > cos_b { 1.0 } else { cos_a * cos_b + sin_a * sin_b }
        };
        let sin_sub = |sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32| {
            if cos_a > cos_b { 0.0 } else { sin_a * cos_b - cos_a * sin_b }
        };
        let safe_sqrt = |x: f32| x.max(0.0).sqrt();
        let d = p - self.center;
        let dist2 = d.length_squared();
        let wi = if dist2 > 0.0 { d * dist2.sqrt().recip() } else { Vec3::ZERO };
        let cos_w = self.w.dot(wi);
        let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        // The cone of directions from p that the bounds subtend.
        let cos_b = if dist2 < self.radius2 { -1.0 } else { safe_sqrt(1.0 - self.radius2 / dist2) };
        let sin_b = safe_sqrt(1.0 - cos_b * cos_b);
        let cos_x = cos_sub(sin_w, cos_w, self.sin_theta_o, self.cos_theta_o);
        let sin_x = sin_sub(sin_w, cos_w, self.sin_theta_o, self.cos_theta_o);
        let cos_p = cos_sub(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        // A point light's bounds have no extent: keep a shading point on top of it finite.
        let mut importance = self.phi * cos_p / dist2.max(self.min_d2).max(f32::MIN_POSITIVE);
        if n != Vec3::ZERO {
            let cos_i = wi.dot(n).abs();
            let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
            importance *= cos_sub(sin_i, cos_i, sin_b, cos_b);
        }
        importance.max(0.0)
    }
}

/// The smallest cone holding two cones (pbrt-v4 `Union(DirectionCone, DirectionCone)`).
fn cone_union(wa: Vec3, cos_a: f32, wb: Vec3, cos_b: f32) -> (Vec3, f32) {
    let (theta_a, theta_b) = (cos_a.clamp(-1.0, 1.0).acos(), cos_b.clamp(-1.0, 1.0).acos());
    let theta_d = wa.angle_between(wb);
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (wa, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (wb, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= PI {
        return (Vec3::Z, -1.0);
    }
    let axis = wa.cross(wb);
    if axis.length_squared() == 0.0 {
        return (Vec3::Z, -1.0);
    }
    let w = Quat::from_axis_angle(axis.normalize(), theta_o - theta_a) * wa;
    (w.normalize(), theta_o.cos())
}

/// A node: its bounds and either its second child (interior; the first child is the next node) or
/// its light (leaf).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub(crate) bounds: NodeBounds,
    /// Second child's index for an interior node, the light's index for a leaf.
    pub(crate) index: u32,
    pub(crate) leaf: bool,
}

/// The light tree.
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// Per light: its path from the root, one bit per level (1 = second child), lowest bit first.
    trails: Vec<u64>,
}

impl LightTree {
    /// Build the tree over `lights` (lights with no power are left out: they are never chosen).
    pub fn build(lights: &[Light]) -> Self {
        let mut items: Vec<(u32, LightBounds)> = lights
            .iter()
            .enumerate()
            .map(|(i, l)| (i as u32, LightBounds::of(l)))
            .filter(|(_, b)| b.phi > 0.0 && b.min.is_finite() && b.max.is_finite())
            .collect();
        let mut tree = Self { nodes: Vec::with_capacity(2 * items.len()), trails: vec![0; lights.len()] };
        if !items.is_empty() {
            tree.build_range(&mut items, 0, 0);
        }
        tree
    }

    fn build_range(&mut self, items: &mut [(u32, LightBounds)], trail: u64, depth: u32) -> LightBounds {
        if items.len() == 1 || depth >= 63 {
            // Depth 63 can only be reached by 2^63 lights; the guard keeps the trail within 64 bits.
            let (light, bounds) = items[0];
            self.trails[light as usize] = trail;
            self.nodes.push(Node { bounds: NodeBounds::new(bounds), index: light, leaf: true });
            return bounds;
        }
        // Split at the median of the centroids along the widest axis of the centroids' bounds.
        let centroid = |b: &LightBounds| 0.5 * (b.min + b.max);
        let (lo, hi) = items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (_, b)| {
            (lo.min(centroid(b)), hi.max(centroid(b)))
        });
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| {
            centroid(&a.1)[axis].total_cmp(&centroid(&b.1)[axis]).then(a.0.cmp(&b.0))
        });
        let node = self.nodes.len();
        self.nodes.push(Node { bounds: NodeBounds::new(items[0].1), index: 0, leaf: false });
        let (left, right) = items.split_at_mut(mid);
        let a = self.build_range(left, trail, depth + 1);
        self.nodes[node].index = self.nodes.len() as u32;
        let b = self.build_range(right, trail | (1 << depth), depth + 1);
        let union = a.union(&b);
        self.nodes[node].bounds = NodeBounds::new(union);
        union
    }

    /// The nodes, depth first (for the descent in lanes, `kernel::lanes::tree`).
    pub(crate) fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// A light's path from the root (bit `l`: the turn at level `l`, set for the second child).
    #[inline]
    pub(crate) fn trail(&self, light: u32) -> Option<u64> {
        self.trails.get(light as usize).copied()
    }

    /// Whether the tree holds no light.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Bytes of the flat node array and trails.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<Node>() + self.trails.len() * size_of::<u64>()
    }

    /// The probability of a node's first child at (p, n). When the children's bounds both rule p out
    /// although their parent's looser bounds did not, the split falls back to power: a sample there
    /// is wasted, but the probabilities over all lights still sum to one.
    #[inline]
    fn split(&self, node: usize, p: Vec3, n: Vec3) -> Option<f32> {
        let (a, b) = (&self.nodes[node + 1].bounds, &self.nodes[self.nodes[node].index as usize].bounds);
        let (first, second) = (a.importance(p, n), b.importance(p, n));
        let total = first + second;
        if total > 0.0 && total.is_finite() {
            Some(first / total)
        } else {
            let phi = a.phi + b.phi;
            (phi > 0.0).then(|| a.phi / phi)
        }
    }

    /// Pick a light for a point `p` with normal `n` (zero for none), and its probability.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<(u32, f32)> {
        if self.nodes.is_empty() || self.nodes[0].bounds.importance(p, n) <= 0.0 {
            return None;
        }
        // The whole tree is the cluster of depth 0.
        self.sample_in_cluster(0, 0, p, n, u)
    }

    /// The nodes at `depth` (or leaves above it), by cluster id (the bits of the path to them), and
    /// `u32::MAX` for ids no node has.
    pub fn cluster_nodes(&self, depth: u32) -> Vec<u32> {
        let mut nodes = vec![u32::MAX; 1usize << depth];
        if !self.nodes.is_empty() {
            self.collect_clusters(0, 0, 0, depth, &mut nodes);
        }
        nodes
    }

    fn collect_clusters(&self, node: usize, level: u32, prefix: u32, depth: u32, out: &mut [u32]) {
        if level == depth || self.nodes[node].leaf {
            out[prefix as usize] = node as u32;
            return;
        }
        self.collect_clusters(node + 1, level + 1, prefix, depth, out);
        self.collect_clusters(self.nodes[node].index as usize, level + 1, prefix | (1 << level), depth, out);
    }

    /// The importance of node `node` for (p, n).
    #[inline]
    pub fn node_importance(&self, node: u32, p: Vec3, n: Vec3) -> f32 {
        self.nodes[node as usize].bounds.importance(p, n)
    }

    /// The first `depth` bits of a light's path from the root: its cluster at that depth (a light
    /// whose leaf is shallower is a cluster of its own, and no other light shares its prefix).
    pub fn cluster(&self, light: u32, depth: u32) -> u32 {
        (self.trails.get(light as usize).copied().unwrap_or(0) & ((1u64 << depth) - 1)) as u32
    }

    /// Pick a light within cluster `cluster` of depth `depth` (its first `depth` turns are forced, the
    /// rest follow importance as in [`LightTree::sample`]); returns it and its probability within
    /// the cluster.
    #[inline]
    pub fn sample_in_cluster(
        &self,
        cluster: u32,
        depth: u32,
        p: Vec3,
        n: Vec3,
        mut u: f32,
    ) -> Option<(u32, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let (mut node, mut pmf, mut level) = (0usize, 1.0f32, 0);
        while !self.nodes[node].leaf {
            if level < depth {
                node = if cluster & (1 << level) == 0 { node + 1 } else { self.nodes[node].index as usize };
            } else {
                let p_first = self.split(node, p, n)?;
                if u < p_first {
                    u = (u / p_first).min(ONE_MINUS_EPSILON);
                    pmf *= p_first;
                    node += 1;
                } else {
                    u = ((u - p_first) / (1.0 - p_first)).min(ONE_MINUS_EPSILON);
                    pmf *= 1.0 - p_first;
                    node = self.nodes[node].index as usize;
                }
            }
            level += 1;
        }
        (pmf > 0.0).then_some((self.nodes[node].index, pmf))
    }

    /// The probability that [`LightTree::sample`] picks `light` at (p, n), and the probability that
    /// [`LightTree::sample_in_cluster`] picks it within its cluster of depth `depth`.
    #[inline]
    pub fn pmf_and_in_cluster(&self, light: u32, depth: u32, p: Vec3, n: Vec3) -> (f32, f32) {
        let Some(&trail) = self.trails.get(light as usize) else { return (0.0, 0.0) };
        if self.nodes.is_empty() {
            return (0.0, 0.0);
        }
        let root = self.nodes[0].bounds.importance(p, n) > 0.0;
        let (mut node, mut above, mut below, mut level) = (0usize, 1.0f32, 1.0f32, 0);
        while !self.nodes[node].leaf {
            let first = trail & (1 << level) == 0;
            let p_turn = self.split(node, p, n).map(|p_first| if first { p_first } else { 1.0 - p_first });
            if level < depth {
                above *= p_turn.unwrap_or(0.0);
            } else {
                let Some(p_turn) = p_turn else { return (0.0, 0.0) };
                below *= p_turn;
            }
            node = if first { node + 1 } else { self.nodes[node].index as usize };
            level += 1;
        }
        if self.nodes[node].index != light {
            return (0.0, 0.0);
        }
        (if root { above * below } else { 0.0 }, below)
    }

    /// The probability that [`LightTree::sample`] picks light `light` at (p, n).
    #[inline]
    pub fn pmf(&self, light: u32, p: Vec3, n: Vec3) -> f32 {
        self.pmf_and_in_cluster(light, 0, p, n).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn lights(n: u32) -> Vec<Light> {
        crate::test_scenes::scattered_lights(n, 10.0)
    }

    fn shading_points() -> impl Iterator<Item = (Vec3, Vec3)> {
        (0..20u32).map(|i| {
            let s = Sampler::new(11, i, 0);
            let p = Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) * 12.0 - 1.0;
            (p, crate::sampling::warp::uniform_sphere(s.get2d(3)))
        })
    }

    #[test]
    fn probabilities_sum_to_one_at_random_shading_points() {
        let lights = lights(300);
        let tree = LightTree::build(&lights);
        for (p, n) in shading_points() {
            let total: f64 = (0..lights.len() as u32).map(|i| tree.pmf(i, p, n) as f64).sum();
            // Zero only where no light's bounds can reach p at all.
            let reachable = tree.nodes[0].bounds.importance(p, n) > 0.0;
            let expected = if reachable { 1.0 } else { 0.0 };
            assert!((total - expected).abs() < 1e-4, "Σ pmf = {total} at {p}");
        }
    }

    #[test]
    fn sampled_frequencies_match_the_stated_pmf_and_the_pmf_of_the_chosen_light() {
        let lights = lights(40);
        let tree = LightTree::build(&lights);
        for (p, n) in shading_points().take(4) {
            let draws = 200_000u32;
            let mut counts = vec![0u32; lights.len()];
            for i in 0..draws {
                let (light, pmf) = tree.sample(p, n, Sampler::new(2, i, 0).get1d(0)).unwrap();
                assert!((pmf / tree.pmf(light, p, n) - 1.0).abs() < 1e-5, "pmf at sampling ≠ pmf()");
                counts[light as usize] += 1;
            }
            let pmf: Vec<f64> = (0..lights.len() as u32).map(|i| tree.pmf(i, p, n) as f64).collect();
            let p_value = crate::sampling::chi2::discrete_chi2_p_value(&counts, &pmf, draws).unwrap();
            assert!(p_value > 1e-3, "χ² p-value {p_value} at {p}");
        }
    }

    #[test]
    fn a_light_facing_away_gets_no_probability_and_a_near_one_most() {
        // Two downward-facing triangles above the origin, one near and one far, and one facing up.
        let tri = |c: Vec3, up: bool| {
            let (a, b) = (Vec3::X * 0.1, Vec3::Z * 0.1);
            let p = if up { [c, c + b, c + a] } else { [c, c + a, c + b] };
            Light::new(LightShape::triangle(p), Vec3::ONE, Vec3::ZERO, 0)
        };
        let lights = [tri(Vec3::Y, false), tri(Vec3::Y * 8.0, false), tri(Vec3::Y * 2.0, true)];
        let normal_y = |l: &Light| match l.shape {
            LightShape::Triangle { n, .. } => n.y,
            _ => 0.0,
        };
        assert!(normal_y(&lights[0]) < 0.0 && normal_y(&lights[2]) > 0.0);
        let tree = LightTree::build(&lights);
        let (p, n) = (Vec3::ZERO, Vec3::Y);
        assert_eq!(tree.pmf(2, p, n), 0.0, "the upward light cannot reach a point below it");
        assert!(
            tree.pmf(0, p, n) > 10.0 * tree.pmf(1, p, n),
            "near {} far {}",
            tree.pmf(0, p, n),
            tree.pmf(1, p, n)
        );
    }
}
