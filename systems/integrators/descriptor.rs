//! What an integrator is, in one value: the rules the run file, the driver, the partial renders and
//! the hosts ask about it, and the functions that check its settings and build its plan. Each
//! integrator's file holds its descriptor; [`of`](super::of) is the one lookup by kind. Nothing
//! outside `integrators/` asks which integrator runs, only what its descriptor says.

use crate::plan::{Plan, Unit};
use crate::resources::SceneFeatures;
use bevy_ecs::prelude::*;
use caustica_core::choice::Choice;
use caustica_core::error::{Error, Result};
use caustica_core::scene::{IntegratorKind, RunFile, Scene};

/// Light sampling at camera vertices (next-event estimation), as an integrator takes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSampling {
    /// On, unless the run says `[schedule] nee = false`.
    On,
    /// Off by design; `nee = true` is refused.
    Never,
    /// Always on; `nee` is refused whatever its value, for this reason.
    Always(&'static str),
}

/// A run-file setting that only some integrators take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    /// `[schedule] passes`: the order of a progressive pass's camera, photon and statistics groups.
    PassOrder,
    /// `[schedule] caustic_map`.
    CausticMap,
    /// `render.noise_threshold`: adaptive sampling, which stops a pixel alone.
    NoiseThreshold,
    /// `guiding.enabled`: path guiding.
    Guiding,
}

impl Setting {
    /// Its key in the run file.
    fn key(self) -> &'static str {
        match self {
            Self::PassOrder => "schedule.passes",
            Self::CausticMap => "schedule.caustic_map",
            Self::NoiseThreshold => "render.noise_threshold",
            Self::Guiding => "guiding.enabled",
        }
    }

    /// Why the integrators that do not take it cannot.
    fn why_not(self) -> &'static str {
        match self {
            Self::PassOrder => "",
            Self::CausticMap => "",
            Self::NoiseThreshold => {
                ": the photon mappers' pixels share their photons, so a pixel cannot stop alone"
            }
            Self::Guiding => ": its paths are not sampled by the path tracer's continuation",
        }
    }
}

/// What a run of an integrator needs in memory, before anything is allocated.
pub struct MemoryNeed {
    /// Bytes.
    pub bytes: u64,
    /// What needs them, for the message that refuses a run over the budget.
    pub what: String,
}

/// One integrator: what it is called and counts, what it takes, and how it is checked and built.
pub struct Integrator {
    /// Its kind (its name: `kind.name()`).
    pub kind: IntegratorKind,
    /// What its progress is counted in: samples per pixel (`render.spp`) or passes (`progressive.passes`).
    pub unit: Unit,
    /// Whether its film alone is its state, so that any range of its units renders on its own and
    /// merges with the others' into the bits of one run (partial renders), and a checkpoint holds the
    /// film only. False when each pass builds on the statistics of the one before.
    pub film_is_the_state: bool,
    /// Whether a pass is one estimate whose parts must all be there (`lt`: its camera samples count
    /// the light subpaths' splats): it renders into films of its own, folded into the render's at
    /// its end, and a stop drops it at once (`crate::driver`'s pass films) rather than cut its
    /// camera samples short. The memory count has the second film.
    pub whole_passes: bool,
    /// Light sampling at camera vertices.
    pub light_sampling: LightSampling,
    /// The settings of [`Setting`] it takes; the others are refused naming the integrators that do.
    pub takes: &'static [Setting],
    /// Hit points per pixel when `progressive.hit_points_per_pixel` is not given (0: it has none).
    pub default_hit_points_per_pixel: u32,
    /// Whether its camera pass runs once, in the first pass (`ppm`): then `--spp N` asks for N hit
    /// points a pixel, not N passes.
    pub hit_points_traced_once: bool,
    /// Whether its memory grows with how far light's paths go (stored photons, kept light vertices):
    /// then a pilot of them is traced before it is counted ([`super::memory::PilotPaths`]).
    pub counts_light_paths: bool,
    /// Camera samples a pixel gets per unit of progress, beyond one (`pm`'s final-gather rays, the
    /// progressive mappers' hit points per pixel).
    pub camera_samples_per_unit: fn(&Integrator, &RunFile) -> u32,
    /// What a run of `pixels` pixels needs in memory.
    pub memory: fn(&Integrator, u64, &RunFile, &super::memory::PilotPaths) -> MemoryNeed,
    /// Its own checks of the settings against the scene, beyond the shared ones of [`Integrator::check`].
    pub check: fn(&Scene, &RunFile) -> Result<()>,
    /// Build it in `world` (which holds the scene's resources): its entities, resources and phases.
    pub plan: PlanFn,
}

