//! Light tracing, `lt` (Veach's t = 1 strategy; pbrt-v4's `LightPathIntegrator`, Mitsuba's
//! `ptracer`): light subpaths leave the lights in proportion to their power, and every vertex the
//! camera can see sends it what it reflects there, added to the film where it lands. It finds what
//! camera paths cannot: a point light's caustic on a diffuse floor, seen directly.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `integrator` | `lt` | | light tracing |
//! | `spp` | u32 | 64 | light subpaths per pixel (one per pixel a unit), and camera rays per pixel |
//! | `max_depth` | u32 or none | none | maximum bounces of a light subpath |
//! | `rr_depth` | u32 | 5 | first bounce at which Russian roulette may end a subpath |
//! | `seed`, `sampler` | | | as `pt` |
//! | `chunk` | u32 | 4096 | camera paths, and light subpaths, a worker keeps in flight |
//!
//! A unit is a camera ray per pixel that follows delta bounces only and adds the emission it meets on
//! the way (lights and sky seen directly, in a mirror or through glass), and as many light subpaths
//! as pixels; a pass groups units to about a million subpaths and is never cut short (its camera
//! samples count its splats): it renders into films of its own, and a stop drops it whole.
//!
//! Both phases run on the vector core ([`crate::shards`]): each worker owns a chunk of camera paths
//! ([`crate::camera_paths`]) in the camera phase and a chunk of light subpaths
//! ([`crate::light_subpaths`]) in the photons phase, and runs the stages over it bounce after
//! bounce. The camera phase's samples are handed out as `pt`'s; the subpaths' indices from one
//! counter a pass, and each subpath's numbers are a function of its unit and index, so the image
//! does not depend on the thread count or the chunk size.
//!
//! | phase | Emit | Trace | Scatter | Shadow | Gather |
//! |---|---|---|---|---|---|
//! | camera (when a camera ray can see light or feature images are asked for; else `count_camera_samples`) | `emit_paths<LENS, MOTION>` | `trace_paths` | `scatter_to_seen_emission` | | `splat_paths` |
//! | photons (the light subpaths; begun by `begin_light_pass`, `begin_subpaths`) | `emit_subpaths` | `trace_subpaths` | `scatter_subpaths` | `splat_connections` | |
//!
//! The camera rays count the pass's samples, one a pixel, and the subpaths' splats add to the sums
//! uncounted, so a pixel holds (emission seen + splats) / units, as pbrt-v4 scales its splats by
//! 1/spp. Each unit's subpaths draw their numbers from its index, so the film alone is the state: `--part` and checkpoints work as for `pt`. What no strategy here finds: a diffuse surface
//! seen in a mirror or through glass (L…D S+ E: the connection cannot pass the delta bounce, the
//! camera path stops at the diffuse surface; `pt` or `bdpt` find it), and a point light seen
//! directly (a point of no size, as in `pt`).

use super::descriptor::{Integrator, LightSampling, MemoryNeed, no_checks, one_sample_per_unit};
use super::film_image;
use super::memory::PilotPaths;
use crate::camera_paths::{self, PathExtras};
use crate::light_paths::LightPaths;
use crate::light_subpaths::{self, SubpathHandout};
use crate::passes::hand_out_samples;
use crate::plan::{Phase, Plan, Unit, When};
use crate::report::Report;
use crate::resources::{
    AovFilmResource, FilmResource, PassRange, PhotonStats, PhotonWork, RenderConfig, RenderStats,
    SceneFeatures, SceneResource, Workload,
};
use crate::shards::{ShardPlan, Shards};
use crate::stages::PassSystems;
use crate::stages::{configure_stages, stage_order};
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::photon::PhotonMapKind;
use caustica_core::scene::schedule::Stage;
use caustica_core::scene::{IntegratorKind, RunFile};

/// Light subpaths a pass aims at: enough to amortise a pass's fixed cost, few enough that little is
/// lost when a stop drops the pass that runs.
const SUBPATHS_PER_PASS: u32 = 1 << 20;

