//! Feature images: what each camera sample sees at its first non-specular surface, splatted beside
//! its colour. Only a render that asks for them (`film.aovs`) has their film (`AovFilmResource`)
//! and a `PathAov` on each camera path; the systems that already touch a camera path do the work
//! (`emit_camera_paths` starts the search, each integrator's scatter records it from the vertex it
//! builds anyway, `splat_paths_to_film` splats it), so a render without them runs as it did and one
//! with them pays a few stores per sample.

use crate::components::{PathAov, PathState};
use crate::resources::AovFilmResource;
use bevy_ecs::prelude::*;

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
