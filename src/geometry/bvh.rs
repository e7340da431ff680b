//! The scene's primitives in obvhs compressed wide BVHs (CWBVH), with our watertight intersectors.
//!
//! Static primitives live in one BVH. Primitives that move over the shutter live in a second one built
//! over their swept bounds, and are tested with the ray moved back by the primitive's displacement at
//! the ray's time; a scene with nothing moving has no second BVH and pays nothing for motion.

use super::Ray;
use super::alpha::{Cutouts, NO_CUTOUT};
use super::offset::gamma;
use super::sphere::{intersect_sphere, sphere_hit_point};
use super::triangle::{ShearedRay, intersect_triangle_sheared, triangle_point_error};
use crate::scene::{Mesh, Scene};
use glam::{Vec2, Vec3, Vec3A, Vec4};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::RayHit;
use std::time::Duration;

/// The shape of one primitive, in the order the BVH stores them.
#[derive(Clone, Copy, Debug)]
pub enum PrimitiveShape {
    /// Triangle vertices (counter-clockwise = front).
    Triangle([Vec3; 3]),
    /// Sphere centre and radius.
    Sphere(Vec3, f32),
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

/// One BVH and the primitives it indexes (in BVH order, so the traversal index is the array index).
#[derive(Clone, Debug, Default)]
pub struct PrimitiveSet {
    bvh: CwBvh,
    /// Shapes, in BVH order.
    pub shapes: Vec<PrimitiveShape>,
    /// Cold data, in BVH order.
    pub info: Vec<PrimitiveInfo>,
    /// Displacement over the shutter per primitive (empty for the static set).
    pub motion: Vec<Vec3>,
    /// Alpha cut-out per primitive (`NO_CUTOUT`: opaque); empty when the set has none.
    pub cutout: Vec<u32>,
}

/// A ray's closest hit: which primitive, where on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (`f32::INFINITY` for a miss).
    pub t: f32,
    /// Primitive id (see [`Geometry::info`]).
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

/// Everything shading needs to know about a hit point.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    /// Hit point.
    pub p: Vec3,
    /// Conservative bound on the error of `p`, for spawning rays.
    pub p_error: Vec3,
    /// Geometric normal: the front side of the surface (counter-clockwise winding, sphere outside).
    pub ng: Vec3,
    /// Shading normal, in the same hemisphere as `ng`.
    pub ns: Vec3,
    /// Texture coordinates of sets 0 and 1.
    pub uv: [Vec2; 2],
    /// Interpolated vertex colour (white without COLOR_0).
    pub color: Vec3,
    /// Interpolated tangent with the bitangent sign in w (zero without tangents).
    pub tangent: Vec4,
    /// Material index.
    pub material: u32,
    /// Light index or `NO_LIGHT`.
    pub light: u32,
}

/// Vertex attributes of a mesh, kept for shading.
#[derive(Clone, Debug, Default)]
struct MeshShading {
    normals: Option<Vec<Vec3>>,
    uvs: Vec<Vec<Vec2>>,
    colors: Option<Vec<Vec3>>,
    tangents: Option<Vec<Vec4>>,
    indices: Vec<[u32; 3]>,
}

/// The scene's geometry, ready for ray queries.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    static_set: PrimitiveSet,
    moving_set: Option<PrimitiveSet>,
    meshes: Vec<MeshShading>,
    cutouts: Cutouts,
    bounds: Aabb,
    /// Time spent building BVHs.
    pub build_time: Duration,
}

