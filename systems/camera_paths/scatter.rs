//! Scatter: what each active row does where its ray landed — the kernel's camera vertex (emission
//! weighted by MIS, a light sample, the BSDF continuation with Russian roulette) — and which queue
//! it goes to next.

use super::{PathQueues, PathSampler, PathShadow, PathThroughput, ShadowLearning};
use crate::components::{PathAov, PathHit, PathRay};
use crate::resources::{RenderConfig, SceneResource};
use crate::scatter::path_vertex;
use bevy_ecs::prelude::*;

/// What scatter reads and writes.
type ScatterColumns = (
    &'static PathHit,
    &'static PathSampler,
    &'static mut PathRay,
    &'static mut PathThroughput,
    &'static mut PathShadow,
    Option<&'static mut ShadowLearning>,
    Option<&'static mut PathAov>,
);

/// Shade every active row: it stays active with its next ray, or is finished; a light sample
/// queues it for the shadow stage too. `NEE` selects `pt` (light sampling + MIS) over `pt-naive`.
pub fn scatter_paths<const NEE: bool>(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    mut queues: ResMut<PathQueues>,
    mut paths: Query<ScatterColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((hits, samplers, mut rays, mut states, mut shadows, mut learning, mut aovs)) = tables.next()
    else {
        return;
    };
    let (rays, states, shadows) =
        (rays.bypass_change_detection(), states.bypass_change_detection(), shadows.bypass_change_detection());
    let mut learning = learning.as_mut().map(|l| l.bypass_change_detection());
    let mut aovs = aovs.as_mut().map(|a| a.bypass_change_detection());
    let queues = &mut *queues;
    let mut next = std::mem::take(&mut queues.next);
    for &row in &queues.active {
        let i = row as usize;
        let aov = aovs.as_deref_mut().map(|a| &mut a[i].0);
        let (continues, light_sample) = path_vertex::<NEE>(
            &scene,
            &config,
            &hits[i].0,
            &mut rays[i].0,
            &mut states[i].0,
            samplers[i].0,
            aov,
        );
        if let Some(sample) = light_sample {
            shadows[i] = PathShadow { ray: sample.ray, contribution: sample.contribution };
            if let Some(learning) = learning.as_deref_mut() {
                learning[i] = ShadowLearning { light: sample.light, normal: sample.normal };
            }
            queues.shadow.push(row);
        }
        if continues {
            next.push(row);
        } else {
            queues.finished.push(row);
        }
    }
    std::mem::swap(&mut queues.active, &mut next);
    next.clear();
    queues.next = next;
}
