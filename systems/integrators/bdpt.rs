//! Bidirectional path tracing, `bdpt` (Veach 1997, ch. 10; pbrt-v4's `BDPTIntegrator`, SmallVCM's
//! `kBpt`): every path is made by every strategy that can make it — the camera subpath hitting a
//! light (s = 0), sampling one (s = 1), connecting to a light subpath's vertex (s, t ≥ 2), the light
//! subpath's vertex seen by the camera (t = 1) — each weighted by the power heuristic among them,
//! with Georgiev's recursive sums (O(1) a connection). It finds what `pt` finds and what `lt`
//! finds: point-light caustics on diffuse surfaces, and the same surfaces seen in a mirror.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `integrator` | `bdpt` | | bidirectional path tracing |
//! | `spp` | u32 | 64 | passes: a camera subpath and a light subpath per pixel each |
//! | `max_depth` | u32 or none | none | maximum bounces of a whole path |
//! | `rr_depth` | u32 | 5 | first bounce at which Russian roulette may end a subpath |
//! | `seed`, `sampler` | | | as `pt` |
//!
//! Lights are picked by power on both sides (a light tree's choice depends on the shading point's
//! normal, which a connection's weight cannot know), and light sampling ignores the receiver's
//! normal, so every strategy's density is a function of the path alone.
//!
//! | phase | stages |
//! |---|---|
//! | photons (the light subpaths, sharded: a chunk a worker) | `emit_bidirectional_subpaths` → `trace_subpaths` → `scatter_bidirectional_subpaths` → `splat_connections` |
//! | camera (sharded: a chunk of camera subpaths a worker) | `emit_paths_for` → `trace_paths` → `scatter_camera_subpaths` → `trace_shadow_rays` → `connect_to_light_vertices` → `splat_paths` |
//!
//! A pass is a few units (about 2^18 light subpaths): the light subpaths first (their vertices kept by index, their camera
//! connections splatted), then the camera subpaths, the one of pixel i connecting to light
//! subpath i of its unit. The camera subpaths run on the vector core as `pt`'s do — each worker a
//! chunk of rows in its own World, queues of live rows, the kept light vertices shared read-only
//! (`LightVertexStore`, an `Arc`) — and a row's vertex is connected while its columns are in cache. Each unit's subpaths draw their numbers from its index, so the film alone is the
//! state: `--part` and checkpoints work as for `pt`.

use super::descriptor::{Integrator, LightSampling, MemoryNeed, no_checks, one_sample_per_unit};
use super::film_image;
use super::memory::PilotPaths;
use crate::bidirectional::{
    CameraSubpathSums, ConnectionVertex, LightVertexStore, LightVertices, RadiusSequence,
    add_camera_subpath_columns, begin_light_vertices, build_merge_grids, connect_to_light_vertices,
    order_light_vertices, scatter_camera_subpaths,
};
use crate::camera_paths::{
    PathExtras, emit_paths_for, spawn_chunk, splat_paths, trace_paths, trace_shadow_rays,
};
use crate::light_paths::LightPaths;
use crate::light_subpaths::{self, SubpathHandout, bidirectional as subpaths};
use crate::passes::hand_out_samples;
use crate::plan::{Phase, Plan, Unit, When};
use crate::report::Report;
use crate::resources::{FilmResource, SceneFeatures};
use crate::shards::{ShardLink, ShardPlan, Shards};
use crate::stages::PassSystems;
use crate::stages::{configure_stages, stage_order};
use bevy_ecs::prelude::*;
use caustica_core::choice::Choice;
use caustica_core::error::Result;
use caustica_core::kernel::bidirectional::LightVertex;
use caustica_core::scene::schedule::Stage;
use caustica_core::scene::{IntegratorKind, LightSelection, RunFile};
use std::sync::atomic::Ordering;

/// Light subpaths a pass aims at: small images group units (256²: four) to amortise a pass's
/// fixed cost (ordering the table, building the grids, the shards' rounds), within what the kept
/// vertices' table may hold.
const SUBPATHS_PER_PASS: u32 = 1 << 18;

/// Units a pass of a `pixels`-pixel image groups: no more than the run's samples, so that the pass the memory count assumes is the largest any
/// pass will be (a host that raises the target later gets more passes, not larger ones; the film's
/// bits do not depend on how units are grouped).
fn units_per_pass(pixels: u32, run: &RunFile) -> u32 {
    (SUBPATHS_PER_PASS / pixels.max(1)).clamp(1, run.render.spp.max(1))
}