/// Builds an integrator's plan in a World that holds the scene's resources.
pub type PlanFn = fn(&Integrator, &mut World, &RunFile, SceneFeatures) -> Result<Plan>;

impl Integrator {
    /// Its name in run files and on the command line.
    pub fn name(&self) -> &'static str {
        self.kind.name()
    }

    /// Whether a pilot of light paths is traced before its memory is counted.
    pub fn traces_light_paths(&self) -> bool {
        self.counts_light_paths
    }

    /// Whether it takes `setting`.
    pub fn takes(&self, setting: Setting) -> bool {
        self.takes.contains(&setting)
    }

    /// Whether camera vertices sample lights in `run`.
    pub fn nee(&self, run: &RunFile) -> bool {
        match self.light_sampling {
            LightSampling::On => run.schedule.nee.unwrap_or(true),
            LightSampling::Never => false,
            LightSampling::Always(_) => true,
        }
    }

    /// Hit points per pixel in `run` (0 for an integrator without them).
    pub fn hit_points_per_pixel(&self, run: &RunFile) -> u32 {
        if self.default_hit_points_per_pixel == 0 {
            return 0;
        }
        run.progressive.hit_points_per_pixel.unwrap_or(self.default_hit_points_per_pixel)
    }

    /// The units of progress `run` asks for: `render.spp` or `progressive.passes`.
    pub fn units(&self, run: &RunFile) -> u32 {
        match self.unit {
            Unit::Samples => run.render.spp,
            Unit::Passes => run.progressive.passes,
        }
    }

    /// Set [`Integrator::units`] in `run`.
    pub fn set_units(&self, run: &mut RunFile, units: u32) {
        match self.unit {
            Unit::Samples => run.render.spp = units,
            Unit::Passes => run.progressive.passes = units,
        }
    }

    /// The key of the setting that holds [`Integrator::units`].
    pub fn units_key(&self) -> &'static str {
        match self.unit {
            Unit::Samples => "spp",
            Unit::Passes => "passes",
        }
    }

    /// Why a share of this render cannot be rendered alone and merged, if it cannot (partial renders;
    /// the driver adds what only a built render knows).
    pub fn share_refusal(&self, run: &RunFile) -> Option<String> {
        use caustica_core::scene::LightSelection;
        if !self.film_is_the_state {
            return Some(format!(
                "{}'s progressive passes each build on the one before; split {}",
                self.name(),
                names(|i| i.film_is_the_state)
            ));
        }
        if run.is_guided() {
            return Some(
                "path guiding learns from the render's first passes, which a later share does not have: \
                 render guided renders unsplit"
                    .into(),
            );
        }
        if run.render.light_selection == LightSelection::Visibility {
            return Some(
                "visibility-aware light selection learns from the render's first samples, which one share \
                 does not have; use uniform, power or tree"
                    .into(),
            );
        }
        if run.film.aovs.iter().any(|aov| aov.needs_surface()) {
            return Some(
                "a part's accumulator holds colour only: render feature images (--aov) unsplit".into(),
            );
        }
        if run.is_adaptive() {
            return Some(
                "adaptive sampling decides which pixels take more samples from all of a pixel's samples \
                 so far, which one share does not have; split with render.noise_threshold = 0"
                    .into(),
            );
        }
        None
    }

    /// Check `run`'s settings for this integrator, before anything is built: what it takes, then its
    /// own checks. (The memory a run needs is checked once the scene is built: `memory::check`.)
    pub fn check(&self, scene: &Scene, run: &RunFile) -> Result<()> {
        self.check_settings(run)?;
        (self.check)(scene, run)
    }

    /// The settings only some integrators take, and light sampling, against this one.
    pub fn check_settings(&self, run: &RunFile) -> Result<()> {
        let refuse = |name: &str, problem: String| Err(Error::Setting { name: name.into(), problem });
        if self.units(run) == 0 {
            return refuse(self.units_key(), "must be at least 1".into());
        }
        let schedule = &run.schedule;
        let given = [
            (Setting::PassOrder, schedule.passes.is_some()),
            (Setting::CausticMap, schedule.caustic_map == Some(false)),
            (Setting::NoiseThreshold, run.is_adaptive()),
            (Setting::Guiding, run.guiding.enabled),
        ];
        if let Some(&(setting, _)) = given.iter().find(|&&(setting, given)| given && !self.takes(setting)) {
            let takers = names(|i| i.takes(setting));
            let (key, why) = (setting.key(), setting.why_not());
            return refuse(key, format!("{key} applies to {takers}, not {}{why}", self.name()));
        }
        match (self.light_sampling, schedule.nee) {
            (LightSampling::Never, Some(true)) => refuse(
                "schedule.nee",
                format!("schedule.nee = true contradicts {}, which samples no light by design", self.name()),
            ),
            (LightSampling::Always(why), Some(_)) => {
                refuse("schedule.nee", format!("schedule.nee does not apply to {}: {why}", self.name()))
            }
            _ => Ok(()),
        }
    }
}

