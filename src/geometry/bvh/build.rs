//! Building the sets: the binary trees over the primitives' (swept) boxes, their flattening into
//! wide trees with the leaf rules, and the triangle packs.

use super::{NO_LIGHT, PrimitiveInfo, PrimitiveKind, PrimitiveSet, PrimitiveShape};
use crate::geometry::alpha::Cutouts;
use crate::geometry::alpha::NO_CUTOUT;
use crate::geometry::triangle_pack::{LANES, PackLanes, TrianglePack};
use crate::geometry::wide_bvh::{LeafRule, WideBvh, build_bvh2};
use crate::scene::{Mesh, Scene};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

#[derive(Default)]
pub(super) struct SetBuilder {
    cutout: Vec<u32>,
    pub(super) shapes: Vec<PrimitiveShape>,
    info: Vec<PrimitiveInfo>,
    motion: Vec<Vec3>,
    material_runs: Vec<(u32, u32)>,
}

impl SetBuilder {
    pub(super) fn push(
        &mut self,
        shape: PrimitiveShape,
        info: PrimitiveInfo,
        motion: Option<Vec3>,
        cutout: u32,
    ) {
        if self.material_runs.last().is_none_or(|&(material, _)| material != info.material) {
            self.material_runs.push((info.material, self.shapes.len() as u32));
        }
        self.cutout.push(cutout);
        if let Some(m) = motion {
            self.motion.push(m);
        }
        self.shapes.push(shape);
        self.info.push(info);
    }

    /// The set, its trees flattened from `trees` (over its triangles, then its spheres).
    pub(super) fn build(self, trees: [Option<Bvh2>; 2]) -> PrimitiveSet {
        if self.shapes.is_empty() {
            return PrimitiveSet::default();
        }
        let [triangle_tree, sphere_tree] = trees;
        // The leaves' triangles in leaf order, each pack's share of them, and the packs made after
        // the binary tree is freed, all at once into exactly sized tables (a growing table of packs
        // would hold its old and new storage at once) and in parallel.
        let mut leaf_triangles = Vec::with_capacity(self.shapes.len());
        let mut pack_ranges: Vec<(u32, u32)> = Vec::new();
        let triangles = flatten(triangle_tree, TRIANGLE_LEAVES, |prims| {
            let first = pack_ranges.len() as u32;
            for chunk in prims.chunks(LANES) {
                pack_ranges.push((leaf_triangles.len() as u32, chunk.len() as u32));
                leaf_triangles.extend_from_slice(chunk);
            }
            (first, prims.len().div_ceil(LANES) as u32)
        });
        let pack_of = |&(start, len): &(u32, u32)| &leaf_triangles[start as usize..(start + len) as usize];
        let packs: Vec<(TrianglePack, [u32; LANES])> = pack_ranges
            .par_iter()
            .map(|range| {
                let chunk = pack_of(range);
                let vertices: Vec<[Vec3; 3]> = chunk
                    .iter()
                    .map(|&p| match self.shapes[p as usize] {
                        PrimitiveShape::Triangle(v) => v,
                        PrimitiveShape::Sphere(..) => unreachable!("the triangle tree holds triangles"),
                    })
                    .collect();
                (TrianglePack::new(&vertices), std::array::from_fn(|i| chunk[i.min(chunk.len() - 1)]))
            })
            .collect();
        let pack_motion: Vec<[PackLanes; 3]> = if self.motion.is_empty() {
            Vec::new()
        } else {
            pack_ranges
                .par_iter()
                .map(|range| {
                    let chunk = pack_of(range);
                    let m = |i: usize| self.motion[chunk[i.min(chunk.len() - 1)] as usize];
                    std::array::from_fn(|a| PackLanes::new(std::array::from_fn(|i| m(i)[a])))
                })
                .collect()
        };
        let mut sphere_prims = Vec::new();
        let spheres = flatten(sphere_tree, SPHERE_LEAVES, |prims| {
            let first = sphere_prims.len() as u32;
            sphere_prims.extend_from_slice(prims);
            (first, prims.len() as u32)
        });
        let cutout = if self.cutout.iter().all(|&c| c == NO_CUTOUT) { Vec::new() } else { self.cutout };
        PrimitiveSet {
            triangles,
            packs,
            pack_motion,
            spheres,
            sphere_prims,
            shapes: self.shapes,
            info: self.info,
            motion: self.motion,
            cutout,
            material_runs: self.material_runs,
        }
    }
}

