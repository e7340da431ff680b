//! The one driver: build a World and an integrator's [`Plan`] from a scene and its settings, run its
//! passes until the samples or passes are done or a time limit passes, extend, and make the image and
//! the report — the way pbrt-v4's `Render()` runs any integrator. The command, the bench, the tests
//! and a host application all drive every integrator through [`Renderer`]; none of them knows which
//! integrator it runs.

use crate::integrators::{self, Integrator};

mod host;
mod state;

use crate::plan::{Plan, Repeat};
pub use crate::report::StopReason;
use crate::report::{AdaptiveSummary, PhaseTime, Report, Unit};
use crate::resources::{AdaptiveSampling, FilmResource, PassRange, RenderStats, SceneFeatures};
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::film::Image;
use caustica_core::scene::pose::FrameScene;
use caustica_core::scene::{RunFile, Scene};
pub use host::{FrameUpdate, share_refusal};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

pub use crate::world::{DEFAULT_RESOLUTION, MAX_WAVEFRONT, init_thread_pools, resolution, scene_world};

/// How long the shards of a sharded phase run between two meetings with the driver (progress, time
/// limit, interrupts): long enough that the meeting costs nothing, short enough to stop promptly.
const ROUND: std::time::Duration = std::time::Duration::from_millis(100);

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
    /// The scene from frame to frame, when its file is animated or a host moves its nodes
    /// (`Renderer::movable`).
    frames: Option<FrameScene>,
    /// What the scene uses.
    pub features: SceneFeatures,
    /// Passes run.
    passes: u32,
    /// Progress at the end of the last pass.
    done: u32,
    /// Progress the render started from (a partial render's first sample).
    first: u32,
    /// Progress aimed at.
    target: u32,
    /// Set when a time limit stopped the render.
    stopped: bool,
    /// Seconds spent rendering.
    seconds: f64,
    /// Where the time went, phase by phase (same order as the plan's).
    phase_times: Vec<PhaseTime>,
    /// Camera samples per pixel that one unit of progress stands for (`pm`: its final-gather rays).
    samples_per_unit: u32,
    /// Set from outside (a signal handler, a host's UI) to stop the render at the next step.
    interrupt: Arc<AtomicBool>,
    /// Largest pass, in units (`None`: what the plan chooses).
    max_pass: Option<u32>,
    /// Why the last `run` ended early, if it did.
    stopped_by: Option<StopReason>,
    /// Stop only between passes, so that the film holds whole passes (checkpoints).
    whole_passes: bool,
    /// The last pass has ended and no step of the next has run: the film holds exactly `done`.
    at_pass_boundary: bool,
    /// Asked to end the running sample pass at the next whole unit (a checkpoint is due).
    pass_end_requested: AtomicBool,
    /// The run asks for the `spp` feature image.
    spp_image: bool,
    /// This frame reuses what an earlier one traced from the lights (`pm`'s photon maps: only the
    /// camera moved).
    light_kept: bool,
    /// How the BVHs follow moved meshes.
    bvh_update: caustica_core::render_scene::BvhUpdate,
}

impl Renderer {
    /// Check the settings against the scene, build the World and the integrator's plan. The target is
    /// the run's `render.spp` or `progressive.passes`, by the integrator.
    pub fn new(scene: Scene, run: &RunFile) -> Result<Self> {
        Self::with_frames(scene, run, false)
    }

    /// As [`Renderer::new`]; `keep_frames` keeps the scene for frames to come (a host's moves)
    /// even when its file has no animation. A file's animations are posed at time 0.
    pub(crate) fn with_frames(scene: Scene, run: &RunFile, keep_frames: bool) -> Result<Self> {
        let integrator = integrators::of_run(run);
        let (scene, frames, dynamic) = if keep_frames || scene.animation.is_some() {
            let frames = FrameScene::new(scene);
            let (posed, dynamic) = (frames.scene().clone(), frames.dynamic.clone());
            (posed, Some(frames), dynamic)
        } else {
            (scene, None, Vec::new())
        };
        integrator.check(&scene, run)?;
        let (mut world, features) = crate::world::scene_world_dynamic(scene, run, &dynamic)?;
        // With the scene built (what the process holds counts), before the film is allocated.
        let pixels = {
            let camera = world.resource::<crate::resources::CameraResource>();
            camera.width as u64 * camera.height as u64
        };
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
            frames,
            features,
            passes: 0,
            done: 0,
            first: 0,
            target,
            stopped: false,
            seconds: 0.0,
            phase_times,
            samples_per_unit,
            interrupt: Arc::new(AtomicBool::new(false)),
            max_pass: None,
            stopped_by: None,
            whole_passes: false,
            at_pass_boundary: true,
            pass_end_requested: AtomicBool::new(false),
            spp_image: run.film.aovs.contains(&caustica_core::film::aov::Aov::Spp),
            light_kept: false,
            bvh_update: Default::default(),
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
        self.stopped = false;
        self.stopped_by = None;
    }

