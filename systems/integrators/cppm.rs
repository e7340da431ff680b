//! Chi-squared progressive photon mapping, `cppm` (Lin et al. 2020).
//!
//! Parameters: the `[progressive]` table of `ppm` (`alpha` is not used). The camera and photon passes
//! are `sppm`'s. Each hit point counts its photons in 2 equal-area rings × 6 sectors of the gather
//! disc, accumulated over passes. Once the counts hold enough photons (64 at first), Pearson's χ²
//! test for uniformity at the 95% level decides: uniform, keep the radius and keep counting; not
//! uniform but uniform in the inner ring, shrink to the inner ring (r²/2); otherwise shrink r² by 0.8.
//! A shrink restarts the counts and raises the photons needed for the next test by 1.5625×.
//! Each pass's estimate Φ_i / (π r_i²) is averaged into the pixel.
//!
//! This follows the authors' Mitsuba implementation (`cppm1.cpp`: the same cells, level,
//! shrink factors and patience); the count threshold starts at 64 photons here instead of their
//! k-NN parameter.

use super::ppm::{ProgressiveSchedules, add_camera_pass, add_photon_pass};
use crate::PassSystems;
use crate::gather::{build_pass_photon_map, gather_photons_into_chi2_cells};
use crate::radius::update_radii_by_chi2;
use crate::resources::SceneFeatures;
use bevy_ecs::prelude::*;

/// Wire `cppm`: `sppm`'s passes with the cell-counting gather and the χ² radius rule.
/// `nee`: light sampling at the hit points (default); without it photons carry direct light too.
pub fn build(schedules: &mut ProgressiveSchedules, features: SceneFeatures, nee: bool) {
    add_camera_pass(&mut schedules.camera, features, nee);
    add_photon_pass(&mut schedules.photons);
    schedules.statistics.add_systems(
        (build_pass_photon_map, gather_photons_into_chi2_cells).chain().in_set(PassSystems::Gather),
    );
    schedules.statistics.add_systems(update_radii_by_chi2.in_set(PassSystems::Update));
}