/// `lt`: light subpaths connected to the camera.
pub static LT: Integrator = Integrator {
    kind: IntegratorKind::Lt,
    unit: Unit::Samples,
    film_is_the_state: true,
    whole_passes: true,
    light_sampling: LightSampling::Never,
    takes: &[],
    default_hit_points_per_pixel: 0,
    hit_points_traced_once: false,
    counts_light_paths: false,
    camera_samples_per_unit: one_sample_per_unit,
    memory,
    check: no_checks,
    plan,
};

/// A chunk of camera paths and one of light subpaths per worker: their columns and queues. (The
/// camera chunks are counted even where no camera ray is traced, under delta lights alone: a few
/// MiB.)
fn memory(_: &Integrator, pixels: u64, run: &RunFile, _: &PilotPaths) -> MemoryNeed {
    use crate::camera_paths::{PathSample, PathSampler, PathShadow, PathThroughput};
    use crate::components::{PathAov, PathHit, PathRay};
    use crate::light_subpaths::{SubpathConnection, SubpathHit, SubpathPower, SubpathRay, SubpathSampler};
    use crate::world::entity_bytes;
    // A camera path's row is in at most two queues, and scatter's spare; a subpath's likewise.
    const QUEUE_BYTES: u64 = 3 * size_of::<u32>() as u64;
    let mut camera = vec![
        size_of::<PathRay>(),
        size_of::<PathHit>(),
        size_of::<PathThroughput>(),
        size_of::<PathSample>(),
        size_of::<PathSampler>(),
        size_of::<PathShadow>(),
    ];
    if !run.film.aovs.is_empty() {
        camera.push(size_of::<PathAov>());
    }
    let subpath = [
        size_of::<SubpathRay>(),
        size_of::<SubpathHit>(),
        size_of::<SubpathPower>(),
        size_of::<SubpathSampler>(),
        size_of::<SubpathConnection>(),
    ];
    let rows = run.render.chunk as u64 * crate::shards::workers() as u64;
    // Two shards a worker: its camera paths' and its light subpaths'.
    let worlds = 2 * crate::shards::workers() as u64 * crate::shards::SHARD_WORLD_BYTES;
    let bytes = rows * (entity_bytes(&camera) + entity_bytes(&subpath) + 2 * QUEUE_BYTES) + worlds;
    MemoryNeed { bytes, what: format!("a {pixels}-pixel film, its camera paths and light subpaths") }
}

fn plan(_: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let features = super::without_visibility_learning(world, features, "light tracing picks lights by power");
    warn_surfaces_unseen_through_specular(world);
    let order = stage_order(run);
    let pixels = {
        let film = world.resource::<FilmResource>();
        film.width * film.height
    };
    insert_light_path_resources(world, pixels, features);
    world.insert_resource(SubpathHandout::default());

    let units_per_pass = (SUBPATHS_PER_PASS / pixels.max(1)).max(1);
    let camera = if camera_rays_can_see_light(world, run) {
        // As pt's: one lane, which the pass's first schedule replaces keeping it.
        world.insert_resource(Workload::new(pixels, 0, 0, 1));
        let extras =
            PathExtras { aov: world.contains_resource::<AovFilmResource>(), learning: false, guide: false };
        let shards = Shards::new(ShardPlan {
            chunk: run.render.chunk,
            spawn: Box::new(move |world, rows, index, count| {
                camera_paths::spawn_chunk(world, rows, index, count, extras)
            }),
            in_flight: camera_paths::in_flight,
            systems: Box::new(move |schedule| add_camera_systems(schedule, features, order)),
            links: super::path::camera_path_links(),
        });
        Phase::sharded("camera", When::EveryPass, shards).with_begin(hand_out_samples(1))
    } else {
        Phase::once("camera", When::EveryPass, count_camera_samples)
    };
    let shards = Shards::new(ShardPlan {
        chunk: run.render.chunk,
        spawn: Box::new(|world, rows, _, _| light_subpaths::spawn_chunk(world, rows)),
        in_flight: light_subpaths::in_flight,
        systems: Box::new(move |schedule| light_subpaths::add_bounce_systems(schedule, order)),
        links: light_subpaths::links(),
    });
    let light = Phase::sharded("photons", When::EveryPass, shards)
        .with_begin((begin_light_pass(pixels), light_subpaths::begin_subpaths).chain());
    Ok(Plan {
        phases: vec![camera, light],
        // Units enough for about a million subpaths a pass (a stop drops the running one);
        // each unit's subpaths have its own numbers, however the units are grouped into passes.
        pass_end: Box::new(move |done, target| (done + units_per_pass).min(target)),
        image: film_image,
        report,
        reset: |_| {},
    })
}

