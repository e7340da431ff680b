//! Refitting: after meshes moved, their triangles are written into the static set and every box of
//! its tree is recomputed, the tree's shape kept (no build). The alternative to the dynamic set that
//! `benches/animation.rs` measures: it touches every pack and node whatever moved, and a tree fitted
//! to old positions traces slower the further things move.

use super::surface::MeshShading;
use super::{Geometry, PrimitiveSet, PrimitiveShape};
use crate::geometry::triangle_pack::{LANES, TrianglePack};
use crate::scene::Scene;
use glam::Vec3;
use obvhs::aabb::Aabb;
use rayon::prelude::*;
use std::time::Instant;

impl Geometry {
    /// Write the moved meshes `changed` of `scene` (the scene this geometry was built from, its
    /// meshes moved) into the static set and refit its tree. False, and nothing changed, when a
    /// refit cannot stand for a build: a second set, or a changed mesh whose triangle count differs
    /// (validation dropped a triangle its new pose made degenerate).
    pub fn refit(&mut self, scene: &Scene, changed: &[usize]) -> bool {
        let counts_hold = scene.meshes.len() == self.meshes.len()
            && changed.iter().all(|&i| scene.meshes[i].indices.len() == self.meshes[i].indices.len());
        if self.moving_set.is_some() || self.dynamic_set.is_some() || !counts_hold {
            return false;
        }
        let _span = tracing::info_span!("refit_bvh").entered();
        let start = Instant::now();
        // A mesh's triangles are consecutive primitive ids, meshes in scene order.
        let mut first = Vec::with_capacity(self.meshes.len());
        let mut next = 0usize;
        for mesh in &self.meshes {
            first.push(next);
            next += mesh.indices.len();
        }
        let set = &mut self.static_set;
        for &i in changed {
            let mesh = &scene.meshes[i];
            for (k, tri) in mesh.indices.iter().enumerate() {
                set.shapes[first[i] + k] = PrimitiveShape::Triangle(tri.map(|v| mesh.positions[v as usize]));
            }
            self.meshes[i] = MeshShading::from(mesh);
        }
        refit_set(set);
        self.set_bounds[0] = set_bounds(set);
        self.bounds = self.set_bounds.iter().fold(Aabb::empty(), |acc, b| acc.union(b));
        self.build_time = start.elapsed();
        true
    }
}

/// Every pack rewritten from its triangles, then every box of the triangle tree.
fn refit_set(set: &mut PrimitiveSet) {
    let shapes = &set.shapes;
    let triangle = |prim: u32| match shapes[prim as usize] {
        PrimitiveShape::Triangle(v) => v,
        PrimitiveShape::Sphere(..) => unreachable!("packs hold triangles"),
    };
    set.packs.par_iter_mut().for_each(|(pack, ids)| {
        let vertices: [[Vec3; 3]; LANES] = ids.map(triangle);
        *pack = TrianglePack::new(&vertices[..lanes_used(ids)]);
    });
    let packs = &set.packs;
    set.triangles.refit(|first, count| {
        let mut b = Aabb::empty();
        for (_, ids) in &packs[first as usize..(first + count) as usize] {
            for &p in &ids[..lanes_used(ids)] {
                for v in triangle(p) {
                    b.extend(v.into());
                }
            }
        }
        (b.min.to_array(), b.max.to_array())
    });
}

/// How many of a pack's lanes hold a triangle: the unused ones repeat the last id.
fn lanes_used(ids: &[u32; LANES]) -> usize {
    (1..LANES).find(|&i| ids[i] == ids[i - 1]).unwrap_or(LANES)
}

fn set_bounds(set: &PrimitiveSet) -> Aabb {
    set.shapes
        .par_iter()
        .map(|shape| match *shape {
            PrimitiveShape::Triangle(p) => {
                Aabb::new(p[0].min(p[1]).min(p[2]).into(), p[0].max(p[1]).max(p[2]).into())
            }
            PrimitiveShape::Sphere(c, r) => Aabb::new((c - r).into(), (c + r).into()),
        })
        .reduce(Aabb::empty, |a, b| a.union(&b))
}
