//! The scene's primitives in four-wide BVHs built by obvhs (`wide_bvh`), with our watertight
//! intersectors: triangles in packs of four tested together (`triangle_pack.rs`), spheres one by one.
//!
//! Static primitives live in one set. Primitives that move over the shutter live in a second one built
//! over their swept bounds, and are tested with the ray moved back by the primitive's displacement at
//! the ray's time; a scene with nothing moving has no second set and pays nothing for motion.
//! Meshes that frames move (a glTF animation, a host's `move_node`) live in a third, dynamic set whose
//! tree alone is rebuilt when they move (`build_dynamic`, `update_dynamic`), the still sets' trees
//! kept; `refit.rs` instead rewrites one set's triangles in place and recomputes its boxes.
//! Primitive ids are positions in the order the scene lists them (triangles of each mesh, then
//! spheres), whatever the trees' order.
//!
//! This module holds the types and [`Geometry`]'s queries; `build.rs` builds the sets and their
//! trees, `query.rs` traverses one set, `surface.rs` turns a hit into what shading reads.

mod build;
mod query;
mod refit;
mod surface;

pub use surface::{PlainTriangle, SurfaceHit};

use super::Ray;
use super::alpha::{Cutouts, NO_CUTOUT};
use super::triangle_pack::{LANES, PackLanes, TrianglePack};
use super::wide_bvh::{Counts, TraceCounts, Uncounted, WideBvh};
use crate::scene::Scene;
use build::{MeshesOf, SETS, SetBuilder, binary_trees, push_mesh, set_of};
use glam::Vec3;
use obvhs::aabb::Aabb;
use query::{QueryRay, intersect_set, occluded_set};
use std::time::{Duration, Instant};
use surface::MeshShading;

/// The shape of one primitive, in the order the BVH stores them.
#[derive(Clone, Copy, Debug)]
pub enum PrimitiveShape {
    /// Triangle vertices (counter-clockwise = front).
    Triangle([Vec3; 3]),
    /// Sphere centre and radius.
    Sphere(Vec3, f32),
}

impl PrimitiveShape {
    /// Its surface area (not finite for a degenerate or absurd one).
    pub fn area(&self) -> f32 {
        match self {
            Self::Triangle(t) => 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length(),
            Self::Sphere(_, radius) => 4.0 * std::f32::consts::PI * radius * radius,
        }
    }
}

/// What kind of object a primitive belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimitiveKind {
    /// Triangle `index` of mesh `object`.
    Triangle,
    /// Sphere `object`.
    Sphere,
}

/// Cold per-primitive data, read only after a hit.
#[derive(Clone, Copy, Debug)]
pub struct PrimitiveInfo {
    /// Triangle or sphere.
    pub kind: PrimitiveKind,
    /// Mesh index (triangles) or sphere index.
    pub object: u32,
    /// Triangle index within the mesh.
    pub index: u32,
    /// Material index.
    pub material: u32,
    /// Light index, or `NO_LIGHT`.
    pub light: u32,
}

/// `PrimitiveInfo::light` of a primitive that does not emit.
pub const NO_LIGHT: u32 = u32::MAX;
/// High bit of a primitive id: the primitive is in the moving set.
const MOVING_BIT: u32 = 1 << 31;
/// Next bit of a primitive id: the primitive is in the dynamic set.
const DYNAMIC_BIT: u32 = 1 << 30;
/// The set bits of a primitive id.
const SET_BITS: u32 = MOVING_BIT | DYNAMIC_BIT;

/// The primitives of one set and the trees over them: triangles in packs under one BVH, spheres
/// under another.
#[derive(Clone, Debug, Default)]
pub struct PrimitiveSet {
    triangles: WideBvh,
    /// The triangles of the leaves, four to a pack, with the primitive id of each lane beside them
    /// (read on a hit: one cache miss fewer on a big mesh than a separate array).
    packs: Vec<(TrianglePack, [u32; LANES])>,
    /// Each pack lane's displacement over the shutter, per axis (empty for the static set).
    pack_motion: Vec<[PackLanes; 3]>,
    spheres: WideBvh,
    /// The primitive ids of the sphere tree's leaves.
    sphere_prims: Vec<u32>,
    /// Shapes, by primitive id.
    pub shapes: Vec<PrimitiveShape>,
    /// Cold data, by primitive id.
    pub info: Vec<PrimitiveInfo>,
    /// Displacement over the shutter per primitive (empty for the static set).
    pub motion: Vec<Vec3>,
    /// Alpha cut-out per primitive (`NO_CUTOUT`: opaque); empty when the set has none.
    pub cutout: Vec<u32>,
    /// Runs of primitives of one material: the material and the run's first primitive id, so that
    /// finding a material's primitives (the emitters) skips whole meshes.
    material_runs: Vec<(u32, u32)>,
}

