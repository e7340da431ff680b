//! The progressive photon mappers' settings and pass.

use bevy_ecs::resource::Resource;
use caustica_core::photon::progressive::RadiusRule;

/// Settings and progress of a progressive photon-mapping render, read by the gather and update stages.
#[derive(Resource, Clone, Copy, Debug)]
pub struct ProgressiveConfig {
    /// Radius and accumulation rule.
    pub rule: RadiusRule,
    /// Fraction of new photons kept (Hachisuka, Ogaki & Jensen 2008).
    pub alpha: f32,
    /// Starting radius.
    pub r0: f32,
    /// Whether the user gave the starting radius (else the first pass may shrink it).
    pub r0_given: bool,
    /// Photons emitted per pass.
    pub photons_per_pass: u32,
    /// Hit points per pixel.
    pub hit_points_per_pixel: u32,
    /// The running pass (0-based); after the update, the number of passes done minus one.
    pub pass: u32,
}
