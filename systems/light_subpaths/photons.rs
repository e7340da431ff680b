//! Photons on the vector core: the photon passes of `pm` and the progressive mappers, a shard's
//! chunk of photons at a time, on the light subpaths' columns and queues (a photon is a light
//! subpath that leaves deposits for a map instead of connections to the camera).
//!
//! | component | bytes | written by | read by |
//! |---|---|---|---|
//! | `SubpathRay` | 32 | emit, scatter | trace, scatter |
//! | `SubpathHit` | 16 | trace | scatter |
//! | `SubpathPower` (the kernel's `PhotonPath`) | 36 | emit, scatter | scatter |
//! | `SubpathSampler` (its random numbers and its index in the pass) | 24 | emit | scatter |
//!
//! | stage | system |
//! |---|---|
//! | `Emit` | `emit_photon_subpaths` |
//! | `Trace` | `trace_subpaths` |
//! | `Scatter` | `scatter_photon_subpaths` |
//!
//! A photon's index comes from the pass's [`SubpathHandout`], its numbers from (pass, map kind,
//! index): the set of deposits does not depend on the sharding. Each shard appends its deposits,
//! tagged with the photon's index and bounce, to its own [`PhotonTrail`], folded into the main
//! World's after every round; [`order_photon_deposits`] then puts the pass's deposits in the order
//! the one-wavefront photon pass stored them in (bounce after bounce, each in photon-entity order),
//! so the kd-tree, hence every gather's float sums, is the same to the bit whatever the thread
//! count.

use super::{
    SubpathCounts, SubpathHandout, SubpathHit, SubpathPower, SubpathQueues, SubpathRay, SubpathSampler,
};
use crate::resources::{PhotonBuffer, PhotonStats, PhotonWork, SceneResource};
use crate::shards::ShardLink;
use crate::world::MAX_WAVEFRONT;
use bevy_ecs::prelude::*;
use caustica_core::kernel::dimensions::photon_sampler;
use caustica_core::kernel::photon::{emit_photon, photon_time, scatter_photon};
use caustica_core::photon::Photon;
use rayon::slice::ParallelSliceMut;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A pass's deposits, each tagged with where it comes from, and what the order needs.
#[derive(Resource, Debug, Default)]
pub struct PhotonTrail {
    /// Deposits, each with `index << 32 | bounce` (the photon's index in the pass, and the
    /// bounce, from 0, that left it); [`order_photon_deposits`] turns the tags into sort keys.
    pub deposits: Vec<(u64, Photon)>,
    /// (index, scatters) of every photon that ended after scattering: kept only for passes of more
    /// photons than the one-wavefront pass had entities, whose order depends on when photons ended.
    pub ends: Vec<(u32, u32)>,
    /// The pass this trail belongs to: a shard whose trail and queues are of an older one (a pass
    /// dropped by a stop) starts anew.
    pub generation: u64,
}

/// Bytes a stored photon costs while its pass is ordered: its tagged deposit and its place in the
/// ordered buffer (which becomes the kd-tree).
pub const BYTES_PER_DEPOSIT: usize = size_of::<(u64, Photon)>() + size_of::<Photon>();

/// Bytes a shard of `rows` photons costs: their columns and their queues (a row is in at most two,
/// and scatter's spare), the deposits its trail keeps between rounds, and its World.
pub fn photon_chunk_bytes(rows: u32) -> u64 {
    const QUEUE_BYTES: u64 = 3 * size_of::<u32>() as u64;
    let columns = [
        size_of::<SubpathRay>(),
        size_of::<SubpathHit>(),
        size_of::<SubpathPower>(),
        size_of::<SubpathSampler>(),
    ];
    const TRAIL_BYTES: u64 = 4 * size_of::<(u64, Photon)>() as u64;
    rows as u64 * (crate::world::entity_bytes(&columns) + QUEUE_BYTES + TRAIL_BYTES)
        + crate::shards::SHARD_WORLD_BYTES
}

