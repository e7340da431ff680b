//! Splat: trace every queued connection to the camera; a free one adds what it carries to the
//! pixels whose filter reaches where it lands (the film's fixed-point sums: the same bits in any
//! order, from any shard).

use super::{SubpathConnection, SubpathCounts, SubpathQueues};
use crate::light_paths::splat_connection;
use crate::resources::{CameraResource, FilmResource, SceneResource};
use bevy_ecs::prelude::*;

/// Trace the connections of the rows in the connection queue and splat the free ones.
pub fn splat_connections(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    film: Res<FilmResource>,
    mut counts: ResMut<SubpathCounts>,
    mut queues: ResMut<SubpathQueues>,
    connections: Query<&SubpathConnection>,
) {
    if queues.connections.is_empty() {
        return;
    }
    let Ok(mut tables) = connections.contiguous_iter() else { return };
    let Some(connections) = tables.next() else { return };
    let counts = &mut *counts;
    for &row in &queues.connections {
        let connection = &connections[row as usize].0;
        if scene.geometry.occluded(&connection.shadow) {
            continue;
        }
        counts.splatted += 1;
        counts.dropped += splat_connection(&camera, &film, connection);
    }
    counts.connections += queues.connections.len() as u64;
    queues.connections.clear();
}
