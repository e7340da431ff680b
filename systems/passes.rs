//! The systems that run once at the edges of a pass: hand out a pass's samples, start a camera or
//! photon pass, turn a photon pass into a map, and fix what the first pass teaches (the learned light
//! visibility, the initial radius).
//!
//! | system | runs | reads | writes |
//! |---|---|---|---|
//! | `hand_out_samples` | each sample pass | `PassRange`, `FilmResource`, `AdaptiveSampling` | `Workload`, idle `PathState`s |
//! | `select_unconverged_pixels` | after each sample pass, with adaptive sampling | `PassRange`, `FilmResource` | `AdaptiveSampling::next` |
//! | `finish_light_learning` | after the first pass (`pt`, visibility selection) | | `SceneResource` lights |
//! | `begin_progressive_pass` | each progressive pass | `PassRange` | `RenderConfig::pass_time`, `PhotonWork`, `ProgressiveConfig::pass` |
//! | `begin_camera_pass` | each camera pass | `PassRange`, `ProgressiveConfig` | `PathState` (sample, status) |
//! | `cap_initial_radius` | after the first camera pass | `CameraResource`, `HitPoint` | `ProgressiveConfig::r0`, `HitPoint::r2` |
//! | `begin_photon_map` / `finish_photon_map` | `pm`'s first pass, per map | `PhotonBuffer` | `PhotonWork`, `PhotonMaps` |
//!
//! A photon pass of `pm` or a progressive mapper begins and ends on the vector core
//! (`light_subpaths::photons`: `begin_photon_subpaths`, `order_photon_deposits`), and a light
//! subpaths' pass of `lt`, `bdpt` or `vcm` begins there too (`light_subpaths::begin_subpaths`).

use crate::components::{HitPoint, PathState, PathStatus};
use crate::resources::{
    AdaptiveSampling, CameraResource, FilmResource, PassRange, PhotonBuffer, PhotonMapSummary, PhotonMaps,
    PhotonWork, ProgressiveConfig, RenderConfig, SceneResource, Workload,
};
use bevy_ecs::prelude::*;
use caustica_core::kernel::camera_sample::pass_time;
use caustica_core::photon::{PhotonMap, PhotonMapKind};

/// A system that hands the pass's samples (`PassRange` begin..end, each standing for
/// `camera_samples_per_unit` camera samples) of every pixel, or with adaptive sampling of the pixels
/// it chose, to the idle paths in entity order, each from its lane; the rest go to paths as they
/// finish (`splat_paths_to_film`).
/// Named, so that the profile shows it as such rather than as a closure.
pub fn hand_out_samples(camera_samples_per_unit: u32) -> impl System<In = (), Out = ()> {
    let hand_out = move |range: Res<PassRange>,
                         film: Res<FilmResource>,
                         adaptive: Option<Res<AdaptiveSampling>>,
                         mut workload: ResMut<Workload>,
                         mut paths: Query<&mut PathState>| {
        let (begin, end) = (
            range.begin.saturating_mul(camera_samples_per_unit),
            range.end.saturating_mul(camera_samples_per_unit),
        );
        let wavefront = workload.wavefront;
        *workload = match adaptive.and_then(|a| a.next.clone()) {
            Some(order) => Workload::over(order, begin, end, wavefront),
            None => Workload::new(film.width * film.height, begin, end, wavefront),
        };
        if range.stop {
            return;
        }
        for (ordinal, mut state) in paths.iter_mut().enumerate() {
            if state.status != PathStatus::Idle {
                continue;
            }
            let Some((pixel, sample)) = workload.take(workload.lane_of_entity(ordinal as u32)) else {
                continue;
            };
            (state.pixel, state.sample, state.status) = (pixel, sample, PathStatus::NeedsStart);
        }
    };
    IntoSystem::into_system(hand_out).with_name("hand_out_samples")
}

/// After a pass that ran to its end, choose the pixels the next one samples: those that took every
/// sample so far and whose estimated relative error is still at the threshold or above. The choice
/// is a function of the film's fixed-point sums, so it is the same for any thread count.
pub fn select_unconverged_pixels(
    range: Res<PassRange>,
    film: Res<FilmResource>,
    mut adaptive: ResMut<AdaptiveSampling>,
) {
    if range.stop {
        return;
    }
    let pixels = caustica_core::film::adaptive::unconverged_pixels(
        &film,
        &adaptive.squares,
        range.end,
        adaptive.threshold,
    );
    adaptive.next =
        Some(std::sync::Arc::new(crate::resources::PixelOrder::new(pixels, film.width * film.height)));
}

