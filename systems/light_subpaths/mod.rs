//! Light subpaths on the vector core: `lt`'s light half, a shard's chunk of subpaths at a time
//! (`crate::shards`), each stage over its own columns. One place for light-path code that runs on
//! shards; the kernel is `caustica_core::kernel::light_path` (the connection) on the photons'
//! emission, BSDF sampling and Russian roulette.
//!
//! A light subpath is an entity whose components are split by who reads them. It is not a photon:
//! it deposits nothing, so it carries no deposit, and what it leaves is a connection to the camera.
//!
//! | component | bytes | written by | read by |
//! |---|---|---|---|
//! | `SubpathRay` | 32 | emit, scatter | trace, scatter |
//! | `SubpathHit` | 16 | trace | scatter |
//! | `SubpathPower` (the kernel's `PhotonPath`: power, depth, media) | 36 | emit, scatter | scatter |
//! | `SubpathSampler` (its random numbers and its index in the pass) | 24 | emit | scatter |
//! | `SubpathConnection` (the kernel's `CameraConnection`: segment, film point, value) | 52 | scatter | splat |
//!
//! 160 bytes a subpath, about 210 with bevy's change ticks and the entity: a chunk of 4096
//! subpaths is 850 kB, within a core's L2 (the sizes are asserted below, so the table stays true).
//!
//! Which subpaths are alive is not a field: [`SubpathQueues`] holds the rows each stage works on.
//! Emit hands the free rows the pass's next subpath indices ([`SubpathHandout`]: one counter shared
//! by the shards, so a subpath's index, hence its random numbers, does not depend on which shard
//! or row takes it), trace reads the rays of the active rows and writes their hits, scatter makes
//! each hit a vertex, connects it to the camera (queueing the connection) and continues the subpath
//! (active) or ends it (free), and splat traces the queued connections and adds the free ones to the
//! film. The film's sums are fixed point: the same bits whatever shard or order brings a splat.
//!
//! | stage | system |
//! |---|---|
//! | `Emit` | `emit_subpaths` |
//! | `Trace` | `trace_subpaths` |
//! | `Scatter` | `scatter_subpaths` |
//! | `Shadow` | `splat_connections` |

pub mod bidirectional;
mod emit;
pub mod photons;
mod scatter;
mod splat;
mod trace;

pub use emit::emit_subpaths;
pub use scatter::scatter_subpaths;
pub use splat::splat_connections;
pub use trace::trace_subpaths;

use crate::light_paths::LightPaths;
use crate::resources::{PhotonStats, PhotonWork};
use bevy_ecs::prelude::*;
use caustica_core::geometry::Ray;
use caustica_core::geometry::bvh::Hit;
use caustica_core::kernel::light_path::CameraConnection;
use caustica_core::kernel::photon::PhotonPath;
use caustica_core::sampling::Sampler;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// The ray a subpath traces next.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SubpathRay(pub Ray);

/// The closest hit of a subpath's last trace.
#[derive(Component, Clone, Copy, Debug)]
pub struct SubpathHit(pub Hit);

impl Default for SubpathHit {
    fn default() -> Self {
        Self(Hit::MISS)
    }
}

/// Power, bounces and the media a subpath is in: the kernel's state of a light subpath.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SubpathPower(pub PhotonPath);

/// Which subpath of the pass a row carries, and its random numbers (a function of the seed, the
/// unit and the subpath's index in it: `LightPaths::sampler`, set when the subpath is emitted).
#[derive(Component, Clone, Copy, Debug)]
pub struct SubpathSampler {
    /// The subpath's random numbers.
    pub sampler: Sampler,
    /// Its index in the pass (its lens points' numbers are drawn from it).
    pub index: u32,
}

impl Default for SubpathSampler {
    fn default() -> Self {
        Self { sampler: Sampler::new(0, 0, 0), index: 0 }
    }
}

/// A vertex's connection to the camera, waiting for its segment to be traced.
#[derive(Component, Clone, Copy, Debug)]
pub struct SubpathConnection(pub CameraConnection);

impl Default for SubpathConnection {
    fn default() -> Self {
        let connection =
            CameraConnection { shadow: Ray::default(), raster: glam::Vec2::ZERO, value: glam::Vec3::ZERO };
        Self(connection)
    }
}

// The layout table above, held to the code.
const _: () = {
    assert!(size_of::<SubpathRay>() == 32 && size_of::<SubpathHit>() == 16);
    assert!(size_of::<SubpathPower>() == 36 && size_of::<SubpathSampler>() == 24);
    assert!(size_of::<SubpathConnection>() == 52);
};

/// The rows of a shard's subpaths by what they wait for. Every row is in at most one of `free` and
/// `active`; a row in `connections` may be in either (its connection was made at the vertex it
/// just left).
#[derive(Resource, Debug, Default)]
pub struct SubpathQueues {
    /// Rows without a subpath (a stack: the lowest row is taken first).
    pub free: Vec<u32>,
    /// Rows whose ray waits to be traced, then scattered.
    pub active: Vec<u32>,
    /// Rows whose connection to the camera waits to be traced and splatted.
    pub connections: Vec<u32>,
    /// Scatter's next `active`, kept to reuse its allocation.
    next: Vec<u32>,
    /// Rows in the shard.
    pub rows: u32,
}

