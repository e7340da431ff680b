//! Path tracing: `pt` (next-event estimation + MIS) and `pt-naive` (BSDF sampling only).
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `integrator` | `pt` \| `pt-naive` | `pt` | light sampling with MIS, or BSDF sampling alone |
//! | `spp` | u32 | 64 | samples per pixel |
//! | `max_depth` | u32 or none | none | maximum bounces; none = unbounded, Russian roulette ends paths |
//! | `rr_depth` | u32 | 5 | first bounce at which Russian roulette may end a path |
//! | `light_selection` | `uniform` \| `power` \| `tree` \| `visibility` | `tree` | how NEE picks a light |
//! | `seed` | u64 | 0 | sampler seed |
//! | `noise_threshold` | f64 | 0 | adaptive sampling: a pixel stops once its estimated relative error is under it; 0 = off |
//! | `min_spp` | u32 | 16 | adaptive sampling: samples every pixel takes first |
//!
//! One pass hands out all the samples; the bounce schedule (Emit → Trace → Scatter → Shadow →
//! Gather) runs until every path is idle. With visibility-aware selection the first pass renders a
//! sixteenth of the samples while the light selection learns, and the second the rest with what it
//! learned. With adaptive sampling the first pass renders `min_spp` samples of every pixel and each
//! later pass half as many again of the pixels still above the threshold (`AdaptiveSampling::pass_end`),
//! chosen after each pass from the film's own statistics; visibility-aware selection then learns
//! from the first pass. The schedule is built from the scene: the camera system draws lens and time samples only
//! when the camera has an aperture or something moves, and `pt` drops light sampling when there is
//! no light.

use super::descriptor::{Integrator, LightSampling, MemoryNeed, Setting, one_sample_per_unit};
use super::film_image;
use crate::camera_paths::guide::{self, Guide};
use crate::camera_paths::{PathExtras, spawn_chunk};
use crate::passes::{finish_light_learning, hand_out_samples, select_unconverged_pixels};
use crate::plan::{Phase, Plan, Unit, When};
use crate::resources::{AdaptiveSampling, SceneFeatures};
use crate::shards::{ShardLink, ShardPlan, Shards};
use crate::stages::PassSystems;
use crate::stages::{configure_stages, stage_order};
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::scene::schedule::Stage;
use caustica_core::scene::{IntegratorKind, RunFile};

/// `pt`: light sampling and BSDF sampling combined by MIS.
pub static PT: Integrator = PATH_TRACER;

/// `pt-naive`: BSDF sampling only.
pub static PT_NAIVE: Integrator =
    Integrator { kind: IntegratorKind::PtNaive, light_sampling: LightSampling::Never, ..PATH_TRACER };

const PATH_TRACER: Integrator = Integrator {
    kind: IntegratorKind::Pt,
    unit: Unit::Samples,
    film_is_the_state: true,
    whole_passes: false,
    light_sampling: LightSampling::On,
    takes: &[Setting::NoiseThreshold, Setting::Guiding],
    default_hit_points_per_pixel: 0,
    hit_points_traced_once: false,
    counts_light_paths: false,
    camera_samples_per_unit: one_sample_per_unit,
    memory: |_, pixels, run, _| chunked_paths(pixels, run),
    check: |_, run| {
        if run.is_guided() && run.is_adaptive() {
            return Err(caustica_core::error::Error::Setting {
                name: "guiding.enabled".into(),
                problem: "path guiding's training passes and adaptive sampling's passes cannot both set the \
                          passes: render guided with render.noise_threshold = 0"
                    .into(),
            });
        }
        Ok(())
    },
    plan,
};

/// What a sample integrator's wavefront of paths needs, with adaptive sampling's state per pixel (the
/// samples' squares and the order of the pixels still sampled).
pub fn paths(pixels: u64, run: &RunFile) -> MemoryNeed {
    paths_of_wavefront(pixels, crate::world::MAX_WAVEFRONT, run)
}

/// [`paths`] for a wavefront of at most `max` paths.
pub fn paths_of_wavefront(pixels: u64, max: u32, run: &RunFile) -> MemoryNeed {
    use crate::components::{PathAov, PathHit, PathRay, PathState, ShadowRay};
    let mut components =
        vec![size_of::<PathRay>(), size_of::<PathHit>(), size_of::<PathState>(), size_of::<ShadowRay>()];
    if !run.film.aovs.is_empty() {
        components.push(size_of::<PathAov>());
    }
    let paths = pixels.min(max as u64) * crate::world::entity_bytes(&components);
    MemoryNeed {
        bytes: paths + adaptive_bytes(pixels, run),
        what: format!("a {pixels}-pixel film and its paths"),
    }
}

