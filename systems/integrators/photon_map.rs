//! Photon mapping, `pm` (Jensen 2001): in the first pass a photon pass per map, then camera paths
//! that read them.
//!
//! | parameter (`[photons]`) | type | default | meaning |
//! |---|---|---|---|
//! | `photons` | u32 | 200 000 | photons emitted for the global (or indirect) map |
//! | `caustic_photons` | u32 | 200 000 | photons emitted for the caustic map (skipped without specular surfaces) |
//! | `k` | u32 | 100 | photons per radiance estimate |
//! | `max_radius` | f32 | 5% of the scene diagonal | largest gather radius |
//! | `kernel` | name | `epanechnikov` | density kernel over the gather disc (`caustica density --help`) |
//! | `final_gather` | u32 | 0 | final-gather rays per pixel sample; 0 reads the indirect map directly |
//!
//! Each map is a phase of the first pass on the vector core (`light_subpaths::photons`): it begins
//! (`begin_photon_map`, `begin_photon_subpaths`), runs a shard's chunk of photons a worker, a bounce
//! a round (`emit_photon_subpaths` → `trace_subpaths` → `scatter_photon_subpaths`), until every
//! photon has landed, and ends (`order_photon_deposits`, then `finish_photon_map`'s kd-tree build).
//! The camera side is the path tracer's bounce schedule with `scatter_photon_mapped` in the Scatter
//! set. A scene pays for what it has: no caustic pass without specular surfaces.
//!
//! | phase | stages (a round) | begin | end |
//! |---|---|---|---|
//! | `photons` (per map, first pass, on shards) | `emit_photon_subpaths` → `trace_subpaths` → `scatter_photon_subpaths` | `begin_photon_map`, `begin_photon_subpaths` | `order_photon_deposits`, `finish_photon_map` |
//! | `bounce` (every pass) | `emit_camera_paths` → `trace_paths` → `scatter_photon_mapped` → `trace_shadow_rays` → `splat_paths_to_film` | `hand_out_samples` | |

use super::descriptor::{Integrator, LightSampling, MemoryNeed, Setting};
use super::memory::PilotPaths;
use super::{film_image, paths_busy};
use crate::emit::emit_camera_paths_for;
use crate::gather::splat_paths_to_film;
use crate::light_subpaths::SubpathHandout;
use crate::light_subpaths::photons::{
    PhotonTrail, begin_photon_subpaths, order_photon_deposits, photon_shards,
};
use crate::passes::{begin_photon_map, finish_photon_map, hand_out_samples};
use crate::plan::{Phase, Plan, Repeat, Unit, When};
use crate::report::Report;
use crate::resources::{
    PhotonBuffer, PhotonMaps, PhotonStats, PhotonWork, RenderConfig, SceneFeatures, SceneResource,
};
use crate::scatter::scatter_photon_mapped;
use crate::stages::PassSystems;
use crate::stages::{configure_stages, stage_order};
use crate::trace::{trace_paths, trace_shadow_rays};
use crate::world::MAX_WAVEFRONT;
use bevy_ecs::prelude::*;
use caustica_core::error::{Error, Result};
use caustica_core::photon::PhotonMapKind;
use caustica_core::scene::{IntegratorKind, RunFile, Scene};

/// `pm`: photon maps built once per process, read by camera paths at a fixed number of samples.
pub static PM: Integrator = Integrator {
    kind: IntegratorKind::Pm,
    unit: Unit::Samples,
    // The maps are rebuilt by every process from the same seeds: a share's film is all it adds.
    film_is_the_state: true,
    whole_passes: false,
    light_sampling: LightSampling::Always("its direct light always comes from light sampling"),
    takes: &[Setting::CausticMap],
    default_hit_points_per_pixel: 0,
    hit_points_traced_once: false,
    counts_light_paths: true,
    // Each final-gather ray has a camera sample of its own.
    camera_samples_per_unit: |_, run| run.photons.final_gather.max(1),
    memory,
    check,
    plan,
};

/// The paths of the path tracers, each map's photon shards (a chunk of photons a worker), and the
/// photon maps (a stored photon is tagged in its pass's trail and copied into the ordered buffer
/// that becomes its kd-tree), as many photons stored as a pilot of them found.
fn memory(_: &Integrator, pixels: u64, run: &RunFile, pilot: &PilotPaths) -> MemoryNeed {
    use crate::light_subpaths::photons::{BYTES_PER_DEPOSIT, photon_chunk_bytes};
    let (photons, caustic) = (run.photons.photons, run.photons.caustic_photons);
    let paths = super::path::paths(pixels, run);
    let shards = 2 * photon_chunk_bytes(run.render.chunk) * crate::shards::workers() as u64;
    // The global map (final gathering) keeps every non-delta hit, the indirect one those after a
    // diffuse bounce.
    let per_photon = if run.photons.final_gather > 0 { pilot.diffuse_hits } else { pilot.indirect_hits };
    let stored = photons as f64 * per_photon + caustic as f64 * pilot.caustic_hits;
    let maps = stored.ceil() as u64 * BYTES_PER_DEPOSIT as u64;
    // A pass of more photons than 2^18 keeps when each photon ended, to order its deposits.
    let largest = photons.max(caustic);
    let replay = if largest > MAX_WAVEFRONT { largest as u64 * REPLAY_BYTES_PER_PHOTON } else { 0 };
    MemoryNeed {
        bytes: paths.bytes + shards + maps + replay,
        what: format!("a {pixels}-pixel film, its paths and the maps of {photons} + {caustic} photons"),
    }
}