/// A ray's closest hit: which primitive, where on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (`f32::INFINITY` for a miss).
    pub t: f32,
    /// Primitive id (see [`Geometry::primitive`]).
    pub prim: u32,
    /// Barycentric weight of the second vertex (triangles).
    pub b1: f32,
    /// Barycentric weight of the third vertex (triangles).
    pub b2: f32,
}

impl Hit {
    /// No hit.
    pub const MISS: Hit = Hit { t: f32::INFINITY, prim: u32::MAX, b1: 0.0, b2: 0.0 };

    /// Whether the ray hit anything.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.prim != u32::MAX
    }
}

/// The scene's geometry, ready for ray queries.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    static_set: PrimitiveSet,
    moving_set: Option<PrimitiveSet>,
    /// The meshes a frame may move (a file's animations, a host's moves): rebuilt alone when they
    /// do, the static set's tree kept ([`Geometry::update_dynamic`]).
    dynamic_set: Option<PrimitiveSet>,
    /// Which meshes are in the dynamic set, by mesh index.
    dynamic: Vec<bool>,
    meshes: Vec<MeshShading>,
    cutouts: Cutouts,
    /// The cut-out rule of each material (`None`: opaque).
    cutout_materials: Vec<Option<u32>>,
    /// Bounds of each set.
    set_bounds: [Aabb; SETS],
    bounds: Aabb,
    /// Time spent building BVHs.
    pub build_time: Duration,
}

impl Geometry {
    /// Build the BVHs over a validated scene. Light indices are assigned later by [`Geometry::set_light`].
    pub fn build(scene: &Scene) -> Self {
        Self::build_dynamic(scene, &[])
    }

    /// As [`Geometry::build`], the meshes `dynamic` marks (by index) in a set of their own that
    /// [`Geometry::update_dynamic`] rebuilds alone when a frame moves them.
    pub fn build_dynamic(scene: &Scene, dynamic: &[bool]) -> Self {
        let _span = tracing::info_span!("build_bvh").entered();
        let start = Instant::now();
        let (trees, set_bounds) = binary_trees(scene, dynamic, MeshesOf::All);
        let mut builders: [SetBuilder; SETS] = Default::default();
        let (mut cutouts, cutout_materials) = Cutouts::new(scene);
        for (mesh_index, mesh) in scene.meshes.iter().enumerate() {
            let moving = mesh.motion.filter(|m| *m != Vec3::ZERO);
            let cutout_material = cutout_materials.get(mesh.material as usize).copied().flatten();
            let builder = &mut builders[set_of(moving, dynamic, mesh_index)];
            push_mesh(builder, mesh, mesh_index, moving, cutout_material, &mut cutouts);
        }
        for (i, s) in scene.spheres.iter().enumerate() {
            let moving = s.motion.filter(|m| *m != Vec3::ZERO);
            builders[moving.is_some() as usize].push(
                PrimitiveShape::Sphere(s.center, s.radius),
                PrimitiveInfo {
                    kind: PrimitiveKind::Sphere,
                    object: i as u32,
                    index: 0,
                    material: s.material,
                    light: NO_LIGHT,
                },
                moving,
                NO_CUTOUT,
            );
        }
        let [static_builder, moving_builder, dynamic_builder] = builders;
        let [static_trees, moving_trees, dynamic_trees] = trees;
        let static_set = static_builder.build(static_trees);
        let moving_set = (!moving_builder.shapes.is_empty()).then(|| moving_builder.build(moving_trees));
        let dynamic_set = (!dynamic_builder.shapes.is_empty()).then(|| dynamic_builder.build(dynamic_trees));
        let build_time = start.elapsed();
        Self {
            static_set,
            moving_set,
            dynamic_set,
            dynamic: dynamic.to_vec(),
            meshes: scene.meshes.iter().map(MeshShading::from).collect(),
            cutouts,
            cutout_materials,
            bounds: set_bounds.iter().fold(Aabb::empty(), |acc, b| acc.union(b)),
            set_bounds,
            build_time,
        }
    }

