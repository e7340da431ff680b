//! Path tracing: `pt` (next-event estimation + MIS) and `pt-naive` (BSDF sampling only).
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `integrator` | `pt` \| `pt-naive` | `pt` | light sampling with MIS, or BSDF sampling alone |
//! | `spp` | u32 | 64 | samples per pixel |
//! | `max_depth` | u32 or none | none | maximum bounces; none = unbounded, Russian roulette ends paths |
//! | `rr_depth` | u32 | 5 | first bounce at which Russian roulette may end a path |
//! | `light_selection` | `uniform` \| `power` | `power` | how NEE picks a light |
//! | `seed` | u64 | 0 | sampler seed |
//!
//! The schedule is built from the scene: the camera system draws lens and time samples only when the
//! camera has an aperture or something moves, and `pt` drops light sampling when there is no light.

use crate::scene::IntegratorKind;
use crate::PassSystems;
use crate::emit::emit_camera_paths_for;
use crate::gather::splat_paths_to_film;
use crate::resources::SceneFeatures;
use crate::scatter::scatter_paths;
use crate::trace::{trace_paths, trace_shadow_rays};
use bevy_ecs::prelude::*;

/// Add the path tracer's systems to `schedule` (the host's or our own), in the default stage order.
pub fn build(schedule: &mut Schedule, features: SceneFeatures, kind: IntegratorKind) {
    build_ordered(schedule, features, crate::scene::schedule::CYCLE, kind == IntegratorKind::Pt);
}

/// As [`build`], with the stages in `order` (a rotation of the cycle) and light sampling on or off.
pub fn build_ordered(
    schedule: &mut Schedule,
    features: SceneFeatures,
    order: [crate::scene::schedule::Stage; 5],
    nee: bool,
) {
    super::configure_stages(schedule, order);
    schedule.add_systems(emit_camera_paths_for(features).in_set(PassSystems::Emit));
    schedule.add_systems(trace_paths.in_set(PassSystems::Trace));
    if nee && features.lights {
        schedule.add_systems(scatter_paths::<true>.in_set(PassSystems::Scatter));
        schedule.add_systems(trace_shadow_rays.in_set(PassSystems::Shadow));
        if features.learns_visibility {
            schedule.add_systems(
                crate::gather::learn_light_visibility
                    .before(splat_paths_to_film)
                    .in_set(PassSystems::Gather),
            );
        }
    } else {
        schedule.add_systems(scatter_paths::<false>.in_set(PassSystems::Scatter));
    }
    schedule.add_systems(splat_paths_to_film.in_set(PassSystems::Gather));
}
