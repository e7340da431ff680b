//! Bidirectional path tracing's own systems (`bdpt`, `vcm`). A pass traces one light subpath per
//! pixel on the vector core (`crate::light_subpaths::bidirectional`), keeping their non-delta
//! vertices (`LightVertices`, by subpath index) and connecting each to the camera; then one camera
//! subpath per pixel, on the vector core's camera paths (a shard's chunk at a time,
//! `crate::camera_paths`), which at each vertex adds the emission it hit, sends a light sample to
//! the shadow queue, and connects to every kept vertex of the light subpath with its pixel's index
//! in its unit (SmallVCM's pairing), the shards reading the pass's light vertices shared. Tracing,
//! light sampling's shadow rays, the camera splats and handing out work are the other integrators'
//! systems.
//!
//! | system | stage | reads | writes |
//! |---|---|---|---|
//! | `begin_light_vertices` | the light phase's begin | | `LightVertexStore` (emptied) |
//! | light subpaths (shards) | `crate::light_subpaths::bidirectional` | | `LightVertexStore` (each round's kept vertices, folded) |
//! | `order_light_vertices` | the camera phase's begin | | `LightVertexStore` (each subpath's vertices side by side) |
//! | `build_merge_grids` (vcm) | the camera phase's begin, after ordering | `PassRange`, `LightPaths` | `LightVertexStore`'s grids |
//! | `scatter_camera_subpaths` (shards) | Scatter | `PathHit`, `PathSampler`, `PathSample`, `SceneResource`, `CameraResource`, `RenderConfig`, `LightVertexStore` | `PathRay`, `PathThroughput`, `PathShadow`, `CameraSubpathSums`, `ConnectionVertex`, the queues |
//! | `connect_to_light_vertices` (shards) | Shadow, after `trace_shadow_rays` | `PathRay`, `PathSample`, `LightVertexStore`, `SceneResource`, `RenderConfig` | `PathThroughput`, `ConnectionVertex` |

use super::camera_paths::{PathQueues, PathSample, PathSampler, PathShadow, PathThroughput};
use super::components::{PathAov, PathHit, PathRay};
use super::light_paths::LightPaths;
use super::resources::{CameraResource, PassRange, RenderConfig, RenderStats, SceneResource};
use bevy_ecs::prelude::*;
use caustica_core::kernel::Quantity;
use caustica_core::kernel::bidirectional::camera_side::CameraStep;
use caustica_core::kernel::bidirectional::{
    CameraVertex, LightVertex, MergeVertex, MisFactors, SubpathMis, camera_vertex, connect_vertices,
    merge_vertices,
};
use caustica_core::materials::Bsdf;
use caustica_core::photon::hash_grid::HashGrid;
use glam::Vec3;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// The light vertices of the pass's subpaths in one table, subpath by subpath, and the weights'
/// factors. The light phase appends them in the order they are kept (a bounce of every subpath at a
/// time), each with its subpath's index, so an entity holds one vertex, not a buffer as long as its
/// longest subpath; [`order_light_vertices`] then puts each subpath's vertices side by side, in
/// place, so a camera vertex reads its light subpath in one run (linked through the table, each
/// vertex was a cache miss, a third of vcm's connection stage), and consecutive pixels read
/// consecutive runs.
#[derive(Debug, Default)]
pub struct LightVertices {
    /// Light subpaths a unit (the pixels).
    pub light_paths: u32,
    /// vcm's merging radius sequence; none for bdpt.
    pub merging: Option<RadiusSequence>,
    /// Every kept vertex of the pass.
    pub vertices: Vec<LightVertex>,
    /// The BSDFs of the kept vertices that are not Lambertian, which keep their index here.
    pub bsdfs: Vec<Bsdf>,
    /// While the light phase keeps them: each vertex's subpath, by its index in the pass.
    pub owners: Vec<u32>,
    /// Once ordered: where each subpath's vertices start (one more entry than subpaths).
    pub starts: Vec<u32>,
    /// Subpaths in the pass.
    pub subpaths: u32,
    /// vcm: each unit's vertices by cell (what a merge reads of them), for merging.
    pub grids: Vec<HashGrid<MergeVertex>>,
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

/// What the weights' factors of a unit follow from: the subpaths a unit, and vcm's radii. The
/// light subpaths' shards read this, not the pass's table (which the main World writes between
/// their rounds).
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct SubpathWeights {
    /// Light subpaths a unit (the pixels).
    pub light_paths: u32,
    /// vcm's merging radius sequence; none for bdpt.
    pub merging: Option<RadiusSequence>,
}

impl SubpathWeights {
    /// The weights' factors of unit `unit`.
    #[inline]
    pub fn factors(&self, unit: u32) -> MisFactors {
        match self.merging {
            Some(radii) => MisFactors::merging(self.light_paths, radii.radius(unit)),
            None => MisFactors::connections_only(self.light_paths),
        }
    }
}

impl LightVertices {
    /// What the weights' factors follow from.
    #[inline]
    pub fn weights(&self) -> SubpathWeights {
        SubpathWeights { light_paths: self.light_paths, merging: self.merging }
    }

