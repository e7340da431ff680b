//! Scatter: what each active subpath does where its ray landed — the kernel's light vertex: its
//! connection to the camera (queued for the splat), then its continuation (BSDF sample, Russian
//! roulette) — and which queue its row goes to next.

use super::SubpathSampler;
use super::{SubpathConnection, SubpathCounts, SubpathHit, SubpathPower, SubpathQueues, SubpathRay};
use crate::light_paths::LightPaths;
use crate::resources::{CameraResource, PhotonWork, SceneResource};
use bevy_ecs::prelude::*;
use caustica_core::kernel::light_path::light_vertex;

/// What scatter reads and writes.
type ScatterColumns = (
    &'static SubpathHit,
    &'static SubpathSampler,
    &'static mut SubpathRay,
    &'static mut SubpathPower,
    &'static mut SubpathConnection,
);

/// Connect every active subpath's vertex to the camera, then continue it (active) or end it (its
/// row is free again).
#[allow(clippy::too_many_arguments)]
pub fn scatter_subpaths(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    mut counts: ResMut<SubpathCounts>,
    mut queues: ResMut<SubpathQueues>,
    mut subpaths: Query<ScatterColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    let Ok(mut tables) = subpaths.contiguous_iter_mut() else { return };
    let Some((hits, samplers, mut rays, mut powers, mut connections)) = tables.next() else { return };
    let (rays, powers, connections) = (
        rays.bypass_change_detection(),
        powers.bypass_change_detection(),
        connections.bypass_change_detection(),
    );
    let mut roulette_kills = 0;
    counts.traced += queues.advance_active(|row, queued| {
        let i = row as usize;
        let SubpathSampler { sampler, index } = samplers[i];
        let path = &mut powers[i].0;
        let u_lens = light_paths.lens_sample(&work, &camera, index, path.depth);
        let bounce =
            light_vertex(&scene, &camera, &work.settings, path, &rays[i].0, &hits[i].0, &sampler, u_lens);
        if let Some(connection) = bounce.connection {
            connections[i].0 = connection;
            queued.push(row);
        }
        roulette_kills += bounce.roulette_kill as u64;
        if let Some(ray) = bounce.next {
            rays[i].0 = ray;
        }
        bounce.next.is_some()
    });
    counts.roulette_kills += roulette_kills;
}