/// Bytes a photon of a pass larger than 2^18 costs while its deposits are ordered: its end, its
/// start and its entity in the replayed hand-out.
pub const REPLAY_BYTES_PER_PHOTON: u64 = 24;

/// The caustic map cannot be dropped; a map of no photons is said.
fn check(_: &Scene, run: &RunFile) -> Result<()> {
    if run.photons.photons == 0 {
        tracing::warn!("pm with photons = 0: no global map, so no indirect light beyond caustics");
    }
    if run.photons.caustic_photons == 0 {
        tracing::warn!("pm with caustic_photons = 0: no caustic map, so no light through glass or mirrors");
    }
    if run.schedule.caustic_map == Some(false) {
        return Err(Error::Setting {
            name: "schedule.caustic_map".into(),
            problem:
                "schedule.caustic_map = false would lose caustics: pm's indirect and global estimates leave \
                      out L S+ D E paths, which only the caustic map carries"
                    .into(),
        });
    }
    Ok(())
}

/// The plan of `pm` for the scene in `world`.
fn plan(this: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let settings = &run.photons;
    let features = super::without_visibility_learning(world, features, "photon mapping uses the light tree");
    let order = stage_order(run);
    super::spawn_path_wavefront(world, MAX_WAVEFRONT);

    let final_gather = settings.final_gather > 0;
    let mut maps = Vec::new();
    if settings.photons > 0 {
        maps.push((
            if final_gather { PhotonMapKind::Global } else { PhotonMapKind::Indirect },
            settings.photons,
        ));
    }
    if features.specular && settings.caustic_photons > 0 {
        maps.push((PhotonMapKind::Caustic, settings.caustic_photons));
    }
    let diagonal = {
        let (min, max) = world.resource::<SceneResource>().geometry.bounds();
        (max - min).length()
    };
    let max_radius = settings.max_radius.unwrap_or(0.05 * diagonal);
    world.insert_resource(PhotonMaps {
        k: settings.k.max(1) as usize,
        max_radius2: max_radius * max_radius,
        kernel: settings.kernel,
        final_gather,
        ..Default::default()
    });
    let config = world.resource::<RenderConfig>().clone();
    world.insert_resource(PhotonWork::new(PhotonMapKind::Global, 0, &config, features.motion));
    world.insert_resource(PhotonBuffer::default());
    world.insert_resource(PhotonStats::default());
    world.insert_resource(PhotonTrail::default());
    world.insert_resource(SubpathHandout::default());

    let mut phases = Vec::new();
    for (kind, count) in maps {
        let shards = photon_shards(run.render.chunk, order);
        let photons = Phase::sharded("photons", When::FirstPassOfProcess, shards)
            .with_begin((begin_photon_map(kind, count), begin_photon_subpaths).chain())
            .with_end((order_photon_deposits, finish_photon_map(kind)).chain())
            .dropped_on_stop();
        phases.push(photons);
    }
    let mut bounce = Phase::new("bounce", When::EveryPass, Repeat::WhileBusy(paths_busy))
        .with_begin(hand_out_samples((this.camera_samples_per_unit)(this, run)));
    configure_stages(&mut bounce.schedule, order);
    bounce.schedule.add_systems(emit_camera_paths_for(features).in_set(PassSystems::Emit));
    bounce.schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    bounce.schedule.add_systems(scatter_photon_mapped.in_set(PassSystems::Scatter));
    bounce.schedule.add_systems(trace_shadow_rays.in_set(PassSystems::Shadow));
    bounce.schedule.add_systems(splat_paths_to_film.in_set(PassSystems::Gather));
    phases.push(bounce);
    Ok(Plan {
        phases,
        pass_end: Plan::all_at_once(),
        image: film_image,
        report,
        reset: |world| world.resource_mut::<PhotonMaps>().built.clear(),
    })
}

/// The photon maps built and the photon counters.
fn report(world: &World, report: &mut Report) {
    report.photons =
        Some(super::photon_summary(world, (0, None), world.resource::<PhotonMaps>().built.clone()));
}
