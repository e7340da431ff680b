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
//!
//! The ECS layer: components, resources and the staged systems that move paths through a frame.
//!
//! One run of the schedule advances every path of the wavefront by one bounce:
//!
//! | `PassSystems::` | file | systems | reads | writes |
//! |---|---|---|---|---|
//! | `Emit` | `emit.rs` | `emit_camera_paths` | `Camera`, `RenderConfig` | `PathRay`, `PathState` (new sample) |
//! | `Trace` | `trace.rs` | `trace_paths` | `SceneGeometry`, `PathRay` | `PathHit` |
//! | `Scatter` | `scatter.rs` | `scatter_paths` | `PathHit`, `SceneGeometry` | `PathRay`, `PathState`, `ShadowRay` |
//! | `Shadow` | `trace.rs` | `trace_shadow_rays` | `ShadowRay` | `PathState::l` |
//! | `Gather` | `gather.rs` | `splat_paths_to_film` | finished `PathState`s | `Film`, `RenderStats` |
//! | `Gather` | `gather.rs` | `build_pass_photon_map`, `gather_photons_into_hit_points` | `PhotonBuffer`, `HitPoint` | `PassPhotons`, `HitPoint::m`, `phi` |
//! | `Update` | `radius.rs` | `update_hit_point_radii` (and the `appm`/`cppm` rules) | `HitPoint` | `HitPoint::n`, `r2`, `tau` |
//!
//! Photon passes (`photons.rs`) and the camera pass of progressive photon mapping
//! (`visible_points.rs`) use the same stages over their own entities; `progressive.rs` drives the
//! passes of `ppm`, `sppm`, `appm` and `cppm`.
//!
//! Paths are entities of a wavefront spawned once; a path that ends takes the next work item (pixel, sample)
//! (Laine, Karras & Aila 2013), and its state lives in component fields, so no entity
//! changes archetype while rendering.

// The physics, re-exported so that a host needs one crate: `caustica::scene::load`, `caustica::film::Image`.
pub use caustica_core::{
    Choice, Error, Result, camera, choice, density, error, film, geometry, lights, materials, photon, sampling,
    scene, test_scenes,
};

pub mod components;
pub mod emit;
pub mod gather;
pub mod integrators;
pub mod photon_estimate;
pub mod photons;
pub mod progressive;
pub mod radius;
pub mod render;
pub mod resources;
pub mod scatter;
pub mod trace;
pub mod visible_points;

use bevy_ecs::schedule::SystemSet;

/// The stages of one bounce, in order. Integrators place their systems into these sets.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PassSystems {
    /// Start new camera paths where the previous ones ended.
    Emit,
    /// Closest-hit queries for every active path.
    Trace,
    /// Shade hits: emission, light sampling (NEE), BSDF sampling, Russian roulette.
    Scatter,
    /// Any-hit queries for the shadow rays of this bounce.
    Shadow,
    /// Splat finished paths onto the film; store photons; gather photons into hit points.
    Gather,
    /// Fold a pass's photons into the hit points' statistics: radius and flux (progressive photon
    /// mapping).
    Update,
}
