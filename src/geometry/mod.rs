//! Geometry: rays, robust intersection, and the obvhs BVH over the scene's primitives.

pub mod alpha;
pub mod bvh;
pub mod offset;
pub mod sphere;
pub mod triangle;
pub mod triangle_pack;
pub mod wide_bvh;

pub use bvh::{Geometry, PrimitiveKind, SurfaceHit};

use glam::Vec3;

/// A ray `o + t·d`, `0 < t < t_max`, at a time in the shutter interval (0 = open, 1 = close).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction (unit length for camera and scattered rays; shadow rays span the segment).
    pub d: Vec3,
    /// Upper bound on t.
    pub t_max: f32,
    /// Normalized shutter time in [0, 1].
    pub time: f32,
}

impl Default for Ray {
    fn default() -> Self {
        Self { o: Vec3::ZERO, d: Vec3::Z, t_max: 0.0, time: 0.0 }
    }
}

/// Centre and radius of the sphere around the box [`min`, `max`]. An empty or non-finite box (a
/// scene with no geometry) is taken as the unit sphere at the origin, so that what is framed or
/// lit around it stays finite.
pub fn bounding_sphere(min: Vec3, max: Vec3) -> (Vec3, f32) {
    if (max - min).is_finite() && max.cmpge(min).all() {
        (0.5 * (min + max), 0.5 * (max - min).length())
    } else {
        (Vec3::ZERO, 1.0)
    }
}
