//! The memory budget: what a render will hold, counted before it is allocated and checked against
//! the budget together with what the process already holds (the program, the scene and its BVH), so
//! that the budget bounds the process's peak resident memory, checkpoints included.
//!
//! Each integrator counts its own working set (its descriptor's `memory`: paths, hit points,
//! photons) with [`entity_bytes`] for its entities; this file adds what every render has (the film,
//! the feature images' film, the final image as it is written) and a checkpoint's snapshot.

use super::{Integrator, MemoryNeed};
use caustica_core::error::{Error, Result};
use caustica_core::film::Film;
use caustica_core::film::accumulator::Snapshot;
use caustica_core::film::aov::AovFilm;
use caustica_core::scene::RunFile;

/// Bytes an ECS entity of components of `component_bytes` costs in bevy's tables: each component,
/// the two change ticks bevy keeps beside every component, the table's `Entity` column, and the
/// entity's place in the World's index (24 bytes a slot, grown by doubling: counted twice).
pub fn entity_bytes(component_bytes: &[usize]) -> u64 {
    const TICKS: usize = 2 * size_of::<u32>();
    const INDEX_SLOT: usize = 24;
    let components: usize = component_bytes.iter().map(|b| b + TICKS).sum();
    (components + size_of::<bevy_ecs::entity::Entity>() + 2 * INDEX_SLOT) as u64
}

/// Bytes a pixel of the final image costs while it is written: the mean image (12 bytes), and the
/// encoder's copy of it (an EXR's f32 channels, a PNG's 8-bit rows and its compressor's input).
const WRITTEN_BYTES_PER_PIXEL: u64 = 24;
/// The feature images (albedo, normal, depth, samples) and their channels as an EXR writes them.
const WRITTEN_AOV_BYTES_PER_PIXEL: u64 = 2 * (12 + 12 + 4 + 4);

/// Everything a `pixels`-pixel render of `run` with `integrator` adds to the process: the film (and
/// the feature images' film), the integrator's working set, and the final image as it is written.
pub fn render_need(integrator: &Integrator, pixels: u64, run: &RunFile) -> MemoryNeed {
    let own = (integrator.memory)(integrator, pixels, run);
    let aovs = run.film.aovs.iter().any(|aov| aov.needs_surface());
    let film = Film::BYTES_PER_PIXEL + if aovs { AovFilm::BYTES_PER_PIXEL } else { 0 };
    let written = WRITTEN_BYTES_PER_PIXEL + if aovs { WRITTEN_AOV_BYTES_PER_PIXEL } else { 0 };
    MemoryNeed { bytes: own.bytes + pixels * (film + written), what: own.what }
}

/// Refuse a render of `need` over the memory budget (the run's, else half the machine's), counted
/// with what the process holds now, before anything of it is allocated. The bytes the process will
/// hold at its peak, as counted.
pub fn check(run: &RunFile, need: MemoryNeed) -> Result<u64> {
    // What is held now, not the lifetime peak: a host (Python) that once held more for its own
    // arrays would otherwise be refused every render after. A scene's build that peaked above the
    // budget has peaked already; what the budget can still bound is what the render adds.
    let held = caustica_core::memory::resident_bytes().unwrap_or(0);
    let budget = budget(run);
    let total = held + need.bytes;
    if total > budget {
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
        return Err(Error::Setting { name: "render.memory_budget_mib".into(), problem });
    }
    Ok(total)
}

/// The run's budget, else half the machine's memory.
pub fn budget(run: &RunFile) -> u64 {
    run.memory_budget_bytes(crate::world::physical_memory_bytes() / 2)
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
    let budget = budget(run);
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
