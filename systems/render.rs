//! The driver: turn a loaded scene and its settings into a World and a Schedule, and run it.
//!
//! A host application can call [`prepare`] and then run the schedule itself, or put the resources
//! and `integrators::path::build` into its own World and Schedule (see the crate docs).

use super::components::{PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::integrators;
use super::resources::{RenderCamera, RenderConfig, RenderFilm, RenderStats, SceneFeatures, SceneGeometry, Workload, scene_lights};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{Film, Image};
use crate::geometry::Geometry;
use crate::scene::{IntegratorKind, RunFile, Scene};
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;
use std::time::Instant;

/// Largest wavefront: enough paths to keep every core busy and the tables in cache-sized batches;
/// larger images reuse each entity for several pixels.
pub const MAX_WAVEFRONT: u32 = 1 << 18;

/// Default image size when neither the run file nor the glTF gives one.
pub const DEFAULT_RESOLUTION: u32 = 512;

/// Size the worker pools once per process: bevy's compute pool (parallel queries) and rayon's (BVH
/// builds). They never run at the same time, so they do not oversubscribe the cores.
pub fn init_thread_pools(threads: Option<usize>) {
    let n = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())).max(1);
    bevy_tasks::ComputeTaskPool::get_or_init(|| bevy_tasks::TaskPoolBuilder::new().num_threads(n).build());
    // Err means the global pool already exists (a second render in one process): keep it.
    let _ = rayon::ThreadPoolBuilder::new().num_threads(n).build_global();
}

/// A World ready to render and the Schedule that advances it by one bounce per run.
pub struct Renderer {
    /// Scene, settings, film and path entities.
    pub world: World,
    /// The staged systems of the chosen integrator.
    pub schedule: Schedule,
    /// What the scene uses (decides which systems are in the schedule).
    pub features: SceneFeatures,
    /// Samples per pixel still to render once visibility learning ends.
    pub pending_spp: Option<u32>,
}

/// Resolve the image size: run file, then the glTF's extras, then the camera's aspect ratio.
pub fn resolution(scene: &Scene, run: &RunFile) -> Result<(u32, u32)> {
    let aspect = scene.camera.as_ref().and_then(|c| c.aspect_ratio);
    let (w, h) = match (run.film.width, run.film.height, scene.resolution) {
        (Some(w), Some(h), _) => (w, h),
        (Some(w), None, Some((sw, sh))) => (w, ((w as u64 * sh as u64) / sw.max(1) as u64) as u32),
        (None, Some(h), Some((sw, sh))) => (((h as u64 * sw as u64) / sh.max(1) as u64) as u32, h),
        (None, None, Some(r)) => r,
        (w, h, None) => {
            let a = aspect.unwrap_or(1.0);
            let w = w.unwrap_or_else(|| h.map_or(DEFAULT_RESOLUTION, |h| (h as f32 * a).round() as u32));
            let h = h.unwrap_or_else(|| (w as f32 / a).round() as u32);
            (w, h)
        }
    };
    for (name, v) in [("width", w), ("height", h)] {
        if v == 0 || v > 1 << 15 {
            return Err(Error::Setting { name: name.into(), problem: format!("{v} is not in 1..=32768") });
        }
    }
    Ok((w, h))
}