    /// What the integrator is.
    pub fn integrator(&self) -> &'static Integrator {
        self.integrator
    }

    /// Whether adaptive sampling chooses the pixels that take samples (`render.noise_threshold`).
    pub fn is_adaptive(&self) -> bool {
        self.world.contains_resource::<AdaptiveSampling>()
    }

    /// Whether adaptive sampling has stopped every pixel.
    pub fn converged(&self) -> bool {
        self.world.get_resource::<AdaptiveSampling>().is_some_and(|a| a.converged())
    }

    /// Whether the render makes feature images (`film.aovs`).
    pub fn has_aovs(&self) -> bool {
        self.world.contains_resource::<crate::resources::AovFilmResource>()
    }

    /// The feature images so far, when the render makes them.
    pub fn aov_images(&self) -> Option<caustica_core::film::aov::AovImages> {
        let surface =
            self.world.get_resource::<crate::resources::AovFilmResource>().map(|film| film.images());
        if !self.spp_image {
            return surface;
        }
        let mut images = surface.unwrap_or_default();
        let film = self.film();
        images.spp = (0..film.width * film.height).map(|p| film.samples(p) as f32).collect();
        Some(images)
    }

    /// Stop for a signal or the time limit only between passes, so that the film always holds whole
    /// passes (what a checkpoint needs): a photon pass in flight is finished first, a sample pass
    /// is cut at the next whole sample per pixel.
    pub fn set_whole_passes(&mut self, whole: bool) {
        self.whole_passes = whole;
    }

    /// End the running sample pass at the next whole sample per pixel, so that a checkpoint can be
    /// written soon without cutting every pass short (each pass's tail, its last paths alone on the
    /// cores, costs time). Photon passes end by themselves; callable from `on_step`.
    pub fn request_pass_end(&self) {
        self.pass_end_requested.store(true, Ordering::Relaxed);
    }

    /// Cut the running sample pass `begin..end` at the next whole unit past the samples handed out
    /// so far, and say where it ends now.
    fn cut_sample_pass(&mut self, begin: u32, end: u32) -> u32 {
        let per_unit = self.samples_per_unit.max(1);
        let first_sample = begin.saturating_mul(per_unit);
        let cut = match self.world.get_resource::<crate::resources::Workload>() {
            // This pass's samples, some handed out already.
            Some(work) if work.spp_begin == first_sample && work.spp_end > first_sample => {
                work.cut_at_unit(per_unit) / per_unit
            }
            // None handed out yet (the phase that hands them out has not run): one unit.
            _ => begin + 1,
        };
        let end = cut.clamp(begin + 1, end);
        self.world.resource_mut::<PassRange>().end = end;
        end
    }

    /// Whether the film holds exactly the passes done (no step of a next pass has run).
    pub fn at_pass_boundary(&self) -> bool {
        self.at_pass_boundary
    }

    /// Units of progress whole in the film: samples per pixel, or passes.
    pub fn units_done(&self) -> u32 {
        self.done
    }

    /// Camera samples a pixel gets per unit of progress (a sample per pixel, or a pass).
    pub fn camera_samples_per_unit(&self) -> u32 {
        self.samples_per_unit
    }

    /// The film: every sample's sum and count so far.
    pub fn film(&self) -> &caustica_core::film::Film {
        self.world.resource::<FilmResource>()
    }

    /// The flag that stops the render at its next step when raised (from a signal handler or another
    /// thread): no new work starts, what is in flight finishes, and the image so far stays valid.
    pub fn interrupt_flag(&self) -> Arc<AtomicBool> {
        self.interrupt.clone()
    }

    /// Clear a stop (an interrupt, a time limit) so that `run` goes on from where it stopped.
    pub fn clear_stop(&mut self) {
        self.interrupt.store(false, Ordering::Relaxed);
        self.stopped = false;
    }

    /// Cut passes to at most `units` samples per pixel (or passes), so that a caller gets control —
    /// to write the image so far — that often; the sample integrators otherwise run one pass to the end.
    pub fn set_max_pass(&mut self, units: Option<u32>) {
        self.max_pass = units.filter(|&u| u > 0);
    }

    /// Why the last run stopped before its target, if it did.
    pub fn stopped_by(&self) -> Option<StopReason> {
        self.stopped_by
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

    /// Run passes until the target is reached or, with `time_limit`, that many seconds have passed:
    /// then no new work starts, what is in flight finishes (a sample's path, or the pass that is
    /// running), and every pixel keeps the samples it got (samples are handed out sample-major, so
    /// pixels differ by at most one). `on_step` is called after every bounce step and every pass.
    pub fn run(&mut self, time_limit: Option<f64>, mut on_step: impl FnMut(&Renderer)) -> Report {
        let start = Instant::now();
        let deadline = time_limit.map(|limit| (start, limit));
        self.stopped_by = None;
        while self.done < self.target && !self.stopped && !self.converged() {
            self.run_pass(deadline, &mut on_step);
        }
        self.report()
    }

    /// Run one pass of the plan, towards the current target.
    pub fn run_pass(&mut self, deadline: Option<(Instant, f64)>, on_step: &mut impl FnMut(&Renderer)) {
        let pass_start = Instant::now();
        let (index, begin) = (self.passes, self.done);
        let mut end = (self.plan.pass_end)(begin, self.target).clamp(begin + 1, self.target.max(begin + 1));
        if let Some(units) = self.max_pass {
            end = end.min(begin.saturating_add(units));
        }
        self.world.insert_resource(PassRange { index, begin, end, stop: false });
        self.at_pass_boundary = false;
        self.pass_end_requested.store(false, Ordering::Relaxed);
        let mut cut = false;
        let _span = tracing::info_span!("pass", index).entered();
        for i in 0..self.plan.phases.len() {
            let when = self.plan.phases[i].when;
            if !when.includes(index, begin)
                || (self.light_kept && when == crate::plan::When::FirstPassOfProcess)
            {
                continue;
            }
            let phase_start = Instant::now();
            let mut runs = 0;
            self.plan.phases[i].begin.run(&mut self.world);
            // A sharded phase's shards are taken out while it runs, so that `on_step` can see the
            // renderer whole.
            let mut shards = self.plan.phases[i].shards.take();
            loop {
                let busy = match shards.as_mut() {
                    Some(shards) => {
                        let round = shards.run_round(&mut self.world, ROUND);
                        runs += round.steps;
                        self.world.resource_mut::<RenderStats>().active_paths = round.in_flight;
                        self.plan.phases[i].schedule.run(&mut self.world);
                        round.in_flight > 0
                    }
                    None => {
                        self.plan.phases[i].schedule.run(&mut self.world);
                        runs += 1;
                        let Repeat::WhileBusy(busy) = self.plan.phases[i].repeat else { break };
                        busy(&self.world)
                    }
                };
                let whole_passes = self.whole_passes || self.integrator.whole_passes;
                if let Some(reason) = self.should_stop(deadline) {
                    if self.plan.phases[i].dropped_on_stop && busy {
                        // Nothing of this pass is in the film yet: stop now, not at the phase's end.
                        self.stopped = true;
                        self.stopped_by.get_or_insert(reason);
                        self.phase_times[i].seconds += phase_start.elapsed().as_secs_f64();
                        self.phase_times[i].runs += runs;
                        self.at_pass_boundary = true;
                        self.seconds += pass_start.elapsed().as_secs_f64();
                        self.plan.phases[i].shards = shards;
                        on_step(self);
                        return;
                    }
                    if !whole_passes {
                        self.world.resource_mut::<PassRange>().stop = true;
                    }
                    self.stopped = true;
                    self.stopped_by.get_or_insert(reason);
                }
                let end_requested = self.pass_end_requested.swap(false, Ordering::Relaxed);
                if self.whole_passes
                    && !self.integrator.whole_passes
                    && self.integrator.unit == Unit::Samples
                    && !cut
                    && (self.stopped || end_requested)
                {
                    end = self.cut_sample_pass(begin, end);
                    cut = true;
                }
                on_step(self);
                if !busy {
                    break;
                }
            }
            self.plan.phases[i].shards = shards;
            self.plan.phases[i].end.run(&mut self.world);
            let time = &mut self.phase_times[i];
            time.seconds += phase_start.elapsed().as_secs_f64();
            time.runs += runs;
        }
        self.passes += 1;
        self.done = end;
        self.at_pass_boundary = true;
        self.seconds += pass_start.elapsed().as_secs_f64();
        if let Some(reason) = self.should_stop(deadline)
            && self.done < self.target
        {
            self.stopped = true;
            self.stopped_by.get_or_insert(reason);
        }
        on_step(self);
    }

    /// Whether to stop now, and why: the interrupt flag first, then the time limit.
    fn should_stop(&self, deadline: Option<(Instant, f64)>) -> Option<StopReason> {
        if self.interrupt.load(Ordering::Relaxed) {
            Some(StopReason::Interrupted)
        } else if deadline.is_some_and(|(start, limit)| start.elapsed().as_secs_f64() >= limit) {
            Some(StopReason::TimeLimit)
        } else {
            None
        }
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
            stopped_by: self.stopped_by,
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
