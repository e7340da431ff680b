//! Photon storage for photon mapping: compact photon records and a kd-tree over them.

pub mod kdtree;
pub mod record;

pub use kdtree::{Neighbors, PhotonMap};
pub use record::Photon;