/// `bdpt`: camera and light subpaths, every strategy weighted.
pub static BDPT: Integrator = Integrator {
    kind: IntegratorKind::Bdpt,
    unit: Unit::Samples,
    film_is_the_state: true,
    whole_passes: true,
    light_sampling: LightSampling::Always(
        "light sampling is one of bdpt's strategies, weighted among the others",
    ),
    takes: &[],
    default_hit_points_per_pixel: 0,
    hit_points_traced_once: false,
    counts_light_paths: true,
    camera_samples_per_unit: one_sample_per_unit,
    memory,
    check: no_checks,
    plan,
};

/// The camera paths' chunks with their sums and connection vertex, a wavefront of light subpaths,
/// and the pass's kept light vertices.
fn memory(_: &Integrator, pixels: u64, run: &RunFile, pilot: &PilotPaths) -> MemoryNeed {
    let paths = super::path::chunked_paths(pixels, run);
    let rows = run.render.chunk as u64 * crate::shards::workers() as u64;
    // The two columns of their own (their change ticks too) and the connection queue.
    let camera = rows
        * (crate::world::entity_bytes(&[size_of::<CameraSubpathSums>(), size_of::<ConnectionVertex>()])
            - crate::world::entity_bytes(&[])
            + size_of::<u32>() as u64);
    // A chunk of light subpaths a worker: lt's columns, two of their own, the queues, and what a
    // round keeps before it is folded (about four vertices a row).
    let subpaths =
        rows * light_subpath_row_bytes() + crate::shards::workers() as u64 * crate::shards::SHARD_WORLD_BYTES;
    // Where each subpath's vertices start, and each kept vertex with its subpath's index.
    let kept = subpaths_per_pass(pixels, run) * size_of::<u32>() as u64
        + kept_vertices_per_pass(pixels, run, pilot) * (size_of::<LightVertex>() + size_of::<u32>()) as u64
        + kept_glossy_per_pass(pixels, run, pilot) * size_of::<caustica_core::materials::Bsdf>() as u64;
    MemoryNeed {
        bytes: paths.bytes + camera + subpaths + kept,
        what: format!("a {pixels}-pixel film, its paths, light subpaths and their kept vertices"),
    }
}

/// Bytes a row of a light subpaths' chunk costs: its columns, its place in the queues, and the
/// vertices it keeps in a round before they are folded into the pass's table.
fn light_subpath_row_bytes() -> u64 {
    use crate::light_subpaths::{SubpathConnection, SubpathHit, SubpathPower, SubpathRay, SubpathSampler};
    const QUEUE_BYTES: usize = 3 * size_of::<u32>();
    const KEPT_IN_A_ROUND: usize =
        subpaths::KEPT_ROWS_IN_A_ROUND * (size_of::<LightVertex>() + size_of::<u32>());
    crate::world::entity_bytes(&[
        size_of::<SubpathRay>(),
        size_of::<SubpathHit>(),
        size_of::<SubpathPower>(),
        size_of::<SubpathSampler>(),
        size_of::<SubpathConnection>(),
        size_of::<subpaths::SubpathOrigin>(),
        size_of::<subpaths::SubpathSums>(),
    ]) + (QUEUE_BYTES + KEPT_IN_A_ROUND) as u64
}

/// Light subpaths a pass of a `pixels`-pixel image traces.
fn subpaths_per_pass(pixels: u64, run: &RunFile) -> u64 {
    pixels * units_per_pass(pixels.min(u32::MAX as u64) as u32, run) as u64
}

/// The light vertices a pass keeps, as the memory count assumes.
pub(super) fn kept_vertices_per_pass(pixels: u64, run: &RunFile, pilot: &PilotPaths) -> u64 {
    // A subpath keeps a vertex at each non-delta surface it meets: what a pilot of them found.
    (subpaths_per_pass(pixels, run) as f64 * pilot.diffuse_hits).ceil() as u64
}

/// Of those, the ones whose BSDF is not Lambert's (kept whole in the pass's table of BSDFs).
fn kept_glossy_per_pass(pixels: u64, run: &RunFile, pilot: &PilotPaths) -> u64 {
    (subpaths_per_pass(pixels, run) as f64 * pilot.glossy_hits).ceil() as u64
}

fn plan(_: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    plan_bidirectional(world, run, features, None)
}

