//! bdpt's and vcm's light subpaths on the vector core: `lt`'s columns, queues and stages (a shard's
//! chunk of subpaths at a time), with two columns of their own and the vertices they keep for the
//! camera subpaths.
//!
//! | component | bytes | written by | read by |
//! |---|---|---|---|
//! | `SubpathRay`, `SubpathHit`, `SubpathPower`, `SubpathSampler`, `SubpathConnection` | 160 | as `lt`'s | as `lt`'s |
//! | `SubpathOrigin` (its light and the densities of its start) | 40 | emit | scatter |
//! | `SubpathSums` (the running MIS sums of its last vertex) | 12 | scatter | scatter |
//!
//! | stage | system |
//! |---|---|
//! | `Emit` | `emit_bidirectional_subpaths` |
//! | `Trace` | `trace_subpaths` |
//! | `Scatter` | `scatter_bidirectional_subpaths` |
//! | `Shadow` | `splat_connections` |
//!
//! Scatter appends each non-delta vertex, with its subpath's index, to the shard's
//! [`ShardLightVertices`]; after every round they are folded into the pass's table
//! (`LightVertexStore`), whose order the camera phase makes canonical (subpath by subpath,
//! `order_light_vertices`): the same table, hence the same bits, whichever shard kept what.

use super::{
    SubpathConnection, SubpathCounts, SubpathHandout, SubpathHit, SubpathPower, SubpathQueues, SubpathRay,
    SubpathSampler,
};
use crate::bidirectional::{LightVertexStore, SubpathWeights};
use crate::light_paths::LightPaths;
use crate::resources::{CameraResource, PhotonWork, SceneResource};
use crate::shards::{RoundFull, ShardLink};
use bevy_ecs::prelude::*;
use caustica_core::kernel::bidirectional::{
    KeptBsdf, LightOrigin, LightVertex, SubpathMis, emit_light_subpath, light_subpath_vertex,
};
use caustica_core::kernel::photon::photon_time;
use caustica_core::materials::Bsdf;

/// Where a subpath started: its light and the densities of its start.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SubpathOrigin(pub LightOrigin);

/// The running MIS sums of a subpath's last vertex.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SubpathSums(pub SubpathMis);

// The layout table above, held to the code.
const _: () = assert!(size_of::<SubpathOrigin>() == 40 && size_of::<SubpathSums>() == 12);

/// The vertices a shard's subpaths kept in a round, each with its subpath's index, and the BSDFs of
/// those that are not Lambertian (by their index here until folded).
#[derive(Resource, Debug, Default)]
pub struct ShardLightVertices {
    /// Vertices after which the round ends ([`RoundFull`]), to be folded: what the memory count
    /// gives a shard.
    pub limit: usize,
    /// The vertices, in the order kept.
    pub vertices: Vec<LightVertex>,
    /// Their BSDFs that are not Lambertian.
    pub bsdfs: Vec<Bsdf>,
    /// Each vertex's subpath, by its index in the pass.
    pub owners: Vec<u32>,
}

/// What emit writes.
type EmitColumns = (
    &'static mut SubpathRay,
    &'static mut SubpathPower,
    &'static mut SubpathSampler,
    &'static mut SubpathOrigin,
);

/// Take the pass's next subpath indices for the free rows and start their subpaths on the lights,
/// each with its unit's own numbers. A subpath whose light sample fails leaves its row free for the
/// next index (it keeps nothing and connects nothing, as before it had a row).
pub fn emit_bidirectional_subpaths(
    scene: Res<SceneResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    handout: Res<SubpathHandout>,
    mut queues: ResMut<SubpathQueues>,
    mut subpaths: Query<EmitColumns>,
) {
    if queues.free.is_empty() || !handout.has_more() {
        return;
    }
    let Ok(mut tables) = subpaths.contiguous_iter_mut() else { return };
    let Some((mut rays, mut powers, mut samplers, mut origins)) = tables.next() else { return };
    let (rays, powers, samplers, origins) = (
        rays.bypass_change_detection(),
        powers.bypass_change_detection(),
        samplers.bypass_change_detection(),
        origins.bypass_change_detection(),
    );
    queues.fill_free_rows(&handout, |index, i| {
        let sampler = light_paths.sampler(&work, index, false);
        let time = photon_time(work.time, work.motion, &sampler);
        let Some((first, path, origin)) = emit_light_subpath(&scene, &sampler, time) else { return false };
        rays[i].0 = first;
        powers[i].0 = path;
        origins[i].0 = origin;
        samplers[i] = SubpathSampler { sampler, index };
        true
    });
}

/// What scatter reads and writes.
type ScatterColumns = (
    &'static SubpathHit,
    &'static SubpathSampler,
    &'static SubpathOrigin,
    &'static mut SubpathRay,
    &'static mut SubpathPower,
    &'static mut SubpathSums,
    &'static mut SubpathConnection,
);

