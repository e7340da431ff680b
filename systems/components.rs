//! Path components, split by who reads them: `trace` touches only `PathRay`/`PathHit`.

use crate::geometry::{Ray, bvh::Hit};
use bevy_ecs::component::Component;
use glam::Vec3;

/// The ray a path will trace next (hot: read by `trace_paths`).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PathRay(pub Ray);

/// The closest hit of the last trace.
#[derive(Component, Clone, Copy, Debug)]
pub struct PathHit(pub Hit);

impl Default for PathHit {
    fn default() -> Self {
        Self(Hit::MISS)
    }
}

/// A shadow ray from next-event estimation and what it adds if nothing blocks it.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ShadowRay {
    /// The segment to test (origin to light point, `t_max` just short of 1).
    pub ray: Ray,
    /// β · f · |cos| · Le · w / pdf, added to the path radiance when unoccluded.
    pub contribution: Vec3,
    /// Whether the ray still needs tracing.
    pub pending: bool,
}

/// Where a path is in its life.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PathStatus {
    /// Needs a camera ray for its next sample.
    #[default]
    NeedsCamera,
    /// Bouncing.
    Active,
    /// Ended; radiance waits to be splatted.
    Finished,
    /// No samples left for this entity.
    Idle,
}

/// Per-path state read by `scatter` and `gather` (cold for `trace`).
///
/// Names follow pbrt-v4: `beta` is the path throughput, `l` the radiance gathered so far,
/// `eta_scale` the product of squared relative IORs crossed (for Russian roulette).
#[derive(Component, Clone, Copy, Debug)]
pub struct PathState {
    /// Pixel index (row-major from top-left).
    pub pixel: u32,
    /// Sample index within the pixel.
    pub sample: u32,
    /// Bounces so far.
    pub depth: u32,
    /// Throughput.
    pub beta: Vec3,
    /// Radiance so far.
    pub l: Vec3,
    /// Product of squared relative IORs along the path.
    pub eta_scale: f32,
    /// BSDF pdf of the last bounce (for MIS when the next hit is an emitter).
    pub prev_pdf: f32,
    /// Position of the last scattering vertex.
    pub prev_p: Vec3,
    /// Whether the last bounce was a delta lobe (no MIS, emission counted fully).
    pub specular_bounce: bool,
    /// Photon mapping: the path is a final-gather ray that ends at the next diffuse hit.
    pub gathering: bool,
    /// Life-cycle state.
    pub status: PathStatus,
    /// Rays traced by this path since the last splat (for statistics, summed in `gather`).
    pub rays: u32,
    /// Shadow rays traced since the last splat.
    pub shadow_rays: u32,
    /// Photon-map lookups since the last splat.
    pub lookups: u32,
}

impl PathState {
    /// A fresh path for `pixel`, sample `sample`, waiting for its camera ray.
    pub fn new(pixel: u32, sample: u32) -> Self {
        Self {
            pixel,
            sample,
            depth: 0,
            beta: Vec3::ONE,
            l: Vec3::ZERO,
            eta_scale: 1.0,
            prev_pdf: 0.0,
            prev_p: Vec3::ZERO,
            specular_bounce: false,
            gathering: false,
            status: PathStatus::NeedsCamera,
            rays: 0,
            shadow_rays: 0,
            lookups: 0,
        }
    }
}

/// The ray a photon will trace next.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PhotonRay(pub Ray);

/// The closest hit of a photon's last trace.
#[derive(Component, Clone, Copy, Debug)]
pub struct PhotonHit(pub Hit);

impl Default for PhotonHit {
    fn default() -> Self {
        Self(Hit::MISS)
    }
}

/// A photon in flight. `status` reuses the path life cycle (`NeedsCamera` = needs emitting).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PhotonState {
    /// Photon number within its pass (selects its random numbers).
    pub index: u32,
    /// Power carried, per channel.
    pub power: Vec3,
    /// Bounces so far.
    pub depth: u32,
    /// Whether every bounce so far was specular (a caustic path L S* while it lasts).
    pub specular_only: bool,
    /// Life-cycle state.
    pub status: PathStatus,
    /// A photon left at this bounce's hit, waiting for `store_photons`.
    pub deposit: Option<crate::photon::Photon>,
    /// Rays traced since the last store (statistics).
    pub bounces: u32,
    /// Russian-roulette terminations since the last store (statistics).
    pub roulette_kills: u32,
}
