//! Stochastic progressive photon mapping, `sppm` (Hachisuka & Jensen 2009).
//!
//! Parameters: the `[progressive]` table of `ppm` (see `integrators::ppm`). Each pass re-traces every
//! pixel's camera path with a new camera sample (filter, lens, and one shutter time per pass shared
//! with that pass's photons), so depth of field, motion blur, antialiasing and glossy surfaces converge.
//! The hit point's statistics (N, R, τ) persist per pixel across passes. Direct light comes from one
//! light sample per pass into the film; photons are kept from their second hit on.

use super::ppm::{ProgressiveSchedules, add_camera_pass, add_photon_pass};
use crate::PassSystems;
use crate::gather::{build_pass_photon_map, gather_photons_into_hit_points};
use crate::radius::update_hit_point_radii;
use crate::resources::SceneFeatures;
use bevy_ecs::prelude::*;

/// Wire `sppm`: camera pass with light sampling, photon pass, gather, shrinking-radius update.
/// `nee`: light sampling at the hit points (default); without it photons carry direct light too.
pub fn build(schedules: &mut ProgressiveSchedules, features: SceneFeatures, nee: bool) {
    add_camera_pass(&mut schedules.camera, features, nee);
    add_photon_pass(&mut schedules.photons);
    schedules.statistics.add_systems(
        (build_pass_photon_map, gather_photons_into_hit_points).chain().in_set(PassSystems::Gather),
    );
    schedules.statistics.add_systems(update_hit_point_radii.in_set(PassSystems::Update));
}
