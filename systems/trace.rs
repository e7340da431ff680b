//! Trace: closest-hit queries for paths, any-hit queries for shadow rays.
//!
//! `trace_paths` reads `SceneGeometry`, `PathRay`, `PathState::status`; writes `PathHit`.
//! `trace_shadow_rays` reads `ShadowRay`; writes `PathState::l` (adds the contribution when the
//! segment is free).

use super::components::{PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::resources::SceneGeometry;
use bevy_ecs::prelude::*;

/// Find the closest hit of every active path's ray.
pub fn trace_paths(scene: Res<SceneGeometry>, mut paths: Query<(&PathRay, &mut PathHit, &PathState)>) {
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(ray, mut hit, state)| {
            if state.status != PathStatus::Active {
                return;
            }
            hit.0 = scene.geometry.intersect(&ray.0);
        },
    );
}

/// Test every pending shadow ray and add its contribution when nothing blocks it.
pub fn trace_shadow_rays(scene: Res<SceneGeometry>, mut paths: Query<(&mut ShadowRay, &mut PathState)>) {
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut shadow, mut state)| {
            if !shadow.pending {
                return;
            }
            shadow.pending = false;
            shadow.fresh = true;
            state.shadow_rays += 1;
            shadow.visible = !scene.geometry.occluded(&shadow.ray);
            if shadow.visible {
                state.l += shadow.contribution;
            }
        },
    );
}
