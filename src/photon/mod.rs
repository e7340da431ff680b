//! Photon storage for photon mapping: compact photon records, a kd-tree over them, and the
//! statistics of progressive photon mapping.

pub mod estimate;
pub mod hash_grid;
pub mod kdtree;
pub mod progressive;
pub mod record;
pub mod visible_point;

pub use kdtree::{Neighbors, PhotonMap};
pub use record::Photon;

/// Which photons a pass keeps (Jensen 2001, §7.2, in path notation from the light).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotonMapKind {
    /// Every photon at a non-specular surface, L(S|D)*D: looked up by final-gather rays.
    Global,
    /// Photons after at least one diffuse bounce, L(S|D)*D(S|D)*D minus caustics: looked up directly
    /// at the first diffuse camera hit, where direct light and caustics come from elsewhere.
    Indirect,
    /// L S+ D: caustics, looked up directly at every diffuse camera hit.
    Caustic,
    /// Every photon after its first bounce, L(S|D)+D: progressive photon mapping with next-event
    /// estimation, where direct light comes from light sampling instead.
    Bounced,
}
