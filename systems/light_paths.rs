//! Light tracing's own systems (`lt`): each light subpath's vertex connects to the camera
//! (`scatter_light_paths`, the Scatter stage), and the connections whose segment is free add what
//! they carry to the pixels the filter gives them (`splat_camera_connections`, the Shadow stage).
//! Tracing and handing out subpaths are the photon systems'; `emit_light_paths` is
//! `emit_photons` with each unit's own random numbers. Camera paths find what no
//! connection can: a light seen directly or through mirrors and glass (`scatter_to_seen_emission`).
//!
//! | system | reads | writes |
//! |---|---|---|
//! | `emit_light_paths` | `SceneResource`, `PhotonWork`, `LightPaths` | `PhotonRay`, `PhotonState` |
//! | `scatter_to_seen_emission` | `PathHit`, `SceneResource`, `RenderConfig` | `PathRay`, `PathState` |
//! | `scatter_light_paths` | `PhotonHit`, `SceneResource`, `CameraResource`, `PhotonWork` | `PhotonRay`, `PhotonState`, `CameraSplat` |
//! | `splat_camera_connections` | `CameraSplat`, `SceneResource`, `CameraResource` | `FilmResource`, `LightPaths` |

use super::components::{
    CameraSplat, PathAov, PathHit, PathRay, PathState, PathStatus, PhotonHit, PhotonRay, PhotonState,
};
use super::resources::{
    CameraResource, FilmResource, PhotonWork, RenderConfig, SceneResource, wavefront_batching,
};
use bevy_ecs::prelude::*;
use caustica_core::camera::{filter_radius, filter_weight};
use caustica_core::film::fixed;
use caustica_core::kernel::dimensions::photon_sampler;
use caustica_core::kernel::light_path::light_vertex;
use caustica_core::kernel::photon::{PhotonPassSettings, emit_photon, photon_time};
use caustica_core::kernel::{Arrival, EmissionWeight, continue_path};
use caustica_core::sampling::Sampler;
use glam::Vec2;
use std::sync::atomic::{AtomicU64, Ordering};

/// The random-number stream of the lens points light subpaths connect to: apart from the
/// subpaths' own (photon map kinds 0 to 3), so a pinhole camera leaves them as they were.
const LENS_STREAM: u32 = 8;

/// Light tracing's subpaths: how many a unit of progress has (one a pixel), and what their
/// connections did, for the report.
#[derive(Resource, Debug, Default)]
pub struct LightPaths {
    /// Subpaths a unit: the image's pixels.
    pub per_unit: u32,
    /// Connections to the camera traced.
    pub connections: AtomicU64,
    /// Those whose segment was free and added to the film.
    pub splatted: AtomicU64,
    /// Those dropped because what they carried could not go to the film (beyond its range).
    pub dropped: AtomicU64,
}

impl LightPaths {
    /// What the connections to the camera did, for the report.
    pub fn describe(&self) -> String {
        let (connections, splatted, dropped) = (
            self.connections.load(Ordering::Relaxed),
            self.splatted.load(Ordering::Relaxed),
            self.dropped.load(Ordering::Relaxed),
        );
        format!(
            "{connections} connections from light vertices, {splatted} seen, {dropped} splats out of range dropped"
        )
    }

    /// The lens point of subpath `index`'s connection at `depth` (the pinhole itself without an
    /// aperture).
    pub fn lens_sample(
        &self,
        work: &PhotonWork,
        camera: &caustica_core::camera::Camera,
        index: u32,
        depth: u32,
    ) -> Vec2 {
        if camera.has_lens() { self.sampler(work, index, true).get2d(2 * depth) } else { Vec2::splat(0.5) }
    }

    /// The random numbers of subpath `index` of the pass that starts at unit `work.pass`: those of
    /// subpath `index mod per_unit` of its own unit, so that a pass of any length (a part, a
    /// resumed render) draws what a pass of one unit would; and its lens points' (`lens`).
    pub fn sampler(&self, work: &PhotonWork, index: u32, lens: bool) -> Sampler {
        let unit = work.pass + index / self.per_unit;
        let stream = if lens { LENS_STREAM } else { work.settings.kind as u32 };
        photon_sampler(work.sampler, work.seed, unit, stream, index % self.per_unit)
    }
}

