//! Probabilistic progressive photon mapping, `pppm` (Knaus & Zwicker 2011, "Progressive photon
//! mapping: a probabilistic approach").
//!
//! Parameters: the `[progressive]` table (see `integrators::progressive`). The camera and photon
//! passes are `sppm`'s. What differs: no hit point carries statistics from one pass to the next.
//! Pass i gathers at the global radius r_i² = r₀² Π_{j≤i} (j + α)/(j + 1) (their eq. 16, the same
//! sequence `appm` bands its radii by) and adds its estimate Φ_i / (π r_i²) to the film, whose
//! fixed-point sums average the passes. So any set of passes can be rendered anywhere and merged
//! (`caustica render --part`): the radius and the random numbers of pass i are functions of i alone.
//!
//! The first radius must be one too, so it cannot be `sppm`'s cap from the first pass's hit points
//! (a share that starts at pass 40 has not seen them): it is the same cap computed from rays
//! through the centres of a grid of at most 64 × 64 pixels, traced when the render is prepared.

use super::descriptor::Integrator;
use super::progressive::{self, Variant};
use crate::components::{HitPoint, PathState};
use crate::gather::{build_pass_photon_map, gather_photons_into_hit_points};
use crate::plan::Plan;
use crate::resources::{
    CameraResource, FilmResource, ProgressiveConfig, SceneFeatures, SceneResource, wavefront_batching,
};
use crate::stages::PassSystems;
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::film::fixed;
use caustica_core::photon::progressive::{
    RadiusRule, global_radius2, pass_estimate, probe_hit_distances, radius_cap,
};
use caustica_core::scene::{IntegratorKind, RunFile};

/// `pppm`: independent passes at a global radius sequence: the film is the whole state, so passes split
/// across machines and a checkpoint holds the film only.
pub static PPPM: Integrator =
    Integrator { film_is_the_state: true, ..progressive::descriptor(IntegratorKind::Pppm, plan) };

/// The plan of `pppm`: `sppm`'s camera and photon passes, a gather at the pass's global radius, and
/// the pass's estimate added to the film.
fn plan(this: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let variant = Variant {
        rule: RadiusRule::Global,
        statistics: |schedule| {
            schedule.add_systems(
                (set_global_radius, build_pass_photon_map, gather_photons_into_hit_points)
                    .chain()
                    .in_set(PassSystems::Gather),
            );
            schedule.add_systems(add_pass_estimates_to_film.in_set(PassSystems::Update));
        },
    };
    let plan = progressive::plan(this, world, run, features, variant)?;
    if run.progressive.initial_radius.is_none() {
        fix_initial_radius(world);
    }
    // From here r₀ is a function of the scene and camera alone; the first pass must not change it.
    world.resource_mut::<ProgressiveConfig>().r0_given = true;
    Ok(plan)
}

/// Cap the heuristic r₀ by pixel footprints at the median distance of pixel-centre hits.
fn fix_initial_radius(world: &mut World) {
    let distances = {
        let camera = world.resource::<CameraResource>();
        probe_hit_distances(camera, &world.resource::<SceneResource>().geometry)
    };
    let camera = world.resource::<CameraResource>();
    let cap = radius_cap(camera, distances);
    let mut config = world.resource_mut::<ProgressiveConfig>();
    if let Some(cap) = cap.filter(|&cap| cap < config.r0) {
        config.r0 = cap;
    }
}

/// Every hit point gathers at the radius of the pass's number in the whole render.
pub fn set_global_radius(config: Res<ProgressiveConfig>, mut hit_points: Query<&mut HitPoint>) {
    let r2 = global_radius2(config.r0, config.pass, config.alpha);
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|mut hp| {
        hp.r2 = r2;
    });
}

/// Add each hit point's estimate of this pass, Φ / (π r²), to its pixel's sums (not its sample
/// count: the camera pass counted the sample when it splatted the direct light), and clear the pass.
pub fn add_pass_estimates_to_film(
    film: Res<FilmResource>,
    mut hit_points: Query<(&PathState, &mut HitPoint)>,
) {
    hit_points.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(state, mut hp)| {
        if hp.m > 0 {
            let l = pass_estimate(hp.phi, hp.r2);
            if fixed::accepts(l) {
                film.add_sums(
                    state.pixel,
                    [fixed::to_fixed(l.x), fixed::to_fixed(l.y), fixed::to_fixed(l.z)],
                    0,
                );
            }
        }
        hp.m = 0;
        hp.phi = glam::Vec3::ZERO;
    });
}