/// What emit writes.
type EmitColumns = (&'static mut SubpathRay, &'static mut SubpathPower, &'static mut SubpathSampler);

/// Take the pass's next photon indices for the free rows and start their photons on the lights
/// (`emit_photon`, each photon with its pass's, map's and index's numbers). A photon whose light
/// sample fails leaves its row free for the next index.
pub fn emit_photon_subpaths(
    scene: Res<SceneResource>,
    work: Res<PhotonWork>,
    handout: Res<SubpathHandout>,
    mut queues: ResMut<SubpathQueues>,
    mut photons: Query<EmitColumns>,
) {
    if queues.free.is_empty() || !handout.has_more() {
        return;
    }
    let Ok(mut tables) = photons.contiguous_iter_mut() else { return };
    let Some((mut rays, mut powers, mut samplers)) = tables.next() else { return };
    let (rays, powers, samplers) = (
        rays.bypass_change_detection(),
        powers.bypass_change_detection(),
        samplers.bypass_change_detection(),
    );
    queues.fill_free_rows(&handout, |index, i| {
        let sampler = photon_sampler(work.sampler, work.seed, work.pass, work.settings.kind as u32, index);
        let time = photon_time(work.time, work.motion, &sampler);
        let Some((first, path)) = emit_photon(&scene, &work.settings, &sampler, time) else { return false };
        rays[i].0 = first;
        powers[i].0 = path;
        samplers[i] = SubpathSampler { sampler, index };
        true
    });
}

/// What scatter reads and writes.
type ScatterColumns =
    (&'static SubpathHit, &'static SubpathSampler, &'static mut SubpathRay, &'static mut SubpathPower);

/// Deposit every active photon where its map wants it (appended to the shard's trail), then
/// continue it by BSDF sampling (active) or end it (its row is free again).
pub fn scatter_photon_subpaths(
    scene: Res<SceneResource>,
    work: Res<PhotonWork>,
    mut counts: ResMut<SubpathCounts>,
    mut trail: ResMut<PhotonTrail>,
    mut full: ResMut<crate::shards::RoundFull>,
    mut queues: ResMut<SubpathQueues>,
    mut photons: Query<ScatterColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    let Ok(mut tables) = photons.contiguous_iter_mut() else { return };
    let Some((hits, samplers, mut rays, mut powers)) = tables.next() else { return };
    let (rays, powers) = (rays.bypass_change_detection(), powers.bypass_change_detection());
    let keep_ends = work.settings.total > MAX_WAVEFRONT;
    let trail = &mut *trail;
    let mut roulette_kills = 0;
    counts.traced += queues.advance_active(|row, _| {
        let i = row as usize;
        let SubpathSampler { sampler, index } = samplers[i];
        let path = &mut powers[i].0;
        let depth = path.depth;
        let bounce = scatter_photon(&scene, &work.settings, path, &rays[i].0, &hits[i].0, &sampler);
        if let Some(photon) = bounce.deposit {
            trail.deposits.push(((index as u64) << 32 | depth as u64, photon));
        }
        roulette_kills += bounce.roulette_kill as u64;
        match bounce.next {
            Some(ray) => rays[i].0 = ray,
            None if keep_ends => trail.ends.push((index, depth + 1)),
            None => {}
        }
        bounce.next.is_some()
    });
    counts.roulette_kills += roulette_kills;
    full.0 = trail.deposits.len() >= DEPOSIT_ROWS_IN_A_ROUND * queues.rows as usize;
}

/// Spawn `rows` photons into a shard's World, all in one table, with their queues and trail.
pub fn spawn_photon_chunk(world: &mut World, rows: u32) {
    world.spawn_batch((0..rows).map(|_| {
        (SubpathRay::default(), SubpathHit::default(), SubpathPower::default(), SubpathSampler::default())
    }));
    world.insert_resource(SubpathQueues::new(rows));
    world.insert_resource(PhotonTrail::default());
    world.insert_resource(crate::shards::RoundFull(false));
}

/// A shard's deposits in a round, in rows' worth, after which the round ends to be folded (a
/// bounce deposits at most one a row): within the `4 * rows` its trail keeps between rounds.
const DEPOSIT_ROWS_IN_A_ROUND: usize = 3;

/// What a shard of photons reads from the main World for a round (the scene, the pass's settings
/// and hand-out) and folds into it: its counters into [`PhotonStats`], its deposits into the main
/// World's [`PhotonTrail`].
pub fn photon_links() -> Vec<ShardLink> {
    vec![
        ShardLink::share::<SceneResource>(),
        ShardLink::share::<PhotonWork>(),
        ShardLink::share::<SubpathHandout>(),
        ShardLink::custom(
            |main, shard| {
                shard.insert_resource(SubpathCounts::default());
                let generation = main.resource::<PhotonTrail>().generation;
                if shard.resource::<PhotonTrail>().generation != generation {
                    // A pass begun again after a stop: nothing of the dropped one goes on.
                    let rows = shard.resource::<SubpathQueues>().rows;
                    shard.insert_resource(SubpathQueues::new(rows));
                    shard.insert_resource(PhotonTrail { generation, ..Default::default() });
                }
            },
            |shard, main| {
                let Some(counted) = shard.remove_resource::<SubpathCounts>() else { return };
                let mut own = shard.resource_mut::<PhotonTrail>();
                {
                    let mut stats = main.resource_mut::<PhotonStats>();
                    stats.traced += counted.traced;
                    stats.roulette_kills += counted.roulette_kills;
                    stats.stored += own.deposits.len() as u64;
                }
                let mut trail = main.resource_mut::<PhotonTrail>();
                super::grow_by_eighths(&mut trail.deposits, own.deposits.len());
                super::grow_by_eighths(&mut trail.ends, own.ends.len());
                trail.deposits.append(&mut own.deposits);
                trail.ends.append(&mut own.ends);
                shard.insert_resource(crate::shards::RoundFull(false));
                // What a round left behind is not kept between passes.
                let rows = shard.resource::<SubpathQueues>().rows as usize;
                let mut own = shard.resource_mut::<PhotonTrail>();
                own.deposits.shrink_to(4 * rows);
                own.ends.shrink_to(rows);
            },
        ),
        ShardLink::merge::<crate::trace::TraceStatistics>(crate::trace::TraceStatistics::absorb),
    ]
}

/// A system that starts a photon pass on the shards: as many photons as `PhotonWork` says, none
/// handed out yet, an empty trail and buffer.
pub fn begin_photon_subpaths(
    work: Res<PhotonWork>,
    handout: Res<SubpathHandout>,
    mut stats: ResMut<PhotonStats>,
    mut trail: ResMut<PhotonTrail>,
    mut buffer: ResMut<PhotonBuffer>,
) {
    handout.begin(work.settings.total);
    stats.emitted += work.settings.total as u64;
    trail.deposits.clear();
    trail.ends.clear();
    trail.generation += 1;
    buffer.photons.clear();
}

/// A system that puts the pass's deposits into the photon buffer in the order the one-wavefront
/// photon pass stored them: that pass had `min(total, MAX_WAVEFRONT)` photon entities, handed
/// photon `i` to entity `i` first and the rest, in entity order, to entities whose photon had
/// ended, and stored each bounce's deposits in entity order. A deposit's key is (the bounce's step,
/// the entity): unique, so the order is a function of the deposits alone.
pub fn order_photon_deposits(
    work: Res<PhotonWork>,
    mut trail: ResMut<PhotonTrail>,
    mut buffer: ResMut<PhotonBuffer>,
) {
    let total = work.settings.total;
    let wavefront = total.min(MAX_WAVEFRONT);
    let mut deposits = std::mem::take(&mut trail.deposits);
    if total <= wavefront {
        // Photon i on entity i from the first step: its bounce-b deposit at step b.
        for (tag, _) in &mut deposits {
            let (index, bounce) = (*tag >> 32, *tag & u32::MAX as u64);
            *tag = bounce << 32 | index;
        }
    } else {
        let (start, entity) = replay_hand_out(total, wavefront, &std::mem::take(&mut trail.ends));
        for (tag, _) in &mut deposits {
            let (index, bounce) = ((*tag >> 32) as usize, *tag & u32::MAX as u64);
            *tag = (start[index] as u64 + bounce) << 32 | entity[index] as u64;
        }
    }
    deposits.par_sort_unstable_by_key(|&(key, _)| key);
    buffer.photons.clear();
    buffer.photons.extend(deposits.into_iter().map(|(_, photon)| photon));
}

/// The step at which each photon of a pass of `total` started and the entity it ran on, in the
/// one-wavefront pass of `wavefront` entities: photon `i < wavefront` on entity `i` at step 0; every
/// later one, in index order, on the first entity (by step, then entity) whose photon ended, a
/// photon of `n` scatters (0: its light sample failed) taking `max(n, 1)` steps.
fn replay_hand_out(total: u32, wavefront: u32, ends: &[(u32, u32)]) -> (Vec<u32>, Vec<u32>) {
    let mut scatters = vec![0u32; total as usize];
    for &(index, n) in ends {
        scatters[index as usize] = n;
    }
    let mut start = vec![0u32; total as usize];
    let mut entity: Vec<u32> = (0..total).collect();
    let mut free: BinaryHeap<Reverse<(u32, u32)>> =
        (0..wavefront).map(|e| Reverse((scatters[e as usize].max(1), e))).collect();
    for index in wavefront..total {
        let Reverse((step, e)) = free.pop().expect("as many entities as the wavefront");
        start[index as usize] = step;
        entity[index as usize] = e;
        free.push(Reverse((step + scatters[index as usize].max(1), e)));
    }
    (start, entity)
}

/// Add one bounce of photons over a chunk to `schedule` (a shard's): the stages in `order`.
pub fn add_photon_bounce_systems(schedule: &mut Schedule, order: [caustica_core::scene::schedule::Stage; 5]) {
    use crate::stages::PassSystems;
    crate::stages::configure_stages(schedule, order);
    schedule.add_systems(emit_photon_subpaths.in_set(PassSystems::Emit));
    schedule.add_systems(super::trace_subpaths.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_photon_subpaths.in_set(PassSystems::Scatter));
}

/// The photon phase's shards: `chunk` photons a worker, the stages in `order`.
pub fn photon_shards(chunk: u32, order: [caustica_core::scene::schedule::Stage; 5]) -> crate::shards::Shards {
    crate::shards::Shards::new(crate::shards::ShardPlan {
        chunk,
        spawn: Box::new(|world, rows, _, _| spawn_photon_chunk(world, rows)),
        in_flight: super::in_flight,
        systems: Box::new(move |schedule| add_photon_bounce_systems(schedule, order)),
        links: photon_links(),
    })
}

#[cfg(test)]
mod tests {
    use super::replay_hand_out;

    #[test]
    fn the_replay_hands_later_photons_to_entities_as_theirs_end_in_entity_order() {
        // Three entities; photons 0..3 scatter 2, 1 and 0 times (0: its light sample failed).
        let (start, entity) = replay_hand_out(6, 3, &[(0, 2), (1, 1), (3, 3), (4, 1), (5, 1)]);
        // Entities 1 and 2 are free at step 1 (in that order), then entities 0 and 2 at step 2
        // (photon 4 took one step): entity 0 first.
        assert_eq!(start, [0, 0, 0, 1, 1, 2]);
        assert_eq!(entity, [0, 1, 2, 1, 2, 0]);
    }
}