impl SubpathQueues {
    /// Queues of `rows` free rows.
    fn new(rows: u32) -> Self {
        let capacity = rows as usize;
        Self {
            free: (0..rows).rev().collect(),
            active: Vec::with_capacity(capacity),
            connections: Vec::with_capacity(capacity),
            next: Vec::with_capacity(capacity),
            rows,
        }
    }

    /// Hand the pass's next indices to the free rows (lowest first): `start(index, row)` starts
    /// subpath `index` in `row` and says whether it did; a subpath whose light sample fails leaves
    /// its row free for the next index. Emit's loop, whatever a subpath is.
    pub fn fill_free_rows(&mut self, handout: &SubpathHandout, mut start: impl FnMut(u32, usize) -> bool) {
        while !self.free.is_empty() {
            let indices = handout.take(self.free.len() as u32);
            if indices.is_empty() {
                return;
            }
            for index in indices {
                let row = *self.free.last().expect("no more indices than free rows");
                if start(index, row as usize) {
                    self.free.pop();
                    self.active.push(row);
                }
            }
        }
    }

    /// One scatter of every active row: `step(row, connections)` makes its vertex (queueing a
    /// connection to the camera if it makes one) and says whether the subpath goes on (active next
    /// step) or ended (its row free). Returns the rows scattered. Scatter's loop, whatever a
    /// subpath leaves.
    pub fn advance_active(&mut self, mut step: impl FnMut(u32, &mut Vec<u32>) -> bool) -> u64 {
        let mut next = std::mem::take(&mut self.next);
        let mut active = std::mem::take(&mut self.active);
        for &row in &active {
            if step(row, &mut self.connections) { next.push(row) } else { self.free.push(row) }
        }
        let scattered = active.len() as u64;
        active.clear();
        self.active = next;
        self.next = active;
        scattered
    }
}

/// The pass's subpath indices, handed out to the shards' free rows from one counter (a clone
/// shares it). Which shard and row take an index varies with the threads' timing; what the subpath
/// draws does not: its numbers are a function of its unit and index.
#[derive(Resource, Clone, Debug, Default)]
pub struct SubpathHandout(Arc<Handout>);

/// The counter behind a [`SubpathHandout`].
#[derive(Debug, Default)]
struct Handout {
    /// Indices handed out (past `total` once they have run out).
    next: AtomicU64,
    /// The pass's subpaths.
    total: AtomicU64,
}

impl SubpathHandout {
    /// Start a pass of `total` subpaths, none handed out.
    pub fn begin(&self, total: u32) {
        self.0.total.store(total as u64, Ordering::Relaxed);
        self.0.next.store(0, Ordering::Relaxed);
    }

    /// The next at most `want` indices (empty once the pass's have run out).
    pub fn take(&self, want: u32) -> std::ops::Range<u32> {
        let total = self.0.total.load(Ordering::Relaxed);
        if want == 0 || self.0.next.load(Ordering::Relaxed) >= total {
            return 0..0;
        }
        let first = self.0.next.fetch_add(want as u64, Ordering::Relaxed).min(total);
        first as u32..(first + want as u64).min(total) as u32
    }

    /// Whether indices are left to hand out.
    pub fn has_more(&self) -> bool {
        self.0.next.load(Ordering::Relaxed) < self.0.total.load(Ordering::Relaxed)
    }
}

/// What a shard's subpaths counted in a round, folded into the main World's [`PhotonStats`] and
/// [`LightPaths`] after it.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct SubpathCounts {
    /// Subpath rays traced and scattered.
    pub traced: u64,
    /// Subpaths ended by Russian roulette.
    pub roulette_kills: u64,
    /// Connections to the camera traced.
    pub connections: u64,
    /// Those whose segment was free and added to the film.
    pub splatted: u64,
    /// Splats dropped because what they carried could not go to the film.
    pub dropped: u64,
}

/// Spawn `rows` light subpaths into a shard's World, all in one table, with their queues.
pub fn spawn_chunk(world: &mut World, rows: u32) {
    spawn_chunk_with(world, rows, ());
}

/// [`spawn_chunk`] with `extra` on every row too: the rows are born in their one table, which a
/// later insert would move them out of, leaving the first table's room behind.
pub fn spawn_chunk_with<B>(world: &mut World, rows: u32, extra: B)
where
    B: Bundle + Clone,
    <B as bevy_ecs::bundle::DynamicBundle>::Effect: bevy_ecs::bundle::NoBundleEffect,
{
    world.spawn_batch((0..rows).map(|_| {
        (
            SubpathRay::default(),
            SubpathHit::default(),
            SubpathPower::default(),
            SubpathSampler::default(),
            SubpathConnection::default(),
            extra.clone(),
        )
    }));
    world.insert_resource(SubpathQueues::new(rows));
}

