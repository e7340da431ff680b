//! Adaptive progressive photon mapping, `appm` (Kaplanyan & Dachsbacher 2013).
//!
//! Parameters: the `[progressive]` table of `ppm`. The camera and photon passes are `sppm`'s. What
//! differs is the radius: each hit point estimates the per-pass variance of its estimate (times r²,
//! which makes it radius-free) and the Laplacian of its radiance (biweight-kernel Laplacian over the
//! pass's photons), and takes the radius that minimises the asymptotic MSE of the average of the
//! passes' estimates, r⁶ = 2C / (μ₂² ΔL² i), kept within [¼, 2] × the global PPM radius of that pass
//! and below the initial radius.
//!
//! Where this departs from the paper: the paper works in the pixel's measurement with its own
//! kernel and a separate Laplacian bandwidth; we estimate both with the current gather radius and
//! the uniform disc kernel (μ₂ = 1/4), so the Laplacian estimate is itself biased by the disc's
//! size, and the band keeps that in check. Per-pass estimates are averaged (each with its own radius)
//! instead of Hachisuka's flux correction, which assumes a radius that only shrinks.

use super::ppm::{ProgressiveSchedules, add_camera_pass, add_photon_pass};
use crate::PassSystems;
use crate::gather::{build_pass_photon_map, gather_photons_with_laplacian};
use crate::radius::update_radii_adaptive;
use crate::resources::SceneFeatures;
use bevy_ecs::prelude::*;

/// Wire `appm`: `sppm`'s passes with the Laplacian-estimating gather and the MSE-optimal radius.
/// `nee`: light sampling at the hit points (default); without it photons carry direct light too.
pub fn build(schedules: &mut ProgressiveSchedules, features: SceneFeatures, nee: bool) {
    add_camera_pass(&mut schedules.camera, features, nee);
    add_photon_pass(&mut schedules.photons);
    schedules.statistics.add_systems(
        (build_pass_photon_map, gather_photons_with_laplacian).chain().in_set(PassSystems::Gather),
    );
    schedules.statistics.add_systems(update_radii_adaptive.in_set(PassSystems::Update));
}
