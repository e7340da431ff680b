//! The pass loop: run the plan's phases pass after pass towards the target, and stop where asked
//! (an interrupt, a time limit, a checkpoint due) without leaving the film between passes.

use super::{Renderer, StopReason};
use crate::plan::Repeat;
use crate::report::{Report, Unit};
use crate::resources::{PassRange, RenderStats};
use caustica_core::choice::Choice;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// How long the shards of a sharded phase run between two meetings with the driver (progress, time
/// limit, interrupts): long enough that the meeting costs nothing, short enough to stop promptly.
const ROUND: std::time::Duration = std::time::Duration::from_millis(100);

/// When the pass loop stops: what asks it to, from outside and from the render's own settings, and
/// why it last did.
#[derive(Default)]
pub(super) struct Stops {
    /// Set from outside (a signal handler, a host's UI) to stop the render at the next step.
    pub(super) interrupt: Arc<AtomicBool>,
    /// Set when an interrupt or a time limit stopped the render.
    pub(super) stopped: bool,
    /// Why the last `run` ended early, if it did.
    pub(super) reason: Option<StopReason>,
    /// Stop only between passes, so that the film holds whole passes (checkpoints).
    whole_passes: bool,
    /// Asked to end the running sample pass at the next whole unit (a checkpoint is due).
    pass_end_requested: AtomicBool,
}

impl Stops {
    fn stop(&mut self, reason: StopReason) {
        self.stopped = true;
        self.reason.get_or_insert(reason);
    }

    /// Whether to stop now, and why: the interrupt flag first, then the time limit.
    fn due(&self, deadline: Option<(Instant, f64)>) -> Option<StopReason> {
        if self.interrupt.load(Ordering::Relaxed) {
            Some(StopReason::Interrupted)
        } else if deadline.is_some_and(|(start, limit)| start.elapsed().as_secs_f64() >= limit) {
            Some(StopReason::TimeLimit)
        } else {
            None
        }
    }
}

impl Renderer {
    /// Stop for a signal or the time limit only between passes, so that the film always holds whole
    /// passes (what a checkpoint needs): a photon pass in flight is finished first, a sample pass
    /// is cut at the next whole sample per pixel.
    pub fn set_whole_passes(&mut self, whole: bool) {
        self.stops.whole_passes = whole;
    }

