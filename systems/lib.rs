//! # Caustica
//!
//! A physically based offline renderer whose light paths are entities of a bevy_ecs World, advanced
//! a bounce at a time by staged systems:
//!
//! ```text
//! scene (glTF + run file) ─load─▶ World resources: SceneResource (BVH, lights, materials), camera, film
//!   integrator = a descriptor (integrators::of: unit, split rule, settings, checks) whose Plan is
//!                the phases of a pass, each a Schedule of the stages below, run once or until idle
//!   Emit ─▶ Trace ─▶ Scatter (kernel: emission, NEE, BSDF continuation, Russian roulette) ─▶ Shadow ─▶ Gather ─▶ Update
//!   entities: camera paths, photons, progressive hit points, spawned once and reused
//! ```
//!
//! The physics is `caustica-core` (`src/`), re-exported here so that a host needs one crate; this
//! crate (`systems/`) is the ECS layer and the driver; the `caustica` command (`cli/`) parses and
//! prints. Neither library names the command, and the core names neither.
//!
//! ## Running any integrator
//! ```
//! use caustica::Renderer;
//! use caustica::scene::load;
//!
//! caustica::driver::init_thread_pools(Some(1));
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf");
//! let (scene, mut run) = load(std::path::Path::new(path)).unwrap();
//! run.render.integrator = caustica::scene::IntegratorKind::Sppm;
//! (run.progressive.passes, run.progressive.photons_per_pass) = (2, 1000);
//! (run.film.width, run.film.height) = (Some(16), Some(16));
//! let mut renderer = Renderer::new(scene, &run).unwrap();
//! let report = renderer.run(None, |_| {});
//! assert_eq!(report.done, 2.0);
//! assert!(renderer.image().mean().is_finite());
//! ```
//!
//! ## Embedding in a host's World and Schedule
//! The World is the host's to extend: its resources go in `renderer.world`. `pt`, `pt-naive` and `lt` run
//! their bounces on shards, a World per worker with a chunk of the camera paths each
//! ([`shards`]): a host's system given to `Phase::add_path_systems` runs in every shard, every
//! bounce, on every path of its chunk, placed by the stage sets; a resource it writes there is each
//! shard's own, folded into the main World's after every round by a [`shards::ShardLink`]. (See
//! `examples/simulation.rs`, which also moves an object between frames.)
//! ```
//! use bevy_ecs::prelude::*;
//! use caustica::camera_paths::PathQueues;
//! use caustica::shards::ShardLink;
//! use caustica::{PassSystems, Renderer};
//!
//! /// Camera paths that ended, counted by the host.
//! #[derive(Resource, Default)]
//! struct Ended(u64);
//!
//! fn count(mut ended: ResMut<Ended>, queues: Res<PathQueues>) {
//!     ended.0 += queues.finished.len() as u64;
//! }
//!
//! caustica::driver::init_thread_pools(Some(1));
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.gltf");
//! let (scene, mut run) = caustica::scene::load(std::path::Path::new(path)).unwrap();
//! (run.render.spp, run.film.width, run.film.height) = (1, Some(16), Some(16));
//! let mut renderer = Renderer::new(scene, &run).unwrap();
//! renderer.world.insert_resource(Ended::default());
//! let bounce = renderer.plan.phase_mut("bounce").unwrap();
//! bounce.add_path_systems(|schedule| {
//!     schedule.add_systems(count.before(PassSystems::Gather).after(PassSystems::Shadow));
//! });
//! bounce.add_link(ShardLink::merge::<Ended>(|total, shard| total.0 += shard.0));
//! renderer.run(None, |_| {});
//! assert_eq!(renderer.world.resource::<Ended>().0, 16 * 16);
//! ```
//!
//! ## Systems
//! Every system, by stage (one file per stage; the kernel functions they call are in
//! `caustica_core::kernel`):
//!
//! | stage | file | system | entities | reads | writes |
//! |---|---|---|---|---|---|
//! | `Emit` | `camera_paths/emit.rs` | `emit_paths<LENS, MOTION>` (`pt`, `pt-naive`, on shards) | free rows | `CameraResource`, `RenderConfig`, `Workload` | `PathRay`, `PathSample`, `PathSampler`, `PathThroughput`, `PathQueues` |
//! | `Trace` | `camera_paths/trace.rs` | `trace_paths` (on shards) | active rows | `SceneResource`, `PathRay` | `PathHit` |
//! | `Scatter` | `camera_paths/scatter.rs` | `scatter_paths<NEE>` (on shards; lanes for plain Lambertian vertices) | active rows | `PathHit`, `PathSampler`, `SceneResource` | `PathRay`, `PathThroughput`, `PathShadow`, `PathQueues` |
//! | `Shadow` | `camera_paths/shadow.rs` | `trace_shadow_rays` (on shards) | shadow rows | `PathShadow` | `PathThroughput` |
//! | `Gather` | `camera_paths/splat.rs` | `splat_paths` (on shards) | finished rows | `PathSample`, `PathThroughput` | `FilmResource`, `RenderStats`, `PathQueues` |
//! | `Emit` | `emit.rs` | `emit_camera_paths<LENS, MOTION>` (the other camera-path integrators) | camera paths | `CameraResource`, `RenderConfig` | `PathRay`, `PathState` |
//! | `Emit` | `light_subpaths/photons.rs` | `emit_photon_subpaths` (`pm`, progressive; on shards) | free rows | `SceneResource`, `PhotonWork`, `SubpathHandout` | `SubpathRay`, `SubpathPower`, `SubpathSampler`, `SubpathQueues` |
//! | `Trace` | `trace.rs` | `trace_paths` | camera paths | `SceneResource`, `PathRay` | `PathHit` |
//! | `Trace` | `light_subpaths/trace.rs` | `trace_subpaths` (photons, `lt`; on shards) | active rows | `SceneResource`, `SubpathRay` | `SubpathHit` |
//! | `Scatter` | `scatter.rs` | `scatter_photon_mapped` (`pm`) | camera paths | `PathHit`, `PhotonMaps` | `PathRay`, `PathState`, `ShadowRay` |
//! | `Scatter` | `scatter.rs` | `scatter_to_visible_points<NEE>` (`ppm`…) | hit points | `PathHit` | `HitPoint`, `PathRay`, `PathState`, `ShadowRay` |
//! | `Scatter` | `light_subpaths/photons.rs` | `scatter_photon_subpaths` (`pm`, progressive; on shards) | active rows | `SubpathHit`, `SubpathSampler`, `PhotonWork` | `SubpathRay`, `SubpathPower`, `SubpathQueues`, `PhotonTrail` |
//! | `Shadow` | `trace.rs` | `trace_shadow_rays` | camera paths | `ShadowRay` | `PathState` |
//! | `Gather` | `gather.rs` | `splat_paths_to_film` | camera paths | `PathState`, `PassRange` | `FilmResource`, `RenderStats`, `Workload` |
//! | `Gather` | `gather.rs` | `learn_light_visibility` (visibility selection) | camera paths | `ShadowRay` | `SceneResource` |
//! | `Gather` | `gather.rs` | `build_pass_photon_map` | | `PhotonBuffer` | `PassPhotons` |
//! | `Gather` | `gather.rs` | `gather_photons_into_hit_points` (`_into_chi2_cells`, `_with_laplacian`) | hit points | `PassPhotons` | `HitPoint` (`Chi2Cells`, `AdaptiveStats`) |
//! | `Update` | `update.rs` | `update_hit_point_radii`, `update_radii_by_chi2`, `update_radii_adaptive` | hit points | `ProgressiveConfig` | `HitPoint` |
//! | `Gather` | `integrators/pppm.rs` | `set_global_radius` (`pppm`, before the gather) | hit points | `ProgressiveConfig` | `HitPoint::r2` |
//! | `Update` | `integrators/pppm.rs` | `add_pass_estimates_to_film` (`pppm`) | hit points | `PathState` | `FilmResource`, `HitPoint` |
//! | pass edges | `passes.rs` | `select_unconverged_pixels` (adaptive sampling, after each pass) | | `PassRange`, `FilmResource` | `AdaptiveSampling` |
//! | pass edges | `passes.rs` | `hand_out_samples`, `finish_light_learning`, `begin_progressive_pass`, `begin_camera_pass`, `cap_initial_radius`, `begin_photon_map`, `finish_photon_map` | | `PassRange` | see the file |
//! | photon pass edges | `light_subpaths/photons.rs` | `begin_photon_subpaths`, `order_photon_deposits` (the pass's deposits in a thread-independent order) | | `PhotonWork`, `PhotonTrail` | `SubpathHandout`, `PhotonBuffer` |
//!
//! Entities are spawned once and reused: a camera path that ends takes the next work item (pixel,
//! sample) (Laine, Karras & Aila 2013), and state lives in component fields, so no entity changes
//! archetype while rendering.

pub mod aov;
pub mod bidirectional;
pub mod camera_paths;
pub mod components;
pub mod driver;
pub mod emit;
pub mod gather;
pub mod hit_point_state;
pub mod integrators;
pub mod light_paths;
pub mod light_subpaths;
pub mod passes;
pub mod plan;
pub mod report;
pub mod resources;
pub mod scatter;
pub mod shards;
pub mod stages;
pub mod trace;
pub mod update;
pub mod workload;
pub mod world;

// The physics, re-exported so that a host needs one crate: `caustica::scene::load`, `caustica::film::Image`.
pub use caustica_core::{
    Choice, Error, RenderScene, Result, camera, choice, density, error, files, film, geometry, kernel,
    lights, materials, memory, photon, render_scene, sampling, scene, test_scenes,
};
pub use driver::{Progress, Renderer};
pub use report::Report;
pub use stages::PassSystems;