/// Start a light subpath wherever an entity needs one (`emit_photons`, with each unit's numbers).
pub fn emit_light_paths(
    scene: Res<SceneResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    mut paths: Query<(&mut PhotonRay, &mut PhotonState)>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut ray, mut state)| {
        if state.status != PathStatus::NeedsStart {
            return;
        }
        let sampler = light_paths.sampler(&work, state.index, false);
        let time = photon_time(work.time, work.motion, &sampler);
        // Each subpath is a whole estimate: its power is not divided among the pass's (which would
        // round differently for passes of different lengths, and a part would not merge exactly).
        let settings = PhotonPassSettings { total: 1, ..work.settings };
        match emit_photon(&scene, &settings, &sampler, time) {
            Some((first, path)) => {
                ray.0 = first;
                state.path = path;
                state.status = PathStatus::Active;
            }
            None => state.status = PathStatus::Finished,
        }
    });
}

/// Follow every active camera path through delta bounces only, adding the emission it meets while
/// it has seen nothing else (L S* E): it ends at its first non-delta surface, where the light
/// subpaths' connections take over.
pub fn scatter_to_seen_emission(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    mut paths: Query<(&PathHit, &mut PathRay, &mut PathState, Option<&mut PathAov>)>,
) {
    let arrival =
        Arrival { emission: Some(EmissionWeight::SeenDirectly), last_depth: config.limits.max_depth };
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut aov)| {
            if state.status != PathStatus::Active {
                return;
            }
            state.rays += 1;
            let state = &mut *state;
            // The feature images of the first non-specular surface, as every camera path records them.
            let aov = aov.as_deref_mut().map(|a| &mut a.0);
            let goes_on = arrival.arrive(
                &scene,
                &mut ray.0,
                &hit.0,
                &mut state.path,
                state.sampler,
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
            );
            if !goes_on {
                state.status = PathStatus::Finished;
            }
        },
    );
}

/// Connect every active light subpath's vertex to the camera, then continue it or end it.
pub fn scatter_light_paths(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    mut paths: Query<(&PhotonHit, &mut PhotonRay, &mut PhotonState, &mut CameraSplat)>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut splat)| {
            if state.status != PathStatus::Active {
                return;
            }
            state.bounces += 1;
            let sampler = light_paths.sampler(&work, state.index, false);
            let u_lens = light_paths.lens_sample(&work, &camera, state.index, state.path.depth);
            let bounce = light_vertex(
                &scene,
                &camera,
                &work.settings,
                &mut state.path,
                &ray.0,
                &hit.0,
                &sampler,
                u_lens,
            );
            splat.0 = bounce.connection;
            state.roulette_kills += bounce.roulette_kill as u32;
            match bounce.next {
                Some(next) => ray.0 = next,
                None => state.status = PathStatus::Finished,
            }
        },
    );
}

/// Trace every pending connection to the camera; a free one adds what it carries to the pixels
/// whose filter reaches where it lands, each its share (integer sums: the same bits in any order).
pub fn splat_camera_connections(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    film: Res<FilmResource>,
    stats: Res<LightPaths>,
    mut splats: Query<&mut CameraSplat>,
) {
    let (width, height) = (camera.width as i64, camera.height as i64);
    let radius = filter_radius(camera.filter);
    splats.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|mut splat| {
        let Some(connection) = splat.0.take() else { return };
        stats.connections.fetch_add(1, Ordering::Relaxed);
        if scene.geometry.occluded(&connection.shadow) {
            return;
        }
        stats.splatted.fetch_add(1, Ordering::Relaxed);
        let at = connection.raster;
        // Pixel centres within the filter's reach of the point.
        let (x0, x1) = (
            ((at.x - 0.5 - radius).ceil() as i64).max(0),
            ((at.x - 0.5 + radius).floor() as i64).min(width - 1),
        );
        let (y0, y1) = (
            ((at.y - 0.5 - radius).ceil() as i64).max(0),
            ((at.y - 0.5 + radius).floor() as i64).min(height - 1),
        );
        for y in y0..=y1 {
            for x in x0..=x1 {
                let offset = at - Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let weight = filter_weight(camera.filter, offset);
                if weight <= 0.0 {
                    continue;
                }
                let value = connection.value * weight;
                if fixed::accepts(value) {
                    film.splat((y * width + x) as u32, value);
                } else {
                    stats.dropped.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
    });
}
