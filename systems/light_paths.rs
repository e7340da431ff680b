//! Light-path code shared by `lt`, `bdpt` and `vcm`: the subpaths' random numbers and counters
//! ([`LightPaths`]) and the splat of a connection to the camera ([`splat_connection`]). Their light
//! subpaths run on shards (`crate::light_subpaths`), their camera paths too (`crate::camera_paths`).

use super::resources::PhotonWork;
use bevy_ecs::prelude::*;
use caustica_core::camera::{Camera, filter_radius, filter_weight};
use caustica_core::film::{Film, fixed};
use caustica_core::kernel::dimensions::photon_sampler;
use caustica_core::kernel::light_path::CameraConnection;
use caustica_core::sampling::Sampler;
use glam::Vec2;
use std::sync::atomic::{AtomicU64, Ordering};

/// The random-number stream of the lens points light subpaths connect to: apart from the
/// subpaths' own (photon map kinds 0 to 3), so a pinhole camera leaves them as they were.
const LENS_STREAM: u32 = 8;

/// Light tracing's subpaths: how many a unit of progress has (one a pixel), and what their
/// connections did, for the report.
#[derive(Resource, Debug, Default)]
pub struct LightPaths {
    /// Subpaths a unit: the image's pixels.
    pub per_unit: u32,
    /// Connections to the camera traced.
    pub connections: AtomicU64,
    /// Those whose segment was free and added to the film.
    pub splatted: AtomicU64,
    /// Those dropped because what they carried could not go to the film (beyond its range).
    pub dropped: AtomicU64,
}

impl LightPaths {
    /// What the connections to the camera did, for the report.
    pub fn describe(&self) -> String {
        let (connections, splatted, dropped) = (
            self.connections.load(Ordering::Relaxed),
            self.splatted.load(Ordering::Relaxed),
            self.dropped.load(Ordering::Relaxed),
        );
        format!(
            "{connections} connections from light vertices, {splatted} seen, {dropped} splats out of range dropped"
        )
    }

    /// The lens point of subpath `index`'s connection at `depth` (the pinhole itself without an
    /// aperture).
    pub fn lens_sample(
        &self,
        work: &PhotonWork,
        camera: &caustica_core::camera::Camera,
        index: u32,
        depth: u32,
    ) -> Vec2 {
        if camera.has_lens() { self.sampler(work, index, true).get2d(2 * depth) } else { Vec2::splat(0.5) }
    }

    /// The random numbers of subpath `index` of the pass that starts at unit `work.pass`: those of
    /// subpath `index mod per_unit` of its own unit, so that a pass of any length (a part, a
    /// resumed render) draws what a pass of one unit would; and its lens points' (`lens`).
    pub fn sampler(&self, work: &PhotonWork, index: u32, lens: bool) -> Sampler {
        let unit = work.pass + index / self.per_unit;
        let stream = if lens { LENS_STREAM } else { work.settings.kind as u32 };
        photon_sampler(work.sampler, work.seed, unit, stream, index % self.per_unit)
    }
}

/// Add what a free connection carries to the pixels whose filter reaches where it lands, each its
/// share (integer sums: the same bits in any order); the shares that cannot go to the film (beyond
/// its range) are dropped and counted.
#[inline]
pub fn splat_connection(camera: &Camera, film: &Film, connection: &CameraConnection) -> u64 {
    let (width, height) = (camera.width as i64, camera.height as i64);
    let radius = filter_radius(camera.filter);
    let mut dropped = 0;
    let at = connection.raster;
    // Pixel centres within the filter's reach of the point.
    let (x0, x1) =
        (((at.x - 0.5 - radius).ceil() as i64).max(0), ((at.x - 0.5 + radius).floor() as i64).min(width - 1));
    let (y0, y1) = (
        ((at.y - 0.5 - radius).ceil() as i64).max(0),
        ((at.y - 0.5 + radius).floor() as i64).min(height - 1),
    );
    for y in y0..=y1 {
        for x in x0..=x1 {
            let offset = at - Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let weight = filter_weight(camera.filter, offset);
            if weight <= 0.0 {
                continue;
            }
            let value = connection.value * weight;
            if fixed::accepts(value) {
                film.splat((y * width + x) as u32, value);
            } else {
                dropped += 1;
            }
        }
    }
    dropped
}
