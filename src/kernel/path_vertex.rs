//! A camera vertex of path tracing, whole: what `pt` (light sampling and BSDF sampling under MIS)
//! and `pt-naive` (BSDF sampling alone) do where a ray lands. The scalar reference that the lanes
//! ([`super::lanes`]) are held to.

use super::aov::FirstSurface;
use super::{Arrival, CameraPath, EmissionWeight, PathLimits, ShadowSample, continue_path, sample_light};
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;

/// One vertex of `pt` (`NEE`) or `pt-naive` for the path whose ray `ray` found `hit` (its random
/// numbers from `sampler`): whether the path goes on (its next ray written into `ray`), and the
/// light sample to test, if it took one.
#[inline]
pub fn path_vertex<const NEE: bool>(
    scene: &RenderScene,
    limits: PathLimits,
    hit: &Hit,
    ray: &mut Ray,
    path: &mut CameraPath,
    sampler: Sampler,
    aov: Option<&mut FirstSurface>,
) -> (bool, Option<ShadowSample>) {
    let mut light_sample = None;
    let continues = arrival::<NEE>(limits).arrive(scene, ray, hit, path, sampler, aov, |path, ray, v, u| {
        if NEE && !v.bsdf.is_delta() {
            light_sample = sample_light(scene, v, path, ray.time, u, true);
        }
        match continue_path(path, v, ray.time, u, limits) {
            Some(next) => {
                *ray = next;
                true
            }
            None => false,
        }
    });
    (continues, light_sample)
}

/// How a path of `pt` (`NEE`: emission weighed by MIS against light sampling) or `pt-naive` arrives at
/// a vertex, guided or not.
#[inline]
pub(super) fn arrival<const NEE: bool>(limits: PathLimits) -> Arrival {
    Arrival {
        emission: Some(if NEE { EmissionWeight::Mis } else { EmissionWeight::One }),
        last_depth: limits.max_depth,
    }
}