    /// Rebuild the dynamic set from `scene`'s meshes (the scene this geometry was built from, its
    /// dynamic meshes moved, nothing else changed): the static set's tree is kept. False, and
    /// nothing changed, when that cannot stand for a whole build: a mesh outside the dynamic set,
    /// one with alpha cut-outs, or one moving over the shutter is among them; then build anew.
    pub fn update_dynamic(&mut self, scene: &Scene, changed: &[usize]) -> bool {
        let cut_out = |m: &crate::scene::Mesh| {
            self.cutout_materials.get(m.material as usize).copied().flatten().is_some()
        };
        let updatable = scene.meshes.len() == self.meshes.len()
            && changed.iter().all(|&i| {
                self.dynamic.get(i).copied().unwrap_or(false)
                    && !cut_out(&scene.meshes[i])
                    && scene.meshes[i].motion.is_none_or(|m| m == Vec3::ZERO)
            });
        if !updatable {
            return false;
        }
        let _span = tracing::info_span!("update_bvh").entered();
        let start = Instant::now();
        let dynamic = &self.dynamic;
        let is_dynamic = |i: usize| dynamic.get(i).copied().unwrap_or(false);
        let (trees, set_bounds) = binary_trees(scene, dynamic, MeshesOf::Dynamic);
        let [_, _, trees] = trees;
        let mut builder = SetBuilder::default();
        for (mesh_index, mesh) in scene.meshes.iter().enumerate().filter(|(i, _)| is_dynamic(*i)) {
            push_mesh(&mut builder, mesh, mesh_index, None, None, &mut self.cutouts);
        }
        self.dynamic_set = (!builder.shapes.is_empty()).then(|| builder.build(trees));
        for &i in changed {
            self.meshes[i] = MeshShading::from(&scene.meshes[i]);
        }
        self.set_bounds[2] = set_bounds[2];
        self.bounds = self.set_bounds.iter().fold(Aabb::empty(), |acc, b| acc.union(b));
        self.build_time = start.elapsed();
        true
    }

    /// Whether any primitive moves over the shutter.
    pub fn has_motion(&self) -> bool {
        self.moving_set.is_some()
    }