/// Adaptive sampling's state per pixel, when the run asks for it.
fn adaptive_bytes(pixels: u64, run: &RunFile) -> u64 {
    const ADAPTIVE_BYTES_PER_PIXEL: u64 =
        caustica_core::film::Film::BYTES_PER_PIXEL + 2 * size_of::<u32>() as u64;
    if run.is_adaptive() { pixels * ADAPTIVE_BYTES_PER_PIXEL } else { 0 }
}

/// What `pt`'s and `pt-naive`'s shards hold: a chunk of camera paths per worker (their columns and
/// queues), with adaptive sampling's state per pixel.
pub(super) fn chunked_paths(pixels: u64, run: &RunFile) -> MemoryNeed {
    use crate::camera_paths::{PathSample, PathSampler, PathShadow, PathThroughput, ShadowLearning};
    use crate::components::{PathAov, PathHit, PathRay};
    let mut components = vec![
        size_of::<PathRay>(),
        size_of::<PathHit>(),
        size_of::<PathThroughput>(),
        size_of::<PathSample>(),
        size_of::<PathSampler>(),
        size_of::<PathShadow>(),
    ];
    if !run.film.aovs.is_empty() {
        components.push(size_of::<PathAov>());
    }
    if run.render.light_selection == caustica_core::scene::LightSelection::Visibility {
        components.push(size_of::<ShadowLearning>());
    }
    if run.is_guided() {
        components.push(size_of::<guide::PathGuide>());
    }
    // The queues: a row in at most two of them, each a u32, and scatter's spare; the lanes' scratch.
    const QUEUE_BYTES: u64 = 3 * size_of::<u32>() as u64;
    let scratch = crate::camera_paths::LANE_SCRATCH_BYTES_PER_ROW as u64;
    let rows = run.render.chunk as u64 * crate::shards::workers() as u64;
    let paths = rows * (crate::world::entity_bytes(&components) + QUEUE_BYTES + scratch)
        + crate::shards::workers() as u64 * crate::shards::SHARD_WORLD_BYTES;
    // The guide's tree may grow to its cap (refining never passes it): counted whole.
    let (tree, with_tree) = match run.is_guided() {
        true => (guide::tree_cap(run.memory_budget_bytes()), ", its paths and the guiding tree"),
        false => (0, " and its paths"),
    };
    MemoryNeed {
        bytes: paths + tree + adaptive_bytes(pixels, run),
        what: format!("a {pixels}-pixel film{with_tree}"),
    }
}

/// The plan of `pt` or `pt-naive` for the scene in `world`.
fn plan(this: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let nee = this.nee(run);
    if !nee {
        warn_unseen_delta_lights(world);
    }
    // Only light sampling's shadow rays teach visibility-aware selection.
    let features = if nee {
        features
    } else {
        super::without_visibility_learning(world, features, "using the light tree")
    };
    let guided = guide::begin(world, run);
    let extras = PathExtras {
        aov: world.contains_resource::<crate::resources::AovFilmResource>(),
        learning: features.learns_visibility,
        guide: guided,
    };
    let chunk = run.render.chunk;
    // The Workload the pass's first schedule replaces, keeping its lanes: one, as no entity of the
    // main World takes work. Shards take runs of up to 64 samples an atomic step, so one counter is
    // not contended, and what is handed out is always a prefix of the pass: a stop at whole samples
    // per pixel ends just past it. (With a lane per shard, a shard that fell behind left items
    // below the cut; with 8 lanes for 2 shards, the stop rendered four times the work done.)
    let wavefront = 1;
    let pixels = {
        let film = world.resource::<crate::resources::FilmResource>();
        film.width * film.height
    };
    world.insert_resource(crate::resources::Workload::new(pixels, 0, 0, wavefront));

    let mut phases = Vec::new();
    if features.learns_visibility {
        phases.push(Phase::once("learning", When::LaterPasses, finish_light_learning));
    }
    let order = stage_order(run);
    let shards = Shards::new(ShardPlan {
        chunk,
        spawn: Box::new(move |world, rows, index, count| spawn_chunk(world, rows, index, count, extras)),
        in_flight: crate::camera_paths::in_flight,
        systems: Box::new(move |schedule| {
            add_bounce_systems(schedule, features, order, nee);
            if guided {
                schedule.add_systems(
                    guide::record_guided_paths
                        .in_set(PassSystems::Gather)
                        .before(crate::camera_paths::splat_paths),
                );
            }
        }),
        links: camera_path_links(),
    });
    let mut bounce = Phase::sharded("bounce", When::EveryPass, shards).with_begin(hand_out_samples(1));
    if run.is_adaptive() {
        let film = world.resource::<crate::resources::FilmResource>();
        let pixels = film.width as usize * film.height as usize;
        let (threshold, min_spp) = (run.render.noise_threshold, run.render.min_spp);
        world.insert_resource(AdaptiveSampling::new(threshold, min_spp, pixels));
        bounce = bounce.with_end(select_unconverged_pixels);
    }
    phases.push(bounce);
    if guided {
        phases.push(Phase::once("guiding", When::EveryPass, guide::refine_guide));
    }
    let pass_end: crate::plan::PassEnd = if guided {
        let training = world.resource::<Guide>().training_passes.clone();
        Box::new(move |done, target| {
            Guide::pass_end(training.load(std::sync::atomic::Ordering::Relaxed), done, target)
        })
    } else if run.is_adaptive() {
        let min_spp = run.render.min_spp;
        Box::new(move |done, target| AdaptiveSampling::pass_end(min_spp, done, target))
    } else if features.learns_visibility {
        // Learn from the shadow rays of the first sixteenth of the samples (at least one per pixel).
        Box::new(|done, target| if done == 0 { (target / 16).clamp(1, target) } else { target })
    } else {
        Plan::all_at_once()
    };
    let report: fn(&World, &mut crate::report::Report) = if guided { report_guide } else { |_, _| {} };
    Ok(Plan { phases, pass_end, image: film_image, report, reset: |_| {} })
}

