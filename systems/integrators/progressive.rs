//! What the progressive photon mappers (`ppm`, `sppm`, `appm`, `cppm`) share: hit-point entities per
//! pixel, spawned once, photon shards (a chunk of photons a worker, on the vector core), and a pass
//! of three groups of phases, like pbrt-v4's SPPM loop:
//! - camera: every pixel's camera paths to their hit points (`ppm`: the first pass only);
//! - photons: one pass of photons on the shards (`light_subpaths::photons`: `begin_photon_subpaths`,
//!   then a bounce a round, `emit_photon_subpaths` → `trace_subpaths` → `scatter_photon_subpaths`,
//!   until every photon has landed, then `order_photon_deposits`);
//! - statistics: Gather (the pass's kd-tree, then the integrator's gather) → Update (its radius rule).
//!
//! | parameter (`[progressive]`) | type | default | meaning |
//! |---|---|---|---|
//! | `passes` | u32 | 64 | photon passes (`render.time_limit` may stop earlier) |
//! | `photons_per_pass` | u32 | 65 536 | photons emitted per pass |
//! | `alpha` | f32 | 2/3 | fraction of each pass's photons kept (`ppm`, `sppm`, and `appm`'s bounds) |
//! | `initial_radius` | f32 | from the scene | first gather radius (`photon::progressive::initial_radius`) |
//! | `hit_points_per_pixel` | power of two | 32 (`ppm`), 1 | hit points per pixel, stratified over the filter |
//! | `memory_budget_mib` | u64 | half the RAM | hit points + photons may not exceed it |

use super::descriptor::{Integrator, LightSampling, MemoryNeed, PlanFn, Setting};
use super::memory::PilotPaths;
use super::paths_busy;
use crate::components::{
    AdaptiveStats, Chi2Cells, HitPoint, PathHit, PathRay, PathState, PathStatus, ShadowRay,
};
use crate::emit::emit_camera_paths_for;
use crate::gather::splat_paths_to_film;
use crate::light_subpaths::SubpathHandout;
use crate::light_subpaths::photons::{
    PhotonTrail, begin_photon_subpaths, order_photon_deposits, photon_shards,
};
use crate::passes::{begin_camera_pass, begin_progressive_pass, cap_initial_radius};
use crate::plan::{Phase, Plan, Repeat, Unit, When};
use crate::report::{HitPointSummary, Report};
use crate::resources::{
    FilmResource, PassPhotons, PhotonBuffer, PhotonStats, PhotonWork, ProgressiveConfig, RenderConfig,
    SceneFeatures, SceneResource, Workload,
};
use crate::scatter::scatter_to_visible_points;
use crate::stages::PassSystems;
use crate::stages::{configure_stages, stage_order};
use crate::trace::{trace_paths, trace_shadow_rays};
use crate::world::MAX_WAVEFRONT;
use bevy_ecs::prelude::*;
use caustica_core::error::{Error, Result};
use caustica_core::film::Image;
use caustica_core::photon::PhotonMapKind;
use caustica_core::photon::progressive::{CHI2_CELLS, CHI2_FIRST_TEST, RadiusRule, initial_radius};
use caustica_core::scene::schedule::Pass;
use caustica_core::scene::{IntegratorKind, RunFile, Scene};
use glam::Vec3;
use std::sync::atomic::Ordering;

/// Bytes a photon of one pass costs: its tagged deposit in the pass's trail and its place in the
/// ordered buffer that becomes the pass's kd-tree, while the previous pass's kd-tree is still held.
pub const BYTES_PER_PHOTON: usize =
    crate::light_subpaths::photons::BYTES_PER_DEPOSIT + size_of::<caustica_core::photon::Photon>();

/// The descriptor the progressive mappers share: progress in passes, each building on the statistics
/// of the one before, light sampling at the hit points unless the run turns it off, one hit point per
/// pixel; each file names its kind and plan and changes what differs.
pub const fn descriptor(kind: IntegratorKind, plan: PlanFn) -> Integrator {
    Integrator {
        kind,
        unit: Unit::Passes,
        film_is_the_state: false,
        whole_passes: false,
        light_sampling: LightSampling::On,
        takes: &[Setting::PassOrder],
        default_hit_points_per_pixel: 1,
        hit_points_traced_once: false,
        counts_light_paths: false,
        camera_samples_per_unit: |this, run| this.hit_points_per_pixel(run),
        memory,
        check,
        plan,
    }
}

/// What distinguishes one progressive integrator from another in its plan.
pub struct Variant {
    /// How statistics become radiance and a radius.
    pub rule: RadiusRule,
    /// Adds the gather and the update to the statistics schedule.
    pub statistics: fn(&mut Schedule),
}

/// The settings of a progressive integrator (`[progressive]`, checked however they arrived) and the
/// material indices its hit points hold in 16 bits.
fn check(scene: &Scene, run: &RunFile) -> Result<()> {
    run.progressive.check().map_err(|problem| Error::Setting { name: "progressive".into(), problem })?;
    if scene.materials.len() > u16::MAX as usize + 1 {
        return Err(Error::Setting {
            name: "integrator".into(),
            problem: format!(
                "progressive photon mapping holds material indices in 16 bits; the scene has {} materials",
                scene.materials.len()
            ),
        });
    }
    Ok(())
}

