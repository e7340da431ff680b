//! What a render reports: one type for every integrator, which the command prints and a host reads.

use crate::resources::{PhotonMapSummary, RenderStats};
use caustica_core::photon::PhotonMapKind;
use caustica_core::scene::IntegratorKind;

/// What a render's progress is counted in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Samples per pixel (`pt`, `pt-naive`, `pm`): a pass renders a range of them.
    Samples,
    /// Photon passes (`ppm`, `sppm`, `appm`, `cppm`): a pass is one.
    Passes,
}

impl Unit {
    /// The unit's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Samples => "spp",
            Self::Passes => "passes",
        }
    }
}

/// Why a render ended before its target (here rather than in the driver, which reports it, so that
/// the report names nothing of the driver's: no import circle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The time limit passed.
    TimeLimit,
    /// The interrupt flag was raised (Ctrl-C, SIGTERM, a host).
    Interrupted,
}

/// Time spent in one phase.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseTime {
    /// The phase's name.
    pub name: &'static str,
    /// Seconds, all passes.
    pub seconds: f64,
    /// Runs of its schedule.
    pub runs: u64,
}

/// The photon side of a render.
#[derive(Clone, Debug, Default)]
pub struct PhotonSummary {
    /// Photons emitted.
    pub emitted: u64,
    /// Photons stored.
    pub stored: u64,
    /// Photon rays traced.
    pub traced: u64,
    /// Photons ended by Russian roulette.
    pub roulette_kills: u64,
    /// Photon contributions to hit points dropped for being NaN or infinite.
    pub dropped: u64,
    /// The first pass that dropped one.
    pub first_dropped_pass: Option<u32>,
    /// `pm`'s maps.
    pub maps: Vec<PhotonMapSummary>,
}

/// The hit points of a progressive render.
#[derive(Clone, Copy, Debug, Default)]
pub struct HitPointSummary {
    /// Hit points.
    pub count: u64,
    /// Per pixel.
    pub per_pixel: u32,
    /// Bytes each takes with its camera path.
    pub bytes_each: u64,
    /// Mean gather radius.
    pub mean_radius: f32,
    /// The radius rule's initial radius.
    pub initial_radius: f32,
}

/// A render's report.
#[derive(Clone, Debug)]
pub struct Report {
    /// Which integrator.
    pub integrator: IntegratorKind,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// What progress is counted in.
    pub unit: Unit,
    /// Progress reached: samples per pixel (fractional when a time limit cut a pass), or passes.
    pub done: f64,
    /// Progress aimed at.
    pub target: u32,
    /// The sampler seed.
    pub seed: u64,
    /// Seconds spent rendering.
    pub seconds: f64,
    /// Where the time went.
    pub phases: Vec<PhaseTime>,
    /// Camera-path counters.
    pub paths: RenderStats,
    /// Camera-path entities.
    pub wavefront: u32,
    /// Photons, for the integrators that trace them.
    pub photons: Option<PhotonSummary>,
    /// Hit points, for the progressive integrators.
    pub hit_points: Option<HitPointSummary>,
    /// Why the render stopped before its target, if it did.
    pub stopped_by: Option<StopReason>,
    /// Adaptive sampling's outcome, when it was on.
    pub adaptive: Option<AdaptiveSummary>,
    /// Lines of the integrator's own (`lt`'s connections), each `(label, text)`.
    pub notes: Vec<(&'static str, String)>,
}

/// Where adaptive sampling sent the samples, and the error it estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSummary {
    /// The noise threshold.
    pub threshold: f64,
    /// Samples every pixel took first.
    pub min_spp: u32,
    /// Fewest samples a pixel took.
    pub fewest: u32,
    /// Most samples a pixel took.
    pub most: u32,
    /// Pixels under the threshold, and the image's estimated relMSE.
    pub estimate: caustica_core::film::adaptive::ErrorEstimate,
}

impl Report {
    /// Camera samples splatted per second.
    pub fn samples_per_second(&self) -> f64 {
        self.paths.samples as f64 / self.seconds.max(1e-9)
    }

    /// Rays (closest-hit and shadow) per second.
    pub fn rays_per_second(&self) -> f64 {
        (self.paths.rays + self.paths.shadow_rays) as f64 / self.seconds.max(1e-9)
    }

    /// Seconds spent in phases whose name starts with `prefix`.
    pub fn phase_seconds(&self, prefix: &str) -> f64 {
        self.phases.iter().filter(|p| p.name.starts_with(prefix)).map(|p| p.seconds).sum()
    }

    /// The name of a photon map kind in the report.
    pub fn map_name(kind: PhotonMapKind) -> &'static str {
        match kind {
            PhotonMapKind::Global => "global",
            PhotonMapKind::Indirect => "indirect",
            PhotonMapKind::Caustic => "caustic",
            PhotonMapKind::Bounced => "bounced",
        }
    }
}
