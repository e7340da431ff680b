//! Trace: the closest hit of every active subpath's ray. Reads rays, writes hits, nothing else.

use super::{SubpathHit, SubpathQueues, SubpathRay};
use crate::resources::SceneResource;
use crate::trace::TraceStatistics;
use bevy_ecs::prelude::*;

/// Find the closest hit of every active subpath's ray.
pub fn trace_subpaths(
    scene: Res<SceneResource>,
    statistics: Option<Res<TraceStatistics>>,
    queues: Res<SubpathQueues>,
    rays: Query<&SubpathRay>,
    mut hits: Query<&mut SubpathHit>,
) {
    if queues.active.is_empty() {
        return;
    }
    let (Ok(mut ray_tables), Ok(mut hit_tables)) = (rays.contiguous_iter(), hits.contiguous_iter_mut())
    else {
        return;
    };
    let (Some(rays), Some(mut hits)) = (ray_tables.next(), hit_tables.next()) else { return };
    let hits = hits.bypass_change_detection();
    let geometry = &scene.geometry;
    match statistics.as_deref() {
        None => {
            for &row in &queues.active {
                let i = row as usize;
                hits[i].0 = geometry.intersect(&rays[i].0);
            }
        }
        Some(statistics) => {
            for &row in &queues.active {
                let i = row as usize;
                hits[i].0 = statistics.count_photons(|counts| geometry.intersect_counted(&rays[i].0, counts));
            }
        }
    }
}
