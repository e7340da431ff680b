//! Resources shared by the systems: the scene, the settings of this render, the film, the work to
//! hand out, and the counters.

use bevy_ecs::resource::Resource;
use caustica_core::camera::Camera;
use caustica_core::film::Film;
use caustica_core::kernel::PathLimits;
use caustica_core::kernel::photon::PhotonPassSettings;
use caustica_core::photon::progressive::RadiusRule;
use caustica_core::photon::{PhotonMap, PhotonMapKind};
use caustica_core::render_scene::RenderScene;
use caustica_core::scene::IntegratorKind;
use std::sync::atomic::AtomicU64;

/// A core type as a resource, read through `Deref` (the core names no ECS).
macro_rules! resource_of {
    ($(#[$doc:meta])* $name:ident($inner:ty)) => {
        $(#[$doc])*
        #[derive(Resource, Clone, Debug)]
        pub struct $name(pub $inner);

        impl std::ops::Deref for $name {
            type Target = $inner;
            fn deref(&self) -> &$inner {
                &self.0
            }
        }

        impl std::ops::DerefMut for $name {
            fn deref_mut(&mut self) -> &mut $inner {
                &mut self.0
            }
        }
    };
}

resource_of!(
    /// The scene the systems trace and shade: BVHs, lights, materials, textures.
    SceneResource(RenderScene)
);
resource_of!(
    /// The camera that `emit` generates rays from.
    CameraResource(Camera)
);
resource_of!(
    /// The film that `gather` splats finished samples onto.
    FilmResource(Film)
);
resource_of!(
    /// The feature images' film, present only when the run asks for them (`film.aovs`).
    AovFilmResource(caustica_core::film::aov::AovFilm)
);

/// Settings of the camera paths.
#[derive(Resource, Clone, Debug)]
pub struct RenderConfig {
    /// Which integrator (for messages).
    pub integrator: IntegratorKind,
    /// Sampler seed.
    pub seed: u64,
    /// How sample numbers are drawn.
    pub sampler: caustica_core::sampling::SamplerKind,
    /// Maximum depth and Russian roulette.
    pub limits: PathLimits,
    /// One shutter time for every camera ray of this pass (stochastic PPM), instead of one per sample.
    pub pass_time: Option<f32>,
    /// Camera samples of a pixel that share one pass (several hit points per pixel): the pixel filter
    /// is stratified over them, sample `s` taking point `s mod strata` of a (0, m, 2)-net.
    pub strata: u32,
}

pub use crate::workload::{PixelOrder, Workload};

/// Adaptive sampling's state, present only when the run asks for it (`render.noise_threshold`).
#[derive(Resource, Debug)]
pub struct AdaptiveSampling {
    /// A pixel whose estimated relative error is under this stops taking samples.
    pub threshold: f64,
    /// Samples every pixel takes first.
    pub min_spp: u32,
    /// The samples' squares, beside the film's sums.
    pub squares: caustica_core::film::adaptive::SampleSquares,
    /// The pixels the next pass samples; `None`: every pixel (the first pass).
    pub next: Option<std::sync::Arc<PixelOrder>>,
}

impl AdaptiveSampling {
    /// Fresh state for an image of `pixels` pixels.
    pub fn new(threshold: f64, min_spp: u32, pixels: usize) -> Self {
        let squares = caustica_core::film::adaptive::SampleSquares::new(pixels);
        Self { threshold, min_spp, squares, next: None }
    }

    /// Whether every pixel has stopped.
    pub fn converged(&self) -> bool {
        self.next.as_ref().is_some_and(|order| order.is_empty())
    }

    /// Where the pass that starts at sample `done` ends, towards `target`: the minimum first, then
    /// steps of half the samples so far (at least 4), so a pixel takes at most half again what it
    /// needed while a render of n samples makes about 2.5·ln(n / min) passes, each with a tail
    /// (measured: quarter steps gave 2% fewer samples in 10 s on the Cornell box).
    pub fn pass_end(min_spp: u32, done: u32, target: u32) -> u32 {
        let end = if done == 0 { min_spp } else { done.saturating_add((done / 2).max(4)) };
        end.min(target)
    }
}

/// What the driver tells the systems about the pass that is running.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct PassRange {
    /// Passes before this one.
    pub index: u32,
    /// Progress at its start: samples per pixel, or passes.
    pub begin: u32,
    /// Progress when it ends.
    pub end: u32,
    /// Set once a time limit or an interrupt has passed: systems that hand out work stop doing so,
    /// and what is in flight finishes.
    pub stop: bool,
}

/// Counters, summed in `gather` (no atomics in the hot systems).
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Camera samples splatted.
    pub samples: u64,
    /// Closest-hit rays traced.
    pub rays: u64,
    /// Shadow rays traced.
    pub shadow_rays: u64,
    /// Photon-map k-nearest lookups (photon mapping).
    pub lookups: u64,
    /// Samples whose radiance was NaN or infinite, dropped (counted as black).
    pub nan_samples: u64,
    /// The first of them in sample order (sample index, then pixel): the same for any thread count.
    pub first_bad: Option<BadSample>,
    /// Paths still working (not idle) after the last step.
    pub active_paths: u32,
    /// Schedule runs (bounce steps).
    pub steps: u64,
}

