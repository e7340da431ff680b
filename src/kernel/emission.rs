//! Light that a path finds by BSDF sampling: emission at a surface it hits and the environment when
//! it escapes, weighted by what else in the integrator counts the same light.

use super::mis::power_heuristic;
use super::{CameraPath, Quantity};
use crate::geometry::SurfaceHit;
use crate::geometry::bvh::NO_LIGHT;
use crate::render_scene::RenderScene;
use glam::Vec3;

/// How emission found by BSDF sampling is weighted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmissionWeight {
    /// Fully: BSDF sampling is the only way light is found (`pt-naive`).
    One,
    /// Against light sampling at the previous vertex with the power heuristic (`pt`), except after
    /// the camera or a delta bounce, where light sampling could not have found it.
    Mis,
    /// Only after the camera or a delta bounce; everywhere else light sampling or photons count it
    /// (`pm` and the progressive photon mappers).
    SeenDirectly,
}

impl EmissionWeight {
    /// The weight for `path`, with `light_pdf` the density with which light sampling at the previous
    /// vertex would have found this light (evaluated only for MIS).
    #[inline]
    fn of(self, path: &CameraPath, light_pdf: impl FnOnce() -> f32) -> Option<f32> {
        match self {
            Self::One => Some(1.0),
            Self::Mis if path.seen_directly() => Some(1.0),
            Self::Mis => Some(power_heuristic(path.prev_pdf, light_pdf())),
            Self::SeenDirectly => path.seen_directly().then_some(1.0),
        }
    }
}

/// Add the environment's radiance along `d` to a path that left the scene.
#[inline]
pub fn add_escaped_radiance(scene: &RenderScene, rule: EmissionWeight, path: &mut CameraPath, d: Vec3) {
    let Some(environment) = &scene.lights.environment else { return };
    let Some(weight) = rule.of(path, || scene.lights.environment_pdf(d, path.prev_p, path.prev_n)) else {
        return;
    };
    path.add(path.beta * environment.le(d) * weight, Quantity::Environment);
}

/// Add the emission of the surface `si`, seen from direction `wo` (towards where the ray came from),
/// if it is the front side of a light; `time` is the ray's shutter time.
#[inline]
pub fn add_surface_emission(
    scene: &RenderScene,
    rule: EmissionWeight,
    path: &mut CameraPath,
    si: &SurfaceHit,
    wo: Vec3,
    time: f32,
) {
    // Written as a positive test so that a NaN normal adds nothing.
    if si.light != NO_LIGHT && si.ng.dot(wo) > 0.0 {
        let light_pdf = || scene.lights.pdf(si.light, path.prev_p, path.prev_n, si.p, si.ng, time);
        if let Some(weight) = rule.of(path, light_pdf) {
            path.add(path.beta * scene.emission(si) * weight, Quantity::Emission);
        }
    }
}