/// The plan of bdpt, and of vcm with its radii (`merging`): the same subpaths, connections and
/// weights, and for vcm the merges.
pub(super) fn plan_bidirectional(
    world: &mut World,
    run: &RunFile,
    features: SceneFeatures,
    merging: Option<RadiusSequence>,
) -> Result<Plan> {
    let name = super::of_run(run).name();
    let features =
        super::without_visibility_learning(world, features, &format!("{name} picks lights by power"));
    // The tree is every run's default: only a choice a user made and bdpt overrides is named.
    if !matches!(run.render.light_selection, LightSelection::Power | LightSelection::Tree) {
        tracing::warn!(
            "{name} picks lights by power on both sides (a strategy's weight needs the density with which \
             the other side picks a light, and a light tree's depends on a normal the other side cannot \
             know); render.light_selection = {} is not used",
            run.render.light_selection.name()
        );
    }
    let order = stage_order(run);
    let pixels = {
        let film = world.resource::<FilmResource>();
        film.width * film.height
    };
    super::light_tracing::insert_light_path_resources(world, pixels, features);
    world.insert_resource(LightVertexStore::new(LightVertices {
        light_paths: pixels,
        merging,
        subpaths: pixels * units_per_pass(pixels, run),
        ..Default::default()
    }));
    let units = units_per_pass(pixels, run);
    // The camera subpaths' shards take samples from one lane, as pt's do.
    world.insert_resource(crate::resources::Workload::new(pixels, 0, 0, 1));
    world.insert_resource(SubpathHandout::default());
    let light_shards = Shards::new(ShardPlan {
        chunk: run.render.chunk,
        spawn: Box::new(|world, rows, _, _| subpaths::spawn_bidirectional_chunk(world, rows)),
        in_flight: light_subpaths::in_flight,
        systems: Box::new(move |schedule| subpaths::add_bidirectional_systems(schedule, order)),
        links: subpaths::bidirectional_links(),
    });
    let light = Phase::sharded("photons", When::EveryPass, light_shards).with_begin(
        (
            super::light_tracing::begin_light_pass(pixels),
            begin_light_vertices,
            light_subpaths::begin_subpaths,
        )
            .chain(),
    );
    let extras = PathExtras {
        aov: world.contains_resource::<crate::resources::AovFilmResource>(),
        learning: false,
        guide: false,
    };
    let mut links = super::path::camera_path_links();
    links.push(ShardLink::share::<LightVertexStore>());
    let shards = Shards::new(ShardPlan {
        chunk: run.render.chunk,
        spawn: Box::new(move |world, rows, index, count| {
            spawn_chunk(world, rows, index, count, extras);
            add_camera_subpath_columns(world);
        }),
        in_flight: crate::camera_paths::in_flight,
        systems: Box::new(move |schedule| add_camera_subpath_systems(schedule, features, order)),
        links,
    });
    let camera = Phase::sharded("camera", When::EveryPass, shards)
        .with_begin((hand_out_samples(1), order_light_vertices, build_merge_grids).chain());
    Ok(Plan {
        phases: vec![light, camera],
        // Units enough for about 2^18 light subpaths a pass; each unit's subpaths have its own
        // numbers, and its camera subpaths connect to them, however the units are grouped.
        pass_end: Box::new(move |done, target| (done + units).min(target)),
        image: film_image,
        report,
        reset: |_| {},
    })
}

/// One bounce of the camera subpaths over a shard's chunk: emission, light samples and continuation,
/// then the shadow rays and the connections (and merges), then the finished paths to the film.
fn add_camera_subpath_systems(schedule: &mut Schedule, features: SceneFeatures, order: [Stage; 5]) {
    configure_stages(schedule, order);
    schedule.add_systems(emit_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_camera_subpaths.in_set(PassSystems::Scatter));
    schedule.add_systems((trace_shadow_rays, connect_to_light_vertices).chain().in_set(PassSystems::Shadow));
    schedule.add_systems(splat_paths.in_set(PassSystems::Gather));
}

/// The subpaths and their connections.
fn report(world: &World, report: &mut Report) {
    report.photons = Some(super::photon_summary(world, (0, None), Vec::new()));
    let store = world.resource::<LightVertexStore>();
    report.notes.push((
        "connections",
        format!(
            "{} light vertices kept, {} camera–light connections, {} merges",
            store.kept,
            store.connections.load(Ordering::Relaxed),
            store.merges.load(Ordering::Relaxed)
        ),
    ));
    report.notes.push(("camera", world.resource::<LightPaths>().describe()));
}
