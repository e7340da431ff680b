//! Bidirectional path tracing (Veach 1997, ch. 10; Lafortune & Willems 1993) as pure functions on
//! plain data: light subpaths whose non-delta vertices are kept ([`LightVertex`]) and connected to
//! the camera (t = 1), camera subpaths that add the emission they hit (s = 0), sample a light at
//! each vertex (s = 1) and connect to every kept vertex of one light subpath (s, t ≥ 2). Every
//! strategy's contribution carries its power-heuristic weight among all the strategies that make
//! the same path, from the running sums of [`mis`].
//!
//! Emission, the BSDFs and Russian roulette are the photons' and the camera paths' own
//! ([`super::photon`], [`super::continuation`]); what is new here is the bookkeeping of densities
//! and the connections.

pub mod camera_side;
pub mod light_side;
pub mod mis;

#[cfg(test)]
mod tests;

pub use camera_side::{CameraVertex, camera_vertex, connect_vertices, merge_vertices};
pub use light_side::{
    KeptBsdf, LightOrigin, LightVertex, MergeVertex, NewLightVertex, emit_light_subpath, light_subpath_vertex,
};
pub use mis::{MisFactors, SubpathMis};
