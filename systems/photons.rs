//! The photon pass of photon mapping (Jensen 2001): photons are entities that go through
//! Emit → Trace → Scatter → Store, one bounce per run of the photon schedule.
//!
//! | system | reads | writes |
//! |---|---|---|
//! | `emit_photons` | `SceneGeometry` (lights), `PhotonWork` | `PhotonRay`, `PhotonState` (new photon) |
//! | `trace_photons` | `SceneGeometry`, `PhotonRay` | `PhotonHit` |
//! | `scatter_photons` | `PhotonHit`, `SceneGeometry`, `PhotonWork` | `PhotonRay`, `PhotonState` (deposit, power) |
//! | `store_photons` | deposits | `PhotonBuffer`, `PhotonStats`, `PhotonWork` (next photon) |
//!
//! Emission picks a light in proportion to its power and a cosine-weighted direction, so every photon
//! leaves with the same luminance power ΔΦ = Φ / n. At each hit Russian roulette keeps the photon with
//! the surface's reflectivity and divides by it, so surviving photons keep roughly that power.

use super::components::{PathStatus, PhotonHit, PhotonRay, PhotonState};
use super::resources::{PhotonBuffer, PhotonMapKind, PhotonStats, PhotonWork, SceneGeometry};
use crate::geometry::Ray;
use crate::geometry::offset::offset_ray_origin;
use crate::materials::{Bsdf, TransportMode};
use crate::photon::Photon;
use crate::sampling::Sampler;
use crate::sampling::warp::Frame;
use bevy_ecs::prelude::*;

/// Sampler dimensions of a photon: 6 at emission, then 4 per bounce.
mod dim {
    pub const TIME: u32 = 0;
    pub const LIGHT: u32 = 1;
    pub const POSITION: u32 = 2;
    pub const DIRECTION: u32 = 4;
    pub const FIRST_BOUNCE: u32 = 6;
    pub const PER_BOUNCE: u32 = 4;
    pub const LOBE: u32 = 0;
    pub const BSDF: u32 = 1;
    pub const ROULETTE: u32 = 3;
}

/// Highest survival probability once Russian roulette is in force: bounds the length of photon paths
/// trapped between lossless surfaces (glass, mirrors).
const MAX_SURVIVAL: f32 = 0.95;

fn photon_sampler(work: &PhotonWork, index: u32) -> Sampler {
    // The map kind keeps the caustic and global passes' photons independent of each other, and the
    // pass number those of successive progressive passes.
    Sampler::new(work.seed ^ ((work.pass as u64) << 32), index, (work.kind as u32 + 1) << 16)
}

/// Start photons on lights wherever an entity needs one.
pub fn emit_photons(
    scene: Res<SceneGeometry>,
    work: Res<PhotonWork>,
    mut photons: Query<(&mut PhotonRay, &mut PhotonState)>,
) {
    photons.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(mut ray, mut state)| {
            if state.status != PathStatus::NeedsCamera {
                return;
            }
            let s = photon_sampler(&work, state.index);
            let time = match (work.time, work.motion) {
                (Some(time), _) => time,
                (None, true) => s.get1d(dim::TIME),
                (None, false) => 0.0,
            };
            let emitted = scene.lights.sample_emission(
                time,
                s.get1d(dim::LIGHT),
                s.get2d(dim::POSITION),
                s.get2d(dim::DIRECTION),
            );
            let state = &mut *state;
            state.depth = 0;
            state.specular_only = true;
            state.deposit = None;
            match emitted {
                Some((_, e)) => {
                    ray.0 = Ray {
                        o: offset_ray_origin(e.p, e.p.abs() * crate::geometry::offset::gamma(4), e.n, e.d),
                        d: e.d,
                        t_max: f32::INFINITY,
                        time,
                    };
                    state.power = e.weight / work.total as f32;
                    state.status = PathStatus::Active;
                }
                None => state.status = PathStatus::Finished,
            }
        },
    );
}

/// Closest hit of every flying photon.
pub fn trace_photons(
    scene: Res<SceneGeometry>,
    mut photons: Query<(&PhotonRay, &mut PhotonHit, &PhotonState)>,
) {
    photons.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(ray, mut hit, state)| {
            if state.status == PathStatus::Active {
                hit.0 = scene.geometry.intersect(&ray.0);
            }
        },
    );
}

/// Deposit the photon where the map wants it, then continue it by BSDF sampling or end it by
/// Russian roulette.
pub fn scatter_photons(
    scene: Res<SceneGeometry>,
    work: Res<PhotonWork>,
    mut photons: Query<(&PhotonHit, &mut PhotonRay, &mut PhotonState)>,
) {
    photons.par_iter_mut().batching_strategy(super::resources::wavefront_batching()).for_each(
        |(hit, mut ray, mut state)| {
            if state.status != PathStatus::Active {
                return;
            }
            scatter_one(&scene, &work, &hit.0, &mut ray.0, &mut state);
        },
    );
}