/// Visibility-aware light selection learns from the first pass only: freeze what it learned.
pub fn finish_light_learning(mut scene: ResMut<SceneResource>) {
    scene.lights.finish_learning();
}

/// A system that starts a progressive pass: one shutter time for the camera and the photons of the
/// pass when something moves (Hachisuka & Jensen 2009, §5), the pass's photon numbers, and the pass
/// number for the update. Named, so that the profile shows it as such rather than as a closure.
pub fn begin_progressive_pass(motion: bool) -> impl System<In = (), Out = ()> {
    let begin = move |range: Res<PassRange>,
                      mut config: ResMut<RenderConfig>,
                      mut work: ResMut<PhotonWork>,
                      mut progressive: ResMut<ProgressiveConfig>| {
        // The pass's number in the whole render (`begin`), not in this process: a render split by
        // passes gives each pass the photons and shutter time it has in one run.
        let pass = range.begin;
        let time = motion.then(|| pass_time(config.sampler, config.seed, pass));
        config.pass_time = time;
        work.time = time;
        work.pass = pass;
        progressive.pass = pass;
    };
    IntoSystem::into_system(begin).with_name("begin_progressive_pass")
}

/// Send every pixel's camera paths out again, with the pass's samples: sample `pass · N + j` for the
/// `j`-th of a pixel's N hit points, so that each keeps its stratum of the pixel.
pub fn begin_camera_pass(
    range: Res<PassRange>,
    config: Res<ProgressiveConfig>,
    mut paths: Query<&mut PathState>,
) {
    let per_pixel = config.hit_points_per_pixel;
    for mut state in &mut paths {
        state.sample = range.begin * per_pixel + state.sample % per_pixel;
        state.status = PathStatus::NeedsStart;
    }
}

/// After the first camera pass, bound the heuristic initial radius by `FOOTPRINT_PIXELS` pixel footprints at the median
/// distance of the first pass's hit points: the area heuristic alone fails where a huge ground
/// plane or backdrop dominates the area, and a radius of metres would make every hit point
/// gather every photon.
pub fn cap_initial_radius(
    range: Res<PassRange>,
    camera: Res<CameraResource>,
    mut config: ResMut<ProgressiveConfig>,
    mut hit_points: Query<&mut HitPoint>,
) {
    if config.r0_given || range.index > 0 {
        return;
    }
    let distances: Vec<f32> =
        hit_points.iter().filter(|hp| hp.is_valid()).map(|hp| (hp.p - camera.origin).length()).collect();
    let Some(cap) =
        caustica_core::photon::progressive::radius_cap(&camera, distances).filter(|&cap| cap < config.r0)
    else {
        return;
    };
    config.r0 = cap;
    for mut hp in &mut hit_points {
        hp.r2 = cap * cap;
    }
}

/// A system that sets up `pm`'s photon pass for the map `kind` with `count` photons (each map's
/// photons are independent of the others': the kind selects their random numbers). Named, as
/// [`hand_out_samples`] is.
pub fn begin_photon_map(kind: PhotonMapKind, count: u32) -> impl System<In = (), Out = ()> {
    let begin = move |mut work: ResMut<PhotonWork>| {
        work.settings.kind = kind;
        work.settings.total = count;
        (work.pass, work.time) = (0, None);
    };
    IntoSystem::into_system(begin).with_name("begin_photon_map")
}

/// A system that builds the photon map of `kind` from the pass's deposits. Named, as
/// [`hand_out_samples`] is.
pub fn finish_photon_map(kind: PhotonMapKind) -> impl System<In = (), Out = ()> {
    let finish =
        move |mut buffer: ResMut<PhotonBuffer>, work: Res<PhotonWork>, mut maps: ResMut<PhotonMaps>| {
            let map = PhotonMap::build(std::mem::take(&mut buffer.photons));
            // A pass dropped by a stop and begun again builds its maps again.
            maps.built.retain(|built| built.kind != kind);
            maps.built.push(PhotonMapSummary {
                kind,
                emitted: work.settings.total,
                stored: map.len(),
                bytes: map.memory_bytes(),
            });
            let slot = match kind {
                PhotonMapKind::Global => &mut maps.global,
                PhotonMapKind::Indirect => &mut maps.indirect,
                PhotonMapKind::Caustic => &mut maps.caustic,
                PhotonMapKind::Bounced => return,
            };
            *slot = Some(map);
        };
    IntoSystem::into_system(finish).with_name("finish_photon_map")
}