    /// The weights' factors of unit `unit`.
    #[inline]
    pub fn factors(&self, unit: u32) -> MisFactors {
        self.weights().factors(unit)
    }

    /// The kept vertices of subpath `index` of this pass, first first (once ordered).
    #[inline]
    pub fn subpath(&self, index: u32) -> &[LightVertex] {
        let i = index as usize;
        match (self.starts.get(i), self.starts.get(i + 1)) {
            (Some(&start), Some(&end)) => &self.vertices[start as usize..end as usize],
            _ => &[],
        }
    }

    /// Put each subpath's vertices side by side in subpath order, each subpath's in the order kept
    /// (its bounces'), in place: a counting sort of the owners into destinations, then the
    /// permutation's cycles followed with swaps (a second table would double the largest buffer
    /// of the pass).
    pub fn order_by_subpath(&mut self) {
        let subpaths = self.subpaths as usize;
        self.starts.clear();
        self.starts.resize(subpaths + 1, 0);
        for &owner in &self.owners {
            self.starts[owner as usize + 1] += 1;
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        // Each vertex's place, written over its owner; `starts[s]` walks past subpath s's places.
        let mut destinations = std::mem::take(&mut self.owners);
        for owner in &mut destinations {
            let next = &mut self.starts[*owner as usize];
            *owner = *next;
            *next += 1;
        }
        // Now starts[s] is where subpath s + 1 starts: shift back by one.
        self.starts.copy_within(0..subpaths, 1);
        self.starts[0] = 0;
        for i in 0..destinations.len() {
            loop {
                let to = destinations[i] as usize;
                if to == i {
                    break;
                }
                self.vertices.swap(i, to);
                destinations.swap(i, to);
            }
        }
        destinations.clear();
        self.owners = destinations;
    }
}

/// The pass's [`LightVertices`] as a resource the camera subpaths' shards share for a round
/// (`ShardLink::share`: a clone is a reference). Between rounds only the main World holds it, and
/// the light phase writes it.
#[derive(Resource, Clone, Debug, Default)]
pub struct LightVertexStore(Arc<LightVertices>);

impl LightVertexStore {
    /// A store of `vertices`.
    pub fn new(vertices: LightVertices) -> Self {
        Self(Arc::new(vertices))
    }

