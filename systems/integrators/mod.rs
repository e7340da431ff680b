//! Integrators as plans: each file builds what its integrator is — the checks on its settings, the
//! entities and resources it puts into the World, and the phases of its passes (schedules of the
//! `PassSystems` stages) — and [`plan`] picks the one the run asks for. The driver runs any plan.

pub mod appm;
pub mod cppm;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod pppm;
pub mod progressive;
pub mod sppm;

use crate::PassSystems;
use crate::plan::Plan;
use crate::resources::SceneFeatures;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::IntoScheduleConfigs;
use caustica_core::error::{Error, Result};
use caustica_core::scene::schedule::{CYCLE, Stage};
use caustica_core::scene::{IntegratorKind, RunFile, Scene};

/// Check the run's settings for its integrator before anything is built: `pixels` is the image
/// size the run asks for (budgets are checked before anything that big is allocated).
pub fn check(pixels: u64, scene: &Scene, run: &RunFile) -> Result<()> {
    let kind = run.render.integrator;
    run.schedule.check(kind).map_err(|problem| Error::Setting { name: "schedule".into(), problem })?;
    if kind.is_progressive() {
        return progressive::check(pixels, scene, run);
    }
    if run.render.spp == 0 {
        return Err(Error::Setting { name: "spp".into(), problem: "must be at least 1".into() });
    }
    check_memory(run, sample_integrator_bytes(pixels, run), || match kind {
        IntegratorKind::Pm => format!(
            "a {pixels}-pixel film, its paths and the maps of {} + {} photons",
            run.photons.photons, run.photons.caustic_photons
        ),
        _ => format!("a {pixels}-pixel film and its paths"),
    })
}

/// Bytes a sample integrator needs: the film (f64 sums and counts per pixel), its wavefront of paths,
/// and for `pm` its photon maps (each stored photon twice while its kd-tree is built; a photon is
/// stored about 1/(1 − albedo) times, counted as 4).
fn sample_integrator_bytes(pixels: u64, run: &RunFile) -> u64 {
    use crate::components::{PathHit, PathRay, PathState, ShadowRay};
    const STORES_PER_PHOTON: u64 = 4;
    let film = pixels * (size_of::<glam::DVec3>() + size_of::<u32>()) as u64;
    let path = (size_of::<PathRay>() + size_of::<PathHit>() + size_of::<PathState>() + size_of::<ShadowRay>())
        as u64;
    let paths = pixels.min(crate::world::MAX_WAVEFRONT as u64) * path;
    let photons = if run.render.integrator == IntegratorKind::Pm {
        (run.photons.photons as u64 + run.photons.caustic_photons as u64)
            * STORES_PER_PHOTON
            * 2
            * size_of::<caustica_core::photon::Photon>() as u64
    } else {
        0
    };
    film + paths + photons
}

/// Refuse a render whose `needed` bytes exceed the memory budget (the run's, else half the machine's),
/// before anything is allocated; `what` says what needs them.
pub fn check_memory(run: &RunFile, needed: u64, what: impl FnOnce() -> String) -> Result<()> {
    let budget = run.memory_budget_bytes(crate::world::physical_memory_bytes() / 2);
    if needed > budget {
        return Err(Error::Setting {
            name: "render.memory_budget_mib".into(),
            problem: format!(
                "{} need {} MiB, over the budget of {} MiB: lower the resolution or the photon counts, or raise \
                 the budget (--memory-budget-mib)",
                what(),
                needed >> 20,
                budget >> 20
            ),
        });
    }
    Ok(())
}

/// Build the integrator the run asks for in `world` (which holds the scene's resources, as
/// `driver::scene_world` makes them): its entities, resources and phases.
pub fn plan(world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    match run.render.integrator {
        IntegratorKind::Pt | IntegratorKind::PtNaive => path::plan(world, run, features),
        IntegratorKind::Pm => photon_map::plan(world, run, features),
        IntegratorKind::Ppm => ppm::plan(world, run, features),
        IntegratorKind::Sppm => sppm::plan(world, run, features),
        IntegratorKind::Appm => appm::plan(world, run, features),
        IntegratorKind::Cppm => cppm::plan(world, run, features),
        IntegratorKind::Pppm => pppm::plan(world, run, features),
    }
}

/// Camera samples per pixel that one sample of progress stands for: `pm` shoots each final-gather
/// ray with a camera sample of its own.
pub fn camera_samples_per_unit(run: &RunFile) -> u32 {
    if run.render.integrator == IntegratorKind::Pm { run.photons.final_gather.max(1) } else { 1 }
}

