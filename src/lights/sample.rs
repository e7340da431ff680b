//! What sampling a light gives: a point for a shadow ray, or a photon's start. Every kind of light
//! (`light.rs`, `punctual.rs`) returns these, so they live apart from each, and neither light file
//! imports the other's types.

use glam::Vec3;

/// A point sampled on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// The point.
    pub p: Vec3,
    /// Surface normal there (front side).
    pub n: Vec3,
    /// Radiance leaving the point towards the reference point (zero from the back of a triangle); for
    /// a delta light, the irradiance it brings to a surface facing it.
    pub le: Vec3,
    /// Solid-angle density at the reference point (a delta light: 1, with `delta`).
    pub pdf: f32,
    /// A point, spot or sun: `le` is already the irradiance and no other strategy can find the light.
    pub delta: bool,
}

/// A photon's start on a light: where it leaves, which way, and how much it carries.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// Point on the light.
    pub p: Vec3,
    /// Front normal there.
    pub n: Vec3,
    /// Unit direction of travel.
    pub d: Vec3,
    /// Le·cosθ / (pdf_area · pdf_direction), per channel: π · area · Le for cosine-weighted directions.
    pub weight: Vec3,
}
