//! Random numbers and the warps that turn them into directions and points.
//!
//! Every random number is a pure function of (seed, pixel, sample index, dimension), so images do not
//! depend on how work is split between threads.

pub mod chi2;
pub mod distribution;
pub mod lane_math;
pub mod net;
pub mod rng;
pub mod sobol;
pub mod spherical;
pub mod warp;

pub use rng::{Sampler, SamplerKind};

/// Largest f32 below one: keeps remapped random numbers in [0, 1).
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;
