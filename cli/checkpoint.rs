//! `--checkpoint` and `--resume`: a render's whole passes so far, written as an accumulator EXR
//! (the format of `--part`, `caustica::film::accumulator`), and a render continued from one.
//!
//! A checkpoint is share 1 of 1 holding samples `0..done` of a render aiming at `spp`. It is written
//! only between passes (the film then holds exactly `done`), with a temporary file renamed over the
//! last one, so a crash while writing leaves the previous checkpoint whole. The render waits only for
//! a copy of its state: a thread of its own compresses and writes it while the render goes on.

use anyhow::{Context, Result};
use caustica::Renderer;
use caustica::film::Film;
use caustica::film::accumulator::{self, PartInfo};
use caustica::scene::{RunFile, Scene};
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::Instant;

/// Where and how often to write checkpoints, and what they are of.
pub struct Checkpoints {
    path: PathBuf,
    every: f64,
    last: Instant,
    last_units: u32,
    /// The checkpoint being written in the background, and the seconds its write took.
    writer: Option<JoinHandle<Result<f64>>>,
    /// Checkpoints written, the seconds the render waited for them, and the seconds their writing
    /// took on the writer's thread.
    written: u32,
    waited: f64,
    writing: f64,
    fingerprint: String,
    integrator: String,
    /// The bytes the render is counted to hold at its peak, its checkpoints' snapshot included.
    pub memory_counted: u64,
}

/// A checkpoint read for `--resume`, checked against this scene and settings.
pub struct Resumed {
    film: Film,
    hit_points: Option<accumulator::HitPointState>,
    done: u32,
    per_unit: u32,
    path: PathBuf,
}

/// The fingerprint and integrator name of a render, as accumulators record them.
fn identity(scene: &Scene, run: &RunFile) -> (String, String) {
    (
        caustica::scene::fingerprint::fingerprint(scene, run),
        caustica::Choice::name(run.render.integrator).to_owned(),
    )
}

/// Read and check `--resume`'s file before anything is rendered or written: a file of another scene
/// or settings, an incomplete one, or a part of a split render is refused, naming the file.
pub fn read_resume(path: &Path, scene: &Scene, run: &RunFile) -> Result<Resumed> {
    let (film, info, hit_points) = accumulator::read_checkpoint(path)?;
    let (fingerprint, integrator) = identity(scene, run);
    if info.fingerprint != fingerprint {
        anyhow::bail!(
            "{}: a checkpoint of another scene or settings ({} render): refusing to resume it",
            path.display(),
            info.integrator
        );
    }
    // The fingerprint covers the integrator: a file whose entry names another contradicts itself.
    if info.integrator != integrator {
        anyhow::bail!(
            "{}: its integrator entry says {:?} where its fingerprint is of a {integrator} render: the file is damaged",
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
    // A checkpoint is written at or before its target: one past it says the spp entry lies.
    if info.samples.end > info.spp {
        anyhow::bail!(
            "{}: it holds units {}..{} of a render of spp {}: the file is damaged",
            path.display(),
            info.samples.start,
            info.samples.end,
            info.spp
        );
    }
    Ok(Resumed {
        film,
        hit_points,
        done: info.samples.end,
        per_unit: info.per_unit,
        path: path.to_path_buf(),
    })
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
        let per_unit = renderer.camera_samples_per_unit();
        if self.per_unit != per_unit {
            anyhow::bail!(
                "{}: {} camera samples per unit where this render takes {per_unit}: the file is damaged",
                self.path.display(),
                self.per_unit
            );
        }
        // Hit points beside a film that is the whole state would be ignored: they say the file is
        // of another render.
        if renderer.film_is_the_state() && self.hit_points.is_some() {
            anyhow::bail!(
                "{}: it holds hit points, which a {} render does not make: the file is damaged",
                self.path.display(),
                renderer.integrator().name()
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
            writer: None,
            written: 0,
            waited: 0.0,
            writing: 0.0,
            fingerprint,
            integrator,
            memory_counted: 0,
        })
    }

    /// Stop only between passes.
    pub fn configure(&mut self, renderer: &mut Renderer) -> Result<()> {
        if let Some(problem) = renderer.checkpoint_refusal() {
            anyhow::bail!("--checkpoint: {problem}");
        }
        self.memory_counted = renderer.check_checkpoint_memory()?;
        renderer.set_whole_passes(true);
        self.last_units = renderer.units_done();
        Ok(())
    }

    /// Start writing a checkpoint if one is due, the film holds whole passes and the last one is
    /// written; a failed write is reported here, and the render goes on.
    pub fn write_if_due(&mut self, renderer: &Renderer) -> Result<()> {
        if self.last.elapsed().as_secs_f64() < self.every
            || self.writer.as_ref().is_some_and(|w| !w.is_finished())
        {
            return Ok(());
        }
        if !renderer.at_pass_boundary() {
            renderer.request_pass_end();
            return Ok(());
        }
        self.finish_writing()?;
        self.start_writing(renderer)
    }

    /// Write the checkpoint now and wait for it (the render must be between passes): at the end,
    /// or when a signal stopped the render.
    pub fn write(&mut self, renderer: &Renderer) -> Result<()> {
        let earlier = self.finish_writing();
        self.start_writing(renderer)?;
        let last = self.finish_writing();
        earlier.and(last)
    }

    /// Copy what the checkpoint holds and hand it to a thread that writes it.
    fn start_writing(&mut self, renderer: &Renderer) -> Result<()> {
        let done = renderer.units_done();
        self.last = Instant::now();
        if done == self.last_units && self.path.exists() {
            return Ok(());
        }
        let started = Instant::now();
        let info = PartInfo {
            fingerprint: self.fingerprint.clone(),
            integrator: self.integrator.clone(),
            part: 1,
            parts: 1,
            samples: 0..done,
            spp: renderer.target(),
            per_unit: renderer.camera_samples_per_unit(),
        };
        // The snapshot is the written channels themselves: one copy, not a film and then its channels.
        let snapshot = accumulator::Snapshot::of(renderer.film(), renderer.hit_point_state());
        let path = self.path.clone();
        let writer = std::thread::Builder::new().name("checkpoint".into()).spawn(move || {
            let started = Instant::now();
            snapshot.write_checkpoint(&info, &path)?;
            Ok(started.elapsed().as_secs_f64())
        });
        self.writer = Some(writer.context("cannot start the checkpoint's writer thread")?);
        self.last_units = done;
        self.waited += started.elapsed().as_secs_f64();
        Ok(())
    }

    /// Wait for the checkpoint being written, if any, and say whether it was.
    fn finish_writing(&mut self) -> Result<()> {
        let Some(writer) = self.writer.take() else { return Ok(()) };
        let started = Instant::now();
        let outcome =
            writer.join().unwrap_or_else(|_| Err(anyhow::anyhow!("the checkpoint's writer panicked")));
        self.waited += started.elapsed().as_secs_f64();
        match outcome {
            Ok(seconds) => {
                self.written += 1;
                self.writing += seconds;
                Ok(())
            }
            Err(e) => {
                // Written again at the next chance, even if the render has not moved since.
                self.last_units = u32::MAX;
                Err(e)
            }
        }
    }

    /// The report's line: how many checkpoints were written and what they cost.
    pub fn summary(&self) -> String {
        format!(
            "{} written to {}; the render waited {:.3} s for them, writing took {:.3} s each on its own thread",
            self.written,
            self.path.display(),
            self.waited,
            self.writing / self.written.max(1) as f64
        )
    }
}
