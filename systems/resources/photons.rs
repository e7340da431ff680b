//! The photon passes' resources: the pass that is running, its deposits and counters, and `pm`'s
//! maps.

use super::RenderConfig;
use bevy_ecs::resource::Resource;
use caustica_core::kernel::photon::PhotonPassSettings;
use caustica_core::photon::{PhotonMap, PhotonMapKind};
use std::sync::atomic::AtomicU64;

/// The photons of the pass that is running and how they are handed out.
#[derive(Resource, Clone, Copy, Debug)]
pub struct PhotonWork {
    /// Which photons are kept, how many are emitted, and their limits.
    pub settings: PhotonPassSettings,
    /// Sampler seed.
    pub seed: u64,
    /// How the photons' numbers are drawn.
    pub sampler: caustica_core::sampling::SamplerKind,
    /// Whether anything moves (photons then draw a shutter time).
    pub motion: bool,
    /// One shutter time for the whole pass (stochastic PPM: the camera pass uses the same one).
    pub time: Option<f32>,
    /// Photon pass number (progressive photon mapping): selects the pass's random numbers.
    pub pass: u32,
}

impl PhotonWork {
    /// A pass of `total` photons kept by `kind`, none handed out yet, with the path settings of
    /// `config` (seed, depths); `motion` says whether photons draw a shutter time.
    pub fn new(kind: PhotonMapKind, total: u32, config: &RenderConfig, motion: bool) -> Self {
        let settings = PhotonPassSettings {
            kind,
            total,
            max_depth: config.limits.max_depth,
            rr_depth: config.limits.rr_depth,
        };
        Self { settings, seed: config.seed, sampler: config.sampler, motion, time: None, pass: 0 }
    }
}

/// Photons deposited by the running pass, in a thread-independent order.
#[derive(Resource, Clone, Debug, Default)]
pub struct PhotonBuffer {
    /// The deposits.
    pub photons: Vec<caustica_core::photon::Photon>,
}

/// Counters of the photon passes.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct PhotonStats {
    /// Photons emitted, all passes.
    pub emitted: u64,
    /// Photons stored, all passes.
    pub stored: u64,
    /// Photon rays traced.
    pub traced: u64,
    /// Photons ended by Russian roulette.
    pub roulette_kills: u64,
}

/// One photon map of a `pm` render, as the report shows it.
#[derive(Clone, Copy, Debug)]
pub struct PhotonMapSummary {
    /// Which map.
    pub kind: PhotonMapKind,
    /// Photons emitted for it.
    pub emitted: u32,
    /// Photons it holds.
    pub stored: usize,
    /// Bytes it holds.
    pub bytes: usize,
}

/// The photon maps a `pm` render looks up, and how it looks them up.
#[derive(Resource, Debug, Default)]
pub struct PhotonMaps {
    /// Every photon at a non-specular hit (for final gathering), when final gathering is on.
    pub global: Option<PhotonMap>,
    /// Photons after a diffuse bounce (looked up directly), when final gathering is off.
    pub indirect: Option<PhotonMap>,
    /// L S+ D photons; absent when the scene has no specular surface.
    pub caustic: Option<PhotonMap>,
    /// Photons per estimate.
    pub k: usize,
    /// Largest squared gather radius.
    pub max_radius2: f32,
    /// Density-estimation kernel over the gather disc.
    pub kernel: caustica_core::density::kernels::Kernel,
    /// Whether the first diffuse hit shoots a final-gather ray.
    pub final_gather: bool,
    /// The maps built, in order.
    pub built: Vec<PhotonMapSummary>,
}

impl PhotonMaps {
    /// Room a k-nearest query's result needs: `k`, or the largest map's photons where that is fewer
    /// (a query finds no more than a map holds; `k` is the user's word, up to 2^32).
    pub fn neighbors_room(&self) -> usize {
        let largest = [&self.global, &self.indirect, &self.caustic]
            .iter()
            .filter_map(|m| m.as_ref())
            .map(|m| m.len())
            .max();
        self.k.min(largest.unwrap_or(0))
    }
}

/// The photons of the running progressive pass, as a kd-tree for the hit points' radius queries.
#[derive(Resource, Debug)]
pub struct PassPhotons {
    /// This pass's photons.
    pub map: PhotonMap,
    /// Photon contributions that were NaN or infinite, dropped before they reached a hit point (all
    /// passes). Incremented only on that rare event, so the atomic costs nothing in the gather loop.
    pub dropped: AtomicU64,
    /// The first pass that dropped one (`u32::MAX`: none).
    pub first_dropped_pass: std::sync::atomic::AtomicU32,
}

impl Default for PassPhotons {
    fn default() -> Self {
        Self {
            map: PhotonMap::default(),
            dropped: AtomicU64::new(0),
            first_dropped_pass: std::sync::atomic::AtomicU32::new(u32::MAX),
        }
    }
}
