//! Emit: a light subpath for every free row while the pass has subpaths to hand out.

use super::{SubpathHandout, SubpathPower, SubpathQueues, SubpathRay, SubpathSampler};
use crate::light_paths::LightPaths;
use crate::resources::{PhotonWork, SceneResource};
use bevy_ecs::prelude::*;
use caustica_core::kernel::photon::{PhotonPassSettings, emit_photon, photon_time};

/// What emit writes.
type EmitColumns = (&'static mut SubpathRay, &'static mut SubpathPower, &'static mut SubpathSampler);

/// Take the pass's next subpath indices for the free rows and start their subpaths on the lights
/// (`emit_photon`, each subpath with its unit's own numbers). A subpath whose light sample fails
/// leaves its row free for the next index.
pub fn emit_subpaths(
    scene: Res<SceneResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    handout: Res<SubpathHandout>,
    mut queues: ResMut<SubpathQueues>,
    mut subpaths: Query<EmitColumns>,
) {
    if queues.free.is_empty() || !handout.has_more() {
        return;
    }
    let Ok(mut tables) = subpaths.contiguous_iter_mut() else { return };
    let Some((mut rays, mut powers, mut samplers)) = tables.next() else { return };
    let (rays, powers, samplers) = (
        rays.bypass_change_detection(),
        powers.bypass_change_detection(),
        samplers.bypass_change_detection(),
    );
    // Each subpath is a whole estimate: its power is not divided among the pass's (which would
    // round differently for passes of different lengths, and a part would not merge exactly).
    let settings = PhotonPassSettings { total: 1, ..work.settings };
    queues.fill_free_rows(&handout, |index, i| {
        let sampler = light_paths.sampler(&work, index, false);
        let time = photon_time(work.time, work.motion, &sampler);
        let Some((first, path)) = emit_photon(&scene, &settings, &sampler, time) else { return false };
        rays[i].0 = first;
        powers[i].0 = path;
        samplers[i] = SubpathSampler { sampler, index };
        true
    });
}