/// A diffuse or glossy surface seen in a mirror or through smooth glass is black under light
/// tracing (a connection to the camera cannot pass a delta bounce): say which materials hide what, as
/// pt-naive says which lights it cannot find, rather than render black spheres without a word.
fn warn_surfaces_unseen_through_specular(world: &World) {
    let specular: Vec<&str> = world.resource::<SceneResource>().specular_materials().collect();
    if !specular.is_empty() {
        tracing::warn!(
            "lt cannot see surfaces in a mirror or through smooth glass: what materials {} reflect or \
             transmit is black but for lights and the sky; bdpt, vcm or pt see it",
            specular.iter().map(|name| format!("'{name}'")).collect::<Vec<_>>().join(", ")
        );
    }
}

/// Whether a camera ray can find anything: an area light or the sky (seen directly, in a mirror or
/// through glass), or a surface for the feature images. Under point, spot and sun lights alone
/// (`scenes/point-caustic.toml`) it finds nothing and took half the render: the pass's samples are
/// then counted without rays (the same sums and counts, to the bit).
fn camera_rays_can_see_light(world: &World, run: &RunFile) -> bool {
    let lights = &world.resource::<SceneResource>().lights;
    lights.environment.is_some()
        || lights.lights.iter().any(|l| !l.shape.is_delta())
        || !run.film.aovs.is_empty()
}

/// Add one bounce of lt's camera rays over a chunk of camera paths to `schedule` (a shard's): the
/// stages in `order`, without light sampling (no Shadow stage).
fn add_camera_systems(schedule: &mut Schedule, features: SceneFeatures, order: [Stage; 5]) {
    use crate::camera_paths::{emit_paths_for, scatter_to_seen_emission, splat_paths, trace_paths};
    configure_stages(schedule, order);
    schedule.add_systems(emit_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_to_seen_emission.in_set(PassSystems::Scatter));
    schedule.add_systems(splat_paths.in_set(PassSystems::Gather));
}

/// Count the pass's camera samples, one a pixel a unit, each adding nothing.
fn count_camera_samples(range: Res<PassRange>, film: Res<FilmResource>, mut stats: ResMut<RenderStats>) {
    let units = range.end - range.begin;
    let pixels = film.width * film.height;
    for pixel in 0..pixels {
        film.add_sums(pixel, [0; 3], units);
    }
    stats.samples += pixels as u64 * units as u64;
}

/// What light subpaths of one a pixel a unit share with photon passes: the pass's work (one
/// subpath a pixel a unit), its counters, and the subpaths' own numbers.
pub(super) fn insert_light_path_resources(world: &mut World, pixels: u32, features: SceneFeatures) {
    let config = world.resource::<RenderConfig>().clone();
    world.insert_resource(PhotonWork::new(PhotonMapKind::Global, pixels, &config, features.motion));
    world.insert_resource(PhotonStats::default());
    world.insert_resource(LightPaths { per_unit: pixels, ..Default::default() });
}

/// A system that sets up the pass's light subpaths: as many as the pass has camera samples, with
/// the random numbers of its unit index. Named, so that the profile shows it as such rather than as
/// a closure.
pub(super) fn begin_light_pass(pixels: u32) -> impl System<In = (), Out = ()> {
    let begin = move |range: Res<PassRange>, mut work: ResMut<PhotonWork>| {
        work.pass = range.begin;
        work.settings.total = pixels.saturating_mul(range.end - range.begin);
    };
    IntoSystem::into_system(begin).with_name("begin_light_pass")
}

/// The subpaths and their connections.
fn report(world: &World, report: &mut Report) {
    report.photons = Some(super::photon_summary(world, (0, None), Vec::new()));
    report.notes.push(("camera", world.resource::<LightPaths>().describe()));
}
