//! The memory budget: what a render will hold, counted before it is allocated and checked against
//! the budget together with what the process already holds (the program, the scene and its BVH), so
//! that the budget bounds the process's peak resident memory, checkpoints included.
//!
//! Each integrator counts its own working set (its descriptor's `memory`: paths, hit points,
//! photons) with [`crate::world::entity_bytes`] for its entities; this file adds what every render has (the film,
//! the feature images' film, the final image as it is written) and a checkpoint's snapshot.

use super::{Integrator, MemoryNeed};
use caustica_core::error::{Error, Result};
use caustica_core::film::Film;
use caustica_core::film::accumulator::Snapshot;
use caustica_core::film::aov::AovFilm;
use caustica_core::kernel::PathLimits;
use caustica_core::kernel::dimensions::photon_sampler;
use caustica_core::photon::PhotonMapKind;
use caustica_core::render_scene::RenderScene;
use caustica_core::sampling::SamplerKind;
use caustica_core::scene::RunFile;

/// Bytes a pixel of the final image costs while it is written: the mean image (12 bytes), and what
/// the encoder holds beside it (an EXR's blocks, about 1 byte a pixel; a PNG's 8-bit rows, 3),
/// measured with a counting allocator (tests/memory_count.rs).
const WRITTEN_BYTES_PER_PIXEL: u64 = 14;
/// The feature images (albedo, normal, depth, samples) and their channels as an EXR writes them.
const WRITTEN_AOV_BYTES_PER_PIXEL: u64 = 2 * (12 + 12 + 4 + 4);

/// Everything a `pixels`-pixel render of `run` with `integrator` adds to the process: the film (and
/// the feature images' film; twice for a whole-pass integrator, whose passes have films of their
/// own), the integrator's working set, and the final image as it is written.
pub fn render_need(integrator: &Integrator, pixels: u64, run: &RunFile, pilot: &PilotPaths) -> MemoryNeed {
    let own = (integrator.memory)(integrator, pixels, run, pilot);
    let aovs = run.film.aovs.iter().any(|aov| aov.needs_surface());
    let mut film = Film::BYTES_PER_PIXEL + if aovs { AovFilm::BYTES_PER_PIXEL } else { 0 };
    if integrator.whole_passes {
        // The pass's films beside the render's.
        film *= 2;
    }
    let written = WRITTEN_BYTES_PER_PIXEL + if aovs { WRITTEN_AOV_BYTES_PER_PIXEL } else { 0 };
    MemoryNeed { bytes: own.bytes + pixels * (film + written), what: own.what }
}

/// Refuse a render of `need` over the memory budget (the run's, else half the machine's), counted
/// with what the process holds now, before anything of it is allocated. The bytes the process will
/// hold at its peak, as counted.
pub fn check(run: &RunFile, need: MemoryNeed) -> Result<u64> {
    let budget = run.memory_budget_bytes();
    let over = |held: u64| {
        let mib = |b: u64| b.div_ceil(1 << 20);
        let problem = format!(
            "{} need {} MiB beside the {} MiB this process holds (the program and the scene), over the \
             budget of {} MiB: lower the resolution or the photon counts, or raise the budget \
             (--memory-budget-mib)",
            need.what,
            mib(need.bytes),
            mib(held),
            mib(budget)
        );
        Error::Setting { name: "render.memory_budget_mib".into(), problem }
    };
    if need.bytes > budget {
        return Err(over(0));
    }
    // A budget raised by hand past the machine (or under `ulimit -v`) lets through what cannot be
    // had: find out now, by name, rather than abort halfway through the ECS tables. Before what is
    // held is counted, so that a host counting with its allocator does not count the probe.
    caustica_core::memory::reserve(&need.what, need.bytes, budget)?;
    // What is held now, not the lifetime peak: a host (Python) that once held more for its own
    // arrays would otherwise be refused every render after. A scene's build that peaked above the
    // budget has peaked already; what the budget can still bound is what the render adds.
    let held = caustica_core::memory::held_bytes().unwrap_or(0);
    let total = held + need.bytes;
    if total > budget {
        return Err(over(held));
    }
    Ok(total)
}

/// What a checkpoint's snapshot of a `pixels`-pixel film and `hit_point_bytes` of hit points holds
/// while its thread writes it.
pub fn checkpoint_need(pixels: u64, hit_point_bytes: u64) -> MemoryNeed {
    MemoryNeed {
        bytes: pixels * Snapshot::BYTES_PER_PIXEL + hit_point_bytes,
        what: format!("checkpoints of a {pixels}-pixel film and {} MiB of hit points", hit_point_bytes >> 20),
    }
}