/// A camera sample whose radiance was not finite: enough to find it again, since every random number
/// of a sample is a function of the seed, its pixel and its index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadSample {
    /// Pixel index (row-major).
    pub pixel: u32,
    /// Sample index within the pixel.
    pub sample: u32,
    /// Depth and quantity that went bad first, when the kernel saw it happen.
    pub cause: Option<(caustica_core::kernel::Quantity, u8)>,
}

impl BadSample {
    /// Its place in sample-major order, which names the same first bad sample for any thread count.
    pub fn order(&self) -> (u32, u32) {
        (self.sample, self.pixel)
    }
}

/// What the scene uses (decided once; it picks the systems of the schedule).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneFeatures {
    /// The camera has an aperture.
    pub lens: bool,
    /// Something moves over the shutter.
    pub motion: bool,
    /// There is at least one emitter (otherwise NEE is skipped).
    pub lights: bool,
    /// Light selection learns visibility from shadow rays (then a learning system runs).
    pub learns_visibility: bool,
    /// Some surface is a pure delta (mirror, smooth glass): only then can caustics form.
    pub specular: bool,
}

impl SceneFeatures {
    /// Features of a camera and scene.
    pub fn of(camera: &Camera, scene: &RenderScene) -> Self {
        Self {
            lens: camera.has_lens(),
            motion: scene.geometry.has_motion(),
            lights: !scene.lights.is_empty(),
            learns_visibility: scene.lights.is_learning(),
            specular: scene.has_specular(),
        }
    }
}

/// How bevy splits a wavefront among the workers: many small batches per thread, because the work
/// per path varies (a path that ended costs nothing, a glass hit costs more) and a thread that
/// finishes its share early would otherwise wait idle at the end of every stage.
pub fn wavefront_batching() -> bevy_ecs::batching::BatchingStrategy {
    bevy_ecs::batching::BatchingStrategy::new().batches_per_thread(16)
}

/// The photons of the pass that is running and how they are handed out.
#[derive(Resource, Clone, Copy, Debug)]
pub struct PhotonWork {
    /// Which photons are kept, how many are emitted, and their limits.
    pub settings: PhotonPassSettings,
    /// Next photon to hand out.
    pub next: u32,
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
        Self { settings, next: 0, seed: config.seed, sampler: config.sampler, motion, time: None, pass: 0 }
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
    /// Photons still in flight after the last step.
    pub active: u32,
    /// Steps run.
    pub steps: u64,
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

/// Settings and progress of a progressive photon-mapping render, read by the gather and update stages.
#[derive(Resource, Clone, Copy, Debug)]
pub struct ProgressiveConfig {
    /// Radius and accumulation rule.
    pub rule: RadiusRule,
    /// Fraction of new photons kept (Hachisuka, Ogaki & Jensen 2008).
    pub alpha: f32,
    /// Starting radius.
    pub r0: f32,
    /// Whether the user gave the starting radius (else the first pass may shrink it).
    pub r0_given: bool,
    /// Photons emitted per pass.
    pub photons_per_pass: u32,
    /// Hit points per pixel.
    pub hit_points_per_pixel: u32,
    /// The running pass (0-based); after the update, the number of passes done minus one.
    pub pass: u32,
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
