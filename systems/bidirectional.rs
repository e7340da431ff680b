//! Bidirectional path tracing's own systems (`bdpt`). A pass traces one light subpath per pixel,
//! keeping their non-delta vertices (`LightVertices`, by subpath index) and connecting each to the
//! camera; then one camera subpath per pixel, which at each vertex adds the emission it hit, sends
//! a light sample to the shadow stage, and connects to every kept vertex of the light subpath with
//! its pixel's index in its unit (SmallVCM's pairing). Tracing, light sampling's shadow rays, the camera splats
//! and handing out work are the other integrators' systems.
//!
//! | system | stage | reads | writes |
//! |---|---|---|---|
//! | `emit_light_subpaths` | Emit | `SceneResource`, `PhotonWork`, `LightPaths` | `PhotonRay`, `PhotonState`, `LightSubpath` |
//! | `scatter_light_subpaths` | Scatter | `PhotonHit`, `SceneResource`, `CameraResource`, `PhotonWork`, `LightVertices` | `PhotonRay`, `PhotonState`, `LightSubpath`, `CameraSplat` |
//! | `keep_light_vertices` | Gather, before `store_photons` | `PhotonState` | `LightSubpath`, `LightVertices` |
//! | `scatter_camera_subpaths` | Scatter | `PathHit`, `SceneResource`, `CameraResource`, `RenderConfig`, `LightVertices` | `PathRay`, `PathState`, `ShadowRay`, `CameraSubpath` |
//! | `connect_to_light_vertices` | Shadow | `CameraSubpath`, `LightVertices`, `SceneResource`, `RenderConfig` | `PathState` |

use super::components::{
    CameraSplat, CameraSubpath, LightSubpath, PathAov, PathHit, PathRay, PathState, PathStatus, PhotonHit,
    PhotonRay, PhotonState, ShadowRay,
};
use super::light_paths::LightPaths;
use super::resources::{
    CameraResource, PassRange, PhotonWork, RenderConfig, SceneResource, wavefront_batching,
};
use bevy_ecs::prelude::*;
use caustica_core::kernel::Quantity;
use caustica_core::kernel::bidirectional::camera_side::CameraStep;
use caustica_core::kernel::bidirectional::{
    LightVertex, MisFactors, camera_vertex, connect_vertices, emit_light_subpath, light_subpath_vertex,
    merge_vertices,
};
use caustica_core::kernel::photon::photon_time;
use caustica_core::materials::Bsdf;
use caustica_core::photon::hash_grid::HashGrid;
use glam::Vec3;
use std::sync::atomic::{AtomicU64, Ordering};

/// No vertex: the end of a subpath's chain.
const NONE: u32 = u32::MAX;

/// The light vertices of the pass's subpaths in one table, in the order they were kept (the
/// wavefront's steps, in entity order: the same for any thread count), each linked to its
/// subpath's previous one, with each subpath's last vertex by index; and the weights' factors.
/// Linked, not contiguous: an entity then holds one vertex, not a buffer as long as its longest
/// subpath (65 536 of those took 300 MB).
#[derive(Resource, Debug, Default)]
pub struct LightVertices {
    /// Light subpaths a unit (the pixels).
    pub light_paths: u32,
    /// vcm's merging radius sequence; none for bdpt.
    pub merging: Option<RadiusSequence>,
    /// Every kept vertex of the pass.
    pub vertices: Vec<LightVertex>,
    /// The BSDFs of the kept vertices that are not Lambertian, which keep their index here.
    pub bsdfs: Vec<Bsdf>,
    /// For each vertex, its subpath's previous one (`NONE` for the first).
    pub previous: Vec<u32>,
    /// Each subpath's last vertex, by index.
    pub last: Vec<u32>,
    /// vcm: each unit's vertices by cell, for merging.
    pub grids: Vec<HashGrid>,
    /// Connections between camera and light vertices made (segments traced).
    pub connections: AtomicU64,
    /// Light vertices merged with camera vertices (vcm).
    pub merges: AtomicU64,
    /// Light vertices kept.
    pub kept: u64,
}

/// vcm's merging radii: r_u = r₀ · u^((α − 1)/2) for unit u counted from one (Georgiev et al. 2012,
/// after Knaus & Zwicker 2011), a function of the unit alone, so parts and passes of any length
/// merge at the same radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusSequence {
    /// r₀.
    pub r0: f32,
    /// α.
    pub alpha: f32,
}

impl RadiusSequence {
    /// The radius of unit `unit` (from zero).
    pub fn radius(&self, unit: u32) -> f32 {
        self.r0 * ((unit as f64 + 1.0).powf((self.alpha as f64 - 1.0) / 2.0)) as f32
    }
}

impl LightVertices {
    /// The weights' factors of unit `unit`.
    #[inline]
    pub fn factors(&self, unit: u32) -> MisFactors {
        match self.merging {
            Some(radii) => MisFactors::merging(self.light_paths, radii.radius(unit)),
            None => MisFactors::connections_only(self.light_paths),
        }
    }

