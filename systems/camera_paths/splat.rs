//! Splat: add every finished row's radiance to the film (and its feature images and squares), count
//! it, and free the row for the next sample.

use super::{PathQueues, PathSample, PathThroughput};
use crate::components::PathAov;
use crate::resources::{AdaptiveSquares, AovFilmResource, BadSample, FilmResource, RenderStats};
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Splat the finished rows onto the film. The film's sums are fixed point, so their bits do not
/// depend on the order samples arrive in, nor on which shard brings them.
#[allow(clippy::too_many_arguments)]
pub fn splat_paths(
    film: Res<FilmResource>,
    aov_film: Option<Res<AovFilmResource>>,
    squares: Option<Res<AdaptiveSquares>>,
    mut stats: ResMut<RenderStats>,
    mut queues: ResMut<PathQueues>,
    paths: Query<(&PathSample, &PathThroughput, Option<&PathAov>)>,
) {
    stats.steps += 1;
    stats.slot_steps += queues.rows as u64;
    if queues.finished.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter() else { return };
    let Some((samples, states, aovs)) = tables.next() else { return };
    let queues = &mut *queues;
    for &row in &queues.finished {
        let i = row as usize;
        let (sample, path) = (samples[i], &states[i].0);
        // NaN/Inf (and absurd magnitudes) never reach the film: the sample counts, its radiance
        // does not.
        let l = if caustica_core::film::fixed::accepts(path.l) {
            path.l
        } else {
            stats.nan_samples += 1;
            let bad = BadSample { pixel: sample.pixel, sample: sample.sample, cause: path.first_bad };
            if stats.first_bad.is_none_or(|first| bad.order() < first.order()) {
                stats.first_bad = Some(bad);
            }
            Vec3::ZERO
        };
        film.add(sample.pixel, l);
        if let Some(squares) = &squares {
            squares.0.add(sample.pixel, l);
        }
        // Feature images count every sample, as colour does.
        if let (Some(aov_film), Some(aovs)) = (&aov_film, aovs) {
            aov_film.add(sample.pixel, &aovs[i].0.sample);
        }
    }
    stats.samples += queues.finished.len() as u64;
    queues.free.extend(queues.finished.drain(..).rev());
}