/// A World holding the scene's resources (`SceneGeometry`, `Camera`, `Film`, `RenderConfig`) and no
/// entities yet, and what the scene uses. Shared by every integrator's `prepare`.
pub fn scene_world(scene: Scene, run: &RunFile) -> Result<(World, SceneFeatures)> {
    let settings = &run.render;
    let (width, height) = resolution(&scene, run)?;
    let mut geometry = Geometry::build(&scene);
    let camera_desc = match &scene.camera {
        Some(c) => c.clone(),
        None => {
            let (min, max) = geometry.bounds();
            // With both eye and target given the user has placed the camera: nothing to warn about.
            if run.camera.eye.is_none() || run.camera.target.is_none() {
                tracing::warn!(
                    "{}: no camera in the file; framing the scene's bounds from +Z (looking down -Z) with a \
                 45° vertical field of view; set [camera] eye/target/yfov_degrees or --eye/--target/--yfov",
                    scene.source.display()
                );
            }
            // Frame for the field of view the camera will have, so that a narrower one does not crop.
            let yfov = run.camera.yfov_degrees.filter(|d| *d > 0.0 && *d < 180.0).unwrap_or(45.0);
            Camera::framing(min, max, width as f32 / height as f32, yfov.to_radians())
        }
    };
    // Name the scene file: a bad camera override is the user's to fix there.
    let camera = Camera::new(&camera_desc, &run.camera, width, height, run.film.filter).map_err(|e| {
        Error::InvalidScene { path: scene.source.clone(), object: "camera".into(), problem: e.to_string() }
    })?;
    let lights = scene_lights(&mut geometry, &scene, settings.light_selection);
    let scene_geometry =
        SceneGeometry { geometry, lights, materials: scene.materials, textures: scene.textures };
    let features = SceneFeatures::of(&camera, &scene_geometry);
    let mut world = World::new();
    world.insert_resource(RenderConfig {
        integrator: settings.integrator,
        seed: settings.seed,
        max_depth: settings.max_depth.unwrap_or(u32::MAX),
        rr_depth: settings.rr_depth,
        pass_time: None,
    });
    world.insert_resource(RenderFilm(Film::new(width, height)));
    world.insert_resource(RenderCamera(camera));
    world.insert_resource(scene_geometry);
    world.insert_resource(RenderStats::default());
    Ok((world, features))
}

/// Build the World (resources + one wavefront of path entities) and the Schedule for a scene.
pub fn prepare(scene: Scene, run: &RunFile) -> Result<Renderer> {
    let settings = &run.render;
    if settings.spp == 0 {
        return Err(Error::Setting { name: "spp".into(), problem: "must be at least 1".into() });
    }
    if settings.integrator.is_progressive() {
        return Err(Error::Setting {
            name: "integrator".into(),
            problem: format!(
                "{:?} is progressive: prepare it with systems::progressive::prepare_progressive",
                settings.integrator
            ),
        });
    }
    run.schedule
        .check(settings.integrator)
        .map_err(|problem| Error::Setting { name: "schedule".into(), problem })?;
    let order = run.schedule.stage_order().unwrap_or(crate::scene::schedule::CYCLE);
    let (mut world, features) = scene_world(scene, run)?;
    let pixels = {
        let film = world.resource::<RenderFilm>();
        film.width * film.height
    };
    let wavefront = pixels.min(MAX_WAVEFRONT);
    // Each final-gather ray comes with its own camera sample.
    let spp = if settings.integrator == IntegratorKind::Pm {
        settings.spp.saturating_mul(run.photons.final_gather.max(1))
    } else {
        settings.spp
    };
    // Visibility-aware selection learns from the shadow rays of the first sixteenth of the samples
    // (at least one per pixel), rendered with the plain tree; `run` then freezes what it learned and
    // renders the rest. Only `pt` with light sampling has the learning system.
    let learns = features.learns_visibility
        && settings.integrator == IntegratorKind::Pt
        && run.schedule.nee_for(settings.integrator);
    if features.learns_visibility && !learns {
        tracing::warn!(
            "visibility-aware light selection learns only in pt with light sampling; using the light tree"
        );
        world.resource_mut::<SceneGeometry>().lights.finish_learning();
    }
    let features = SceneFeatures { learns_visibility: learns, ..features };
    let first_spp = if learns { (spp / 16).clamp(1, spp) } else { spp };
    let mut workload = Workload::new(pixels, 0, first_spp, wavefront);
    spawn_wavefront(&mut world, &mut workload);
    world.insert_resource(workload);

    let mut schedule = Schedule::default();
    schedule.set_executor(SingleThreadedExecutor::new());
    if settings.integrator == IntegratorKind::Pm {
        integrators::photon_map::prepare_maps(&mut world, &run.photons, features.motion);
        integrators::photon_map::build_ordered(&mut schedule, features, order);
    } else {
        let nee = run.schedule.nee_for(settings.integrator);
        integrators::path::build_ordered(&mut schedule, features, order, nee);
    }
    Ok(Renderer { world, schedule, features, pending_spp: (first_spp < spp).then_some(spp) })
}

