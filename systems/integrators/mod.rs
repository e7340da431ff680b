//! Integrators as schedule builders: each only places systems into the `PassSystems` stages.

pub mod path;
pub mod photon_map;