/// Subpaths of a shard in flight, or that will be: rows with a ray or a connection to trace, and
/// the free rows while the pass still has subpaths to hand out.
pub fn in_flight(world: &World) -> u32 {
    let queues = world.resource::<SubpathQueues>();
    let working = queues.active.len() + queues.connections.len();
    let more = world.get_resource::<SubpathHandout>().is_some_and(SubpathHandout::has_more);
    let waiting = if more { queues.free.len() } else { 0 };
    (working + waiting) as u32
}

/// What a shard of light subpaths reads from the main World for a round, and counts into it: the
/// scene, the camera, the film (its sums are shared), the pass's settings and hand-out, and the
/// counters (its own, folded back).
pub fn links() -> Vec<crate::shards::ShardLink> {
    use crate::resources::{CameraResource, FilmResource, SceneResource};
    use crate::shards::ShardLink;
    vec![
        ShardLink::share::<SceneResource>(),
        ShardLink::share::<CameraResource>(),
        ShardLink::share::<FilmResource>(),
        ShardLink::share::<PhotonWork>(),
        ShardLink::share::<SubpathHandout>(),
        // The subpaths' numbers need only the subpaths a unit; the counters are the shard's own.
        ShardLink::custom(
            |main, shard| {
                let per_unit = main.resource::<LightPaths>().per_unit;
                shard.insert_resource(LightPaths { per_unit, ..Default::default() });
            },
            |shard, _| {
                shard.remove_resource::<LightPaths>();
            },
        ),
        ShardLink::custom(
            |_, shard| shard.insert_resource(SubpathCounts::default()),
            |shard, main| {
                let Some(counted) = shard.remove_resource::<SubpathCounts>() else { return };
                {
                    let mut stats = main.resource_mut::<PhotonStats>();
                    stats.traced += counted.traced;
                    stats.roulette_kills += counted.roulette_kills;
                }
                let paths = main.resource::<LightPaths>();
                paths.connections.fetch_add(counted.connections, Ordering::Relaxed);
                paths.splatted.fetch_add(counted.splatted, Ordering::Relaxed);
                paths.dropped.fetch_add(counted.dropped, Ordering::Relaxed);
            },
        ),
        ShardLink::merge::<crate::trace::TraceStatistics>(crate::trace::TraceStatistics::absorb),
    ]
}

/// A system that starts the pass's subpaths: as many as `PhotonWork` says (`begin_light_pass` set
/// them), none handed out yet.
pub fn begin_subpaths(work: Res<PhotonWork>, handout: Res<SubpathHandout>, mut stats: ResMut<PhotonStats>) {
    handout.begin(work.settings.total);
    stats.emitted += work.settings.total as u64;
}

/// Add one bounce of the light subpaths over a chunk to `schedule` (a shard's): the stages in
/// `order` (a rotation of the cycle).
pub fn add_bounce_systems(schedule: &mut Schedule, order: [caustica_core::scene::schedule::Stage; 5]) {
    use crate::stages::PassSystems;
    crate::stages::configure_stages(schedule, order);
    schedule.add_systems(emit_subpaths.in_set(PassSystems::Emit));
    schedule.add_systems(trace_subpaths.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_subpaths.in_set(PassSystems::Scatter));
    schedule.add_systems(splat_connections.in_set(PassSystems::Shadow));
}

/// Room for `additional` more in a pass's `table` (its kept light vertices, its photon deposits),
/// grown an eighth at a time rather than doubled: the table is the pass's largest, and doubling would hold up to twice what it keeps (and both
/// blocks while it moves), where the memory count has the kept vertices alone. A large block grows
/// in place (`mremap`), so the extra reallocations cost no copies.
pub(crate) fn grow_by_eighths<T>(table: &mut Vec<T>, additional: usize) {
    if table.capacity() - table.len() < additional {
        table.reserve_exact(additional.max(table.len() / 8));
    }
}

#[cfg(test)]
mod tests {
    use super::SubpathHandout;

    #[test]
    fn the_handout_deals_every_index_of_the_pass_once_then_nothing() {
        let handout = SubpathHandout::default();
        let shared = handout.clone();
        handout.begin(10);
        let mut dealt = Vec::new();
        for want in [3, 0, 4, 5, 2] {
            let (a, b) = (handout.take(want), shared.take(want));
            assert!(a.len() <= want as usize && b.len() <= want as usize, "no more than asked");
            dealt.extend(a.chain(b));
        }
        dealt.sort();
        assert_eq!(dealt, (0..10).collect::<Vec<_>>(), "each index once, whichever clone takes it");
        assert!(!handout.has_more() && shared.take(1).is_empty());
        handout.begin(2);
        assert_eq!(shared.take(5), 0..2, "a new pass starts at 0");
    }
}