/// Spawn the path entities once, each with its first work item; they are reused until the render ends.
pub fn spawn_wavefront(world: &mut World, workload: &mut Workload) {
    let items: Vec<PathState> = (0..workload.wavefront)
        .map(|_| match workload.take() {
            Some((pixel, sample)) => PathState::new(pixel, sample),
            None => PathState { status: PathStatus::Idle, ..PathState::new(0, 0) },
        })
        .collect();
    world.spawn_batch(
        items.into_iter().map(|state| (PathRay::default(), PathHit::default(), state, ShadowRay::default())),
    );
}

/// What a finished render reports.
#[derive(Clone, Debug)]
pub struct RenderSummary {
    /// Counters.
    pub stats: RenderStats,
    /// Wall time of the bounce loop, in seconds.
    pub seconds: f64,
}

impl Renderer {
    /// Run bounce steps until every path is idle, calling `progress` after each step.
    pub fn run(&mut self, progress: impl FnMut(&RenderStats)) -> RenderSummary {
        self.run_until(None, progress)
    }

    /// As [`Renderer::run`], but once `time_limit` seconds have passed no new sample starts: the paths
    /// in flight finish, and each pixel keeps the samples it got (the work is handed out sample-major,
    /// so pixels differ by at most one sample).
    pub fn run_until(
        &mut self,
        time_limit: Option<f64>,
        mut progress: impl FnMut(&RenderStats),
    ) -> RenderSummary {
        let start = Instant::now();
        loop {
            let _span = tracing::trace_span!("step").entered();
            self.schedule.run(&mut self.world);
            let stats = *self.world.resource::<RenderStats>();
            progress(&stats);
            if stats.active_paths == 0 {
                // The learning samples are done: freeze the learned selection and render the rest.
                let Some(spp) = self.pending_spp.take() else { break };
                if time_limit.is_some_and(|limit| start.elapsed().as_secs_f64() >= limit) {
                    break;
                }
                self.extend_samples(spp);
                continue;
            }
            if time_limit.is_some_and(|limit| start.elapsed().as_secs_f64() >= limit) {
                let mut workload = self.world.resource_mut::<Workload>();
                workload.next = workload.total_samples();
            }
        }
        RenderSummary { stats: *self.world.resource::<RenderStats>(), seconds: start.elapsed().as_secs_f64() }
    }

    /// Hand out more work: samples up to `spp_end` per pixel, to idle paths first and to the rest as
    /// they finish. The film keeps what it has, so a render can be refined in steps (benchmarks
    /// measure the error after each).
    pub fn extend_samples(&mut self, spp_end: u32) {
        // Visibility-aware selection learns from the first batch of samples only.
        self.world.resource_mut::<SceneGeometry>().lights.finish_learning();
        let old = *self.world.resource::<Workload>();
        if spp_end <= old.spp_end {
            return;
        }
        let mut workload = Workload::new(old.pixels, old.spp_end, spp_end, old.wavefront);
        let mut paths = self.world.query::<&mut PathState>();
        for mut state in paths.iter_mut(&mut self.world) {
            if state.status != PathStatus::Idle {
                continue;
            }
            let Some((pixel, sample)) = workload.take() else { break };
            (state.pixel, state.sample, state.status) = (pixel, sample, PathStatus::NeedsCamera);
        }
        self.world.insert_resource(workload);
    }

    /// The mean radiance per pixel so far.
    pub fn image(&self) -> Image {
        self.world.resource::<RenderFilm>().image()
    }
}