/// Weigh every active subpath's vertex, keep it (if it is not a delta one), connect it to the
/// camera (queueing the connection), then continue the subpath (active) or end it (its row is
/// free again).
#[allow(clippy::too_many_arguments)]
pub fn scatter_bidirectional_subpaths(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    (work, weights, light_paths): (Res<PhotonWork>, Res<SubpathWeights>, Res<LightPaths>),
    mut kept: ResMut<ShardLightVertices>,
    mut full: ResMut<RoundFull>,
    mut counts: ResMut<SubpathCounts>,
    mut queues: ResMut<SubpathQueues>,
    mut subpaths: Query<ScatterColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    let Ok(mut tables) = subpaths.contiguous_iter_mut() else { return };
    let Some((hits, samplers, origins, mut rays, mut powers, mut sums, mut connections)) = tables.next()
    else {
        return;
    };
    let (rays, powers, sums, connections) = (
        rays.bypass_change_detection(),
        powers.bypass_change_detection(),
        sums.bypass_change_detection(),
        connections.bypass_change_detection(),
    );
    let kept = &mut *kept;
    let mut roulette_kills = 0;
    let mut vertex = None;
    counts.traced += queues.advance_active(|row, queued| {
        let i = row as usize;
        let SubpathSampler { sampler, index } = samplers[i];
        let factors = weights.factors(work.pass + index / light_paths.per_unit);
        let path = &mut powers[i].0;
        let u_lens = light_paths.lens_sample(&work, &camera, index, path.depth);
        let step = light_subpath_vertex(
            &scene,
            &camera,
            &factors,
            &work.settings,
            &origins[i].0,
            &mut sums[i].0,
            path,
            &rays[i].0,
            &hits[i].0,
            &sampler,
            u_lens,
            &mut vertex,
        );
        if let Some(new) = vertex.take() {
            kept.owners.push(index);
            kept.vertices.push(new.keep(&mut kept.bsdfs));
        }
        if let Some(connection) = step.connection {
            connections[i].0 = connection;
            queued.push(row);
        }
        roulette_kills += step.roulette_kill as u64;
        if let Some(ray) = step.next {
            rays[i].0 = ray;
        }
        step.next.is_some()
    });
    counts.roulette_kills += roulette_kills;
    // A bounce keeps at most a vertex a row, so the round ends within a row of the limit.
    full.0 = kept.vertices.len() >= kept.limit;
}

/// Spawn `rows` light subpaths of bdpt or vcm into a shard's World: `lt`'s chunk and two columns.
pub fn spawn_bidirectional_chunk(world: &mut World, rows: u32) {
    super::spawn_chunk_with(world, rows, (SubpathOrigin::default(), SubpathSums::default()));
    // A bounce keeps at most a vertex a row: the round ends within one of the limit, and the
    // tables never grow past what is reserved here.
    let limit = (KEPT_ROWS_IN_A_ROUND - 1) * rows as usize;
    let room = limit + rows as usize;
    let mut kept = ShardLightVertices { limit, ..Default::default() };
    kept.vertices.reserve_exact(room);
    kept.owners.reserve_exact(room);
    world.insert_resource(kept);
    world.insert_resource(RoundFull(false));
}

/// A shard's kept vertices in a round, in rows' worth: what bdpt's memory count gives it.
pub const KEPT_ROWS_IN_A_ROUND: usize = 4;

/// `lt`'s links, the weights' factors, and the fold of each round's kept vertices into the pass's
/// table (its BSDF indices moved past the table's).
pub fn bidirectional_links() -> Vec<ShardLink> {
    let mut links = super::links();
    links.push(ShardLink::custom(
        |main, shard| shard.insert_resource(main.resource::<LightVertexStore>().weights()),
        |shard, main| {
            shard.remove_resource::<SubpathWeights>();
            shard.insert_resource(RoundFull(false));
            let mut own = shard.resource_mut::<ShardLightVertices>();
            if own.vertices.is_empty() {
                return;
            }
            let mut store = main.resource_mut::<LightVertexStore>();
            let store = store.tables_mut();
            let moved = store.bsdfs.len() as u32;
            store.kept += own.vertices.len() as u64;
            super::grow_by_eighths(&mut store.vertices, own.vertices.len());
            super::grow_by_eighths(&mut store.bsdfs, own.bsdfs.len());
            super::grow_by_eighths(&mut store.owners, own.owners.len());
            store.vertices.extend(own.vertices.drain(..).map(|mut vertex| {
                if let KeptBsdf::InTable(at) = &mut vertex.bsdf {
                    *at += moved;
                }
                vertex
            }));
            store.bsdfs.append(&mut own.bsdfs);
            store.owners.append(&mut own.owners);
        },
    ));
    links
}

/// Add one bounce of bdpt's or vcm's light subpaths over a chunk to `schedule` (a shard's): the
/// stages in `order` (a rotation of the cycle).
pub fn add_bidirectional_systems(schedule: &mut Schedule, order: [caustica_core::scene::schedule::Stage; 5]) {
    use crate::stages::PassSystems;
    crate::stages::configure_stages(schedule, order);
    schedule.add_systems(emit_bidirectional_subpaths.in_set(PassSystems::Emit));
    schedule.add_systems(super::trace_subpaths.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_bidirectional_subpaths.in_set(PassSystems::Scatter));
    schedule.add_systems(super::splat_connections.in_set(PassSystems::Shadow));
}
