//! Emit: a camera ray for every free row while the pass has samples to hand out.

use super::{PathQueues, PathSample, PathSampler, PathThroughput, ShardIndex};
use crate::components::{PathAov, PathRay};
use crate::resources::{CameraResource, PassRange, RenderConfig, Workload};
use bevy_ecs::prelude::*;
use caustica_core::kernel::CameraPath;
use caustica_core::kernel::aov::FirstSurface;
use caustica_core::kernel::camera_sample::{camera_sampler, filter_sample};
use caustica_core::kernel::dimensions::camera as dim;
use glam::Vec2;

/// What emit writes.
type EmitColumns = (
    &'static mut PathRay,
    &'static mut PathSample,
    &'static mut PathSampler,
    &'static mut PathThroughput,
    Option<&'static mut PathAov>,
);

/// Take the next samples for the free rows and make their camera rays. `LENS`: sample the aperture;
/// `MOTION`: sample the shutter (compile-time, so a pinhole camera in a still scene draws neither).
#[allow(clippy::too_many_arguments)]
pub fn emit_paths<const LENS: bool, const MOTION: bool>(
    camera: Res<CameraResource>,
    config: Res<RenderConfig>,
    range: Res<PassRange>,
    workload: Res<Workload>,
    shard: Res<ShardIndex>,
    mut queues: ResMut<PathQueues>,
    mut paths: Query<EmitColumns>,
) {
    if range.stop || queues.free.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((mut rays, mut samples, mut samplers, mut states, mut aovs)) = tables.next() else { return };
    let (rays, samples, samplers, states) = (
        rays.bypass_change_detection(),
        samples.bypass_change_detection(),
        samplers.bypass_change_detection(),
        states.bypass_change_detection(),
    );
    let mut aovs = aovs.as_mut().map(|a| a.bypass_change_detection());
    let view_axis = camera.view_axis();
    let lane = shard.lane(&workload);
    let queues = &mut *queues;
    while !queues.free.is_empty() {
        let want = queues.free.len() as u32;
        let got = workload.take_run(lane, want, |pixel, sample| {
            let row = queues.free.pop().expect("no more samples than free rows");
            let i = row as usize;
            let sampler = camera_sampler(config.sampler, config.seed, pixel, sample);
            let (x, y) = (pixel % camera.width, pixel / camera.width);
            let u_filter = filter_sample(&sampler, config.sampler, config.seed, pixel, sample, config.strata);
            let u_lens = if LENS { sampler.get2d(dim::LENS) } else { Vec2::splat(0.5) };
            let time =
                if MOTION { config.pass_time.unwrap_or_else(|| sampler.get1d(dim::TIME)) } else { 0.0 };
            rays[i].0 = camera.generate_ray(x, y, u_filter, u_lens, time);
            if let Some(aovs) = aovs.as_deref_mut() {
                aovs[i].0 = FirstSurface::start(rays[i].0.d, view_axis);
            }
            samples[i] = PathSample { pixel, sample };
            samplers[i] = PathSampler(sampler);
            states[i] = PathThroughput(CameraPath::START);
            queues.active.push(row);
        });
        if got == 0 {
            break;
        }
    }
}

/// The `emit_paths` instance for a scene: lens and time sampling only when it has an aperture or
/// motion.
pub fn emit_paths_for(
    features: crate::resources::SceneFeatures,
) -> bevy_ecs::schedule::ScheduleConfigs<bevy_ecs::system::ScheduleSystem> {
    match (features.lens, features.motion) {
        (false, false) => emit_paths::<false, false>.into_configs(),
        (true, false) => emit_paths::<true, false>.into_configs(),
        (false, true) => emit_paths::<false, true>.into_configs(),
        (true, true) => emit_paths::<true, true>.into_configs(),
    }
}
