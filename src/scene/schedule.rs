//! The `[schedule]` table of a run file: the order of the stages within a step and of the passes
//! within a progressive pass, and the optional systems, checked against what the data flow allows.
//!
//! One run of a schedule is one bounce: Emit → Trace → Scatter → Shadow → Gather, and Gather hands
//! finished paths their next sample for the next run's Emit. Any rotation of that cycle only moves
//! where a run starts, so every rotation renders the same image bit for bit; any other order feeds a
//! stage data its predecessor has not written yet, and is refused with the dependency it breaks.

use serde::Deserialize;

/// A stage of the per-bounce cycle (`systems::PassSystems`), as named in run files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage {
    /// Camera rays (or photons) for paths that need one.
    Emit,
    /// Closest hits.
    Trace,
    /// Shading, light sampling, BSDF sampling, Russian roulette.
    Scatter,
    /// Shadow rays.
    Shadow,
    /// Film splats (or photon storage) and work hand-out.
    Gather,
}

/// The canonical cycle.
pub const CYCLE: [Stage; 5] = [Stage::Emit, Stage::Trace, Stage::Scatter, Stage::Shadow, Stage::Gather];

/// What each stage reads from the one before it in the cycle.
fn reads_from_previous(stage: Stage) -> &'static str {
    match stage {
        Stage::Emit => "the next sample that gather hands out",
        Stage::Trace => "the rays that emit and scatter write",
        Stage::Scatter => "the hits that trace finds",
        Stage::Shadow => "the shadow rays that scatter writes",
        Stage::Gather => "the radiance that shadow adds",
    }
}

/// The schedules of one progressive pass, as named in run files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pass {
    /// Camera paths to hit points.
    Camera,
    /// Photon tracing.
    Photons,
    /// Gather the pass's photons into the hit points, then update them.
    Statistics,
}

/// The `[schedule]` table.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScheduleSettings {
    /// Stage order within a step: a rotation of emit, trace, scatter, shadow, gather.
    pub order: Option<Vec<Stage>>,
    /// Progressive integrators: order of the camera, photon and statistics schedules in a pass.
    pub passes: Option<Vec<Pass>>,
    /// Light sampling at camera vertices (`pt`, `sppm`, `appm`, `cppm`); off, `pt` samples BSDFs only
    /// and the progressive ones take direct light from photons, as `ppm` does.
    pub nee: Option<bool>,
    /// `pm`'s caustic map (it cannot be dropped: no other estimate carries L S+ D E light).
    pub caustic_map: Option<bool>,
}

impl ScheduleSettings {
    /// The stage order to use, checked.
    pub fn stage_order(&self) -> Result<[Stage; 5], String> {
        let Some(order) = &self.order else { return Ok(CYCLE) };
        for stage in CYCLE {
            let count = order.iter().filter(|&&s| s == stage).count();
            if count != 1 {
                return Err(format!(
                    "schedule.order names {stage:?} {count} times; it needs each of emit, trace, scatter, shadow, gather once"
                ));
            }
        }
        if order.len() != CYCLE.len() {
            return Err(format!("schedule.order has {} stages; it needs the five of the cycle", order.len()));
        }
        let start = CYCLE.iter().position(|&s| s == order[0]).unwrap_or(0);
        for (i, &stage) in order.iter().enumerate() {
            let expected = CYCLE[(start + i) % CYCLE.len()];
            if stage != expected {
                let before = CYCLE
                    [(CYCLE.iter().position(|&s| s == stage).unwrap_or(0) + CYCLE.len() - 1) % CYCLE.len()];
                return Err(format!(
                    "schedule.order puts {stage:?} where {expected:?} must run: {stage:?} reads {} and must come right \
                     after {before:?} (any rotation of emit, trace, scatter, shadow, gather is valid)",
                    reads_from_previous(stage)
                ));
            }
        }
        Ok([order[0], order[1], order[2], order[3], order[4]])
    }

    /// The progressive pass order to use, checked.
    pub fn pass_order(&self) -> Result<[Pass; 3], String> {
        let Some(passes) = &self.passes else { return Ok([Pass::Camera, Pass::Photons, Pass::Statistics]) };
        let mut sorted = passes.clone();
        sorted.sort_by_key(|p| *p as u8);
        if sorted != [Pass::Camera, Pass::Photons, Pass::Statistics] {
            return Err(format!(
                "schedule.passes is {passes:?}; it needs camera, photons and statistics once each"
            ));
        }
        if passes[2] != Pass::Statistics {
            return Err(
                "schedule.passes must end with statistics: it gathers this pass's photons into this pass's hit points"
                    .into(),
            );
        }
        Ok([passes[0], passes[1], passes[2]])
    }

    /// Check the orders (what each integrator takes is its descriptor's to check:
    /// `systems::integrators::Integrator::check`).
    pub fn check(&self) -> Result<(), String> {
        self.stage_order()?;
        self.pass_order()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with_order(order: &[Stage]) -> ScheduleSettings {
        ScheduleSettings { order: Some(order.to_vec()), ..Default::default() }
    }

    #[test]
    fn every_rotation_of_the_cycle_is_valid() {
        for start in 0..5 {
            let order: Vec<Stage> = (0..5).map(|i| CYCLE[(start + i) % 5]).collect();
            assert_eq!(with_order(&order).stage_order().unwrap().to_vec(), order);
        }
    }

    #[test]
    fn a_swap_is_refused_naming_the_broken_dependency() {
        use Stage::*;
        let message = with_order(&[Trace, Emit, Scatter, Shadow, Gather]).stage_order().unwrap_err();
        assert!(message.contains("Emit") && message.contains("after Gather"), "{message}");
        let message = with_order(&[Emit, Trace, Scatter, Gather, Shadow]).stage_order().unwrap_err();
        assert!(message.contains("Gather") && message.contains("Shadow"), "{message}");
        assert!(with_order(&[Emit, Trace, Scatter, Shadow]).stage_order().is_err());
        assert!(with_order(&[Emit, Emit, Trace, Scatter, Shadow, Gather]).stage_order().is_err());
    }

    #[test]
    fn statistics_must_close_a_progressive_pass() {
        use Pass::*;
        let s = |p: &[Pass]| ScheduleSettings { passes: Some(p.to_vec()), ..Default::default() };
        assert!(s(&[Photons, Camera, Statistics]).pass_order().is_ok());
        assert!(s(&[Camera, Statistics, Photons]).pass_order().is_err());
        assert!(s(&[Camera, Photons]).pass_order().is_err());
    }
}
