//! # caustica-core
//!
//! The physics of Caustica as plain data and pure functions: counter-based sampling, geometry and
//! the obvhs BVH, materials and their BSDFs, lights and light selection, the camera, the film, scene
//! loading (glTF and run files), photon maps and density estimation, and the camera-vertex kernel
//! that every integrator shares.
//!
//! This crate names neither the ECS layer nor the command line: the `caustica` crate (`systems/`)
//! puts these functions into bevy_ecs systems, and the `caustica` command (`cli/`) parses and
//! prints. The dependency only goes that way, so the compiler keeps the layering.

pub mod camera;
pub mod choice;
pub mod density;
pub mod error;
pub mod files;
pub mod film;
pub mod geometry;
pub mod guiding;
pub mod kernel;
pub mod lights;
pub mod materials;
pub mod memory;
pub mod photon;
pub mod render_scene;
pub mod sampling;
pub mod scene;

#[doc(hidden)]
pub mod test_scenes;

pub use choice::Choice;
pub use error::{Error, Result};
pub use render_scene::RenderScene;
