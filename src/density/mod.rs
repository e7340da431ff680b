//! Density estimation (Silverman 1986): kernels, histogram, kernel, nearest-neighbour and variable
//! kernel estimates, bandwidth rules, and a plot of an estimate over its data. Photon mapping uses the
//! disc kernels ([`Kernel::k2`]) for its radiance estimate.

pub mod bandwidth;
pub mod estimators;
pub mod kernels;
pub mod plot;

pub use estimators::{Histogram, KernelEstimate, KnnEstimate, Sample, VariableKernel};
pub use kernels::Kernel;