    /// The kept vertices of subpath `index` of this pass, last first.
    #[inline]
    pub fn subpath(&self, index: u32) -> impl Iterator<Item = &LightVertex> {
        let mut at = self.last.get(index as usize).copied().unwrap_or(NONE);
        std::iter::from_fn(move || {
            let vertex = self.vertices.get(at as usize)?;
            at = self.previous[at as usize];
            Some(vertex)
        })
    }
}

/// A system that empties the table for the pass's subpaths (keeping its memory).
pub fn begin_light_vertices(mut store: ResMut<LightVertices>) {
    store.vertices.clear();
    store.bsdfs.clear();
    store.previous.clear();
    store.last.fill(NONE);
}

/// Start a light subpath wherever an entity needs one, with its unit's own numbers.
pub fn emit_light_subpaths(
    scene: Res<SceneResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    mut paths: Query<(&mut PhotonRay, &mut PhotonState, &mut LightSubpath)>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(
        |(mut ray, mut state, mut subpath)| {
            if state.status != PathStatus::NeedsStart {
                return;
            }
            let sampler = light_paths.sampler(&work, state.index, false);
            let time = photon_time(work.time, work.motion, &sampler);
            match emit_light_subpath(&scene, &sampler, time) {
                Some((first, path, origin)) => {
                    ray.0 = first;
                    state.path = path;
                    subpath.origin = origin;
                    state.status = PathStatus::Active;
                }
                None => state.status = PathStatus::Finished,
            }
        },
    );
}

/// Weigh every active light subpath's vertex, keep it, connect it to the camera, and continue the
/// subpath or end it.
#[allow(clippy::type_complexity)]
pub fn scatter_light_subpaths(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    work: Res<PhotonWork>,
    light_paths: Res<LightPaths>,
    store: Res<LightVertices>,
    mut paths: Query<(&PhotonHit, &mut PhotonRay, &mut PhotonState, &mut CameraSplat, &mut LightSubpath)>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut splat, mut subpath)| {
            if state.status != PathStatus::Active {
                return;
            }
            let factors = store.factors(work.pass + state.index / light_paths.per_unit);
            state.bounces += 1;
            let sampler = light_paths.sampler(&work, state.index, false);
            let u_lens = light_paths.lens_sample(&work, &camera, state.index, state.path.depth);
            let subpath = &mut *subpath;
            let step = light_subpath_vertex(
                &scene,
                &camera,
                &factors,
                &work.settings,
                &subpath.origin,
                &mut subpath.mis,
                &mut state.path,
                &ray.0,
                &hit.0,
                &sampler,
                u_lens,
                &mut subpath.kept,
            );
            splat.0 = step.connection;
            state.roulette_kills += step.roulette_kill as u32;
            match step.next {
                Some(next) => ray.0 = next,
                None => state.status = PathStatus::Finished,
            }
        },
    );
}

/// Append this bounce's kept vertices to the pass's table, and record the last vertex of every
/// subpath that ended under its index.
pub fn keep_light_vertices(
    mut store: ResMut<LightVertices>,
    mut paths: Query<(&PhotonState, &mut LightSubpath)>,
) {
    let store = &mut *store;
    for (state, mut subpath) in &mut paths {
        // Only a subpath that moved this step has kept anything: the others' 370-byte components
        // stay unread (the tail of a pass has few subpaths left among 65 536 entities).
        if !matches!(state.status, PathStatus::Active | PathStatus::Finished) {
            continue;
        }
        if let Some(vertex) = subpath.kept.take() {
            store.previous.push(subpath.last);
            subpath.last = store.vertices.len() as u32;
            let vertex = vertex.keep(&mut store.bsdfs);
            store.vertices.push(vertex);
            store.kept += 1;
        }
        if state.status == PathStatus::Finished && subpath.last != NONE {
            if let Some(last) = store.last.get_mut(state.index as usize) {
                *last = subpath.last;
            }
            subpath.last = NONE;
        }
    }
}

/// One vertex of every active camera subpath: emission and the sky, weighted; its light sample to
/// the shadow stage; its vertex to the connection stage; its continuation.
#[allow(clippy::type_complexity)]
pub fn scatter_camera_subpaths(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    config: Res<RenderConfig>,
    store: Res<LightVertices>,
    mut paths: Query<(
        &PathHit,
        &mut PathRay,
        &mut PathState,
        &mut ShadowRay,
        &mut CameraSubpath,
        Option<&mut PathAov>,
    )>,
) {
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(
        |(hit, mut ray, mut state, mut shadow, mut subpath, mut aov)| {
            if state.status != PathStatus::Active {
                return;
            }
            let factors = store.factors(state.sample);
            state.rays += 1;
            let state = &mut *state;
            let subpath = &mut *subpath;
            let mut step = CameraStep { shadow: None, vertex: &mut subpath.vertex };
            let goes_on = camera_vertex(
                &scene,
                &camera,
                &factors,
                config.limits,
                &mut ray.0,
                &hit.0,
                &mut state.path,
                &mut subpath.mis,
                state.sampler,
                aov.as_deref_mut().map(|a| &mut a.0),
                &mut step,
            );
            if let Some(sample) = step.shadow {
                shadow.queue(sample);
            }
            if !goes_on {
                state.status = PathStatus::Finished;
            }
        },
    );
}