/// The names of the integrators `which` picks, as a list in prose ("pt, pt-naive and pm").
pub fn names(which: impl Fn(&Integrator) -> bool) -> String {
    let picked: Vec<&str> = super::ALL.iter().filter(|i| which(i)).map(|i| i.name()).collect();
    match picked.split_last() {
        None => String::new(),
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
    }
}

/// One camera sample per unit (the path tracers).
pub fn one_sample_per_unit(_: &Integrator, _: &RunFile) -> u32 {
    1
}

/// No checks beyond the shared ones.
pub fn no_checks(_: &Scene, _: &RunFile) -> Result<()> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::{ALL, of};

    fn run(kind: IntegratorKind, edit: impl FnOnce(&mut RunFile)) -> RunFile {
        let mut run = RunFile::default();
        run.render.integrator = kind;
        edit(&mut run);
        run
    }

    #[test]
    fn every_kind_has_its_own_descriptor() {
        use caustica_core::choice::Choice;
        for (kind, descriptor) in IntegratorKind::all().zip(ALL) {
            assert_eq!(of(kind).kind, kind);
            assert_eq!(descriptor.kind, kind);
        }
    }

    #[test]
    fn light_sampling_is_checked_against_the_integrator() {
        use IntegratorKind::*;
        let nee = |kind, v| of(kind).check_settings(&run(kind, |r| r.schedule.nee = Some(v)));
        assert!(nee(Pt, false).is_ok() && nee(Sppm, false).is_ok() && nee(PtNaive, false).is_ok());
        assert!(nee(Ppm, true).is_err() && nee(PtNaive, true).is_err());
        assert!(nee(Pm, true).is_err() && nee(Pm, false).is_err());
        assert!(!of(Sppm).nee(&run(Sppm, |r| r.schedule.nee = Some(false))));
        assert!(of(Sppm).nee(&run(Sppm, |_| {})) && !of(Ppm).nee(&run(Ppm, |_| {})));
    }

    #[test]
    fn a_setting_an_integrator_does_not_take_is_refused_naming_those_that_do() {
        use IntegratorKind::*;
        let passes = |r: &mut RunFile| {
            use caustica_core::scene::schedule::Pass;
            r.schedule.passes = Some(vec![Pass::Camera, Pass::Photons, Pass::Statistics]);
        };
        let message = of(Pt).check_settings(&run(Pt, passes)).unwrap_err().to_string();
        // Every taker named, in the registry's order, then the one refused.
        let takers = names(|i| i.takes(Setting::PassOrder));
        assert!(takers.contains("sppm") && takers.contains("cppm"), "{takers}");
        assert!(message.contains(&format!("{takers}, not pt")), "{message}");
        assert!(of(Cppm).check_settings(&run(Cppm, passes)).is_ok());
        let adaptive = |r: &mut RunFile| r.render.noise_threshold = 0.1;
        let message = of(Sppm).check_settings(&run(Sppm, adaptive)).unwrap_err().to_string();
        assert!(message.contains("pt and pt-naive, not sppm"), "{message}");
        let no_caustics = |r: &mut RunFile| r.schedule.caustic_map = Some(false);
        assert!(of(Pt).check_settings(&run(Pt, no_caustics)).unwrap_err().to_string().contains("pm, not pt"));
    }

    #[test]
    fn the_share_rule_follows_the_film() {
        for integrator in ALL {
            let refusal = integrator.share_refusal(&run(integrator.kind, |_| {}));
            assert_eq!(refusal.is_none(), integrator.film_is_the_state, "{}", integrator.name());
        }
    }
}
