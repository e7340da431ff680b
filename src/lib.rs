//! # Caustica
//!
//! A physically based offline renderer whose paths are entities of a bevy_ecs World, advanced one
//! bounce per Schedule run by staged systems:
//!
//! ```text
//! scene (glTF + run file) ─load─▶ resources: SceneGeometry (obvhs BVH, lights, materials), Camera, Film
//!   Schedule: Emit ─▶ Trace ─▶ Scatter (emission, NEE, BSDF sample, Russian roulette) ─▶ Shadow ─▶ Gather
//!   entities: one wavefront of paths (PathRay, PathHit, PathState, ShadowRay), reused until done
//! ```
//!
//! `src/` holds the physics as plain data and pure functions; `systems/` is the ECS layer.
//!
//! ## Embedding in a host World and Schedule
//! ```
//! use caustica::scene::{load, RunFile};
//! use caustica::systems::render::{init_thread_pools, prepare};
//!
//! init_thread_pools(Some(1));
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf");
//! let (scene, mut run): (_, RunFile) = load(std::path::Path::new(path)).unwrap();
//! run.render.spp = 1;
//! run.film.width = Some(16);
//! run.film.height = Some(16);
//! let mut renderer = prepare(scene, &run).unwrap();
//! // The host owns the loop: each run advances every path by one bounce.
//! while {
//!     renderer.schedule.run(&mut renderer.world);
//!     renderer.world.resource::<caustica::systems::resources::RenderStats>().active_paths > 0
//! } {}
//! assert!(renderer.image().mean().is_finite());
//! ```

pub mod bench;
pub mod camera;
pub mod cli;
pub mod density;
pub mod error;
pub mod film;
pub mod geometry;
pub mod lights;
pub mod materials;
pub mod photon;
pub mod profile;
pub mod sampling;
pub mod scene;
#[path = "../systems/mod.rs"]
pub mod systems;

#[doc(hidden)]
pub mod test_scenes;

pub use error::{Error, Result};
