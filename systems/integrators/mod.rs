//! Integrators as descriptors and plans: each file holds its integrator's [`Integrator`] — what it
//! counts, splits and takes, the checks on its settings, and the plan that puts its entities and
//! resources into the World with the phases of its passes (schedules of the `PassSystems` stages).
//! [`ALL`] is the registry and [`of`] the one lookup by kind; the driver runs any plan.

pub mod appm;
pub mod bdpt;
pub mod cppm;
pub mod descriptor;
pub mod light_tracing;
pub mod memory;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod pppm;
pub mod progressive;
pub mod sppm;
pub mod vcm;

use crate::resources::SceneFeatures;
use bevy_ecs::prelude::*;
use caustica_core::choice::Choice;
use caustica_core::scene::{IntegratorKind, RunFile};
pub use descriptor::{Integrator, LightSampling, MemoryNeed, Setting};

/// The registry: every integrator's descriptor, in the name table's order (`IntegratorKind::CHOICES`).
/// Adding an integrator is its file, its name in the name table, and one line here; every test,
/// fuzzer, help text and doc table that goes over the integrators reads this.
pub static ALL: [&Integrator; 11] = [
    &path::PT,
    &path::PT_NAIVE,
    &photon_map::PM,
    &ppm::PPM,
    &sppm::SPPM,
    &appm::APPM,
    &cppm::CPPM,
    &pppm::PPPM,
    &light_tracing::LT,
    &bdpt::BDPT,
    &vcm::VCM,
];

// The registry holds each named integrator once, at its place in the name table: checked when the
// crate compiles, so [`of`] is an index that cannot miss and a kind left out does not build.
const _: () = {
    assert!(ALL.len() == IntegratorKind::CHOICES.len(), "an integrator is named but not registered");
    let mut i = 0;
    while i < ALL.len() {
        assert!(ALL[i].kind as usize == i, "the registry's order is the name table's");
        assert!(IntegratorKind::CHOICES[i].0 as usize == i, "the name table's order is the enum's");
        i += 1;
    }
};

/// The descriptor of `kind`, from the registry.
pub fn of(kind: IntegratorKind) -> &'static Integrator {
    ALL[kind as usize]
}

/// Every integrator's kind, in the registry's order.
pub fn kinds() -> impl Iterator<Item = IntegratorKind> {
    ALL.iter().map(|integrator| integrator.kind)
}

/// The names of every integrator, in the registry's order.
pub fn names() -> impl Iterator<Item = &'static str> {
    ALL.iter().map(|integrator| integrator.name())
}

/// The descriptor of the integrator `run` asks for.
pub fn of_run(run: &RunFile) -> &'static Integrator {
    of(run.render.integrator)
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

/// The film's mean per pixel: the image of the integrators whose every sample goes to the film.
pub fn film_image(world: &World, _passes: u32) -> caustica_core::film::Image {
    crate::resources::committed_film(world).image()
}

/// The wavefront of the integrators whose camera paths are not yet on the vector core: one
/// camera-path entity per pixel, at most `max`, idle until a pass hands them samples, and the work
/// list they take them from.
pub fn spawn_path_wavefront(world: &mut World, max: u32) {
    let pixels = {
        let film = world.resource::<crate::resources::FilmResource>();
        film.width * film.height
    };
    let wavefront = pixels.min(max);
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
