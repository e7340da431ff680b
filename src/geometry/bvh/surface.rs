//! What shading reads after a hit: each mesh's vertex attributes, kept beside the trees, and the
//! surface at a hit point interpolated from them (or a triangle as lanes of shading take it whole).

use super::{Geometry, Hit, MOVING_BIT, PrimitiveShape, SET_BITS};
use crate::geometry::Ray;
use crate::geometry::offset::gamma;
use crate::geometry::sphere::sphere_hit_point;
use crate::geometry::triangle::triangle_point_error;
use crate::scene::Mesh;
use glam::{Vec2, Vec3, Vec4};

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

/// A triangle as lanes of shading read it ([`Geometry::plain_triangle`]).
#[derive(Clone, Copy, Debug)]
pub struct PlainTriangle {
    /// Vertices.
    pub p: [Vec3; 3],
    /// Vertex normals, when the mesh has them.
    pub normals: Option<[Vec3; 3]>,
    /// Material index.
    pub material: u32,
    /// Light index or `NO_LIGHT`.
    pub light: u32,
}

impl PlainTriangle {
    /// A placeholder (a degenerate triangle at the origin).
    pub const EMPTY: Self = Self { p: [Vec3::ZERO; 3], normals: None, material: 0, light: super::NO_LIGHT };
}

/// Vertex attributes of a mesh, kept for shading.
#[derive(Clone, Debug, Default)]
pub(super) struct MeshShading {
    normals: Option<Vec<Vec3>>,
    uvs: Vec<Vec<Vec2>>,
    colors: Option<Vec<Vec3>>,
    tangents: Option<Vec<Vec4>>,
    pub(super) indices: Vec<[u32; 3]>,
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

impl Geometry {
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

    /// Triangle `prim` as lanes of shading read it ([`crate::kernel::lanes`]): its vertices, its
    /// vertex normals if the mesh has them, its material and light. `None` for what lanes leave to
    /// [`Geometry::surface_hit`]: spheres, primitives that move over the shutter, and meshes with
    /// vertex colours.
    #[inline]
    pub fn plain_triangle(&self, prim: u32) -> Option<PlainTriangle> {
        if prim & SET_BITS == MOVING_BIT {
            return None;
        }
        let (shape, info, _) = self.primitive(prim);
        let PrimitiveShape::Triangle(p) = *shape else { return None };
        let mesh = &self.meshes[info.object as usize];
        if mesh.colors.is_some() {
            return None;
        }
        let normals = mesh.normals.as_ref().map(|n| mesh.indices[info.index as usize].map(|v| n[v as usize]));
        Some(PlainTriangle { p, normals, material: info.material, light: info.light })
    }

    /// Ask for what [`Geometry::plain_triangle`] reads of primitive `prim` (its shape and cold
    /// data), ahead of reading it: lanes ask for a group's before they read any.
    #[inline]
    pub fn prefetch_primitive(&self, prim: u32) {
        let (set, i) = self.set_of(prim);
        if let (Some(shape), Some(info)) = (set.shapes.get(i), set.info.get(i)) {
            crate::geometry::wide_bvh::prefetch_line(shape);
            crate::geometry::wide_bvh::prefetch_line(info);
        }
    }

    /// The material and light of triangle `prim` when lanes can shade it
    /// ([`Geometry::plain_triangle`] would return it): `None` for spheres, primitives that move
    /// over the shutter and meshes with vertex colours. One load of the primitive's cold data.
    #[inline]
    pub fn lane_material(&self, prim: u32) -> Option<(u32, u32)> {
        if prim & SET_BITS == MOVING_BIT {
            return None;
        }
        let (set, i) = self.set_of(prim);
        let info = &set.info[i];
        if info.kind != super::PrimitiveKind::Triangle || self.meshes[info.object as usize].colors.is_some() {
            return None;
        }
        Some((info.material, info.light))
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