/// Refuse checkpoints whose snapshot, beside the `counted` bytes the render was checked with, is over
/// the budget.
pub fn check_checkpoints(run: &RunFile, counted: u64, snapshot: MemoryNeed) -> Result<()> {
    let budget = run.memory_budget_bytes();
    if counted + snapshot.bytes > budget {
        return Err(Error::Setting {
            name: "render.memory_budget_mib".into(),
            problem: format!(
                "{} need {} MiB beside the render's {} MiB, over the budget of {} MiB: raise the budget \
                 (--memory-budget-mib) or render without --checkpoint",
                snapshot.what,
                snapshot.bytes.div_ceil(1 << 20),
                counted.div_ceil(1 << 20),
                budget.div_ceil(1 << 20)
            ),
        });
    }
    Ok(())
}

/// How far light's paths go in a scene, found by tracing a few before the render: what the light
/// vertices bdpt and vcm keep and the photons pm stores grow with, and no formula of albedo and area
/// foresees (the open front of a Cornell box loses a third of its photons to the sky).
#[derive(Clone, Copy, Debug, Default)]
pub struct PilotPaths {
    /// Non-delta surfaces a path from a light meets before it leaves or roulette ends it: the
    /// global map's photons, bdpt's kept light vertices.
    pub diffuse_hits: f64,
    /// Those after a diffuse bounce: the indirect map's photons.
    pub indirect_hits: f64,
    /// Its first non-delta hit after delta ones only: the caustic map's photons.
    pub caustic_hits: f64,
    /// Those of `diffuse_hits` whose BSDF is not Lambert's: a kept light vertex's BSDF then goes
    /// into the pass's table of BSDFs.
    pub glossy_hits: f64,
}

/// Paths the pilot traces: the means it gives are within a few percent (each path's count of hits
/// is a few at most).
pub const PILOT_PATHS: u32 = 4096;

impl PilotPaths {
    /// Trace [`PILOT_PATHS`] photons of `scene` as a global map's pass would, with the run's limits,
    /// and count where they would be stored. Deterministic: its own sampler stream.
    pub fn pilot(scene: &RenderScene, limits: PathLimits, sampler: SamplerKind) -> Self {
        use caustica_core::kernel::photon::{PhotonPassSettings, emit_photon, scatter_photon};
        let settings = PhotonPassSettings {
            kind: PhotonMapKind::Global,
            total: PILOT_PATHS,
            max_depth: limits.max_depth,
            rr_depth: limits.rr_depth,
        };
        let mut hits = Self::default();
        for index in 0..PILOT_PATHS {
            // A map number no pass uses: the pilot's numbers are its own.
            let sampler = photon_sampler(sampler, PILOT_SEED, 0, PILOT_MAP, index);
            let Some((mut ray, mut path)) = emit_photon(scene, &settings, &sampler, 0.0) else { continue };
            loop {
                let hit = scene.geometry.intersect(&ray);
                let (depth, specular_only) = (path.depth, path.specular_only);
                let bounce = scatter_photon(scene, &settings, &mut path, &ray, &hit, &sampler);
                if bounce.deposit.is_some() {
                    hits.diffuse_hits += 1.0;
                    let si = scene.geometry.surface_hit(&ray, &hit);
                    if caustica_core::materials::Bsdf::new(&scene.shading_params(&si))
                        .lambert_albedo()
                        .is_none()
                    {
                        hits.glossy_hits += 1.0;
                    }
                    if depth > 0 && specular_only {
                        hits.caustic_hits += 1.0;
                    } else if depth > 0 {
                        hits.indirect_hits += 1.0;
                    }
                }
                match bounce.next {
                    Some(next) => ray = next,
                    None => break,
                }
            }
        }
        let n = f64::from(PILOT_PATHS);
        Self {
            diffuse_hits: hits.diffuse_hits / n,
            indirect_hits: hits.indirect_hits / n,
            caustic_hits: hits.caustic_hits / n,
            glossy_hits: hits.glossy_hits / n,
        }
    }
}

const PILOT_SEED: u64 = 0x5EED_0F91_7000;
const PILOT_MAP: u32 = 1 << 12;
