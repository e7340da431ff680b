//! Scatter for `lt`'s camera paths: follow delta bounces only and add the emission met on the way
//! (a light or the sky seen directly, in a mirror or through glass: L S* E). A path ends at its
//! first non-delta surface, where the light subpaths' connections take over
//! (`crate::light_subpaths`).

use super::{PathQueues, PathSampler, PathThroughput};
use crate::components::{PathAov, PathHit, PathRay};
use crate::resources::{RenderConfig, SceneResource};
use bevy_ecs::prelude::*;
use caustica_core::kernel::{Arrival, EmissionWeight, continue_path};

/// What the scatter reads and writes.
type SeenColumns = (
    &'static PathHit,
    &'static PathSampler,
    &'static mut PathRay,
    &'static mut PathThroughput,
    Option<&'static mut PathAov>,
);

/// Follow every active row through a delta bounce, adding the emission it meets while it has seen
/// nothing else; it stays active with its next ray, or is finished.
pub fn scatter_to_seen_emission(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    mut queues: ResMut<PathQueues>,
    mut paths: Query<SeenColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((hits, samplers, mut rays, mut states, mut aovs)) = tables.next() else { return };
    let (rays, states) = (rays.bypass_change_detection(), states.bypass_change_detection());
    let mut aovs = aovs.as_mut().map(|a| a.bypass_change_detection());
    let arrival =
        Arrival { emission: Some(EmissionWeight::SeenDirectly), last_depth: config.limits.max_depth };
    queues.advance_active(|row, _| {
        let i = row as usize;
        // The feature images of the first non-specular surface, as every camera path records them.
        let aov = aovs.as_deref_mut().map(|a| &mut a[i].0);
        arrival.arrive(
            &scene,
            &mut rays[i].0,
            &hits[i].0,
            &mut states[i].0,
            samplers[i].0,
            aov,
            |path, ray, v, u| {
                if !v.bsdf.is_delta() {
                    return false;
                }
                match continue_path(path, v, ray.time, u, config.limits) {
                    Some(next) => {
                        *ray = next;
                        true
                    }
                    None => false,
                }
            },
        )
    });
}