    /// The tables, to write: only between rounds, when no shard holds them.
    pub fn tables_mut(&mut self) -> &mut LightVertices {
        Arc::get_mut(&mut self.0).expect("the light vertices are written only while no shard reads them")
    }
}

impl std::ops::Deref for LightVertexStore {
    type Target = LightVertices;
    fn deref(&self) -> &LightVertices {
        &self.0
    }
}

/// A system that empties the table for the pass's subpaths (keeping its memory).
pub fn begin_light_vertices(mut store: ResMut<LightVertexStore>) {
    let store = store.tables_mut();
    store.vertices.clear();
    store.bsdfs.clear();
    store.owners.clear();
    store.starts.clear();
}

/// A system that orders the pass's light vertices by subpath ([`LightVertices::order_by_subpath`]),
/// between the light phase that keeps them and the camera phase that reads them.
pub fn order_light_vertices(mut store: ResMut<LightVertexStore>) {
    store.tables_mut().order_by_subpath();
}

/// A camera subpath's running MIS sums at its last vertex (on the vector core's camera paths).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct CameraSubpathSums(pub SubpathMis);

/// The camera vertex a bounce leaves for the connection stage, if it is not a delta one.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ConnectionVertex(pub Option<CameraVertex>);

/// The rows whose vertex waits for its connections and merges.
#[derive(Resource, Debug, Default)]
pub struct ConnectionQueue(pub Vec<u32>);

/// Add the camera subpaths' own columns to every camera path of a shard (spawned by
/// `camera_paths::spawn_chunk`), and their queue.
pub fn add_camera_subpath_columns(world: &mut World) {
    let rows: Vec<Entity> = world.query_filtered::<Entity, With<PathRay>>().iter(world).collect();
    for row in rows {
        world.entity_mut(row).insert((CameraSubpathSums::default(), ConnectionVertex::default()));
    }
    world.insert_resource(ConnectionQueue::default());
}

/// What the camera subpaths' scatter reads and writes.
type CameraSubpathColumns = (
    &'static PathHit,
    &'static PathSample,
    &'static PathSampler,
    &'static mut PathRay,
    &'static mut PathThroughput,
    &'static mut PathShadow,
    &'static mut CameraSubpathSums,
    &'static mut ConnectionVertex,
    Option<&'static mut PathAov>,
);

/// One vertex of every active camera subpath of the shard: emission and the sky, weighted; its light
/// sample to the shadow queue; its vertex to the connection queue; its continuation (active) or its
/// end (finished).
pub fn scatter_camera_subpaths(
    scene: Res<SceneResource>,
    camera: Res<CameraResource>,
    config: Res<RenderConfig>,
    store: Res<LightVertexStore>,
    mut queues: ResMut<PathQueues>,
    mut connections: ResMut<ConnectionQueue>,
    mut paths: Query<CameraSubpathColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((hits, samples, samplers, mut rays, mut states, mut shadows, mut sums, mut vertices, mut aovs)) =
        tables.next()
    else {
        return;
    };
    let (rays, states, shadows) =
        (rays.bypass_change_detection(), states.bypass_change_detection(), shadows.bypass_change_detection());
    let (sums, vertices) = (sums.bypass_change_detection(), vertices.bypass_change_detection());
    let mut aovs = aovs.as_mut().map(|a| a.bypass_change_detection());
    queues.advance_active(|row, shadow_queue| {
        let i = row as usize;
        let factors = store.factors(samples[i].sample);
        let mut step = CameraStep { shadow: None, vertex: &mut vertices[i].0 };
        let goes_on = camera_vertex(
            &scene,
            &camera,
            &factors,
            config.limits,
            &mut rays[i].0,
            &hits[i].0,
            &mut states[i].0,
            &mut sums[i].0,
            samplers[i].0,
            aovs.as_deref_mut().map(|a| &mut a[i].0),
            &mut step,
        );
        if let Some(sample) = step.shadow {
            shadows[i] = PathShadow { ray: sample.ray, contribution: sample.contribution };
            shadow_queue.push(row);
        }
        if vertices[i].0.is_some() {
            connections.0.push(row);
        }
        goes_on
    });
}

/// Connect every queued camera vertex to each kept vertex of its pixel's light subpath, adding what
/// each free segment carries (paths of at most `max_depth` bounces); with merging (vcm), also merge
/// it with every light vertex of its unit within the unit's radius.
pub fn connect_to_light_vertices(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    range: Res<PassRange>,
    store: Res<LightVertexStore>,
    mut stats: ResMut<RenderStats>,
    mut connections: ResMut<ConnectionQueue>,
    mut paths: Query<(&PathRay, &PathSample, &mut PathThroughput, &mut ConnectionVertex)>,
) {
    if connections.0.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((rays, samples, mut states, mut vertices)) = tables.next() else { return };
    let (states, vertices) = (states.bypass_change_detection(), vertices.bypass_change_detection());
    let max_depth = config.limits.max_depth as u64;
    let (mut traced, mut merged_all) = (0u64, 0u64);
    for &row in &connections.0 {
        let i = row as usize;
        let Some(c) = vertices[i].0.take() else { continue };
        let path = &mut states[i].0;
        let PathSample { pixel, sample } = samples[i];
        let factors = store.factors(sample);
        // The light subpath of the same unit and pixel.
        let unit_in_pass = sample - range.begin;
        let index = unit_in_pass * store.light_paths + pixel;
        // Last first: the order the sums have always been made in.
        for l in store.subpath(index).iter().rev() {
            if (c.depth as u64 + l.depth as u64 + 2) > max_depth {
                continue;
            }
            let Some((segment, contribution)) =
                connect_vertices(&scene, &factors, &c, (l, &store.bsdfs), rays[i].0.time)
            else {
                continue;
            };
            traced += 1;
            if !scene.geometry.occluded(&segment) {
                path.add(contribution, Quantity::Connection);
            }
        }
        let Some(grid) = store.grids.get(unit_in_pass as usize).filter(|_| factors.merges()) else {
            continue;
        };
        let (radius, mut merged, mut sum) = (factors.radius, 0u64, Vec3::ZERO);
        grid.for_each_within(c.v.si.p, radius, |l| {
            // The merged vertex is both subpaths' last: c.depth + l.depth + 1 bounces.
            if c.depth as u64 + l.depth as u64 + 1 > max_depth {
                return;
            }
            sum += merge_vertices(&factors, &c, l);
            merged += 1;
        });
        if merged > 0 {
            path.add(sum * factors.merge_normalization(), Quantity::Merge);
            merged_all += merged;
        }
    }
    connections.0.clear();
    stats.shadow_rays += traced;
    store.connections.fetch_add(traced, Ordering::Relaxed);
    store.merges.fetch_add(merged_all, Ordering::Relaxed);
}

/// vcm: sort each unit's light vertices of the pass into its grid, at the unit's radius (before the
/// camera subpaths, which merge with them).
pub fn build_merge_grids(
    range: Res<PassRange>,
    light_paths: Res<LightPaths>,
    mut store: ResMut<LightVertexStore>,
) {
    let Some(radii) = store.merging else { return };
    let units = (range.end - range.begin) as usize;
    let store = store.tables_mut();
    store.grids.resize_with(units.max(store.grids.len()), HashGrid::default);
    // The grids out of the table while they are built from it.
    let mut grids = std::mem::take(&mut store.grids);
    let vertices = &*store;
    for (k, grid) in grids.iter_mut().enumerate().take(units) {
        let subpaths = k as u32 * light_paths.per_unit..(k as u32 + 1) * light_paths.per_unit;
        // Each subpath last first: the order of the grid's cells that merges have been summed in.
        let points = || {
            subpaths
                .clone()
                .flat_map(|index| vertices.subpath(index).iter().rev().map(LightVertex::merge_vertex))
        };
        grid.build_from(points, radii.radius(range.begin + k as u32));
    }
    store.grids = grids;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vertices kept bounce by bounce, in any order of subpaths come out subpath by subpath, each
    /// subpath's in the order it kept them, and a subpath that kept nothing has none.
    #[test]
    fn ordering_puts_each_subpaths_vertices_side_by_side_in_the_order_kept() {
        use caustica_core::kernel::bidirectional::KeptBsdf;
        use caustica_core::sampling::warp::Frame;
        let vertex = |subpath: u32, bounce: u32| LightVertex {
            p: Vec3::new(subpath as f32, bounce as f32, 0.0),
            p_error: Vec3::ZERO,
            ng: Vec3::Z,
            frame: Frame { x: Vec3::X, y: Vec3::Y, z: Vec3::Z },
            wo: Vec3::Z,
            bsdf: KeptBsdf::Lambert(Vec3::ONE),
            beta: Vec3::ONE,
            mis: SubpathMis::default(),
            depth: bounce,
        };
        // Bounce 0 of subpaths 4, 0, 2, 5; bounce 1 of 2, 4; bounce 2 of 4 (subpaths 1 and 3 keep none).
        let kept = [(4, 0), (0, 0), (2, 0), (5, 0), (2, 1), (4, 1), (4, 2)];
        let mut store = LightVertices { subpaths: 6, ..LightVertices::default() };
        for (subpath, bounce) in kept {
            store.vertices.push(vertex(subpath, bounce));
            store.owners.push(subpath);
        }
        store.order_by_subpath();
        for subpath in 0..6u32 {
            let bounces: Vec<u32> = store.subpath(subpath).iter().map(|v| v.depth).collect();
            let want: Vec<u32> = kept.iter().filter(|k| k.0 == subpath).map(|k| k.1).collect();
            assert_eq!(bounces, want, "subpath {subpath}");
            assert!(
                store.subpath(subpath).iter().all(|v| v.p.x == subpath as f32),
                "subpath {subpath}'s own"
            );
        }
        assert!(store.subpath(6).is_empty() && store.owners.is_empty());
        assert_eq!(store.starts, vec![0, 1, 1, 3, 3, 6, 7]);
    }

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