/// The stage set of a run-file stage name.
pub fn stage_set(stage: Stage) -> PassSystems {
    match stage {
        Stage::Emit => PassSystems::Emit,
        Stage::Trace => PassSystems::Trace,
        Stage::Scatter => PassSystems::Scatter,
        Stage::Shadow => PassSystems::Shadow,
        Stage::Gather => PassSystems::Gather,
    }
}

/// Chain the five per-bounce stages in `order` (a checked rotation, `ScheduleSettings::stage_order`).
pub fn configure_stages(schedule: &mut Schedule, order: [Stage; 5]) {
    let [a, b, c, d, e] = order.map(stage_set);
    schedule.configure_sets((a, b, c, d, e).chain());
}

/// The run's stage order (checked by [`check`]).
pub fn stage_order(run: &RunFile) -> [Stage; 5] {
    run.schedule.stage_order().unwrap_or(CYCLE)
}

/// Visibility-aware selection learns only in `pt` with light sampling: elsewhere, warn and use the
/// light tree it is built on.
pub fn without_visibility_learning(world: &mut World, features: SceneFeatures, why: &str) -> SceneFeatures {
    if features.learns_visibility {
        tracing::warn!("visibility-aware light selection learns only in pt with light sampling; {why}");
        world.resource_mut::<crate::resources::SceneResource>().lights.finish_learning();
    }
    SceneFeatures { learns_visibility: false, ..features }
}

/// Whether any path still works.
pub fn paths_busy(world: &World) -> bool {
    world.resource::<crate::resources::RenderStats>().active_paths > 0
}

/// Whether any photon is still in flight.
pub fn photons_busy(world: &World) -> bool {
    world.resource::<crate::resources::PhotonStats>().active > 0
}

/// The photon pass's systems, one bounce of every photon per run (Emit → Trace → Scatter → Gather),
/// in `order`.
pub fn add_photon_systems(schedule: &mut Schedule, order: [Stage; 5]) {
    use crate::emit::emit_photons;
    use crate::gather::store_photons;
    use crate::scatter::scatter_photons;
    use crate::trace::trace_photons;
    configure_stages(schedule, order);
    schedule.add_systems(emit_photons.in_set(PassSystems::Emit));
    schedule.add_systems(trace_photons.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_photons.in_set(PassSystems::Scatter));
    schedule.add_systems(store_photons.in_set(PassSystems::Gather));
}

/// The film's mean per pixel: the image of the integrators whose every sample goes to the film.
pub fn film_image(world: &World, _passes: u32) -> caustica_core::film::Image {
    world.resource::<crate::resources::FilmResource>().image()
}

/// The wavefront of the sample integrators: one camera-path entity per pixel, at most
/// `MAX_WAVEFRONT`, idle until a pass hands them samples, and the work list they take them from.
pub fn spawn_path_wavefront(world: &mut World) {
    let pixels = {
        let film = world.resource::<crate::resources::FilmResource>();
        film.width * film.height
    };
    let wavefront = pixels.min(crate::world::MAX_WAVEFRONT);
    world.insert_resource(crate::resources::Workload::new(pixels, 0, 0, wavefront));
    spawn_paths(world, wavefront);
}

/// Spawn `count` camera-path entities, idle until a pass hands them samples.
fn spawn_paths(world: &mut World, count: u32) {
    use crate::components::{PathHit, PathRay, PathState, PathStatus, ShadowRay};
    let idle = PathState { status: PathStatus::Idle, ..PathState::new(0, 0) };
    world.spawn_batch(
        (0..count).map(|_| (PathRay::default(), PathHit::default(), idle, ShadowRay::default())),
    );
}

/// The photon counters for the report; `dropped` and `maps` are the integrator's own.
pub fn photon_summary(
    world: &World,
    (dropped, first_dropped_pass): (u64, Option<u32>),
    maps: Vec<crate::resources::PhotonMapSummary>,
) -> crate::report::PhotonSummary {
    let stats = world.resource::<crate::resources::PhotonStats>();
    crate::report::PhotonSummary {
        emitted: stats.emitted,
        stored: stats.stored,
        traced: stats.traced,
        roulette_kills: stats.roulette_kills,
        dropped,
        first_dropped_pass,
        maps,
    }
}

/// Spawn `count` photon entities, idle until a photon pass hands them photons.
pub fn spawn_photons(world: &mut World, count: u32) {
    use crate::components::{PathStatus, PhotonHit, PhotonRay, PhotonState};
    world.spawn_batch((0..count).map(|index| {
        let state = PhotonState { index, status: PathStatus::Idle, ..Default::default() };
        (PhotonRay::default(), PhotonHit::default(), state)
    }));
}
