//! Chunks that stay in cache: a World per worker (a shard), each holding one chunk of the wavefront.
//!
//! A sharded phase does not run its stages over the whole wavefront one stage at a time. Each worker
//! owns a shard — its own World with a chunk of path entities (a few thousand, sized so that their
//! columns fit in a core's L2) and the integrator's stage schedule on the single-threaded executor
//! — and runs the stages over its chunk one after another, bounce after bounce. A path's columns are
//! still in cache for the next stage, and no worker waits for another between stages: the only
//! meeting point is the end of a round (a few tens of milliseconds), where the driver folds what the
//! shards counted into the main World, reports progress and decides whether to stop.
//!
//! What a shard reads from the main World (the scene, the camera, the film, the pass's work) is
//! lent to it for the round by [`ShardLink`]s: resources that share their contents through an `Arc`
//! (the film's sums are atomic, so every shard adds to the one film), or small ones copied. What it
//! counts is folded back. Entities are rows of one table per shard; which paths are alive is a
//! queue of rows ([`crate::camera_paths::PathQueues`]), not a field every stage reads.
//!
//! Images do not depend on the number of shards or the chunk size: a sample's random numbers are a
//! function of its pixel and index, whichever shard renders it, and the film's fixed-point sums do
//! not depend on the order samples arrive in.

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// What a shard's World costs beside its chunk's tables: bevy's registries and entity index, the
/// schedule and its systems' state. Measured with the counting allocator (tests/memory_count.rs):
/// 385 to 530 KiB.
pub const SHARD_WORLD_BYTES: u64 = 450 << 10;

/// Systems added to every shard's schedule: the integrator's stages, or a host's own.
pub type ShardSystems = Box<dyn Fn(&mut Schedule) + Send + Sync>;
/// Lends a resource of the main World (first) to a shard's (second).
type Lend = Box<dyn Fn(&World, &mut World) + Send + Sync>;
/// Takes it back from a shard's World (first) into the main World (second).
type TakeBack = Box<dyn Fn(&mut World, &mut World) + Send + Sync>;
/// Spawns a shard's chunk of entities: the World, the chunk, the shard's index and their count.
pub type SpawnChunk = Box<dyn Fn(&mut World, u32, usize, usize) + Send + Sync>;

/// How one resource travels between the main World and a shard's for a round: `lend` before the
/// round (copy or share it in), `take_back` after (remove the shard's copy, fold what it counted
/// into the main World).
pub struct ShardLink {
    lend: Lend,
    take_back: TakeBack,
}

impl ShardLink {
    /// The main World's `R`, cloned into every shard for each round (a resource that shares its
    /// contents, such as the scene, or a small one, such as the camera) and removed after, so that
    /// between rounds the main World's is the only one. A shard without it when the main World has
    /// none.
    pub fn share<R: Resource + Clone>() -> Self {
        Self {
            lend: Box::new(|main, shard| match main.get_resource::<R>() {
                Some(r) => shard.insert_resource(r.clone()),
                None => {
                    shard.remove_resource::<R>();
                }
            }),
            take_back: Box::new(|shard, _| {
                shard.remove_resource::<R>();
            }),
        }
    }

    /// A resource each shard keeps its own of (counters), folded into the main World's by `fold`
    /// after every round and started anew: present in the shards only while the main World has one.
    pub fn merge<R: Resource<Mutability = bevy_ecs::component::Mutable> + Default>(
        fold: fn(&mut R, R),
    ) -> Self {
        Self {
            lend: Box::new(|main, shard| {
                if main.contains_resource::<R>() {
                    shard.insert_resource(R::default());
                } else {
                    shard.remove_resource::<R>();
                }
            }),
            take_back: Box::new(move |shard, main| {
                if let (Some(counted), Some(mut total)) =
                    (shard.remove_resource::<R>(), main.get_resource_mut::<R>())
                {
                    fold(&mut total, counted);
                }
            }),
        }
    }

    /// A link of its own: `lend` before a round, `take_back` after.
    pub fn custom(
        lend: impl Fn(&World, &mut World) + Send + Sync + 'static,
        take_back: impl Fn(&mut World, &mut World) + Send + Sync + 'static,
    ) -> Self {
        Self { lend: Box::new(lend), take_back: Box::new(take_back) }
    }
}

/// What a sharded phase needs to make its shards.
pub struct ShardPlan {
    /// Paths per shard.
    pub chunk: u32,
    /// Spawn a shard's `chunk` entities and the resources it keeps: shard `index` of `count`.
    pub spawn: SpawnChunk,
    /// Paths still in flight in a shard, or that will be (work it can still take): 0 once it is idle.
    pub in_flight: fn(&World) -> u32,
    /// The integrator's stage systems.
    pub systems: ShardSystems,
    /// What the shards read from the main World and count into it.
    pub links: Vec<ShardLink>,
}

/// The shards of a phase: one per worker, each a World with its chunk of paths and its schedule.
pub struct Shards {
    plan: ShardPlan,
    /// A host's systems, added after the integrator's.
    host_systems: Vec<ShardSystems>,
    shards: Vec<Shard>,
    /// The shards' schedules lack systems added since they were made.
    stale: bool,
}

/// One worker's World and schedule.
struct Shard {
    world: World,
    schedule: Schedule,
}

/// The label of a shard's schedule.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash)]
struct ShardSchedule;

/// What a round of every shard did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Round {
    /// Schedule runs (bounces) summed over the shards.
    pub steps: u64,
    /// Paths in flight after it, over every shard (0: the phase is done).
    pub in_flight: u32,
}

impl Shards {
    /// Shards made by `plan`, one per worker thread, created when the phase first runs.
    pub fn new(plan: ShardPlan) -> Self {
        Self { plan, host_systems: Vec::new(), shards: Vec::new(), stale: true }
    }

