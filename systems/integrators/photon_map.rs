//! Photon mapping, `pm` (Jensen 2001): a photon pass per map, then a camera pass that reads them.
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
//! Each photon pass is its own Schedule over photon entities (Emit → Trace → Scatter → Store, run until
//! every photon has landed); the camera pass is the path schedule with `scatter_photon_mapped` in the
//! Scatter set. A scene pays for what it has: no caustic pass without specular surfaces.

use crate::materials::Bsdf;
use crate::photon::PhotonMap;
use crate::scene::PhotonSettings;
use crate::PassSystems;
use crate::components::PathStatus;
use crate::emit::emit_camera_paths_for;
use crate::gather::splat_paths_to_film;
use crate::photon_estimate::scatter_photon_mapped;
use crate::photons::{
    emit_photons, scatter_photons, spawn_photon_wavefront, store_photons, trace_photons,
};
use crate::render::MAX_WAVEFRONT;
use crate::resources::{
    PhotonBuffer, PhotonMapKind, PhotonMaps, PhotonStats, PhotonWork, RenderConfig, SceneFeatures,
    SceneGeometry,
};
use crate::trace::{trace_paths, trace_shadow_rays};
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;
use std::time::Instant;

/// What one photon pass did.
#[derive(Clone, Copy, Debug)]
pub struct PhotonPassReport {
    /// Which map.
    pub kind: PhotonMapKind,
    /// Photons emitted.
    pub emitted: u32,
    /// Photons stored in the map.
    pub stored: usize,
    /// Photon rays traced.
    pub traced: u64,
    /// Photons ended by Russian roulette.
    pub roulette_kills: u64,
    /// Wall time of tracing, seconds.
    pub trace_seconds: f64,
    /// Wall time of the kd-tree build, seconds.
    pub build_seconds: f64,
    /// Bytes held by the map.
    pub bytes: usize,
}

/// Everything the photon passes did, for the end-of-run report.
#[derive(Resource, Clone, Debug, Default)]
pub struct PhotonReport {
    /// One entry per pass, in the order they ran.
    pub passes: Vec<PhotonPassReport>,
}

/// Add the camera pass of `pm` to `schedule`, in the default stage order.
pub fn build(schedule: &mut Schedule, features: SceneFeatures) {
    build_ordered(schedule, features, crate::scene::schedule::CYCLE);
}

/// As [`build`], with the stages in `order` (a rotation of the cycle).
pub fn build_ordered(
    schedule: &mut Schedule,
    features: SceneFeatures,
    order: [crate::scene::schedule::Stage; 5],
) {
    super::configure_stages(schedule, order);
    schedule.add_systems(emit_camera_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_photon_mapped.in_set(PassSystems::Scatter));
    schedule.add_systems(trace_shadow_rays.in_set(PassSystems::Shadow));
    schedule.add_systems(splat_paths_to_film.in_set(PassSystems::Gather));
}

/// The photon pass: one bounce of every photon per run.
pub fn photon_schedule() -> Schedule {
    let mut schedule = Schedule::default();
    schedule.set_executor(SingleThreadedExecutor::new());
    schedule.configure_sets(
        (PassSystems::Emit, PassSystems::Trace, PassSystems::Scatter, PassSystems::Gather).chain(),
    );
    schedule.add_systems(emit_photons.in_set(PassSystems::Emit));
    schedule.add_systems(trace_photons.in_set(PassSystems::Trace));
    schedule.add_systems(scatter_photons.in_set(PassSystems::Scatter));
    schedule.add_systems(store_photons.in_set(PassSystems::Gather));
    schedule
}

/// Trace `count` photons for a map of `kind` through `world` (which holds `SceneGeometry`) and build
/// the map. Photon entities are spawned for the pass and despawned after it.
pub fn run_photon_pass(
    world: &mut World,
    kind: PhotonMapKind,
    count: u32,
    config: &RenderConfig,
    motion: bool,
) -> (PhotonMap, PhotonPassReport) {
    let start = Instant::now();
    let wavefront = count.min(MAX_WAVEFRONT);
    // The first wavefront's photons are handed out at spawn.
    world.insert_resource(PhotonWork { next: wavefront, ..PhotonWork::new(kind, count, config, motion) });
    world.insert_resource(PhotonBuffer::default());
    world.insert_resource(PhotonStats::default());
    let entities = spawn_photon_wavefront(world, wavefront, PathStatus::NeedsCamera);
    let mut schedule = photon_schedule();
    loop {
        schedule.run(world);
        if world.resource::<PhotonStats>().active == 0 {
            break;
        }
    }
    for entity in entities {
        world.despawn(entity);
    }
    let stats = world.remove_resource::<PhotonStats>().unwrap_or_default();
    let photons = world.remove_resource::<PhotonBuffer>().unwrap_or_default().photons;
    world.remove_resource::<PhotonWork>();
    let trace_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let map = PhotonMap::build(photons);
    let report = PhotonPassReport {
        kind,
        emitted: count,
        stored: map.len(),
        traced: stats.traced,
        roulette_kills: stats.roulette_kills,
        trace_seconds,
        build_seconds: start.elapsed().as_secs_f64(),
        bytes: map.memory_bytes(),
    };
    (map, report)
}

/// Whether any material is a pure delta (mirror, smooth glass): only then can caustics form.
pub fn has_specular(scene: &SceneGeometry) -> bool {
    scene.materials.iter().any(|m| {
        let params = crate::materials::ShadingParams {
            base_color: m.base_color,
            metallic: m.metallic,
            roughness: m.roughness,
            transmission: m.transmission,
            ior: m.ior,
            specular: m.specular,
            specular_color: m.specular_color,
        };
        Bsdf::new(&params).is_delta()
    })
}

/// Run the photon passes the settings and scene call for and insert `PhotonMaps` and `PhotonReport`.
pub fn prepare_maps(world: &mut World, settings: &PhotonSettings, motion: bool) {
    let config = world.resource::<RenderConfig>().clone();
    let (specular, diagonal) = {
        let scene = world.resource::<SceneGeometry>();
        let (min, max) = scene.geometry.bounds();
        (has_specular(scene), (max - min).length())
    };
    let mut report = PhotonReport::default();
    let mut pass = |world: &mut World, kind, count| {
        let (map, r) = run_photon_pass(world, kind, count, &config, motion);
        report.passes.push(r);
        Some(map)
    };
    let final_gather = settings.final_gather > 0;
    let (global, indirect) = match (final_gather, settings.photons) {
        (_, 0) => (None, None),
        (true, n) => (pass(world, PhotonMapKind::Global, n), None),
        (false, n) => (None, pass(world, PhotonMapKind::Indirect, n)),
    };
    let caustic = if specular && settings.caustic_photons > 0 {
        pass(world, PhotonMapKind::Caustic, settings.caustic_photons)
    } else {
        None
    };
    let max_radius = settings.max_radius.unwrap_or(0.05 * diagonal);
    world.insert_resource(PhotonMaps {
        global,
        indirect,
        caustic,
        k: settings.k.max(1) as usize,
        max_radius2: max_radius * max_radius,
        kernel: settings.kernel,
        final_gather,
    });
    world.insert_resource(report);
}
