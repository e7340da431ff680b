//! What a checkpoint or a partial render must hold for this render to continue exactly: the film,
//! and for the progressive mappers that chain their passes, the hit points.

use super::Renderer;
use crate::resources::FilmResource;
use caustica_core::error::Result;

impl Renderer {
    /// Whether this render's film alone says where it stands, so that a partial render or a
    /// checkpoint of it continues exactly (`Integrator::film_is_the_state`).
    pub fn film_is_the_state(&self) -> bool {
        self.integrator.film_is_the_state
    }

    /// Why a checkpoint cannot hold this render, if it cannot. It holds the film, and for the
    /// progressive mappers but `pppm` their hit points (statistics, and for `ppm`, which traces them
    /// once, the hits).
    pub fn checkpoint_refusal(&self) -> Option<String> {
        if self.has_aovs() {
            return Some("a checkpoint holds colour only: render feature images (--aov) without one".into());
        }
        if self.is_adaptive() {
            return Some(
                "adaptive sampling decides from the samples' squares, which a checkpoint does not hold; \
                 checkpoint with render.noise_threshold = 0"
                    .into(),
            );
        }
        if self.run.is_guided() {
            return Some(
                "path guiding's learnt distribution is not in a checkpoint: render guided renders without one"
                    .into(),
            );
        }
        self.features.learns_visibility.then(|| {
            "visibility-aware light selection learns from the first samples, which a checkpoint does not \
             hold; use uniform, power or tree"
                .to_string()
        })
    }

    /// The memory the render was counted to hold at its peak, checkpoints aside (0 if unknown).
    pub fn memory_counted(&self) -> u64 {
        self.world.get_resource::<crate::resources::MemoryCounted>().map_or(0, |m| m.0)
    }

    /// Refuse checkpoints whose snapshot (the film's channels and the hit points' words, held while
    /// its thread writes them) would take the render over its memory budget; else the bytes the render
    /// is counted to hold at its peak with them.
    pub fn check_checkpoint_memory(&self) -> Result<u64> {
        use crate::integrators::memory;
        let counted = self.memory_counted();
        let film = self.film();
        let hit_points = if self.film_is_the_state() {
            0
        } else {
            crate::hit_point_state::saved_bytes(&self.world, self.traces_visible_points_once())
        };
        let snapshot = memory::checkpoint_need(film.width as u64 * film.height as u64, hit_points);
        let with_snapshot = counted + snapshot.bytes;
        memory::check_checkpoints(&self.run, counted, snapshot)?;
        Ok(with_snapshot)
    }

    /// The memory budget this render is checked against, bytes.
    pub fn memory_budget(&self) -> u64 {
        self.run.memory_budget_bytes()
    }

    /// The hit points' state, for a checkpoint (`None` without hit points).
    pub fn hit_point_state(&self) -> Option<caustica_core::film::accumulator::HitPointState> {
        if self.film_is_the_state() {
            None
        } else {
            crate::hit_point_state::save(&self.world, self.traces_visible_points_once())
        }
    }

    /// Continue from `film`, which holds units `0..done` (samples per pixel, or passes) of this
    /// render, and for `sppm`, `appm`, `cppm` and `ppm` from their `hit_points`, towards the current target:
    /// the same bits, once it is reached, as a render that never stopped. Before the first pass.
    pub fn resume(
        &mut self,
        film: caustica_core::film::Film,
        done: u32,
        hit_points: Option<&caustica_core::film::accumulator::HitPointState>,
    ) -> Result<()> {
        let refuse =
            |problem: String| Err(caustica_core::error::Error::Setting { name: "resume".into(), problem });
        if let Some(problem) = self.checkpoint_refusal() {
            return refuse(problem);
        }
        if self.passes > 0 {
            return refuse("the render has started".into());
        }
        let current = self.film();
        if (film.width, film.height) != (current.width, current.height) {
            return refuse(format!(
                "the checkpoint is {}x{}, the render {}x{}",
                film.width, film.height, current.width, current.height
            ));
        }
        if !self.film_is_the_state() {
            let Some(state) = hit_points else {
                return refuse("the checkpoint holds no hit points, which this integrator needs".into());
            };
            let with_hits = self.traces_visible_points_once();
            crate::hit_point_state::restore(&mut self.world, state, with_hits)?;
        }
        self.world.insert_resource(FilmResource::new(film));
        (self.first, self.done) = (done, done);
        Ok(())
    }

    /// Whether the camera pass runs in the render's first pass only (`ppm`): its visible points are
    /// then state a checkpoint must hold, and the film's counts stop growing after it.
    fn traces_visible_points_once(&self) -> bool {
        self.plan.phases.iter().any(|phase| phase.when == crate::plan::When::RenderStart)
    }

    /// Camera samples each pixel of the film holds once `units` units are done.
    pub fn film_samples_after(&self, units: u32) -> u32 {
        let units = if self.traces_visible_points_once() { units.min(1) } else { units };
        self.camera_samples_per_unit() * units
    }
}
