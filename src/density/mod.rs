//! Density estimation: the kernels that turn photons near a point into a density.

pub mod kernels;

pub use kernels::Kernel;
