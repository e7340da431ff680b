//! Tests of the SD-tree: the directional distributions (`distribution.rs`) and the tree around them,
//! its determinism and its handling of bad input (`tree.rs`). Helpers here train trees the way a path
//! tracer will.

use super::*;
use crate::sampling::Sampler;
use glam::{Vec2, Vec3};

mod distribution;
mod speed;
mod tree;

/// Train `tree` for `iterations` iterations of `base · 2^k` samples at the points `point(i)`, as a path
/// tracer with a BSDF sampling fraction of ½ would: half the directions uniform (the "BSDF"), half
/// from the guide, each recorded as its radiance over the mixture's density.
fn train(
    tree: &mut SdTree,
    iterations: u32,
    base: u32,
    point: impl Fn(u32) -> Vec3,
    radiance: impl Fn(Vec3) -> f32,
) {
    for k in 0..iterations {
        for i in 0..base << k {
            let s = Sampler::new(100 + k as u64, i, 0);
            let leaf = tree.leaf(point(i));
            let u = s.get2d(1);
            let d = if s.get1d(0) < 0.5 { from_square(u) } else { leaf.sample(u).0 };
            let pdf = 0.5 * INV_FOUR_PI + 0.5 * leaf.pdf(d);
            leaf.record(d, radiance(d) / pdf);
        }
        tree.refine(k);
    }
}

/// One spatial leaf for good (c infinite) over the unit cube.
fn one_leaf(config: GuidingConfig) -> SdTree {
    SdTree::with_config(Vec3::ZERO, Vec3::ONE, GuidingConfig { spatial_threshold: f64::INFINITY, ..config })
}

/// Radiance 1 inside the cone of half-angle `degrees` about `axis`, 0 outside.
fn cone(axis: Vec3, degrees: f32) -> impl Fn(Vec3) -> f32 {
    let (axis, cos_max) = (axis.normalize(), degrees.to_radians().cos());
    move |d: Vec3| if d.normalize().dot(axis) > cos_max { 1.0 } else { 0.0 }
}

/// The axis of the test cones: off every coordinate plane, so no cell boundary is special.
const AXIS: Vec3 = Vec3::new(0.3, -0.5, 0.8);

/// A tree trained on a bright narrow lobe, a broad one and a dim floor: every kind of cell.
fn lobes(config: GuidingConfig, iterations: u32) -> SdTree {
    let mut tree = one_leaf(config);
    let narrow = cone(AXIS, 15.0);
    train(
        &mut tree,
        iterations,
        4000,
        |_| Vec3::splat(0.5),
        |d| 50.0 * narrow(d) + d.normalize().x.max(0.0).powi(2) + 0.1,
    );
    tree
}

/// The deepest quadtree node of a distribution (the root is at depth 1; 0 for the uniform sphere).
fn depth(dist: &DirectionalDistribution) -> u32 {
    fn walk(dist: &DirectionalDistribution, node: usize, depth: u32) -> u32 {
        let n = &dist.nodes[node];
        n.child.iter().filter(|&&c| c != 0).map(|&c| walk(dist, c as usize, depth + 1)).max().unwrap_or(depth)
    }
    if dist.nodes.is_empty() { 0 } else { walk(dist, 0, 1) }
}

/// The share of `n` samples of `leaf` that fall where `inside` holds.
fn mass_where(leaf: Leaf<'_>, n: u32, inside: impl Fn(Vec3) -> bool) -> f64 {
    let hits = (0..n).filter(|&i| inside(leaf.sample(Sampler::new(7, i, 0).get2d(0)).0)).count();
    hits as f64 / n as f64
}

/// Midpoint quadrature of the density per steradian over the sphere on an `n` × `n` grid of the
/// cylindrical square (dω = 4π dx dy).
fn integral(leaf: Leaf<'_>, n: u32) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let s = (Vec2::new(i as f32, j as f32) + 0.5) / n as f32;
            sum += leaf.pdf(from_square(s)) as f64;
        }
    }
    sum * 4.0 * std::f64::consts::PI / (n as f64 * n as f64)
}
