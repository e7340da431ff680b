//! The one driver: build a World and an integrator's [`Plan`] from a scene and its settings, run its
//! passes until the samples or passes are done or a time limit passes, extend, and make the image and
//! the report — the way pbrt-v4's `Render()` runs any integrator. The command, the bench, the tests
//! and a host application all drive every integrator through [`Renderer`]; none of them knows which
//! integrator it runs.

use crate::integrators::{self, Integrator};

mod checkpoint;
mod frames;
mod pass_film;
mod pass_loop;
mod restart;
mod shares;

use crate::plan::Plan;
pub use crate::report::StopReason;
use crate::report::{AdaptiveSummary, PhaseTime, Report, Unit};
use crate::resources::{AdaptiveSampling, FilmResource, RenderStats, SceneFeatures};
use bevy_ecs::world::World;
use caustica_core::error::Result;
use caustica_core::film::Image;
use caustica_core::scene::pose::FrameScene;
use caustica_core::scene::{RunFile, Scene};
pub use frames::{FrameRun, FrameUpdate};
pub use shares::share_refusal;

pub use crate::world::{DEFAULT_RESOLUTION, MAX_WAVEFRONT, init_thread_pools, resolution, scene_world};

/// How far a render has come, for a progress bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// What it is counted in.
    pub unit: Unit,
    /// Samples per pixel splatted (fractional while a pass runs), or passes done.
    pub done: f64,
    /// What the render aims at.
    pub target: u32,
}

/// A render in progress: the World (scene, settings, film, entities), the plan that drives it, and
/// where it stands.
pub struct Renderer {
    /// Scene, settings, film and the integrator's entities. A host may add its own resources.
    pub world: World,
    /// The integrator's phases; a host may add its systems to them (`Plan::phase_mut`).
    pub plan: Plan,
    /// What the integrator is: its unit, whether it splits, what it takes.
    integrator: &'static Integrator,
    /// The settings it was made with.
    run: RunFile,
    /// What the scene uses: what the plan was built for.
    features: SceneFeatures,
    /// Passes run.
    passes: u32,
    /// Progress at the end of the last pass.
    done: u32,
    /// Progress the render started from (a partial render's first sample).
    first: u32,
    /// Progress aimed at.
    target: u32,
    /// Seconds spent rendering.
    seconds: f64,
    /// Where the time went, phase by phase (same order as the plan's).
    phase_times: Vec<PhaseTime>,
    /// Camera samples per pixel that one unit of progress stands for (`pm`: its final-gather rays).
    samples_per_unit: u32,
    /// When the pass loop stops.
    stops: pass_loop::Stops,
    /// Largest pass, in units (`None`: what the plan chooses).
    max_pass: Option<u32>,
    /// The last pass has ended and no step of the next has run: the film holds exactly `done`.
    at_pass_boundary: bool,
    /// The run asks for the `spp` feature image.
    spp_image: bool,
    /// What the phases that trace from the lights alone made for an earlier frame is in the World
    /// still (`pm`'s photon maps: only the camera moved): they do not run.
    light_kept: bool,
    /// A whole-pass integrator's films for the next pass, black ([`pass_film`]).
    pass_films: Option<pass_film::PassFilms>,
}

impl Renderer {
    /// Check the settings against the scene, build the World and the integrator's plan. The target is
    /// the run's `render.spp` or `progressive.passes`, by the integrator. A file's animations are
    /// posed at time 0; its other frames are a [`FrameRun`]'s.
    pub fn new(scene: Scene, run: &RunFile) -> Result<Self> {
        if scene.animation.is_none() {
            return Self::with_dynamic(scene, run, &[]);
        }
        // Posed as a FrameRun poses its first frame, the animated meshes in a BVH set of their own:
        // the same trees, so the same bits as that frame.
        let frames = FrameScene::new(scene);
        Self::with_dynamic(frames.scene().clone(), run, &frames.dynamic)
    }

    /// As [`Renderer::new`] of a posed `scene`, whose meshes marked in `dynamic` go to the BVH set
    /// that frames rebuild alone.
    fn with_dynamic(scene: Scene, run: &RunFile, dynamic: &[bool]) -> Result<Self> {
        let integrator = integrators::of_run(run);
        integrator.check(&scene, run)?;
        let (mut world, features) = crate::world::scene_world_dynamic(scene, run, dynamic)?;
        // With the scene built (what the process holds counts), before the film is allocated.
        let pixels = {
            let camera = world.resource::<crate::resources::CameraResource>();
            camera.width as u64 * camera.height as u64
        };
        let mut run = run.clone();
        run.render.chunk = crate::shards::chunk_within_share(run.render.chunk, pixels);
        let run = &run;
        world.insert_resource(crate::shards::ShardLimit::for_film(pixels));
        let pilot = if integrator.traces_light_paths() {
            let config = world.resource::<crate::resources::RenderConfig>();
            let scene = world.resource::<crate::resources::SceneResource>();
            integrators::memory::PilotPaths::pilot(scene, config.limits, config.sampler)
        } else {
            integrators::memory::PilotPaths::default()
        };
        let need = integrators::memory::render_need(integrator, pixels, run, &pilot);
        let counted = integrators::memory::check(run, need)?;
        world.insert_resource(crate::resources::MemoryCounted(counted));
        crate::world::add_films(&mut world, run)?;
        let pass_films = match integrator.whole_passes {
            true => Some(pass_film::PassFilms::try_new(&world, run.memory_budget_bytes())?),
            false => None,
        };
        let plan = (integrator.plan)(integrator, &mut world, run, features)?;
        crate::aov::equip_paths(&mut world);
        let target = integrator.units(run);
        let samples_per_unit = (integrator.camera_samples_per_unit)(integrator, run);
        let phase_times =
            plan.phases.iter().map(|p| PhaseTime { name: p.name, seconds: 0.0, runs: 0 }).collect();
        Ok(Self {
            world,
            plan,
            integrator,
            run: run.clone(),
            features,
            passes: 0,
            done: 0,
            first: 0,
            target,
            seconds: 0.0,
            phase_times,
            samples_per_unit,
            stops: pass_loop::Stops::default(),
            max_pass: None,
            at_pass_boundary: true,
            spp_image: run.film.aovs.contains(&caustica_core::film::aov::Aov::Spp),
            light_kept: false,
            pass_films,
        })
    }