impl Geometry {
    /// Build the BVHs over a validated scene. Light indices are assigned later by [`Geometry::set_light`].
    pub fn build(scene: &Scene) -> Self {
        let _span = tracing::info_span!("build_bvh").entered();
        let mut builders = [SetBuilder::default(), SetBuilder::default()];
        let (mut cutouts, cutout_materials) = Cutouts::new(scene);
        for (mesh_index, mesh) in scene.meshes.iter().enumerate() {
            let moving = mesh.motion.filter(|m| *m != Vec3::ZERO);
            let builder = &mut builders[moving.is_some() as usize];
            let cutout_material = cutout_materials.get(mesh.material as usize).copied().flatten();
            for (i, tri) in mesh.indices.iter().enumerate() {
                let p = tri.map(|v| mesh.positions[v as usize]);
                let cutout = cutout_material.map_or(NO_CUTOUT, |m| {
                    let set =
                        |s: usize| mesh.uvs.get(s).map_or([Vec2::ZERO; 3], |uv| tri.map(|v| uv[v as usize]));
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
        let mut build_time = Duration::ZERO;
        let [static_builder, moving_builder] = builders;
        let bounds_static = static_builder.bounds();
        let bounds_moving = moving_builder.bounds();
        let static_set = static_builder.build(&mut build_time);
        let moving_set = (!moving_builder.shapes.is_empty()).then(|| moving_builder.build(&mut build_time));
        Self {
            static_set,
            moving_set,
            meshes: scene.meshes.iter().map(MeshShading::from).collect(),
            cutouts,
            bounds: bounds_static.union(&bounds_moving),
            build_time,
        }
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
        self.static_set.shapes.len() + self.moving_set.as_ref().map_or(0, |s| s.shapes.len())
    }

    /// Whether there is no primitive at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every primitive id with its shape, info and motion (for building lights).
    pub fn primitives(&self) -> impl Iterator<Item = (u32, &PrimitiveShape, &PrimitiveInfo, Vec3)> {
        let s = &self.static_set;
        let statics = (0..s.shapes.len()).map(move |i| (i as u32, &s.shapes[i], &s.info[i], Vec3::ZERO));
        let moving = self.moving_set.iter().flat_map(|m| {
            (0..m.shapes.len()).map(move |i| (i as u32 | MOVING_BIT, &m.shapes[i], &m.info[i], m.motion[i]))
        });
        statics.chain(moving)
    }

    /// The texture coordinates of set `set` at triangle `prim`'s vertices (zero where the mesh has no
    /// such set, or for a sphere).
    pub fn triangle_uvs(&self, prim: u32, set: u32) -> [Vec2; 3] {
        let (shape, info, _) = self.primitive(prim);
        let PrimitiveShape::Triangle(_) = shape else { return [Vec2::ZERO; 3] };
        let mesh = &self.meshes[info.object as usize];
        match mesh.uvs.get(set as usize) {
            Some(uvs) => mesh.indices[info.index as usize].map(|v| uvs[v as usize]),
            None => [Vec2::ZERO; 3],
        }
    }

    /// Shape, info and displacement over the shutter of primitive `prim`.
    #[inline]
    pub fn primitive(&self, prim: u32) -> (&PrimitiveShape, &PrimitiveInfo, Vec3) {
        if prim & MOVING_BIT == 0 {
            let i = prim as usize;
            (&self.static_set.shapes[i], &self.static_set.info[i], Vec3::ZERO)
        } else {
            let set = self.moving_set.as_ref().expect("moving primitive id without a moving set");
            let i = (prim & !MOVING_BIT) as usize;
            (&set.shapes[i], &set.info[i], set.motion[i])
        }
    }

    /// Assign a light index to a primitive.
    pub fn set_light(&mut self, prim: u32, light: u32) {
        let i = (prim & !MOVING_BIT) as usize;
        if prim & MOVING_BIT == 0 {
            self.static_set.info[i].light = light;
        } else if let Some(set) = self.moving_set.as_mut() {
            set.info[i].light = light;
        }
    }

    /// Closest hit along the ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Hit {
        let mut hit = Hit { t: ray.t_max, ..Hit::MISS };
        intersect_set(&self.static_set, &self.cutouts, ray, 0, &mut hit);
        if let Some(set) = &self.moving_set {
            intersect_set(set, &self.cutouts, ray, MOVING_BIT, &mut hit);
        }
        if hit.is_hit() { hit } else { Hit::MISS }
    }

    /// Whether anything blocks the ray before `t_max` (any-hit query for shadow rays).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        occluded_set(&self.static_set, &self.cutouts, ray, 0)
            || self.moving_set.as_ref().is_some_and(|set| occluded_set(set, &self.cutouts, ray, MOVING_BIT))
    }

    /// Surface data at a hit.
    pub fn surface_hit(&self, ray: &Ray, hit: &Hit) -> SurfaceHit {
        let (shape, info, motion) = self.primitive(hit.prim);
        let shift = motion * ray.time;
        match *shape {
            PrimitiveShape::Triangle([p0, p1, p2]) => {
                let (p0, p1, p2) = (p0 + shift, p1 + shift, p2 + shift);
                let (b1, b2) = (hit.b1, hit.b2);
                let b0 = 1.0 - b1 - b2;
                let p = b0 * p0 + b1 * p1 + b2 * p2;
                let p_error = triangle_point_error(b0, b1, b2, p0, p1, p2) + gamma(2) * shift.abs();
                let ng = (p1 - p0).cross(p2 - p0).normalize();
                let mesh = &self.meshes[info.object as usize];
                let [i0, i1, i2] = mesh.indices[info.index as usize].map(|v| v as usize);
                let lerp3 = |a: Vec3, b: Vec3, c: Vec3| b0 * a + b1 * b + b2 * c;
                let ns = match &mesh.normals {
                    Some(n) => {
                        let ns = lerp3(n[i0], n[i1], n[i2]).normalize_or_zero();
                        if ns == Vec3::ZERO {
                            ng
                        } else if ns.dot(ng) < 0.0 {
                            -ns
                        } else {
                            ns
                        }
                    }
                    None => ng,
                };
                let mut uv = [Vec2::ZERO; 2];
                for (set, out) in mesh.uvs.iter().zip(uv.iter_mut()) {
                    *out = b0 * set[i0] + b1 * set[i1] + b2 * set[i2];
                }
                let color = mesh.colors.as_ref().map_or(Vec3::ONE, |c| lerp3(c[i0], c[i1], c[i2]));
                let tangent = mesh.tangents.as_ref().map_or(Vec4::ZERO, |t| {
                    lerp3(t[i0].truncate(), t[i1].truncate(), t[i2].truncate()).extend(t[i0].w)
                });
                SurfaceHit {
                    p,
                    p_error,
                    ng,
                    ns,
                    uv,
                    color,
                    tangent,
                    material: info.material,
                    light: info.light,
                }
            }
            PrimitiveShape::Sphere(center, radius) => {
                let c = center + shift;
                let (p, p_error) = sphere_hit_point(ray.o, ray.d, hit.t, c, radius);
                let n = (p - c).normalize();
                let local = n;
                let u = 0.5 + local.z.atan2(local.x) * (0.5 / std::f32::consts::PI);
                let v = local.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
                SurfaceHit {
                    p,
                    p_error,
                    ng: n,
                    ns: n,
                    uv: [Vec2::new(u, v); 2],
                    color: Vec3::ONE,
                    tangent: Vec4::ZERO,
                    material: info.material,
                    light: info.light,
                }
            }
        }
    }
}

#[inline]
fn to_bvh_ray(ray: &Ray, t_max: f32) -> obvhs::ray::Ray {
    // obvhs 0.4 picks the ray's octant by `d >= 0` but takes 1/d, so a -0.0 component (from `-Vec3::Z`,
    // a negated normal, ...) counts as positive there and as -inf here, and the ray misses every box.
    // Adding +0.0 turns -0.0 into +0.0 and leaves every other value as it is.
    let d = Vec3A::from(ray.d) + Vec3A::ZERO;
    obvhs::ray::Ray::new(Vec3A::from(ray.o), d, 0.0, t_max)
}

#[inline(always)]
fn intersect_shape(
    shape: &PrimitiveShape,
    o: Vec3,
    d: Vec3,
    sheared: &ShearedRay,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    match *shape {
        PrimitiveShape::Triangle([p0, p1, p2]) => {
            intersect_triangle_sheared(o, sheared, t_max, p0, p1, p2).map(|h| (h.t, h.b1, h.b2))
        }
        PrimitiveShape::Sphere(c, r) => intersect_sphere(o, d, t_max, c, r).map(|t| (t, 0.0, 0.0)),
    }
}

#[inline]
fn intersect_set(set: &PrimitiveSet, cutouts: &Cutouts, ray: &Ray, id_bits: u32, hit: &mut Hit) {
    if set.shapes.is_empty() {
        return;
    }
    let mut bvh_hit = RayHit::none();
    let moving = !set.motion.is_empty();
    let sheared = ShearedRay::new(ray.d);
    set.bvh.ray_traverse(to_bvh_ray(ray, hit.t), &mut bvh_hit, |r, i| {
        let o = if moving { ray.o - set.motion[i] * ray.time } else { ray.o };
        match intersect_shape(&set.shapes[i], o, ray.d, &sheared, r.tmax) {
            Some((_, b1, b2)) if cut_out(set, cutouts, i, b1, b2, ray, id_bits) => f32::INFINITY,
            Some((t, b1, b2)) => {
                *hit = Hit { t, prim: i as u32 | id_bits, b1, b2 };
                t
            }
            None => f32::INFINITY,
        }
    });
}

#[inline]
fn occluded_set(set: &PrimitiveSet, cutouts: &Cutouts, ray: &Ray, id_bits: u32) -> bool {
    if set.shapes.is_empty() {
        return false;
    }
    let moving = !set.motion.is_empty();
    let sheared = ShearedRay::new(ray.d);
    !set.bvh.ray_traverse_miss(to_bvh_ray(ray, ray.t_max), |r, i| {
        let o = if moving { ray.o - set.motion[i] * ray.time } else { ray.o };
        match intersect_shape(&set.shapes[i], o, ray.d, &sheared, r.tmax) {
            Some((_, b1, b2)) if cut_out(set, cutouts, i, b1, b2, ray, id_bits) => f32::INFINITY,
            Some((t, ..)) => t,
            None => f32::INFINITY,
        }
    })
}

/// Whether primitive `i` of `set` is cut out (alpha) where the ray meets it.
#[inline]
fn cut_out(
    set: &PrimitiveSet,
    cutouts: &Cutouts,
    i: usize,
    b1: f32,
    b2: f32,
    ray: &Ray,
    id_bits: u32,
) -> bool {
    match set.cutout.get(i) {
        Some(&id) if id != NO_CUTOUT => cutouts.lets_through(id, b1, b2, ray, i as u32 | id_bits),
        _ => false,
    }
}

#[derive(Default)]
struct SetBuilder {
    cutout: Vec<u32>,
    shapes: Vec<PrimitiveShape>,
    info: Vec<PrimitiveInfo>,
    motion: Vec<Vec3>,
    aabbs: Vec<Aabb>,
}

impl SetBuilder {
    fn push(&mut self, shape: PrimitiveShape, info: PrimitiveInfo, motion: Option<Vec3>, cutout: u32) {
        self.cutout.push(cutout);
        let mut aabb = shape_aabb(&shape);
        if let Some(m) = motion {
            // Linear motion sweeps the box from its start to its end position: their union bounds it.
            let end = Aabb::new(aabb.min + Vec3A::from(m), aabb.max + Vec3A::from(m));
            aabb = aabb.union(&end);
            self.motion.push(m);
        }
        self.shapes.push(shape);
        self.info.push(info);
        self.aabbs.push(aabb);
    }

    fn bounds(&self) -> Aabb {
        self.aabbs.iter().fold(Aabb::empty(), |acc, a| acc.union(a))
    }

    fn build(self, build_time: &mut Duration) -> PrimitiveSet {
        if self.shapes.is_empty() {
            return PrimitiveSet::default();
        }
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&self.aabbs, BvhBuildParams::medium_build(), build_time);
        // Store primitives in BVH leaf order: the traversal's index is then the array index, and
        // neighbouring leaves are neighbours in memory.
        let order = &bvh.primitive_indices;
        let pick = |i: &u32| *i as usize;
        let shapes = order.iter().map(|i| self.shapes[pick(i)]).collect();
        let info = order.iter().map(|i| self.info[pick(i)]).collect();
        let motion = if self.motion.is_empty() {
            Vec::new()
        } else {
            order.iter().map(|i| self.motion[pick(i)]).collect()
        };
        let cutout = if self.cutout.iter().all(|&c| c == NO_CUTOUT) {
            Vec::new()
        } else {
            order.iter().map(|i| self.cutout[pick(i)]).collect()
        };
        PrimitiveSet { bvh, shapes, info, motion, cutout }
    }
}

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

impl From<&Mesh> for MeshShading {
    fn from(m: &Mesh) -> Self {
        Self {
            normals: m.normals.clone(),
            uvs: m.uvs.clone(),
            colors: m.colors.clone(),
            tangents: m.tangents.clone(),
            indices: m.indices.clone(),
        }
    }
}