    /// Add a host's systems to every shard's schedule (a stage's set places them: they run on
    /// every path of the chunk, every bounce).
    pub fn add_systems(&mut self, systems: impl Fn(&mut Schedule) + Send + Sync + 'static) {
        self.host_systems.push(Box::new(systems));
        self.stale = true;
    }

    /// Lend a host's resource to the shards, or fold theirs back ([`ShardLink`]).
    pub fn add_link(&mut self, link: ShardLink) {
        self.plan.links.push(link);
    }

    /// Paths over all shards (a chunk each).
    pub fn paths(&self) -> u32 {
        let shards = if self.shards.is_empty() { workers() } else { self.shards.len() };
        self.plan.chunk * shards as u32
    }

    /// Paths per shard.
    pub fn chunk(&self) -> u32 {
        self.plan.chunk
    }

    /// Make the shards (one per worker, at most `limit`) or bring their schedules up to date.
    fn prepare(&mut self, limit: usize) {
        let workers = workers().min(limit.max(1));
        while self.shards.len() < workers {
            let mut world = World::new();
            (self.plan.spawn)(&mut world, self.plan.chunk, self.shards.len(), workers);
            self.shards.push(Shard { world, schedule: Schedule::new(ShardSchedule) });
            self.stale = true;
        }
        if self.stale {
            for shard in &mut self.shards {
                let mut schedule = Schedule::new(ShardSchedule);
                schedule.set_executor(SingleThreadedExecutor::new());
                (self.plan.systems)(&mut schedule);
                for systems in &self.host_systems {
                    systems(&mut schedule);
                }
                shard.schedule = schedule;
            }
            self.stale = false;
        }
    }

    /// Run every shard on its own worker for about `budget` (at least one bounce each, none for a
    /// shard with nothing in flight), lending it what it reads and folding back what it counted.
    pub fn run_round(&mut self, main: &mut World, budget: Duration) -> Round {
        self.prepare(main.get_resource::<ShardLimit>().map_or(usize::MAX, |limit| limit.0));
        for shard in &mut self.shards {
            for link in &self.plan.links {
                (link.lend)(main, &mut shard.world);
            }
        }
        let in_flight = self.plan.in_flight;
        let rounds: Vec<Round> =
            self.shards.par_iter_mut().map(|shard| shard.run(budget, in_flight)).collect();
        for shard in &mut self.shards {
            for link in self.plan.links.iter().rev() {
                (link.take_back)(&mut shard.world, main);
            }
        }
        rounds.iter().fold(Round::default(), |a, b| Round {
            steps: a.steps + b.steps,
            in_flight: a.in_flight + b.in_flight,
        })
    }

    /// Drop every path in flight (a pass dropped by a stop): the shards are made anew, chunks
    /// and all, when the phase next runs.
    pub fn drop_paths(&mut self) {
        self.shards.clear();
        self.stale = true;
    }

    /// Run `f` on every shard's World (a host reading its paths, a test).
    pub fn for_each_world(&mut self, mut f: impl FnMut(&mut World)) {
        if self.shards.is_empty() {
            self.prepare(usize::MAX);
        } else {
            self.prepare(self.shards.len());
        }
        for shard in &mut self.shards {
            f(&mut shard.world);
        }
    }
}

impl Shard {
    /// Bounces until nothing is in flight or `budget` has passed.
    fn run(&mut self, budget: Duration, in_flight: fn(&World) -> u32) -> Round {
        let start = Instant::now();
        let mut steps = 0;
        loop {
            if in_flight(&self.world) == 0 {
                return Round { steps, in_flight: 0 };
            }
            self.schedule.run(&mut self.world);
            steps += 1;
            let full = self.world.get_resource::<RoundFull>().is_some_and(|full| full.0);
            if full || start.elapsed() >= budget {
                return Round { steps, in_flight: in_flight(&self.world) };
            }
        }
    }
}

/// Set by a shard's systems when what the shard keeps for the main World has reached the size the
/// memory count gave it: its round ends after that bounce, to be folded, whatever time is left.
/// (Rounds end by time anyway, and nothing a render computes depends on where they end.)
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct RoundFull(pub bool);

/// Worker threads: one shard each.
pub fn workers() -> usize {
    rayon::current_num_threads().max(1)
}

/// The most shards a render's phases make, whatever the worker count: a film's pixels over the
/// smallest chunk that is cut, so that a thousand workers on a small film do not each make a World
/// and a chunk (`--threads 1024` on a 32² film took 11 s and 1.6 GB). Any number of shards gives
/// the same bits.
#[derive(Resource, Clone, Copy, Debug)]
pub struct ShardLimit(pub usize);

impl ShardLimit {
    /// The limit for a `pixels`-pixel render.
    pub fn for_film(pixels: u64) -> Self {
        Self(usize::try_from(pixels.div_ceil(SMALLEST_SHARED_CHUNK)).unwrap_or(usize::MAX).max(1))
    }
}

/// Rows below which a chunk is not cut to a worker's share of the film: enough lanes to queue by
/// material, and photon passes (whose work is not the film's) keep a useful batch.
const SMALLEST_SHARED_CHUNK: u64 = 64;

/// The chunk a worker keeps in flight for a `pixels`-pixel render asked for `requested` rows: at
/// most its share of the film, so that many workers on a small film do not each spawn a full chunk
/// (`--threads 1024` on a 32² film made 4 million paths). Any chunk gives the same bits.
pub fn chunk_within_share(requested: u32, pixels: u64) -> u32 {
    let share = pixels.div_ceil(workers() as u64).max(SMALLEST_SHARED_CHUNK);
    requested.min(u32::try_from(share).unwrap_or(u32::MAX))
}