    /// What progress is aimed at.
    pub fn target(&self) -> u32 {
        self.target
    }

    /// Aim at `target` samples per pixel or passes: raise it to continue a finished render (the film
    /// keeps what it has), as benchmarks do to measure the error after 1, 2, 4, … of them.
    pub fn set_target(&mut self, target: u32) {
        self.target = target;
        self.stops.stopped = false;
        self.stops.reason = None;
    }

    /// What the integrator is.
    pub fn integrator(&self) -> &'static Integrator {
        self.integrator
    }

    /// Whether adaptive sampling chooses the pixels that take samples (`render.noise_threshold`).
    fn is_adaptive(&self) -> bool {
        self.world.contains_resource::<AdaptiveSampling>()
    }

    /// Whether adaptive sampling has stopped every pixel.
    pub fn converged(&self) -> bool {
        self.world.get_resource::<AdaptiveSampling>().is_some_and(|a| a.converged())
    }

    /// Whether the render makes feature images (`film.aovs`).
    fn has_aovs(&self) -> bool {
        self.world.contains_resource::<crate::resources::AovFilmResource>()
    }

    /// The feature images so far, when the render makes them.
    pub fn aov_images(&self) -> Option<caustica_core::film::aov::AovImages> {
        let surface = crate::resources::committed_aov_film(&self.world).map(|film| film.images());
        if !self.spp_image {
            return surface;
        }
        let mut images = surface.unwrap_or_default();
        let film = self.film();
        images.spp = (0..film.width * film.height).map(|p| film.samples(p) as f32).collect();
        Some(images)
    }

    /// Units of progress whole in the film: samples per pixel, or passes.
    pub fn units_done(&self) -> u32 {
        self.done
    }

    /// Camera samples a pixel gets per unit of progress (a sample per pixel, or a pass).
    pub fn camera_samples_per_unit(&self) -> u32 {
        self.samples_per_unit
    }

    /// The film: every sample's sum and count so far (of whole passes, for a whole-pass integrator).
    pub fn film(&self) -> &caustica_core::film::Film {
        crate::resources::committed_film(&self.world)
    }

    /// Passes run so far.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// How far the render has come.
    pub fn progress(&self) -> Progress {
        let done = match self.integrator.unit {
            Unit::Passes => (self.first + self.passes) as f64,
            Unit::Samples => {
                let film = self.world.resource::<FilmResource>();
                let pixels = (film.width as u64 * film.height as u64).max(1) as f64;
                self.first as f64
                    + self.world.resource::<RenderStats>().samples as f64
                        / (pixels * self.samples_per_unit as f64)
            }
        };
        Progress { unit: self.integrator.unit, done, target: self.target }
    }

    /// The image so far.
    pub fn image(&self) -> Image {
        (self.plan.image)(&self.world, self.first + self.passes)
    }

    /// What the render did so far.
    pub fn report(&self) -> Report {
        let film = self.world.resource::<FilmResource>();
        let sharded: u32 = self.plan.phases.iter().filter_map(|p| p.shards.as_ref()).map(|s| s.paths()).sum();
        let wavefront = sharded
            + self
                .world
                .try_query::<&crate::components::PathState>()
                .map_or(0, |mut q| q.iter(&self.world).count() as u32);
        let mut report = Report {
            integrator: self.integrator.kind,
            width: film.width,
            height: film.height,
            unit: self.integrator.unit,
            done: self.progress().done,
            target: self.target,
            seed: self.world.resource::<crate::resources::RenderConfig>().seed,
            seconds: self.seconds,
            phases: self.phase_times.clone(),
            paths: *self.world.resource::<RenderStats>(),
            wavefront,
            photons: None,
            hit_points: None,
            stopped_by: self.stops.reason,
            adaptive: self.adaptive_summary(),
            notes: Vec::new(),
        };
        (self.plan.report)(&self.world, &mut report);
        report
    }
}

impl Renderer {
    /// Where adaptive sampling sent the samples and the error it estimates, when it is on.
    fn adaptive_summary(&self) -> Option<AdaptiveSummary> {
        let adaptive = self.world.get_resource::<AdaptiveSampling>()?;
        let film = self.film();
        let pixels = film.width * film.height;
        let (fewest, most) =
            (0..pixels).map(|p| film.samples(p)).fold((u32::MAX, 0), |(lo, hi), n| (lo.min(n), hi.max(n)));
        // Those not chosen for the next pass; none before the first pass has ended.
        let converged = adaptive.next.as_ref().map_or(0, |next| (pixels - next.len()) as u64);
        Some(AdaptiveSummary {
            threshold: adaptive.threshold,
            min_spp: adaptive.min_spp,
            fewest: fewest.min(most),
            most,
            estimate: caustica_core::film::adaptive::ErrorEstimate::of(film, &adaptive.squares, converged),
        })
    }
}