/// Hit points for every pixel (entities: their statistics, the camera path that re-traces them, and
/// the adaptive or χ² statistics of the variants that keep them) plus one pass of photons.
fn memory(this: &Integrator, pixels: u64, run: &RunFile, _: &PilotPaths) -> MemoryNeed {
    let settings = run.progressive;
    let hit_points = pixels * this.hit_points_per_pixel(run) as u64;
    let per_hit_point = bytes_per_hit_point(!run.film.aovs.is_empty());
    let shards = crate::light_subpaths::photons::photon_chunk_bytes(run.render.chunk)
        * crate::shards::workers() as u64;
    // A pass of more photons than 2^18 keeps when each photon ended, to order its deposits.
    let replay = if settings.photons_per_pass > MAX_WAVEFRONT {
        super::photon_map::REPLAY_BYTES_PER_PHOTON
    } else {
        0
    };
    let needed = hit_points * per_hit_point
        + settings.photons_per_pass as u64 * (BYTES_PER_PHOTON as u64 + replay)
        + shards;
    let what = format!(
        "{hit_points} hit points ({per_hit_point} bytes each, see hit_points_per_pixel) and {} photons per pass",
        settings.photons_per_pass
    );
    MemoryNeed { bytes: needed, what }
}

/// Bytes a hit point's entity costs: its statistics, the camera path that re-traces it, the adaptive
/// or χ² statistics of the variants that keep them, and with `aovs` its first surface.
fn bytes_per_hit_point(aovs: bool) -> u64 {
    let mut components = vec![
        size_of::<HitPoint>(),
        size_of::<PathRay>(),
        size_of::<PathHit>(),
        size_of::<PathState>(),
        size_of::<ShadowRay>(),
        size_of::<Chi2Cells>().max(size_of::<AdaptiveStats>()),
    ];
    if aovs {
        components.push(size_of::<crate::components::PathAov>());
    }
    crate::world::entity_bytes(&components)
}

/// The plan of a progressive integrator for the scene in `world`.
pub fn plan(
    this: &Integrator,
    world: &mut World,
    run: &RunFile,
    features: SceneFeatures,
    variant: Variant,
) -> Result<Plan> {
    let settings = run.progressive;
    let nee = this.nee(run);
    let features =
        super::without_visibility_learning(world, features, "progressive passes use the light tree");
    let order = stage_order(run);
    let per_pixel = this.hit_points_per_pixel(run);
    let camera_when = if this.hit_points_traced_once { When::RenderStart } else { When::EveryPass };
    let (area, diagonal) = {
        let scene = world.resource::<SceneResource>();
        let (min, max) = scene.geometry.bounds();
        (scene.surface_area(), (max - min).length())
    };
    let r0 =
        settings.initial_radius.unwrap_or_else(|| initial_radius(area, diagonal, settings.photons_per_pass));
    world.insert_resource(ProgressiveConfig {
        rule: variant.rule,
        alpha: settings.alpha,
        r0,
        r0_given: settings.initial_radius.is_some(),
        photons_per_pass: settings.photons_per_pass,
        hit_points_per_pixel: per_pixel,
        pass: 0,
    });
    world.resource_mut::<RenderConfig>().strata = per_pixel;
    spawn_hit_points(world, variant.rule, per_pixel, r0);

    let config = world.resource::<RenderConfig>().clone();
    // Without light sampling at the hit points, photons carry direct light too.
    let stored = if nee { PhotonMapKind::Bounced } else { PhotonMapKind::Global };
    world.insert_resource(PhotonWork::new(stored, settings.photons_per_pass, &config, features.motion));
    world.insert_resource(PhotonBuffer::default());
    world.insert_resource(PhotonStats::default());
    world.insert_resource(PassPhotons::default());
    world.insert_resource(PhotonTrail::default());
    world.insert_resource(SubpathHandout::default());

    let mut phases = vec![Phase::once("pass", When::EveryPass, begin_progressive_pass(features.motion))];
    for group in run.schedule.pass_order().unwrap_or([Pass::Camera, Pass::Photons, Pass::Statistics]) {
        match group {
            Pass::Camera => {
                let mut camera = Phase::new("camera", camera_when, Repeat::WhileBusy(paths_busy))
                    .with_begin(begin_camera_pass)
                    .with_end(cap_initial_radius);
                add_camera_systems(&mut camera.schedule, features, order, nee);
                phases.push(camera);
            }
            Pass::Photons => {
                let shards = photon_shards(run.render.chunk, order);
                let photons = Phase::sharded("photons", When::EveryPass, shards)
                    .with_begin(begin_photon_subpaths)
                    .with_end(order_photon_deposits);
                phases.push(photons);
            }
            Pass::Statistics => {
                let mut statistics = Phase::new("statistics", When::EveryPass, Repeat::Once);
                statistics.schedule.configure_sets((PassSystems::Gather, PassSystems::Update).chain());
                (variant.statistics)(&mut statistics.schedule);
                phases.push(statistics);
            }
        }
    }
    Ok(Plan { phases, pass_end: Plan::one_per_pass(), image, report, reset })
}