fn scatter_one(
    scene: &SceneGeometry,
    work: &PhotonWork,
    hit: &crate::geometry::bvh::Hit,
    ray: &mut Ray,
    state: &mut PhotonState,
) {
    state.bounces += 1;
    if !hit.is_hit() {
        state.status = PathStatus::Finished;
        return;
    }
    let si = scene.geometry.surface_hit(ray, hit);
    let bsdf = Bsdf::new(&scene.shading_params(&si));
    let wo_world = -ray.d;
    let diffuse = !bsdf.is_delta();
    // A photon on a black surface lights nothing there, and stored it would only leak into the
    // estimates of surfaces within a gather radius (the front of a thin wall with a light behind it).
    if diffuse && bsdf.reflects_nothing() {
        state.status = PathStatus::Finished;
        return;
    }
    if diffuse {
        // Photons are stored only where the BSDF is not a pure delta (Jensen 2001, §7.2).
        let store = match work.kind {
            PhotonMapKind::Caustic => state.depth > 0 && state.specular_only,
            PhotonMapKind::Indirect => state.depth > 0 && !state.specular_only,
            PhotonMapKind::Global => true,
            PhotonMapKind::Bounced => state.depth > 0,
        };
        if store {
            // The normal of the side the photon arrived on, so the estimate can tell the two sides apart.
            let n = if wo_world.dot(si.ng) >= 0.0 { si.ng } else { -si.ng };
            state.deposit = Some(Photon::new(si.p, wo_world, n, state.power));
        }
        if work.kind == PhotonMapKind::Caustic {
            // L S+ D ends at its first diffuse vertex.
            state.status = PathStatus::Finished;
            return;
        }
    }
    if state.depth + 1 >= work.max_depth {
        state.status = PathStatus::Finished;
        return;
    }
    let s = photon_sampler(work, state.index);
    let base = dim::FIRST_BOUNCE + state.depth * dim::PER_BOUNCE;
    let frame = Frame::from_z(si.ns);
    let wo = frame.to_local(wo_world);
    let Some(bs) =
        bsdf.sample(wo, s.get1d(base + dim::LOBE), s.get2d(base + dim::BSDF), TransportMode::Importance)
    else {
        state.status = PathStatus::Finished;
        return;
    };
    // Survive with the surface's reflectivity (capped after rr_depth so lossless loops end).
    let reflectivity = bsdf.albedo_hint().max_element();
    let survive =
        if state.depth >= work.rr_depth { reflectivity.min(MAX_SURVIVAL) } else { reflectivity.min(1.0) };
    if s.get1d(base + dim::ROULETTE) >= survive {
        state.roulette_kills += 1;
        state.status = PathStatus::Finished;
        return;
    }
    let power = state.power * bs.f * (bs.wi.z.abs() / (bs.pdf * survive));
    if !power.is_finite() || power.max_element() <= 0.0 {
        state.status = PathStatus::Finished;
        return;
    }
    state.power = power;
    state.specular_only &= bs.is_specular;
    state.depth += 1;
    let wi_world = frame.to_world(bs.wi);
    *ray = Ray {
        o: offset_ray_origin(si.p, si.p_error, si.ng, wi_world),
        d: wi_world,
        t_max: f32::INFINITY,
        time: ray.time,
    };
}

/// Append this bounce's deposits to the photon buffer and hand finished entities their next photon.
/// One thread, entity order: the buffer's order, and so the maps, do not depend on the thread count.
pub fn store_photons(
    mut work: ResMut<PhotonWork>,
    mut buffer: ResMut<PhotonBuffer>,
    mut stats: ResMut<PhotonStats>,
    mut photons: Query<&mut PhotonState>,
) {
    let mut active = 0;
    for mut state in &mut photons {
        let state = &mut *state;
        if let Some(photon) = state.deposit.take() {
            buffer.photons.push(photon);
        }
        match state.status {
            PathStatus::Idle => continue,
            PathStatus::Active | PathStatus::NeedsCamera => {
                active += 1;
                continue;
            }
            PathStatus::Finished => {}
        }
        stats.traced += state.bounces as u64;
        stats.roulette_kills += state.roulette_kills as u64;
        state.bounces = 0;
        state.roulette_kills = 0;
        if work.next < work.total {
            state.index = work.next;
            work.next += 1;
            state.status = PathStatus::NeedsCamera;
            active += 1;
        } else {
            state.status = PathStatus::Idle;
        }
    }
    stats.active = active;
    stats.steps += 1;
}

/// Spawn `count` photon entities, idle until a pass hands them photons (numbered 0..count).
pub fn spawn_photon_wavefront(world: &mut World, count: u32, status: PathStatus) -> Vec<Entity> {
    world
        .spawn_batch((0..count).map(|index| {
            let state = PhotonState { index, status, ..Default::default() };
            (PhotonRay::default(), PhotonHit::default(), state)
        }))
        .collect()
}
