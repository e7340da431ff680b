//! Gather: splat finished paths onto the film and hand their entity the next work item.
//!
//! Reads: finished `PathState`s. Writes: `Film`, `RenderStats`, `Workload`, `PathState` (next pixel
//! and sample). Runs on one thread on purpose: visiting finished paths in entity order to splat them
//! and hand out work makes the image bit-identical whatever the thread count. The loop does
//! no more than an add per finished path, a small share of a bounce.

use super::components::{PathState, PathStatus};
use super::resources::{RenderStats, Workload};
use crate::film::Film;
use bevy_ecs::prelude::*;
use glam::Vec3;

/// Splat finished paths, count rays and dropped samples, and advance each entity's work.
pub fn splat_paths_to_film(
    mut workload: ResMut<Workload>,
    mut film: ResMut<Film>,
    mut stats: ResMut<RenderStats>,
    mut paths: Query<&mut PathState>,
) {
    let mut active = 0;
    for mut state in &mut paths {
        match state.status {
            PathStatus::Idle => continue,
            PathStatus::Active | PathStatus::NeedsCamera => {
                active += 1;
                continue;
            }
            PathStatus::Finished => {}
        }
        let state = &mut *state;
        // NaN/Inf never reach the film: the sample counts, its radiance does not.
        let l = if state.l.is_finite() {
            state.l
        } else {
            stats.nan_samples += 1;
            Vec3::ZERO
        };
        film.add(state.pixel, l);
        stats.samples += 1;
        stats.rays += state.rays as u64;
        stats.shadow_rays += state.shadow_rays as u64;
        stats.lookups += state.lookups as u64;
        state.lookups = 0;
        state.rays = 0;
        state.shadow_rays = 0;
        match workload.take() {
            Some((pixel, sample)) => {
                state.pixel = pixel;
                state.sample = sample;
                state.status = PathStatus::NeedsCamera;
                active += 1;
            }
            None => state.status = PathStatus::Idle,
        }
    }
    stats.active_paths = active;
    stats.steps += 1;
}
