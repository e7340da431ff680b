//! The stages of a bounce as bevy system sets, and their order: the one vocabulary that integrators,
//! light subpaths and the driver share, below all of them.

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::{IntoScheduleConfigs, SystemSet};
use caustica_core::scene::RunFile;
use caustica_core::scene::schedule::{CYCLE, Stage};

/// The stages of one bounce, in order, and the update that closes a progressive pass. Integrators
/// place their systems into these sets.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PassSystems {
    /// Start new camera paths (or photons) where the previous ones ended.
    Emit,
    /// Closest-hit queries for every active path.
    Trace,
    /// Shade hits: emission, light sampling (NEE), BSDF sampling, Russian roulette.
    Scatter,
    /// Any-hit queries for the shadow rays of this bounce.
    Shadow,
    /// Splat finished paths onto the film; store photons; gather photons into hit points.
    Gather,
    /// Fold a pass's photons into the hit points' statistics: radius and flux (progressive photon
    /// mapping).
    Update,
}

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

/// The run's stage order (checked with the run file).
pub fn stage_order(run: &RunFile) -> [Stage; 5] {
    run.schedule.stage_order().unwrap_or(CYCLE)
}
