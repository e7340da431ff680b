//! The integration tests, one binary: each file of tests/ is a module of this crate, so the
//! dependency tree is linked once rather than once a file (36 binaries took 13 GB of target/debug
//! and most of a cold `cargo test`). Run one file's tests with its module as a filter:
//! `cargo test --test integration fuzz::`.

mod adaptive;
mod albedo;
mod animation;
mod aov;
mod bench;
mod bidirectional;
mod camera;
mod caustics;
mod cli;
mod common;
mod convergence;
mod corpus;
mod denoise;
mod density;
mod determinism;
mod docs;
mod environment;
mod faults;
mod finite;
mod furnace;
mod fuzz;
mod fuzz_cli;
mod fuzz_files;
mod guiding;
mod hard_cases;
mod host;
mod light_selection;
mod light_tracing;
mod loader;
mod memory;
mod parts;
mod photon_mapping;
mod photon_references;
mod profile;
mod progressive;
mod punctual;
mod resume;
mod sampler_dimensions;
mod schedule_order;
mod textures;
mod volume;
