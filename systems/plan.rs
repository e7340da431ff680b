//! What an integrator is, as the driver sees it: the phases of a pass (schedules and how often they
//! run), what its progress is counted in, how its statistics become an image, and what it adds to the
//! report. Each `integrators/*.rs` builds one; the driver runs any of them.

use crate::report::Report;
pub use crate::report::Unit;
use crate::shards::Shards;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};
use caustica_core::film::Image;

/// In which passes a phase runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum When {
    /// Every pass.
    EveryPass,
    /// The first pass this process runs (`pm`'s photon maps, which no part or checkpoint holds).
    FirstPassOfProcess,
    /// The render's first pass, pass 0 of the whole render (`ppm`'s hit points, which a checkpoint
    /// holds: a resumed render does not trace them again).
    RenderStart,
    /// Every pass but the first (what the first pass learned is frozen).
    LaterPasses,
}

impl When {
    /// Whether a phase with this rule runs in this process's pass `index`, which is the render's
    /// pass or sample `begin`.
    pub fn includes(self, index: u32, begin: u32) -> bool {
        match self {
            Self::EveryPass => true,
            Self::FirstPassOfProcess => index == 0,
            Self::RenderStart => begin == 0,
            Self::LaterPasses => index > 0,
        }
    }
}

/// How often a phase's schedule runs within a pass.
#[derive(Clone, Copy, Debug)]
pub enum Repeat {
    /// Once.
    Once,
    /// Until the predicate says no entity has work left (a bounce per run).
    WhileBusy(fn(&World) -> bool),
}

/// One step of a pass: a schedule, when it runs and how often, with a schedule run once before it
/// (hand out the pass's work) and one after it (turn what it made into what the next step reads).
pub struct Phase {
    /// Its name in the report and the profile ("bounce", "camera", "photons", "statistics").
    pub name: &'static str,
    /// Run once before the first run of `schedule`.
    pub begin: Schedule,
    /// Its systems.
    pub schedule: Schedule,
    /// Run once after the last run of `schedule`.
    pub end: Schedule,
    /// In which passes.
    pub when: When,
    /// How often `schedule` runs.
    pub repeat: Repeat,
    /// A stop while it runs drops the whole pass, as if it never began (its `end` and the later
    /// phases do not run, the pass does not count): for work that is long, precedes anything the film
    /// or a checkpoint holds, and is worthless cut short (`pm`'s photon maps).
    pub dropped_on_stop: bool,
    /// The phase runs its stages on shards, a World per worker with a chunk of the paths each
    /// ([`crate::shards`]); `schedule` then runs on the main World once per round.
    pub shards: Option<Shards>,
}

impl Phase {
    /// An empty phase. Its schedules run their systems in order on one thread: the systems
    /// parallelise their own queries, and a parallel executor would only add hand-off cost between
    /// these few, fat systems.
    pub fn new(name: &'static str, when: When, repeat: Repeat) -> Self {
        let schedule = |part: &'static str| {
            let mut schedule = Schedule::new(PhaseLabel(name, part));
            schedule.set_executor(SingleThreadedExecutor::new());
            schedule
        };
        Self {
            name,
            begin: schedule("begin"),
            schedule: schedule("run"),
            end: schedule("end"),
            when,
            repeat,
            dropped_on_stop: false,
            shards: None,
        }
    }

    /// A phase whose stages run on `shards` until every shard is idle.
    pub fn sharded(name: &'static str, when: When, shards: Shards) -> Self {
        Self { shards: Some(shards), ..Self::new(name, when, Repeat::WhileBusy(|_| false)) }
    }

    /// Add systems that run on every path of the phase, every bounce: to each shard's schedule in a
    /// sharded phase, to `schedule` otherwise. Place them with a stage's set
    /// (`.after(PassSystems::Gather)`, `.in_set(PassSystems::Scatter)`).
    pub fn add_path_systems(&mut self, systems: impl Fn(&mut Schedule) + Send + Sync + 'static) {
        match &mut self.shards {
            Some(shards) => shards.add_systems(systems),
            None => systems(&mut self.schedule),
        }
    }

    /// Lend a host's resource to the shards of a sharded phase for every round, or fold what they
    /// counted in theirs back into the main World's ([`crate::shards::ShardLink`]); nothing to do
    /// in a phase that runs on the main World.
    pub fn add_link(&mut self, link: crate::shards::ShardLink) {
        if let Some(shards) = &mut self.shards {
            shards.add_link(link);
        }
    }

    /// A phase that runs `systems` once.
    pub fn once<M>(
        name: &'static str,
        when: When,
        systems: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
    ) -> Self {
        let mut phase = Self::new(name, when, Repeat::Once);
        phase.schedule.add_systems(systems);
        phase
    }

    /// This phase with `systems` run once before it.
    pub fn with_begin<M>(
        mut self,
        systems: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
    ) -> Self {
        self.begin.add_systems(systems);
        self
    }

    /// This phase, whose pass a stop drops whole ([`Phase::dropped_on_stop`]).
    pub fn dropped_on_stop(mut self) -> Self {
        self.dropped_on_stop = true;
        self
    }

    /// This phase with `systems` run once after it.
    pub fn with_end<M>(
        mut self,
        systems: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
    ) -> Self {
        self.end.add_systems(systems);
        self
    }
}

/// A schedule's label by phase name and part, so a profile tells the phases apart.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash)]
pub struct PhaseLabel(pub &'static str, pub &'static str);

/// Where the pass that starts at progress `done` ends, for a render that aims at `target`.
pub type PassEnd = Box<dyn Fn(u32, u32) -> u32 + Send + Sync>;

/// An integrator, ready to run: its entities and resources are in the World; this says how to drive
/// them.
pub struct Plan {
    /// The phases of a pass, in order.
    pub phases: Vec<Phase>,
    /// Where each pass ends.
    pub pass_end: PassEnd,
    /// The image from the World's statistics after `passes` passes.
    pub image: fn(&World, u32) -> Image,
    /// Adds the integrator's own lines to the report.
    pub report: fn(&World, &mut Report),
    /// Clears the statistics for a new render over the same entities (a host's next frame).
    pub reset: fn(&mut World),
}

impl Plan {
    /// The phase named `name`, to add a host's systems to.
    pub fn phase_mut(&mut self, name: &str) -> Option<&mut Phase> {
        self.phases.iter_mut().find(|p| p.name == name)
    }

    /// One pass per unit of progress (the progressive photon mappers).
    pub fn one_per_pass() -> PassEnd {
        Box::new(|done, _| done + 1)
    }

    /// Everything that is left in one pass (the sample integrators: the wavefront hands out samples
    /// continuously, and a pass boundary would only make the paths wait for the last one).
    pub fn all_at_once() -> PassEnd {
        Box::new(|_, target| target)
    }
}
