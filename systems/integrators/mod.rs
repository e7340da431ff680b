//! Integrators as schedule builders: each only places systems into the `PassSystems` stages.

pub mod appm;
pub mod cppm;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod sppm;

use crate::scene::schedule::Stage;
use crate::PassSystems;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule};

/// The stage set of a run-file stage name.
pub fn stage_set(stage: Stage) -> PassSystems {
    match stage {
        Stage::Emit => PassSystems::Emit,
        Stage::Trace => PassSystems::Trace,
        Stage::Scatter => PassSystems::Scatter,
        Stage::Shadow => PassSystems::Shadow,
        Stage::Gather => PassSystems::Gather,
    }
}

/// Chain the five per-bounce stages in `order` (a checked rotation, `ScheduleSettings::stage_order`).
pub fn configure_stages(schedule: &mut Schedule, order: [Stage; 5]) {
    let [a, b, c, d, e] = order.map(stage_set);
    schedule.configure_sets((a, b, c, d, e).chain());
}