    /// Bounds of everything, over the whole shutter.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.bounds.min.into(), self.bounds.max.into())
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.sets().map(|(set, _)| set.shapes.len()).sum()
    }

    /// Whether there is no primitive at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every primitive id with its shape, info and motion (for building lights).
    pub fn primitives(&self) -> impl Iterator<Item = (u32, &PrimitiveShape, &PrimitiveInfo, Vec3)> {
        self.sets().flat_map(|(set, bits)| {
            (0..set.shapes.len()).map(move |i| {
                let motion = set.motion.get(i).copied().unwrap_or(Vec3::ZERO);
                (i as u32 | bits, &set.shapes[i], &set.info[i], motion)
            })
        })
    }

    /// As [`Geometry::primitives`], only those whose material `wanted` takes (the emitters), in the
    /// same order; whole runs of another material are skipped unread.
    pub fn primitives_of(
        &self,
        wanted: impl Fn(u32) -> bool + Copy,
    ) -> impl Iterator<Item = (u32, &PrimitiveShape, &PrimitiveInfo, Vec3)> {
        self.sets().flat_map(move |(set, bits)| {
            let runs = &set.material_runs;
            (0..runs.len()).filter(move |&r| wanted(runs[r].0)).flat_map(move |r| {
                let end = runs.get(r + 1).map_or(set.shapes.len() as u32, |next| next.1);
                (runs[r].1..end).map(move |i| {
                    let i = i as usize;
                    let motion = set.motion.get(i).copied().unwrap_or(Vec3::ZERO);
                    (i as u32 | bits, &set.shapes[i], &set.info[i], motion)
                })
            })
        })
    }

    /// The sets there are, each with the bits its primitive ids carry.
    fn sets(&self) -> impl Iterator<Item = (&PrimitiveSet, u32)> {
        std::iter::once((&self.static_set, 0))
            .chain(self.moving_set.iter().map(|s| (s, MOVING_BIT)))
            .chain(self.dynamic_set.iter().map(|s| (s, DYNAMIC_BIT)))
    }

    /// The set primitive `prim` is in, and its index there.
    #[inline]
    fn set_of(&self, prim: u32) -> (&PrimitiveSet, usize) {
        let i = (prim & !SET_BITS) as usize;
        match prim & SET_BITS {
            0 => (&self.static_set, i),
            MOVING_BIT => (self.moving_set.as_ref().expect("moving primitive id without a moving set"), i),
            _ => (self.dynamic_set.as_ref().expect("dynamic primitive id without a dynamic set"), i),
        }
    }

    /// Shape, info and displacement over the shutter of primitive `prim`.
    #[inline]
    pub fn primitive(&self, prim: u32) -> (&PrimitiveShape, &PrimitiveInfo, Vec3) {
        let (set, i) = self.set_of(prim);
        (&set.shapes[i], &set.info[i], set.motion.get(i).copied().unwrap_or(Vec3::ZERO))
    }

    /// Assign a light index to a primitive.
    pub fn set_light(&mut self, prim: u32, light: u32) {
        let i = (prim & !SET_BITS) as usize;
        let set = match prim & SET_BITS {
            0 => Some(&mut self.static_set),
            MOVING_BIT => self.moving_set.as_mut(),
            _ => self.dynamic_set.as_mut(),
        };
        if let Some(set) = set {
            set.info[i].light = light;
        }
    }

    /// Closest hit along the ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Hit {
        self.intersect_with(ray, &mut Uncounted)
    }

    /// Closest hit along the ray, counting the nodes and leaves visited into `counts`.
    #[inline]
    pub fn intersect_counted(&self, ray: &Ray, counts: &mut TraceCounts) -> Hit {
        self.intersect_with(ray, counts)
    }

    #[inline(always)]
    fn intersect_with(&self, ray: &Ray, counts: &mut impl Counts) -> Hit {
        let mut hit = Hit { t: ray.t_max, ..Hit::MISS };
        let rays = QueryRay::new(ray);
        intersect_set(&self.static_set, &self.cutouts, ray, &rays, 0, &mut hit, counts);
        if let Some(set) = &self.moving_set {
            intersect_set(set, &self.cutouts, ray, &rays, MOVING_BIT, &mut hit, counts);
        }
        if let Some(set) = &self.dynamic_set {
            intersect_set(set, &self.cutouts, ray, &rays, DYNAMIC_BIT, &mut hit, counts);
        }
        if hit.is_hit() { hit } else { Hit::MISS }
    }

    /// Whether anything blocks the ray before `t_max` (any-hit query for shadow rays).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, &mut Uncounted)
    }

    /// [`Geometry::occluded`], counting the nodes and leaves visited into `counts`.
    #[inline]
    pub fn occluded_counted(&self, ray: &Ray, counts: &mut TraceCounts) -> bool {
        self.occluded_with(ray, counts)
    }

    #[inline(always)]
    fn occluded_with(&self, ray: &Ray, counts: &mut impl Counts) -> bool {
        let rays = QueryRay::new(ray);
        occluded_set(&self.static_set, &self.cutouts, ray, &rays, 0, counts)
            || self
                .moving_set
                .as_ref()
                .is_some_and(|set| occluded_set(set, &self.cutouts, ray, &rays, MOVING_BIT, counts))
            || self
                .dynamic_set
                .as_ref()
                .is_some_and(|set| occluded_set(set, &self.cutouts, ray, &rays, DYNAMIC_BIT, counts))
    }

    /// Triangle packs, inner nodes of the triangle trees, and triangles, over every set (for the
    /// trace bench: how full the packs are).
    pub fn pack_counts(&self) -> (usize, usize, usize) {
        self.sets().fold((0, 0, 0), |(packs, nodes, triangles), (s, _)| {
            let tris = s.shapes.iter().filter(|p| matches!(p, PrimitiveShape::Triangle(_))).count();
            (packs + s.packs.len(), nodes + s.triangles.node_count(), triangles + tris)
        })
    }

    /// Bytes of the trees and the triangle packs (for the report on big meshes).
    pub fn acceleration_bytes(&self) -> usize {
        self.sets()
            .map(|(s, _)| {
                s.triangles.bytes()
                    + s.spheres.bytes()
                    + s.packs.len() * size_of::<(TrianglePack, [u32; LANES])>()
                    + s.pack_motion.len() * size_of::<[PackLanes; 3]>()
                    + s.sphere_prims.len() * 4
            })
            .sum()
    }
}