/// The binary trees of the static, the moving and the dynamic set (`[set][kind]`, triangles then
/// spheres; see [`set_of`]) over the meshes `include` admits, and the bounds of each set. They are
/// built from boxes alone, before any shape is copied out of the scene: a big mesh's peak memory is
/// in the tree's build, and the shapes need not be alive for it.
pub(super) fn binary_trees(
    scene: &Scene,
    dynamic: &[bool],
    meshes_of: MeshesOf,
) -> ([[Option<Bvh2>; 2]; SETS], [Aabb; SETS]) {
    let mut boxes: [[Vec<Aabb>; 2]; SETS] = Default::default();
    let include = |i: usize| meshes_of == MeshesOf::All || dynamic.get(i).copied().unwrap_or(false);
    for (index, mesh) in scene.meshes.iter().enumerate().filter(|(i, _)| include(*i)) {
        let moving = mesh.motion.filter(|m| *m != Vec3::ZERO);
        boxes[set_of(moving, dynamic, index)][0].extend(mesh.indices.iter().map(|tri| {
            swept(shape_aabb(&PrimitiveShape::Triangle(tri.map(|v| mesh.positions[v as usize]))), moving)
        }));
    }
    for s in scene.spheres.iter().filter(|_| meshes_of == MeshesOf::All) {
        let moving = s.motion.filter(|m| *m != Vec3::ZERO);
        boxes[moving.is_some() as usize][1]
            .push(swept(shape_aabb(&PrimitiveShape::Sphere(s.center, s.radius)), moving));
    }
    let bounds = boxes.each_ref().map(|set| set.iter().flatten().fold(Aabb::empty(), |acc, a| acc.union(a)));
    let trees = boxes.map(|[triangles, spheres]| {
        // A set holds its triangles first: its spheres' ids follow them.
        let first_sphere = triangles.len() as u32;
        [binary_tree(triangles, 0), binary_tree(spheres, first_sphere)]
    });
    (trees, bounds)
}

/// Which of a scene's primitives [`binary_trees`] builds over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum MeshesOf {
    /// Every mesh and sphere.
    All,
    /// The dynamic set's meshes alone.
    Dynamic,
}

/// Push mesh `mesh_index`'s triangles, with their cut-outs when its material has a rule.
pub(super) fn push_mesh(
    builder: &mut SetBuilder,
    mesh: &Mesh,
    mesh_index: usize,
    moving: Option<Vec3>,
    cutout_material: Option<u32>,
    cutouts: &mut Cutouts,
) {
    for (i, tri) in mesh.indices.iter().enumerate() {
        let p = tri.map(|v| mesh.positions[v as usize]);
        let cutout = cutout_material.map_or(NO_CUTOUT, |m| {
            let set = |s: usize| mesh.uvs.get(s).map_or([Vec2::ZERO; 3], |uv| tri.map(|v| uv[v as usize]));
            cutouts.add_triangle(m, [set(0), set(1)])
        });
        builder.push(
            PrimitiveShape::Triangle(p),
            PrimitiveInfo {
                kind: PrimitiveKind::Triangle,
                object: mesh_index as u32,
                index: i as u32,
                material: mesh.material,
                light: NO_LIGHT,
            },
            moving,
            cutout,
        );
    }
}

/// How many primitive sets there are: static, moving over the shutter, dynamic between frames.
pub(super) const SETS: usize = 3;

/// Which set mesh `index` goes to: the moving one when it moves over the shutter, else the dynamic
/// one when a frame may move it (`dynamic[index]`), else the static one.
pub(super) fn set_of(moving: Option<Vec3>, dynamic: &[bool], index: usize) -> usize {
    if moving.is_some() {
        1
    } else if dynamic.get(index).copied().unwrap_or(false) {
        2
    } else {
        0
    }
}

/// Linear motion sweeps a box from its start to its end position: their union bounds it.
fn swept(aabb: Aabb, motion: Option<Vec3>) -> Aabb {
    motion.map_or(aabb, |m| aabb.union(&Aabb::new(aabb.min + Vec3A::from(m), aabb.max + Vec3A::from(m))))
}

/// The binary tree over the primitives whose boxes are `aabbs`, their ids from `first` on; `None`
/// without primitives. The boxes are freed as soon as the tree is built.
fn binary_tree(aabbs: Vec<Aabb>, first: u32) -> Option<Bvh2> {
    let ids = (first..first + aabbs.len() as u32).collect();
    (!aabbs.is_empty()).then(|| build_bvh2(&aabbs, ids, &BvhBuildParams::medium_build()))
}

/// The wide tree of `bvh2`, its leaves chosen by `rule` and made by `make_leaf`.
fn flatten(bvh2: Option<Bvh2>, rule: LeafRule, make_leaf: impl FnMut(&[u32]) -> (u32, u32)) -> WideBvh {
    bvh2.map_or_else(WideBvh::default, |bvh2| WideBvh::from_bvh2(&bvh2, rule, make_leaf))
}

/// Triangle leaves: one pack of eight, a node test costing about what a pack test does. Measured
/// (incoherent rays, one thread): node costs of 0.5 or 2 are within 2% of this on the Cornell box. obvhs's spatial
/// pre-splits of large triangles gained nothing on either (0% and 2%, within the noise): not used.
const TRIANGLE_LEAVES: LeafRule = LeafRule { pack: LANES as u32, max_items: 1, node_cost: 1.0 };
/// Spheres are tested one by one.
const SPHERE_LEAVES: LeafRule = LeafRule { pack: 1, max_items: 4, node_cost: 1.0 };

fn shape_aabb(shape: &PrimitiveShape) -> Aabb {
    match *shape {
        PrimitiveShape::Triangle(p) => {
            let min = p[0].min(p[1]).min(p[2]);
            let max = p[0].max(p[1]).max(p[2]);
            Aabb::new(min.into(), max.into())
        }
        PrimitiveShape::Sphere(c, r) => Aabb::new((c - r).into(), (c + r).into()),
    }
}
