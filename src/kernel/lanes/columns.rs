//! How lanes reach a chunk's camera paths: through the components' own slices, a row at a time,
//! never through a copy of them. The ECS layer implements [`CameraColumns`] over its columns; the
//! lanes load a group's inputs from it and store what each vertex wrote back into it.

use super::super::{CameraPath, ShadowSample};
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::sampling::Sampler;
use glam::Vec3;

/// A chunk of camera paths as columns, addressed by row.
pub trait CameraColumns {
    /// The ray that found the row's vertex (its next ray is written over it).
    fn ray(&mut self, row: u32) -> &mut Ray;
    /// Where that ray landed.
    fn hit(&self, row: u32) -> &Hit;
    /// The path's throughput, radiance, MIS and roulette state.
    fn path(&mut self, row: u32) -> &mut CameraPath;
    /// The path's random numbers.
    fn sampler(&self, row: u32) -> Sampler;
    /// The row's vertex is shaded: whether its path goes on, and its light sample if it took one.
    fn vertex_done(&mut self, row: u32, continues: bool, light_sample: Option<ShadowSample>);
    /// Shade the row's vertex with the scalar kernel (a lane class found it needs what its lanes
    /// do not hold: a texel that makes the material a mirror, say), then as
    /// [`CameraColumns::vertex_done`].
    fn scalar_vertex(&mut self, row: u32);
    /// Whether the render records feature images (then [`CameraColumns::reached`] is called).
    fn records_features(&self) -> bool {
        false
    }
    /// The row's path reached a non-specular surface `t` along its ray, whose albedo estimate is
    /// `albedo` and whose shading normal on the side seen is `normal`, carrying `beta` there (the
    /// feature images' first surface; called before the vertex changes the path).
    fn reached(&mut self, row: u32, t: f32, albedo: Vec3, normal: Vec3, beta: Vec3) {
        let _ = (row, t, albedo, normal, beta);
    }
}
