//! Trace: closest-hit queries for camera paths and photons, any-hit queries for shadow rays.
//!
//! `trace_paths` reads `SceneResource`, `PathRay`, `PathState::status`; writes `PathHit`.
//! `trace_shadow_rays` reads `ShadowRay`; writes `PathState` (adds the contribution when the
//! segment is free). `trace_photons` reads `PhotonRay`; writes `PhotonHit`.

use super::components::{
    PathHit, PathRay, PathState, PathStatus, PhotonHit, PhotonRay, PhotonState, ShadowRay,
};
use super::resources::{SceneResource, wavefront_batching};
use bevy_ecs::prelude::*;
use caustica_core::kernel::Quantity;

/// Find the closest hit of every active path's ray.
pub fn trace_paths(scene: Res<SceneResource>, mut paths: Query<(&PathRay, &mut PathHit, &PathState)>) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(ray, mut hit, state)| {
        if state.status != PathStatus::Active {
            return;
        }
        hit.0 = scene.geometry.intersect(&ray.0);
    });
}

/// Test every pending shadow ray and add its contribution when nothing blocks it.
pub fn trace_shadow_rays(scene: Res<SceneResource>, mut paths: Query<(&mut ShadowRay, &mut PathState)>) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut shadow, mut state)| {
        if !shadow.pending {
            return;
        }
        shadow.pending = false;
        shadow.fresh = true;
        state.shadow_rays += 1;
        shadow.visible = !scene.geometry.occluded(&shadow.ray);
        if shadow.visible {
            state.path.add(shadow.contribution, Quantity::LightSample);
        }
    });
}

/// Closest hit of every flying photon.
pub fn trace_photons(
    scene: Res<SceneResource>,
    mut photons: Query<(&PhotonRay, &mut PhotonHit, &PhotonState)>,
) {
    photons.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(ray, mut hit, state)| {
        if state.status == PathStatus::Active {
            hit.0 = scene.geometry.intersect(&ray.0);
        }
    });
}
