//! Photon storage for photon mapping: compact photon records, a kd-tree over them, and the
//! statistics of progressive photon mapping.

pub mod kdtree;
pub mod progressive;
pub mod record;

pub use kdtree::{Neighbors, PhotonMap};
pub use record::Photon;
