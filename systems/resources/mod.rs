//! Resources shared by the systems: the scene, the settings of this render, the film, the work to
//! hand out, and the counters; what only some integrators use is in a file of its own.

mod adaptive;
mod photons;
mod progressive;

pub use adaptive::{AdaptiveSampling, AdaptiveSquares};
pub use photons::{PassPhotons, PhotonBuffer, PhotonMapSummary, PhotonMaps, PhotonStats, PhotonWork};
pub use progressive::ProgressiveConfig;

use bevy_ecs::resource::Resource;
use caustica_core::camera::Camera;
use caustica_core::film::Film;
use caustica_core::kernel::PathLimits;
use caustica_core::render_scene::RenderScene;
use caustica_core::scene::IntegratorKind;

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

/// A core type shared by the main World and the shards' (`crate::shards`): a clone shares it, and
/// a change through `DerefMut` copies it first if a shard still holds it (the driver takes the
/// shards' copies back after every round, so between rounds it changes in place).
macro_rules! shared_resource_of {
    ($(#[$doc:meta])* $name:ident($inner:ty)) => {
        $(#[$doc])*
        #[derive(Resource, Clone, Debug)]
        pub struct $name(pub std::sync::Arc<$inner>);

        impl $name {
            /// `inner` as a resource.
            pub fn new(inner: $inner) -> Self {
                Self(std::sync::Arc::new(inner))
            }

            /// What it holds (copied if a shard still shares it).
            pub fn into_inner(self) -> $inner {
                std::sync::Arc::try_unwrap(self.0).unwrap_or_else(|shared| (*shared).clone())
            }
        }

        impl std::ops::Deref for $name {
            type Target = $inner;
            fn deref(&self) -> &$inner {
                &self.0
            }
        }

        impl std::ops::DerefMut for $name {
            fn deref_mut(&mut self) -> &mut $inner {
                std::sync::Arc::make_mut(&mut self.0)
            }
        }
    };
}

shared_resource_of!(
    /// The scene the systems trace and shade: BVHs, lights, materials, textures.
    SceneResource(RenderScene)
);
resource_of!(
    /// The camera that `emit` generates rays from.
    CameraResource(Camera)
);
shared_resource_of!(
    /// The film that `gather` splats finished samples onto (its sums are atomic: every shard adds
    /// to the one film).
    FilmResource(Film)
);
shared_resource_of!(
    /// The feature images' film, present only when the run asks for them (`film.aovs`).
    AovFilmResource(caustica_core::film::aov::AovFilm)
);

/// The render's films while a pass of a whole-pass integrator (`lt`, `bdpt`, `vcm`) runs: its
/// samples and splats go to films of the pass's own (in [`FilmResource`] and [`AovFilmResource`]
/// meanwhile), which the driver folds into these at the pass's end or drops if a stop cuts it.
#[derive(Resource)]
pub struct CommittedFilms {
    /// The render's film: whole passes.
    pub film: FilmResource,
    /// The render's feature images' film, if it makes them.
    pub aov: Option<AovFilmResource>,
}

/// The render's film: whole passes only while a pass of a whole-pass integrator runs.
pub fn committed_film(world: &bevy_ecs::world::World) -> &Film {
    match world.get_resource::<CommittedFilms>() {
        Some(committed) => &committed.film,
        None => world.resource::<FilmResource>(),
    }
}

/// The render's feature images' film, if it makes them (as [`committed_film`]).
pub fn committed_aov_film(world: &bevy_ecs::world::World) -> Option<&caustica_core::film::aov::AovFilm> {
    match world.get_resource::<CommittedFilms>() {
        Some(committed) => committed.aov.as_deref(),
        None => world.get_resource::<AovFilmResource>().map(|film| &**film),
    }
}

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

/// The bytes the render was counted to hold at its peak when it was checked against the memory
/// budget (`integrators::memory`): what checkpoints are counted beside.
#[derive(Resource, Clone, Copy, Debug)]
pub struct MemoryCounted(pub u64);

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
    /// Schedule runs (bounce steps), summed over shards.
    pub steps: u64,
    /// Paths the steps ran over (the wavefront or a shard's chunk, each step): how busy they were is
    /// the rays traced over this.
    pub slot_steps: u64,
}

impl RenderStats {
    /// Add what a shard counted (`active_paths` is the driver's: paths in flight after a round).
    pub fn absorb(&mut self, shard: RenderStats) {
        self.samples += shard.samples;
        self.rays += shard.rays;
        self.shadow_rays += shard.shadow_rays;
        self.lookups += shard.lookups;
        self.nan_samples += shard.nan_samples;
        if let Some(bad) = shard.first_bad
            && self.first_bad.is_none_or(|first| bad.order() < first.order())
        {
            self.first_bad = Some(bad);
        }
        self.steps += shard.steps;
        self.slot_steps += shard.slot_steps;
    }
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
    /// Whether a plan made for `self` renders a scene with `frame`'s features: the same camera, and
    /// nothing the plan has no system for. A frame may lack what the plan has (its only emitter
    /// scaled to nothing, its mirror moved out of the file): those systems then find no work.
    pub fn covers(self, frame: Self) -> bool {
        let within = |planned: bool, used: bool| planned || !used;
        self.lens == frame.lens
            && within(self.motion, frame.motion)
            && within(self.lights, frame.lights)
            && within(self.learns_visibility, frame.learns_visibility)
            && within(self.specular, frame.specular)
    }

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
