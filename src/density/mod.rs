//! Density estimation (Silverman 1986): kernels, histogram, kernel, nearest-neighbour and variable
//! kernel estimates, bandwidth rules, and reading a sample from a text file. Photon mapping uses the
//! disc kernels ([`Kernel::k2`]) for its radiance estimate.

pub mod bandwidth;
pub mod data;
pub mod estimators;
pub mod kernels;

pub use estimators::{Histogram, KernelEstimate, KnnEstimate, Sample, VariableKernel};
pub use kernels::Kernel;