    /// End the running sample pass at the next whole sample per pixel, so that a checkpoint can be
    /// written soon without cutting every pass short (each pass's tail, its last paths alone on the
    /// cores, costs time). Photon passes end by themselves; callable from `on_step`.
    pub fn request_pass_end(&self) {
        self.stops.pass_end_requested.store(true, Ordering::Relaxed);
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

    /// Whether a phase after phase `i` runs in pass `index` (which begins at `begin`).
    fn phases_left_after(&self, i: usize, index: u32, begin: u32) -> bool {
        self.plan.phases[i + 1..].iter().any(|phase| {
            phase.when.includes(index, begin)
                && !(self.light_kept && phase.when == crate::plan::When::FirstPassOfProcess)
        })
    }

    /// Whether the film holds exactly the passes done (no step of a next pass has run).
    pub fn at_pass_boundary(&self) -> bool {
        self.at_pass_boundary
    }

    /// The flag that stops the render at its next step when raised (from a signal handler or another
    /// thread): no new work starts, what is in flight finishes, and the image so far stays valid.
    pub fn interrupt_flag(&self) -> Arc<AtomicBool> {
        self.stops.interrupt.clone()
    }

    /// Clear a stop (an interrupt, a time limit) so that `run` goes on from where it stopped.
    pub fn clear_stop(&mut self) {
        self.stops.interrupt.store(false, Ordering::Relaxed);
        self.stops.stopped = false;
    }

    /// Cut passes to at most `units` samples per pixel (or passes), so that a caller gets control —
    /// to write the image so far — that often; the sample integrators otherwise run one pass to the end.
    pub fn set_max_pass(&mut self, units: Option<u32>) {
        self.max_pass = units.filter(|&u| u > 0);
    }

    /// Why the last run stopped before its target, if it did.
    pub fn stopped_by(&self) -> Option<StopReason> {
        self.stops.reason
    }

    /// Run passes until the target is reached or, with `time_limit`, that many seconds have passed:
    /// then no new work starts, what is in flight finishes (a sample's path, or the pass that is
    /// running), and every pixel keeps the samples it got (samples are handed out sample-major, so
    /// pixels differ by at most one). `on_step` is called after every bounce step and every pass.
    pub fn run(&mut self, time_limit: Option<f64>, mut on_step: impl FnMut(&Renderer)) -> Report {
        let start = Instant::now();
        let deadline = time_limit.map(|limit| (start, limit));
        self.stops.reason = None;
        while self.done < self.target && !self.stops.stopped && !self.converged() {
            self.run_pass(deadline, &mut on_step);
        }
        self.warn_if_stopped_before_a_pass();
        self.report()
    }

    /// A whole-pass integrator stopped inside its first pass has a black film: say so, and why.
    fn warn_if_stopped_before_a_pass(&self) {
        let Some(reason) = self.stops.reason else { return };
        if !self.integrator.whole_passes || self.done != self.first {
            return;
        }
        let film = self.film();
        if (0..film.width * film.height).any(|p| film.samples(p) > 0) {
            return;
        }
        let what = match reason {
            StopReason::TimeLimit => "the time limit",
            StopReason::Interrupted => "the interrupt",
        };
        tracing::warn!(
            "{what} came before {}'s first pass ended, and a pass is one estimate that a stop drops \
             whole: the image is black; allow more time (a pass traces at least as many light \
             subpaths as the film has pixels)",
            self.integrator.kind.name()
        );
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
        self.begin_pass_films();
        let samples_before = self.world.resource::<RenderStats>().samples;
        self.stops.pass_end_requested.store(false, Ordering::Relaxed);
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
                let whole_passes = self.stops.whole_passes || self.integrator.whole_passes;
                if let Some(reason) = self.stops.due(deadline) {
                    // Nothing of this pass is in the render's film yet (a first photon pass; a
                    // whole-pass integrator's pass, in films of its own): drop it now rather than
                    // wait for its end, unless it has just ended.
                    let droppable = self.plan.phases[i].dropped_on_stop || self.integrator.whole_passes;
                    if droppable && (busy || self.phases_left_after(i, index, begin)) {
                        self.stops.stop(reason);
                        self.phase_times[i].seconds += phase_start.elapsed().as_secs_f64();
                        self.phase_times[i].runs += runs;
                        if let Some(shards) = &mut shards {
                            shards.drop_paths();
                        }
                        self.plan.phases[i].shards = shards;
                        self.end_pass_films(false);
                        self.world.resource_mut::<RenderStats>().samples = samples_before;
                        self.at_pass_boundary = true;
                        self.seconds += pass_start.elapsed().as_secs_f64();
                        on_step(self);
                        return;
                    }
                    if !whole_passes {
                        self.world.resource_mut::<PassRange>().stop = true;
                    }
                    self.stops.stop(reason);
                }
                let end_requested = self.stops.pass_end_requested.swap(false, Ordering::Relaxed);
                if self.stops.whole_passes
                    && !self.integrator.whole_passes
                    && self.integrator.unit == Unit::Samples
                    && !cut
                    && (self.stops.stopped || end_requested)
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
        self.end_pass_films(true);
        self.passes += 1;
        self.done = end;
        self.at_pass_boundary = true;
        self.seconds += pass_start.elapsed().as_secs_f64();
        if let Some(reason) = self.stops.due(deadline)
            && self.done < self.target
        {
            self.stops.stop(reason);
        }
        on_step(self);
    }
}
