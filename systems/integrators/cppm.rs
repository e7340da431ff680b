//! Chi-squared progressive photon mapping, `cppm` (Lin et al. 2020).
//!
//! Parameters: the `[progressive]` table (see `integrators::progressive`) (`alpha` is not used). The camera and photon passes
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

use super::descriptor::Integrator;
use super::progressive::{self, Variant};
use crate::gather::{build_pass_photon_map, gather_photons_into_chi2_cells};
use crate::plan::Plan;
use crate::resources::SceneFeatures;
use crate::stages::PassSystems;
use crate::update::update_radii_by_chi2;
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::photon::progressive::RadiusRule;
use caustica_core::scene::{IntegratorKind, RunFile};

/// `cppm`: `sppm` with the radius chosen by a χ² test.
pub static CPPM: Integrator = progressive::descriptor(IntegratorKind::Cppm, plan);

/// The plan of `cppm`: `sppm`'s passes with the cell-counting gather and the χ² radius rule.
fn plan(this: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let variant = Variant {
        rule: RadiusRule::ChiSquare,
        statistics: |schedule| {
            schedule.add_systems(
                (build_pass_photon_map, gather_photons_into_chi2_cells).chain().in_set(PassSystems::Gather),
            );
            schedule.add_systems(update_radii_by_chi2.in_set(PassSystems::Update));
        },
    };
    progressive::plan(this, world, run, features, variant)
}
