//! Stochastic progressive photon mapping, `sppm` (Hachisuka & Jensen 2009).
//!
//! Parameters: the `[progressive]` table (see `integrators::progressive`). Each pass re-traces every
//! pixel's camera path with a new camera sample (filter, lens, and one shutter time per pass shared
//! with that pass's photons), so depth of field, motion blur, antialiasing and glossy surfaces converge.
//! The hit point's statistics (N, R, τ) persist per pixel across passes. Direct light comes from one
//! light sample per pass into the film; photons are kept from their second hit on.

use super::descriptor::Integrator;
use super::progressive::{self, Variant};
use crate::gather::{build_pass_photon_map, gather_photons_into_hit_points};
use crate::plan::Plan;
use crate::resources::SceneFeatures;
use crate::stages::PassSystems;
use crate::update::update_hit_point_radii;
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::photon::progressive::RadiusRule;
use caustica_core::scene::{IntegratorKind, RunFile};

/// `sppm`: hit points re-traced every pass.
pub static SPPM: Integrator = progressive::descriptor(IntegratorKind::Sppm, plan);

/// The plan of `sppm`: camera pass with light sampling (without it, `[schedule] nee = false`, photons
/// carry direct light too), photon pass, gather, shrinking-radius update.
fn plan(this: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let variant = Variant {
        rule: RadiusRule::Shrinking,
        statistics: |schedule| {
            schedule.add_systems(
                (build_pass_photon_map, gather_photons_into_hit_points).chain().in_set(PassSystems::Gather),
            );
            schedule.add_systems(update_hit_point_radii.in_set(PassSystems::Update));
        },
    };
    progressive::plan(this, world, run, features, variant)
}
