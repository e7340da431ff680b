//! Integrators as schedule builders: each only places systems into the `PassSystems` stages.

pub mod appm;
pub mod cppm;
pub mod path;
pub mod photon_map;
pub mod ppm;
pub mod sppm;
