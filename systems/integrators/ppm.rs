//! Progressive photon mapping, `ppm` (Hachisuka, Ogaki & Jensen 2008), and the stages that its
//! stochastic and data-driven variants share.
//!
//! | parameter (`[progressive]`) | type | default | meaning |
//! |---|---|---|---|
//! | `passes` | u32 | 64 | photon passes (`render.time_limit` may stop earlier) |
//! | `photons_per_pass` | u32 | 65 536 | photons emitted per pass |
//! | `alpha` | f32 | 2/3 | fraction of each pass's photons kept (`ppm`, `sppm`, and `appm`'s bounds) |
//! | `initial_radius` | f32 | from the scene | first gather radius (`photon::progressive::initial_radius`) |
//! | `memory_budget_mib` | u64 | half the RAM | hit points + photons may not exceed it |
//!
//! Three schedules, run in this order each pass:
//! - camera: Emit → Trace → Scatter (`scatter_to_visible_points`) → Shadow → Gather (film), until
//!   every camera path has found its hit point (`ppm` runs it in the first pass only);
//! - photons: Emit → Trace → Scatter → Gather (`store_photons`), until every photon has landed;
//! - statistics: Gather (`build_pass_photon_map`, then a `gather_photons_into_*`) → Update.
//!
//! `ppm` takes all light except directly seen emission from photons, as the paper does, so its
//! photons are stored from their first hit on and the camera pass draws no light sample.

use crate::PassSystems;
use crate::emit::emit_camera_paths_for;
use crate::gather::{build_pass_photon_map, gather_photons_into_hit_points, splat_paths_to_film};
use crate::radius::update_hit_point_radii;
use crate::resources::SceneFeatures;
use crate::trace::{trace_paths, trace_shadow_rays};
use crate::visible_points::scatter_to_visible_points;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};

/// The three schedules of a progressive render.
pub struct ProgressiveSchedules {
    /// Camera paths to hit points.
    pub camera: Schedule,
    /// One photon pass, a bounce per run.
    pub photons: Schedule,
    /// Gather the pass's photons into the hit points and update them.
    pub statistics: Schedule,
}

impl ProgressiveSchedules {
    /// Empty schedules with their stages in the default order, on one thread each (systems
    /// parallelise their own queries; a parallel executor would only add hand-off cost between these
    /// few, fat systems).
    pub fn new() -> Self {
        Self::with_order(crate::scene::schedule::CYCLE)
    }

    /// As [`ProgressiveSchedules::new`], with the camera and photon stages in `order` (a rotation).
    pub fn with_order(order: [crate::scene::schedule::Stage; 5]) -> Self {
        let empty = |label: &'static str| {
            let mut schedule = Schedule::new(Named(label));
            schedule.set_executor(SingleThreadedExecutor::new());
            schedule
        };
        let (mut camera, mut photons, mut statistics) =
            (empty("camera"), empty("photons"), empty("statistics"));
        super::configure_stages(&mut camera, order);
        super::configure_stages(&mut photons, order);
        statistics.configure_sets((PassSystems::Gather, PassSystems::Update).chain());
        Self { camera, photons, statistics }
    }
}

impl Default for ProgressiveSchedules {
    fn default() -> Self {
        Self::new()
    }
}

/// A schedule label by name, so a profile tells the three schedules apart.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash)]
pub struct Named(pub &'static str);

/// The camera pass: paths to their first non-specular hit; `nee` adds a light sample there.
pub fn add_camera_pass(schedule: &mut Schedule, features: SceneFeatures, nee: bool) {
    schedule.add_systems(emit_camera_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    if nee && features.lights {
        schedule.add_systems(scatter_to_visible_points::<true>.in_set(PassSystems::Scatter));
        schedule.add_systems(trace_shadow_rays.in_set(PassSystems::Shadow));
    } else {
        schedule.add_systems(scatter_to_visible_points::<false>.in_set(PassSystems::Scatter));
    }
    schedule.add_systems(splat_paths_to_film.in_set(PassSystems::Gather));
}

/// The photon pass (the same systems as photon mapping's).
pub fn add_photon_pass(schedule: &mut Schedule) {
    use crate::photons::{emit_photons, scatter_photons, store_photons, trace_photons};
    schedule.add_systems(emit_photons.in_set(PassSystems::Emit));
    schedule.add_systems(trace_photons.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_photons.in_set(PassSystems::Scatter));
    schedule.add_systems(store_photons.in_set(PassSystems::Gather));
}

/// Wire `ppm`: a camera pass without light sampling, photons from their first hit on, the
/// shrinking-radius update.
pub fn build(schedules: &mut ProgressiveSchedules, features: SceneFeatures) {
    add_camera_pass(&mut schedules.camera, features, false);
    add_photon_pass(&mut schedules.photons);
    schedules.statistics.add_systems(
        (build_pass_photon_map, gather_photons_into_hit_points).chain().in_set(PassSystems::Gather),
    );
    schedules.statistics.add_systems(update_hit_point_radii.in_set(PassSystems::Update));
}