/// Connect every camera vertex left this bounce to each kept vertex of its pixel's light subpath,
/// adding what each free segment carries (paths of at most `max_depth` bounces); with merging
/// (vcm), also merge it with every light vertex of its unit within the unit's radius.
pub fn connect_to_light_vertices(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    range: Res<PassRange>,
    light_paths: Res<LightPaths>,
    store: Res<LightVertices>,
    mut paths: Query<(&PathRay, &mut PathState, &mut CameraSubpath)>,
) {
    let max_depth = config.limits.max_depth as u64;
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(ray, mut state, mut subpath)| {
        let Some(c) = subpath.vertex.take() else { return };
        let factors = store.factors(state.sample);
        let mut traced = 0;
        // The light subpath of the same unit and pixel.
        let unit_in_pass = state.sample - range.begin;
        let index = unit_in_pass * light_paths.per_unit + state.pixel;
        for l in store.subpath(index) {
            if (c.depth as u64 + l.depth as u64 + 2) > max_depth {
                continue;
            }
            let Some((segment, contribution)) =
                connect_vertices(&scene, &factors, &c, (l, &store.bsdfs), ray.0.time)
            else {
                continue;
            };
            traced += 1;
            if !scene.geometry.occluded(&segment) {
                state.path.add(contribution, Quantity::Connection);
            }
        }
        state.shadow_rays += traced;
        store.connections.fetch_add(traced as u64, Ordering::Relaxed);
        let Some(grid) = store.grids.get(unit_in_pass as usize).filter(|_| factors.merges()) else { return };
        let (radius, mut merged, mut sum) = (factors.radius, 0u64, Vec3::ZERO);
        grid.for_each_within(c.v.si.p, radius, |id| {
            let l = &store.vertices[id as usize];
            // The merged vertex is both subpaths' last: c.depth + l.depth + 1 bounces.
            if c.depth as u64 + l.depth as u64 + 1 > max_depth {
                return;
            }
            sum += merge_vertices(&factors, &c, l);
            merged += 1;
        });
        if merged > 0 {
            state.path.add(sum * factors.merge_normalization(), Quantity::Merge);
            store.merges.fetch_add(merged, Ordering::Relaxed);
        }
    });
}

/// vcm: sort each unit's light vertices of the pass into its grid, at the unit's radius (before the
/// camera subpaths, which merge with them).
pub fn build_merge_grids(
    range: Res<PassRange>,
    light_paths: Res<LightPaths>,
    mut store: ResMut<LightVertices>,
) {
    let Some(radii) = store.merging else { return };
    let units = (range.end - range.begin) as usize;
    let store = &mut *store;
    store.grids.resize_with(units.max(store.grids.len()), HashGrid::default);
    let mut points = Vec::new();
    for k in 0..units {
        points.clear();
        let subpaths = k as u32 * light_paths.per_unit..(k as u32 + 1) * light_paths.per_unit;
        for index in subpaths {
            let mut at = store.last.get(index as usize).copied().unwrap_or(NONE);
            while let Some(vertex) = store.vertices.get(at as usize) {
                points.push((at, vertex.p));
                at = store.previous[at as usize];
            }
        }
        store.grids[k].build(&points, radii.radius(range.begin + k as u32));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit k (counted from one) merges at r₀ · k^((α − 1)/2): the radius that sets the variance and
    /// bias rates (tests/caustics.rs renders both), and the weights of a unit use its own radius.
    #[test]
    fn unit_k_merges_at_r0_times_k_to_the_power_alpha_minus_one_over_two() {
        let radii = RadiusSequence { r0: 0.02, alpha: 2.0 / 3.0 };
        for unit in [0u32, 1, 2, 7, 63, 999, 1_000_000] {
            let k = unit as f64 + 1.0;
            let want = 0.02 * k.powf((2.0 / 3.0 - 1.0) / 2.0);
            let got = radii.radius(unit) as f64;
            assert!((got - want).abs() <= 1e-6 * want, "unit {unit}: radius {got}, want {want}");
        }
        // 64^(−1/6) = ½: the 64th unit merges at half the first's radius.
        assert!((radii.radius(63) - 0.01).abs() < 1e-8);
        assert_eq!(RadiusSequence { r0: 0.02, alpha: 1.0 }.radius(500), 0.02, "α = 1 keeps r₀");
        let store = LightVertices { light_paths: 256, merging: Some(radii), ..LightVertices::default() };
        for unit in [0u32, 5, 63] {
            let factors = store.factors(unit);
            assert_eq!(factors.radius, radii.radius(unit), "unit {unit}'s weights use its radius");
            assert_eq!(factors, MisFactors::merging(256, radii.radius(unit)));
        }
        let bdpt = LightVertices { light_paths: 256, ..LightVertices::default() };
        assert!(!bdpt.factors(9).merges(), "bdpt merges nothing");
    }
}