/// The guide's line in the report.
fn report_guide(world: &World, report: &mut crate::report::Report) {
    if let Some(guide) = world.get_resource::<Guide>() {
        report.notes.push(("guiding", guide::describe(guide)));
    }
}

/// Point, spot and sun lights are Dirac deltas: a BSDF-sampled ray never finds them, so without
/// light sampling they light nothing: say so rather than render them black silently.
fn warn_unseen_delta_lights(world: &World) {
    let lights = &world.resource::<crate::resources::SceneResource>().lights.lights;
    let unseen = lights.iter().filter(|l| l.shape.is_delta()).count();
    if unseen > 0 {
        tracing::warn!(
            "{unseen} point, spot or sun light(s) light nothing without light sampling (pt-naive or \
             schedule.nee = false): no ray can hit a light of no size; use pt or a photon integrator"
        );
    }
}

/// What a shard of camera paths reads from the main World for a round, and counts into it.
pub fn camera_path_links() -> Vec<ShardLink> {
    use crate::resources::{
        AdaptiveSquares, AovFilmResource, CameraResource, FilmResource, PassRange, RenderConfig, RenderStats,
        SceneResource, Workload,
    };
    vec![
        ShardLink::share::<SceneResource>(),
        ShardLink::share::<CameraResource>(),
        ShardLink::share::<RenderConfig>(),
        ShardLink::share::<PassRange>(),
        ShardLink::share::<Workload>(),
        ShardLink::share::<FilmResource>(),
        ShardLink::share::<AovFilmResource>(),
        ShardLink::custom(
            |main, shard| match main.get_resource::<AdaptiveSampling>() {
                Some(adaptive) => shard.insert_resource(AdaptiveSquares(adaptive.squares.clone())),
                None => {
                    shard.remove_resource::<AdaptiveSquares>();
                }
            },
            |shard, _| {
                shard.remove_resource::<AdaptiveSquares>();
            },
        ),
        ShardLink::share::<Guide>(),
        ShardLink::merge::<RenderStats>(RenderStats::absorb),
        ShardLink::merge::<crate::trace::TraceStatistics>(crate::trace::TraceStatistics::absorb),
    ]
}

/// Add one bounce of path tracing over a chunk of camera paths to `schedule` (a shard's): the stages
/// in `order` (a rotation of the cycle), light sampling with MIS when `nee` and the scene has lights.
pub fn add_bounce_systems(schedule: &mut Schedule, features: SceneFeatures, order: [Stage; 5], nee: bool) {
    use crate::camera_paths::{emit_paths_for, scatter_paths, splat_paths, trace_paths, trace_shadow_rays};
    configure_stages(schedule, order);
    schedule.add_systems(emit_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    if nee && features.lights {
        schedule.add_systems(scatter_paths::<true>.in_set(PassSystems::Scatter));
        schedule.add_systems(trace_shadow_rays.in_set(PassSystems::Shadow));
    } else {
        schedule.add_systems(scatter_paths::<false>.in_set(PassSystems::Scatter));
    }
    schedule.add_systems(splat_paths.in_set(PassSystems::Gather));
}
