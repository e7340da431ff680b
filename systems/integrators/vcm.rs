//! Vertex connection and merging, `vcm` (Georgiev, Křivánek, Davidovič & Slusallek 2012; Hachisuka,
//! Pantaleoni & Jensen 2012's unified path sampling; SmallVCM's `kVcm`): bdpt's strategies, and at
//! every non-delta camera vertex the light vertices of its unit within a radius merged as photons
//! are, all weighted by one power heuristic. Merging finds what connections cannot (a caustic seen
//! through glass, L S D S E) and connections what merging does badly (glossy surfaces, direct
//! light), so vcm is never much worse than the better of the two families.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `integrator` | `vcm` | | vertex connection and merging |
//! | `spp` | u32 | 64 | units: a camera subpath and a light subpath per pixel each |
//! | `progressive.initial_radius` | f32 | one pixel footprint | r₀, the first unit's merging radius (scene units) |
//! | `progressive.alpha` | f32 | 2/3 | the radii's shrinking: r_u = r₀ · u^((α − 1)/2) |
//! | `max_depth`, `rr_depth`, `seed`, `sampler` | | | as `bdpt` |
//!
//! The default r₀ is one pixel footprint at the median distance of what the pixels' centres see,
//! a function of the scene and camera alone (so every share of a split render has it). Each unit's
//! radius is a function of its index, so `--part` shares and checkpoints merge and resume to the
//! bits of one run, as `pppm`'s passes do. The stages are bdpt's (`systems/integrators/bdpt.rs`),
//! with each pass's light vertices sorted into a hash grid per unit before the camera subpaths
//! (`build_merge_grids`) and the merges made in the connection stage.

use super::descriptor::{Integrator, LightSampling, MemoryNeed, no_checks, one_sample_per_unit};
use super::memory::PilotPaths;
use crate::bidirectional::RadiusSequence;
use crate::plan::{Plan, Unit};
use crate::resources::{CameraResource, SceneFeatures, SceneResource};
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::photon::progressive::{pixel_footprint, probe_hit_distances};
use caustica_core::scene::{IntegratorKind, RunFile};

/// Pixel footprints in the default first radius (SmallVCM's default, 0.3% of the scene's radius,
/// is about 0.6 of one on its Cornell boxes). Two halved the point caustic's error but doubled the
/// cornell box's at equal time, and biased a 32² ball under a constant sky by 2.7% after 8 units
/// (tests/furnace.rs); one keeps that under its 4 standard errors.
const FOOTPRINT_PIXELS: f32 = 1.0;

/// `vcm`: bdpt's connections and the merges, under one MIS.
pub static VCM: Integrator = Integrator {
    kind: IntegratorKind::Vcm,
    unit: Unit::Samples,
    film_is_the_state: true,
    whole_passes: true,
    light_sampling: LightSampling::Always(
        "light sampling is one of vcm's strategies, weighted among the others",
    ),
    takes: &[],
    default_hit_points_per_pixel: 0,
    hit_points_traced_once: false,
    counts_light_paths: true,
    camera_samples_per_unit: one_sample_per_unit,
    memory,
    check: no_checks,
    plan,
};

/// bdpt's, and the grids over the kept vertices: for each, what a merge reads of it (in the grid,
/// built from the table without a copy), its bucket, and at most four buckets' starts.
fn memory(this: &Integrator, pixels: u64, run: &RunFile, pilot: &PilotPaths) -> MemoryNeed {
    use caustica_core::kernel::bidirectional::MergeVertex;
    const GRID_BYTES_PER_VERTEX: u64 = (size_of::<MergeVertex>() + 5 * size_of::<u32>()) as u64;
    let bdpt = (super::bdpt::BDPT.memory)(this, pixels, run, pilot);
    let grids = super::bdpt::kept_vertices_per_pass(pixels, run, pilot) * GRID_BYTES_PER_VERTEX;
    MemoryNeed { bytes: bdpt.bytes + grids, what: format!("{} and their merging grids", bdpt.what) }
}

fn plan(_: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let r0 = match run.progressive.initial_radius {
        Some(r0) => r0,
        None => {
            let camera = &world.resource::<CameraResource>().0;
            let geometry = &world.resource::<SceneResource>().geometry;
            let footprint = pixel_footprint(camera, probe_hit_distances(camera, geometry));
            // A camera that sees nothing merges nothing it could show: any radius will do.
            footprint.map_or(1e-3, |f| FOOTPRINT_PIXELS * f)
        }
    };
    let radii = RadiusSequence { r0, alpha: run.progressive.alpha };
    super::bdpt::plan_bidirectional(world, run, features, Some(radii))
}
