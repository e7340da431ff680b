//! Feature images: what each camera sample sees at its first non-specular surface, splatted beside
//! its colour. Only a render that asks for them (`film.aovs`) has the film, the components and these
//! systems, in every integrator's camera schedule:
//!
//! | system | stage | reads | writes |
//! |---|---|---|---|
//! | `record_first_surfaces` | before Scatter | `PathHit`, `PathRay`, `PathState`, `SceneResource`, `CameraResource` | `PathAov` |
//! | `splat_aovs` | Gather, before `splat_paths_to_film` | finished `PathState`s, `PathAov` | `AovFilmResource` |
//!
//! Recording reads the hit before the integrator's scatter moves the path on, and builds the vertex
//! once more for itself: that costs a shading-point evaluation per camera sample, which only a render
//! that asks for AOVs pays, and leaves every integrator's scatter as it was.

use crate::PassSystems;
use crate::components::{PathAov, PathHit, PathRay, PathState, PathStatus};
use crate::gather::splat_paths_to_film;
use crate::resources::{AovFilmResource, CameraResource, SceneResource, wavefront_batching};
use bevy_ecs::prelude::*;
use caustica_core::kernel::aov::FirstSurface;
use caustica_core::scene::schedule::Stage;

/// At each active path's hit, look for its first non-specular surface (a new sample starts over).
pub fn record_first_surfaces(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    mut paths: Query<(&PathHit, &PathRay, &PathState, &mut PathAov)>,
) {
    let view_axis = camera.view_axis();
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(hit, ray, state, mut aov)| {
        if state.status != PathStatus::Active {
            return;
        }
        if state.path.depth == 0 {
            aov.0 = FirstSurface::start(ray.0.d, view_axis);
        }
        aov.0.visit(&scene, &ray.0, &hit.0, state.path.beta);
    });
}

/// Splat the feature images of every path that finished this bounce, as its colour is: one sample
/// each, whether or not it found a surface (a path that ends among mirrors adds zeros).
pub fn splat_aovs(film: Res<AovFilmResource>, paths: Query<(&PathState, &PathAov)>) {
    paths.par_iter().batching_strategy(wavefront_batching()).for_each(|(state, aov)| {
        if state.status == PathStatus::Finished {
            film.add(state.pixel, &aov.0.sample);
        }
    });
}

/// Give every camera path a feature-image search, when the World has a feature-image film (once,
/// after the integrator has spawned its entities: none changes archetype while rendering).
pub fn equip_paths(world: &mut World) {
    if !world.contains_resource::<AovFilmResource>() {
        return;
    }
    let paths: Vec<Entity> = world.query_filtered::<Entity, With<PathState>>().iter(world).collect();
    for entity in paths {
        world.entity_mut(entity).insert(PathAov::default());
    }
}

/// Add the feature-image systems to a camera schedule whose stages run in `order`, when the World
/// has a feature-image film.
pub fn add_aov_systems(world: &World, schedule: &mut Schedule, order: [Stage; 5]) {
    if !world.contains_resource::<AovFilmResource>() {
        return;
    }
    let record = record_first_surfaces.before(PassSystems::Scatter);
    // Trace comes just before Scatter in every rotation but the one that starts with Scatter (its
    // hits are the previous run's).
    if order[0] == Stage::Scatter {
        schedule.add_systems(record);
    } else {
        schedule.add_systems(record.after(PassSystems::Trace));
    }
    schedule.add_systems(splat_aovs.in_set(PassSystems::Gather).before(splat_paths_to_film));
}
