//! The World every integrator starts from: the scene's resources, sized and checked.

use crate::resources::{
    AovFilmResource, CameraResource, FilmResource, PassRange, RenderConfig, RenderStats, SceneFeatures,
    SceneResource,
};
use bevy_ecs::prelude::*;
use caustica_core::camera::Camera;
use caustica_core::error::{Error, Result};
use caustica_core::film::Film;
use caustica_core::film::aov::AovFilm;
use caustica_core::kernel::PathLimits;
use caustica_core::render_scene::RenderScene;
use caustica_core::scene::{RunFile, Scene};

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

/// The camera `desc` of the scene read from `source`, or one that frames its bounds when the file has none.
pub(crate) fn scene_camera(
    desc: Option<caustica_core::scene::CameraDesc>,
    source: &std::path::Path,
    run: &RunFile,
    geometry: &RenderScene,
    width: u32,
    height: u32,
) -> Result<Camera> {
    let camera_desc = match desc {
        Some(c) => c,
        None => {
            let (min, max) = geometry.geometry.bounds();
            // With both eye and target given the user has placed the camera: nothing to warn about.
            if run.camera.eye.is_none() || run.camera.target.is_none() {
                tracing::warn!(
                    "{}: no camera in the file; framing the scene's bounds in a three-quarter view (from +Z turned \
                 45° towards +X, 30° above the horizon) with a 45° vertical field of view; set [camera] \
                 eye/target/yfov_degrees or --eye/--target/--yfov",
                    source.display()
                );
            }
            // Frame for the field of view the camera will have, so that a narrower one does not crop.
            let yfov = run.camera.yfov_degrees.filter(|d| *d > 0.0 && *d < 180.0).unwrap_or(45.0);
            Camera::framing(min, max, width as f32 / height as f32, yfov.to_radians())
        }
    };
    // Name the scene file: a bad camera override is the user's to fix there.
    Camera::new(&camera_desc, &run.camera, width, height, run.film.filter).map_err(|e| Error::InvalidScene {
        path: source.to_path_buf(),
        object: "camera".into(),
        problem: e.to_string(),
    })
}

/// A World holding the scene's resources (`SceneResource`, `CameraResource`, `RenderConfig`,
/// `RenderStats`, `PassRange`) and no entities or film yet ([`add_films`], once the memory the
/// render will hold is checked with the scene built), and what the scene uses.
pub fn scene_world(scene: Scene, run: &RunFile) -> Result<(World, SceneFeatures)> {
    scene_world_dynamic(scene, run, &[])
}

/// As [`scene_world`], the meshes `dynamic` marks (by index) in the geometry's dynamic set, which
/// a frame rebuilds alone.
pub fn scene_world_dynamic(scene: Scene, run: &RunFile, dynamic: &[bool]) -> Result<(World, SceneFeatures)> {
    let settings = &run.render;
    let (width, height) = resolution(&scene, run)?;
    let (camera_desc, source) = (scene.camera.clone(), scene.source.clone());
    let render_scene = RenderScene::from_scene_dynamic(scene, settings.light_selection, dynamic);
    let camera = scene_camera(camera_desc, &source, run, &render_scene, width, height)?;
    let features = SceneFeatures::of(&camera, &render_scene);
    let mut world = World::new();
    world.insert_resource(RenderConfig {
        integrator: settings.integrator,
        seed: settings.seed,
        sampler: settings.sampler,
        limits: PathLimits { max_depth: settings.max_depth.unwrap_or(u32::MAX), rr_depth: settings.rr_depth },
        pass_time: None,
        strata: 1,
    });
    world.insert_resource(CameraResource(camera));
    world.insert_resource(SceneResource::new(render_scene));
    world.insert_resource(RenderStats::default());
    world.insert_resource(PassRange::default());
    Ok((world, features))
}

/// Add the camera's film, and the feature images' film when `run` asks for them.
pub fn add_films(world: &mut World, run: &RunFile) -> Result<()> {
    let (width, height) = {
        let camera = world.resource::<CameraResource>();
        (camera.width, camera.height)
    };
    let budget = run.memory_budget_bytes();
    world.insert_resource(FilmResource::new(Film::try_new(width, height, budget)?));
    if run.film.aovs.iter().any(|aov| aov.needs_surface()) {
        world.insert_resource(AovFilmResource::new(AovFilm::try_new(width, height, budget)?));
    }
    Ok(())
}

/// Bytes an ECS entity of components of `component_bytes` costs in bevy's tables: each component,
/// the two change ticks bevy keeps beside every component, the table's `Entity` column, and the
/// entity's place in the World's index (24 bytes a slot, grown by doubling: counted twice).
pub fn entity_bytes(component_bytes: &[usize]) -> u64 {
    const TICKS: usize = 2 * size_of::<u32>();
    const INDEX_SLOT: usize = 24;
    let components: usize = component_bytes.iter().map(|b| b + TICKS).sum();
    (components + size_of::<bevy_ecs::entity::Entity>() + 2 * INDEX_SLOT) as u64
}
