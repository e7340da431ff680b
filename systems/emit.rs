//! Emit: start a camera path for the next sample wherever a path ended. (Photons start on the
//! vector core: `light_subpaths::photons::emit_photon_subpaths`.)
//!
//! `emit_camera_paths` reads `CameraResource`, `RenderConfig`; writes `PathRay`, `PathState` (reset
//! for the new sample), and `PathAov` when the render makes feature images. The lens and time dimensions are compile-time switches, so a pinhole camera
//! in a static scene draws neither (the integrator picks the instance from `SceneFeatures`).

use super::components::{PathAov, PathRay, PathState, PathStatus};
use super::resources::{CameraResource, RenderConfig, SceneFeatures};
use bevy_ecs::prelude::*;
use caustica_core::kernel::CameraPath;
use caustica_core::kernel::aov::FirstSurface;
use caustica_core::kernel::camera_sample::{camera_sampler, filter_sample};
use caustica_core::kernel::dimensions::camera as dim;
use glam::Vec2;

/// Generate camera rays for paths that need one. `LENS`: sample the aperture; `MOTION`: sample the shutter.
pub fn emit_camera_paths<const LENS: bool, const MOTION: bool>(
    camera: Res<CameraResource>,
    config: Res<RenderConfig>,
    mut paths: Query<(&mut PathRay, &mut PathState, Option<&mut PathAov>)>,
) {
    let view_axis = camera.view_axis();
    paths.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut ray, mut state, aov)| {
            if state.status != PathStatus::NeedsStart {
                return;
            }
            let sampler = camera_sampler(config.sampler, config.seed, state.pixel, state.sample);
            let x = state.pixel % camera.width;
            let y = state.pixel / camera.width;
            let u_filter = filter_sample(
                &sampler,
                config.sampler,
                config.seed,
                state.pixel,
                state.sample,
                config.strata,
            );
            let u_lens = if LENS { sampler.get2d(dim::LENS) } else { Vec2::splat(0.5) };
            let time =
                if MOTION { config.pass_time.unwrap_or_else(|| sampler.get1d(dim::TIME)) } else { 0.0 };
            ray.0 = camera.generate_ray(x, y, u_filter, u_lens, time);
            if let Some(mut aov) = aov {
                aov.0 = FirstSurface::start(ray.0.d, view_axis);
            }
            state.sampler = sampler;
            state.path = CameraPath::START;
            state.gathering = false;
            state.status = PathStatus::Active;
        },
    );
}

/// The `emit_camera_paths` instance for a scene: lens and time sampling only when the scene has an
/// aperture or motion.
pub fn emit_camera_paths_for(
    features: SceneFeatures,
) -> bevy_ecs::schedule::ScheduleConfigs<bevy_ecs::system::ScheduleSystem> {
    match (features.lens, features.motion) {
        (false, false) => emit_camera_paths::<false, false>.into_configs(),
        (true, false) => emit_camera_paths::<true, false>.into_configs(),
        (false, true) => emit_camera_paths::<false, true>.into_configs(),
        (true, true) => emit_camera_paths::<true, true>.into_configs(),
    }
}
