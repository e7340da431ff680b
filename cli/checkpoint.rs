//! `--checkpoint` and `--resume`: a render's whole passes so far, written as an accumulator EXR
//! (the format of `--part`, `caustica::film::accumulator`), and a render continued from one.
//!
//! A checkpoint is share 1 of 1 holding samples `0..done` of a render aiming at `spp`. It is written
//! only between passes (the film then holds exactly `done`), with a temporary file renamed over the
//! last one, so a crash while writing leaves the previous checkpoint whole.

use anyhow::{Context, Result};
use caustica::Renderer;
use caustica::film::Film;
use caustica::film::accumulator::{self, PartInfo};
use caustica::scene::{RunFile, Scene};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Samples per pixel a pass of the sample integrators may hold while checkpointing, in wavefronts:
/// enough for the pass's tail (the last paths, alone on the cores) to cost little, few enough that a
/// signal is answered within seconds.
const WAVEFRONTS_PER_PASS: u64 = 8;

/// Where and how often to write checkpoints, and what they are of.
pub struct Checkpoints {
    path: PathBuf,
    every: f64,
    last: Instant,
    last_units: u32,
    fingerprint: String,
    integrator: String,
}

/// A checkpoint read for `--resume`, checked against this scene and settings.
pub struct Resumed {
    film: Film,
    hit_points: Option<accumulator::HitPointState>,
    done: u32,
    path: PathBuf,
}

/// The fingerprint and integrator name of a render, as accumulators record them.
fn identity(scene: &Scene, run: &RunFile) -> (String, String) {
    (
        caustica::scene::fingerprint::fingerprint(scene, run),
        format!("{:?}", run.render.integrator).to_lowercase(),
    )
}

/// Read and check `--resume`'s file before anything is rendered or written: a file of another scene
/// or settings, an incomplete one, or a part of a split render is refused, naming the file.
pub fn read_resume(path: &Path, scene: &Scene, run: &RunFile) -> Result<Resumed> {
    let (film, info, hit_points) = accumulator::read_checkpoint(path)?;
    let (fingerprint, _) = identity(scene, run);
    if info.fingerprint != fingerprint {
        anyhow::bail!(
            "{}: a checkpoint of another scene or settings ({} render): refusing to resume it",
            path.display(),
            info.integrator
        );
    }
    if info.parts != 1 || info.samples.start != 0 {
        anyhow::bail!(
            "{}: part {}/{} of a split render, not a checkpoint: merge it with `caustica merge`",
            path.display(),
            info.part,
            info.parts
        );
    }
    Ok(Resumed { film, hit_points, done: info.samples.end, path: path.to_path_buf() })
}

impl Resumed {
    /// Hand the checkpoint's film to `renderer`, which then renders only what is left.
    pub fn apply(self, renderer: &mut Renderer) -> Result<()> {
        let target = renderer.target();
        if self.done > target {
            anyhow::bail!(
                "{}: the checkpoint already holds {} of the {target} asked for: ask for more (--spp or --passes)",
                self.path.display(),
                self.done
            );
        }
        let want = renderer.film_samples_after(self.done);
        if let Some(pixel) = (0..self.film.width * self.film.height).find(|&i| self.film.samples(i) != want) {
            anyhow::bail!(
                "{}: pixel {pixel} has {} samples where the checkpoint says {want}: not a checkpoint this build wrote",
                self.path.display(),
                self.film.samples(pixel)
            );
        }
        let path = self.path.clone();
        renderer
            .resume(self.film, self.done, self.hit_points.as_ref())
            .with_context(|| format!("resuming {}", path.display()))?;
        Ok(())
    }
}

impl Checkpoints {
    /// Checkpoints to `path` every `every` seconds; refused for a render whose film is not its whole
    /// state.
    pub fn new(path: &Path, every: f64, scene: &Scene, run: &RunFile) -> Result<Self> {
        if !(every.is_finite() && every > 0.0) {
            anyhow::bail!("--checkpoint-every {every}: must be a positive number of seconds");
        }
        let (fingerprint, integrator) = identity(scene, run);
        Ok(Self {
            path: path.to_path_buf(),
            every,
            last: Instant::now(),
            last_units: 0,
            fingerprint,
            integrator,
        })
    }

    /// Stop only between passes, and cut the sample integrators' passes so that there are some.
    pub fn configure(&mut self, renderer: &mut Renderer, write_every: Option<u32>) -> Result<()> {
        if let Some(problem) = renderer.checkpoint_refusal() {
            anyhow::bail!("--checkpoint: {problem}");
        }
        renderer.set_whole_passes(true);
        if renderer.progress().unit == caustica::report::Unit::Samples {
            let report = renderer.report();
            let pixels = (report.width as u64 * report.height as u64).max(1);
            let wavefront = pixels.min(caustica::driver::MAX_WAVEFRONT as u64);
            let units = (WAVEFRONTS_PER_PASS * wavefront).div_ceil(pixels) as u32;
            renderer.set_max_pass(Some(write_every.map_or(units, |k| k.min(units))));
        }
        self.last_units = renderer.units_done();
        Ok(())
    }

    /// Write a checkpoint if one is due and the film holds whole passes.
    pub fn write_if_due(&mut self, renderer: &Renderer) -> Result<()> {
        if renderer.at_pass_boundary() && self.last.elapsed().as_secs_f64() >= self.every {
            self.write(renderer)?;
        }
        Ok(())
    }

    /// Write the checkpoint now (the render must be between passes).
    pub fn write(&mut self, renderer: &Renderer) -> Result<()> {
        let done = renderer.units_done();
        if done == self.last_units && self.path.exists() {
            self.last = Instant::now();
            return Ok(());
        }
        let info = PartInfo {
            fingerprint: self.fingerprint.clone(),
            integrator: self.integrator.clone(),
            part: 1,
            parts: 1,
            samples: 0..done,
            spp: renderer.target(),
            per_unit: renderer.camera_samples_per_unit(),
        };
        accumulator::write_checkpoint(
            renderer.film(),
            &info,
            renderer.hit_point_state().as_ref(),
            &self.path,
        )?;
        (self.last, self.last_units) = (Instant::now(), done);
        Ok(())
    }
}
