//! Shadow: test every queued light sample and add what it brings when nothing blocks it; with
//! visibility-aware selection learning, count whether it got through.

use super::{PathQueues, PathShadow, PathThroughput, ShadowLearning};
use crate::resources::{RenderStats, SceneResource};
use crate::trace::TraceStatistics;
use bevy_ecs::prelude::*;
use caustica_core::kernel::Quantity;

/// Trace the shadow rays of the rows in the shadow queue.
pub fn trace_shadow_rays(
    scene: Res<SceneResource>,
    statistics: Option<Res<TraceStatistics>>,
    mut queues: ResMut<PathQueues>,
    mut stats: ResMut<RenderStats>,
    shadows: Query<(&PathShadow, Option<&ShadowLearning>)>,
    mut paths: Query<&mut PathThroughput>,
) {
    if queues.shadow.is_empty() {
        return;
    }
    let (Ok(mut shadow_tables), Ok(mut path_tables)) =
        (shadows.contiguous_iter(), paths.contiguous_iter_mut())
    else {
        return;
    };
    let (Some((shadows, learning)), Some(mut paths)) = (shadow_tables.next(), path_tables.next()) else {
        return;
    };
    let paths = paths.bypass_change_detection();
    let statistics = statistics.as_deref();
    for &row in &queues.shadow {
        let i = row as usize;
        let shadow = &shadows[i];
        let occluded = match statistics {
            None => scene.geometry.occluded(&shadow.ray),
            Some(statistics) => {
                statistics.count_shadow(|counts| scene.geometry.occluded_counted(&shadow.ray, counts))
            }
        };
        if !occluded {
            paths[i].0.add(shadow.contribution, Quantity::LightSample);
        }
        if let Some(learning) = learning {
            let target = &learning[i];
            scene.lights.record_visibility(shadow.ray.o, target.normal, target.light, !occluded);
        }
    }
    stats.shadow_rays += queues.shadow.len() as u64;
    queues.shadow.clear();
}