/// One entity per hit point, pixel-major (`per_pixel` consecutive entities share a pixel, sample `j`
/// taking stratum `j`): its camera path and its statistics, plus the rule's own.
fn spawn_hit_points(world: &mut World, rule: RadiusRule, per_pixel: u32, r0: f32) {
    let pixels = {
        let film = world.resource::<FilmResource>();
        film.width * film.height
    };
    let count = pixels * per_pixel;
    let path = move |k: u32| {
        (
            PathRay::default(),
            PathHit::default(),
            PathState::new(k / per_pixel, k % per_pixel),
            ShadowRay::default(),
        )
    };
    let hit_point = HitPoint::new(r0 * r0);
    match rule {
        RadiusRule::Shrinking | RadiusRule::Global => {
            world.spawn_batch((0..count).map(|k| (path(k), hit_point)));
        }
        RadiusRule::Adaptive => {
            world.spawn_batch((0..count).map(|k| (path(k), hit_point, AdaptiveStats::default())));
        }
        RadiusRule::ChiSquare => {
            let cells = Chi2Cells { counts: [0; CHI2_CELLS], min_photons: CHI2_FIRST_TEST };
            world.spawn_batch((0..count).map(|k| (path(k), hit_point, cells)));
        }
    }
    // The camera paths only splat what they see directly; the film hands out no further work.
    world.insert_resource(Workload::exhausted(pixels));
}

/// The camera pass: paths to their first non-specular hit; `nee` adds a light sample there.
pub fn add_camera_systems(
    schedule: &mut Schedule,
    features: SceneFeatures,
    order: [caustica_core::scene::schedule::Stage; 5],
    nee: bool,
) {
    configure_stages(schedule, order);
    schedule.add_systems(emit_camera_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    if nee && features.lights {
        schedule.add_systems(scatter_to_visible_points::<true>.in_set(PassSystems::Scatter));
        schedule.add_systems(trace_shadow_rays.in_set(PassSystems::Shadow));
    } else {
        schedule.add_systems(scatter_to_visible_points::<false>.in_set(PassSystems::Scatter));
    }
    schedule.add_systems(splat_paths_to_film.in_set(PassSystems::Gather));
}

/// The image so far: emission and direct light from the film, plus the mean of each pixel's hit-point
/// estimates.
fn image(world: &World, passes: u32) -> Image {
    let mut image = world.resource::<FilmResource>().image();
    let config = *world.resource::<ProgressiveConfig>();
    let weight = 1.0 / config.hit_points_per_pixel as f32;
    let Some(mut hit_points) = world.try_query::<(&PathState, &HitPoint)>() else { return image };
    for (state, hp) in hit_points.iter(world) {
        let l = config.rule.radiance(hp.tau, hp.r2, passes).as_vec3() * weight;
        image.pixels[state.pixel as usize] += if l.is_finite() { l } else { Vec3::ZERO };
    }
    image
}

/// Photons, hit points and their mean radius.
fn report(world: &World, report: &mut Report) {
    let config = world.resource::<ProgressiveConfig>();
    let pass_photons = world.resource::<PassPhotons>();
    let first = pass_photons.first_dropped_pass.load(Ordering::Relaxed);
    let dropped = (pass_photons.dropped.load(Ordering::Relaxed), (first != u32::MAX).then_some(first));
    report.photons = Some(super::photon_summary(world, dropped, Vec::new()));
    let (sum, count) = world.try_query::<&HitPoint>().map_or((0.0, 0), |mut q| {
        q.iter(world).fold((0.0f64, 0u64), |(s, c), hp| (s + (hp.r2 as f64).sqrt(), c + 1))
    });
    report.hit_points = Some(HitPointSummary {
        count,
        per_pixel: config.hit_points_per_pixel,
        bytes_each: bytes_per_hit_point(world.contains_resource::<crate::resources::AovFilmResource>()),
        mean_radius: (sum / count.max(1) as f64) as f32,
        initial_radius: config.r0,
    });
}

/// Every hit point back to the initial radius with no statistics.
fn reset(world: &mut World) {
    let r0 = world.resource::<ProgressiveConfig>().r0;
    for mut hp in world.query::<&mut HitPoint>().iter_mut(world) {
        *hp = HitPoint::new(r0 * r0);
    }
    for mut stats in world.query::<&mut AdaptiveStats>().iter_mut(world) {
        *stats = AdaptiveStats::default();
    }
    for mut cells in world.query::<&mut Chi2Cells>().iter_mut(world) {
        *cells = Chi2Cells { counts: [0; CHI2_CELLS], min_photons: CHI2_FIRST_TEST };
    }
    for mut state in world.query::<&mut PathState>().iter_mut(world) {
        state.status = PathStatus::Idle;
    }
    world.insert_resource(PassPhotons::default());
}
