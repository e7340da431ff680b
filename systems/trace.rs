//! Trace: closest-hit queries for camera paths, any-hit queries for shadow rays, and the trace
//! counters of every stage.
//!
//! `trace_paths` reads `SceneResource`, `PathRay`, `PathState::status`; writes `PathHit`.
//! `trace_shadow_rays` reads `ShadowRay`; writes `PathState` (adds the contribution when the
//! segment is free). Photons and light subpaths (of every integrator that has them) are traced on
//! the vector core (`light_subpaths::trace_subpaths`), counted in its row.
//! With a [`TraceStatistics`] resource in the world (`--profile` inserts it) each stage also counts
//! its rays and the BVH nodes and leaves they visited; without it the counting compiles away.

use super::components::{PathHit, PathRay, PathState, PathStatus, ShadowRay};
use super::resources::{SceneResource, wavefront_batching};
use bevy_ecs::prelude::*;
use bevy_utils::Parallel;
use caustica_core::geometry::wide_bvh::TraceCounts;
use caustica_core::kernel::Quantity;

/// Find the closest hit of every active path's ray.
pub fn trace_paths(
    scene: Res<SceneResource>,
    statistics: Option<Res<TraceStatistics>>,
    mut paths: Query<(&PathRay, &mut PathHit, &PathState)>,
) {
    let statistics = statistics.as_deref();
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(ray, mut hit, state)| {
        if state.status != PathStatus::Active {
            return;
        }
        hit.0 = match statistics {
            None => scene.geometry.intersect(&ray.0),
            Some(statistics) => {
                statistics.count(&statistics.paths, |counts| scene.geometry.intersect_counted(&ray.0, counts))
            }
        };
    });
}

/// Test every pending shadow ray and add its contribution when nothing blocks it.
pub fn trace_shadow_rays(
    scene: Res<SceneResource>,
    statistics: Option<Res<TraceStatistics>>,
    mut paths: Query<(&mut ShadowRay, &mut PathState)>,
) {
    let statistics = statistics.as_deref();
    paths.par_iter_mut().batching_strategy(wavefront_batching()).for_each(|(mut shadow, mut state)| {
        if !shadow.pending {
            return;
        }
        shadow.pending = false;
        shadow.fresh = true;
        state.shadow_rays += 1;
        let occluded = match statistics {
            None => scene.geometry.occluded(&shadow.ray),
            Some(statistics) => statistics
                .count(&statistics.shadow, |counts| scene.geometry.occluded_counted(&shadow.ray, counts)),
        };
        shadow.visible = !occluded;
        if shadow.visible {
            state.path.add(shadow.contribution, Quantity::LightSample);
        }
    });
}

/// Rays of one trace stage and the BVH work they took, summed over a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalTotals {
    /// Rays traced.
    pub rays: u64,
    /// Inner nodes whose child boxes were tested.
    pub nodes: u64,
    /// Leaves (packs of eight triangles, or a sphere) whose primitives were tested.
    pub leaves: u64,
}

impl TraversalTotals {
    fn plus(&self, other: &TraversalTotals) -> TraversalTotals {
        TraversalTotals {
            rays: self.rays + other.rays,
            nodes: self.nodes + other.nodes,
            leaves: self.leaves + other.leaves,
        }
    }

    fn add(&mut self, counts: TraceCounts) {
        self.rays += 1;
        self.nodes += u64::from(counts.nodes);
        self.leaves += u64::from(counts.leaves);
    }

    /// Nodes per ray and leaves per ray (zero without rays).
    pub fn per_ray(&self) -> (f64, f64) {
        let rays = self.rays.max(1) as f64;
        (self.nodes as f64 / rays, self.leaves as f64 / rays)
    }
}

/// The trace stages' counters: present only when asked for (the profile), since counting costs a
/// thread-local lookup a ray. Each thread adds to its own totals; [`TraceStatistics::totals`] sums them.
#[derive(Resource, Default)]
pub struct TraceStatistics {
    paths: Parallel<TraversalTotals>,
    shadow: Parallel<TraversalTotals>,
    photons: Parallel<TraversalTotals>,
    /// Camera vertices shaded, by lane class (`kernel::lanes::LaneClass`, the scalar kernel last).
    vertices: Parallel<VertexTotals>,
}

/// Camera vertices shaded by each lane class (the scalar kernel's last), summed over a render.
pub type VertexTotals = [u64; caustica_core::kernel::lanes::CLASSES];

impl TraceStatistics {
    /// Run a camera-path query, counting its ray and the BVH work it took.
    #[inline]
    pub fn count_paths<R>(&self, query: impl FnOnce(&mut TraceCounts) -> R) -> R {
        self.count(&self.paths, query)
    }

    /// Run a shadow-ray query, counting as [`TraceStatistics::count_paths`] does.
    #[inline]
    pub fn count_shadow<R>(&self, query: impl FnOnce(&mut TraceCounts) -> R) -> R {
        self.count(&self.shadow, query)
    }

    /// Run a photon's (or light subpath's) query, counting as [`TraceStatistics::count_paths`] does.
    #[inline]
    pub fn count_photons<R>(&self, query: impl FnOnce(&mut TraceCounts) -> R) -> R {
        self.count(&self.photons, query)
    }

    /// Count camera vertices by class (`counts[class]`).
    #[inline]
    pub fn count_vertices(&self, count: impl FnOnce(&mut VertexTotals)) {
        self.vertices.scope(count);
    }

    /// Camera vertices shaded by each class so far.
    pub fn vertex_totals(&mut self) -> VertexTotals {
        self.vertices.iter_mut().fold(VertexTotals::default(), |a, b| std::array::from_fn(|k| a[k] + b[k]))
    }

    /// Add what another (a shard's) counted.
    pub fn absorb(&mut self, mut other: TraceStatistics) {
        let vertices = other.vertex_totals();
        self.vertices.scope(|t| *t = std::array::from_fn(|k| t[k] + vertices[k]));
        for (mine, theirs) in [
            (&self.paths, &mut other.paths),
            (&self.shadow, &mut other.shadow),
            (&self.photons, &mut other.photons),
        ] {
            let total = theirs.iter_mut().fold(TraversalTotals::default(), |a, b| a.plus(b));
            mine.scope(|t| *t = t.plus(&total));
        }
    }

    fn count<R>(&self, stage: &Parallel<TraversalTotals>, query: impl FnOnce(&mut TraceCounts) -> R) -> R {
        let mut counts = TraceCounts::default();
        let result = query(&mut counts);
        stage.scope(|totals| totals.add(counts));
        result
    }

    /// The totals of each stage so far, named after its system: camera-path rays, shadow rays, photons and light subpaths.
    pub fn totals(&mut self) -> [(&'static str, TraversalTotals); 3] {
        let sum = |stage: &mut Parallel<TraversalTotals>| {
            stage.iter_mut().fold(TraversalTotals::default(), |a, b| a.plus(b))
        };
        [
            ("trace_paths", sum(&mut self.paths)),
            ("trace_shadow_rays", sum(&mut self.shadow)),
            ("trace_subpaths", sum(&mut self.photons)),
        ]
    }
}
