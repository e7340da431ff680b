//! Emit: start a camera path for the next sample wherever a path ended.
//!
//! Reads: `Camera`, `RenderConfig`, `Workload`. Writes: `PathRay`, `PathState` (reset for the new
//! sample). The lens and time dimensions are compile-time switches, so a pinhole camera in a static
//! scene draws neither (the integrator picks the instance from `SceneFeatures`).

use super::components::{PathRay, PathState, PathStatus};
use super::resources::{RenderCamera, RenderConfig};
use crate::sampling::Sampler;
use bevy_ecs::prelude::*;
use glam::{Vec2, Vec3};

/// Generate camera rays for paths that need one. `LENS`: sample the aperture; `MOTION`: sample the shutter.
pub fn emit_camera_paths<const LENS: bool, const MOTION: bool>(
    camera: Res<RenderCamera>,
    config: Res<RenderConfig>,
    mut paths: Query<(&mut PathRay, &mut PathState)>,
) {
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut ray, mut state)| {
            if state.status != PathStatus::NeedsCamera {
                return;
            }
            let sampler = Sampler::new(config.seed, state.pixel, state.sample);
            let x = state.pixel % camera.width;
            let y = state.pixel / camera.width;
            let u_lens = if LENS { sampler.get2d(2) } else { Vec2::splat(0.5) };
            let time = if MOTION { config.pass_time.unwrap_or_else(|| sampler.get1d(4)) } else { 0.0 };
            ray.0 = camera.generate_ray(x, y, sampler.get2d(0), u_lens, time);
            let s = &mut *state;
            s.depth = 0;
            s.beta = Vec3::ONE;
            s.l = Vec3::ZERO;
            s.eta_scale = 1.0;
            s.prev_pdf = 0.0;
            s.specular_bounce = false;
            s.gathering = false;
            s.status = PathStatus::Active;
        },
    );
}

/// The `emit_camera_paths` instance for a scene: lens and time sampling only when the scene has an
/// aperture or motion.
pub fn emit_camera_paths_for(
    features: super::resources::SceneFeatures,
) -> bevy_ecs::schedule::ScheduleConfigs<bevy_ecs::system::ScheduleSystem> {
    match (features.lens, features.motion) {
        (false, false) => emit_camera_paths::<false, false>.into_configs(),
        (true, false) => emit_camera_paths::<true, false>.into_configs(),
        (false, true) => emit_camera_paths::<false, true>.into_configs(),
        (true, true) => emit_camera_paths::<true, true>.into_configs(),
    }
}
