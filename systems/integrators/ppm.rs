//! Progressive photon mapping, `ppm` (Hachisuka, Ogaki & Jensen 2008).
//!
//! Parameters: the `[progressive]` table (see `integrators::progressive`). The camera pass runs in
//! the first pass only: the hit points stay where they are, and photon passes shrink their radii and
//! correct their flux. `ppm` takes all light but directly seen emission from photons, as the paper
//! does, so its photons are stored from their first hit on and the camera pass samples no light.
//! One fixed hit point per pixel would converge to a point-sampled image and alias every edge; the
//! default is 32 per pixel, the points of a (0, 5, 2)-net over the pixel filter (`sampling::net`).

use super::descriptor::{Integrator, LightSampling};
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

/// `ppm`: hit points traced once, 32 per pixel by default, and all light but directly seen emission from photons.
pub static PPM: Integrator = Integrator {
    light_sampling: LightSampling::Never,
    default_hit_points_per_pixel: 32,
    hit_points_traced_once: true,
    ..progressive::descriptor(IntegratorKind::Ppm, plan)
};

/// The plan of `ppm`: the camera pass once, without light sampling; photons from their first hit
/// on; the shrinking-radius update.
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
