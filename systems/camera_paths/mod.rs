//! Camera paths on the vector core: `pt` and `pt-naive`, and `lt`'s camera rays (delta bounces
//! only), a shard's chunk of paths at a time (`crate::shards`), each stage over its own columns.
//!
//! A path is an entity whose components are split by who reads them:
//!
//! | component | bytes | written by | read by |
//! |---|---|---|---|
//! | `PathRay` | 32 | emit, scatter | trace, scatter |
//! | `PathHit` | 16 | trace | scatter |
//! | `PathThroughput` (the kernel's `CameraPath`: β, radiance, MIS and roulette state, media) | 80 | emit, scatter, shadow | scatter, shadow, splat |
//! | `PathSample` (pixel, sample) | 8 | emit | splat |
//! | `PathSampler` | 16 | emit | scatter |
//! | `PathShadow` (segment, contribution) | 44 | scatter | shadow |
//! | `ShadowLearning` (visibility-aware selection only) | 16 | scatter | shadow |
//! | `PathAov` (feature images only) | 40 | emit, scatter | splat |
//!
//! 196 bytes a path, about 250 with bevy's change ticks and the entity: a chunk of 4096 paths is a
//! megabyte, within a core's L2 (the sizes are asserted below, so the table stays true).
//!
//! Which paths are alive is not a field: [`PathQueues`] holds the rows each stage works on
//! (pbrt-v4's wavefront work queues). Emit takes samples for the free rows, trace reads the rays of
//! the active ones and writes their hits, scatter shades them and sorts them into active (it goes
//! on), shadow (a light sample to test) and finished, shadow tests its rows, splat adds the finished
//! ones to the film and frees them. Trace reads rays and writes hits, nothing else.
//!
//! | stage | system |
//! |---|---|
//! | `Emit` | `emit_paths<LENS, MOTION>` |
//! | `Trace` | `trace_paths` |
//! | `Scatter` | `scatter_paths<NEE>`; `lt`: `scatter_to_seen_emission` |
//! | `Shadow` | `trace_shadow_rays` (`pt` with light sampling) |
//! | `Gather` | `splat_paths` |

mod emit;
pub mod guide;
mod scatter;
mod seen;
mod shadow;
mod splat;
mod trace;

pub use emit::{emit_paths, emit_paths_for};
pub use scatter::{LANE_SCRATCH_BYTES_PER_ROW, scatter_paths};
pub use seen::scatter_to_seen_emission;
pub use shadow::trace_shadow_rays;
pub use splat::splat_paths;
pub use trace::trace_paths;

use crate::components::{PathAov, PathHit, PathRay};
use crate::resources::{PassRange, Workload};
use bevy_ecs::prelude::*;
use caustica_core::geometry::Ray;
use caustica_core::kernel::CameraPath;
use caustica_core::sampling::Sampler;
use glam::Vec3;

/// Which camera sample a path renders.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PathSample {
    /// Pixel index (row-major from top-left).
    pub pixel: u32,
    /// Sample index within the pixel.
    pub sample: u32,
}

/// The sample's random numbers (a function of the seed, the pixel and the sample, set when the
/// camera ray is made).
#[derive(Component, Clone, Copy, Debug)]
pub struct PathSampler(pub Sampler);

/// Throughput, radiance so far, and what MIS and Russian roulette remember: the kernel's state of a
/// camera path.
#[derive(Component, Clone, Copy, Debug)]
pub struct PathThroughput(pub CameraPath);

/// A light sample waiting for its shadow ray, and what it adds when nothing blocks it.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PathShadow {
    /// The segment from the vertex to the point on the light.
    pub ray: Ray,
    /// β · f · |cos| · Le · w / pdf.
    pub contribution: Vec3,
}

/// What visibility-aware light selection learns from a shadow ray: the light and the side of the
/// surface it was sampled from. Only on the paths of a render that learns.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ShadowLearning {
    /// The light sampled.
    pub light: u32,
    /// Shading normal at the vertex, on the side it is seen from.
    pub normal: Vec3,
}

// The layout table above, held to the code.
const _: () = {
    assert!(size_of::<PathRay>() == 32 && size_of::<PathHit>() == 16);
    assert!(size_of::<PathThroughput>() == 80 && size_of::<PathSample>() == 8);
    assert!(size_of::<PathSampler>() == 16 && size_of::<PathShadow>() == 44);
    assert!(size_of::<ShadowLearning>() == 16 && size_of::<PathAov>() == 40);
};

/// The rows of a shard's paths by what they wait for. Every row is in at most one of `free`,
/// `active` and `finished`; a row in `shadow` is also in `active` or `finished`.
#[derive(Resource, Debug, Default)]
pub struct PathQueues {
    /// Rows without a sample (a stack: the lowest row is taken first).
    pub free: Vec<u32>,
    /// Rows whose ray waits to be traced, then shaded.
    pub active: Vec<u32>,
    /// Rows whose light sample waits for its shadow ray.
    pub shadow: Vec<u32>,
    /// Rows whose radiance waits to be splatted.
    pub finished: Vec<u32>,
    /// Scatter's next `active`, kept to reuse its allocation.
    next: Vec<u32>,
    /// Rows in the shard.
    pub rows: u32,
}

impl PathQueues {
    /// Queues of `rows` free rows.
    fn new(rows: u32) -> Self {
        let capacity = rows as usize;
        Self {
            free: (0..rows).rev().collect(),
            active: Vec::with_capacity(capacity),
            shadow: Vec::with_capacity(capacity),
            finished: Vec::with_capacity(capacity),
            next: Vec::with_capacity(capacity),
            rows,
        }
    }

    /// One scatter of every active row: `step(row, shadow)` shades its vertex (queueing a light
    /// sample's shadow ray in `shadow` if it makes one) and says whether the path goes on (active
    /// next step) or ended (finished, for the splat). The scatters that shade a row at a time use
    /// it; `scatter_paths` defers its Lambertian rows to lanes and keeps its own loop.
    pub fn advance_active(&mut self, mut step: impl FnMut(u32, &mut Vec<u32>) -> bool) {
        let mut next = std::mem::take(&mut self.next);
        let mut active = std::mem::take(&mut self.active);
        for &row in &active {
            if step(row, &mut self.shadow) { next.push(row) } else { self.finished.push(row) }
        }
        active.clear();
        self.active = next;
        self.next = active;
    }
}

/// The shard's index among `count`: where it takes work from first.
#[derive(Resource, Clone, Copy, Debug)]
pub struct ShardIndex {
    /// This shard.
    pub index: usize,
    /// How many there are.
    pub count: usize,
}

impl ShardIndex {
    /// The lane of `workload` this shard takes from first (shards spread over the lanes, so that
    /// each mostly touches a counter of its own).
    pub fn lane(&self, workload: &Workload) -> usize {
        self.index * workload.lane_count() / self.count.max(1)
    }
}

/// What the chunk's paths carry beyond the always-present columns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PathExtras {
    /// Feature images.
    pub aov: bool,
    /// Visibility-aware light selection learns from the shadow rays.
    pub learning: bool,
    /// Path guiding trains on what the paths find.
    pub guide: bool,
}

/// Spawn `rows` camera paths into a shard's World, all in one table (one archetype: the extras go
/// on every path or none), with their queues.
pub fn spawn_chunk(world: &mut World, rows: u32, index: usize, count: usize, extras: PathExtras) {
    let path = (
        PathRay::default(),
        PathHit::default(),
        PathThroughput(CameraPath::START),
        PathSample::default(),
        PathSampler(Sampler::new(0, 0, 0)),
        PathShadow::default(),
    );
    // One table: every row carries the same extras, each column only where the render uses it.
    macro_rules! spawn_with {
        ($($extra:expr),*) => {{
            world.spawn_batch((0..rows).map(|_| (path, $($extra),*)));
        }};
    }
    let (aov, learning, guide) = (PathAov::default(), ShadowLearning::default(), guide::PathGuide::default());
    match (extras.aov, extras.learning, extras.guide) {
        (false, false, false) => spawn_with!(),
        (true, false, false) => spawn_with!(aov),
        (false, true, false) => spawn_with!(learning),
        (true, true, false) => spawn_with!(aov, learning),
        (false, false, true) => spawn_with!(guide),
        (true, false, true) => spawn_with!(aov, guide),
        (false, true, true) => spawn_with!(learning, guide),
        (true, true, true) => spawn_with!(aov, learning, guide),
    }
    world.insert_resource(PathQueues::new(rows));
    world.insert_resource(ShardIndex { index, count });
    world.insert_resource(crate::resources::RenderStats::default());
}

/// Paths of a shard in flight, or that will be: rows with work, and the free rows while the pass
/// still has samples to hand out.
pub fn in_flight(world: &World) -> u32 {
    let queues = world.resource::<PathQueues>();
    let working = queues.active.len() + queues.finished.len();
    let stopped = world.get_resource::<PassRange>().is_none_or(|range| range.stop);
    let more = world.get_resource::<Workload>().is_some_and(|w| !w.is_exhausted());
    let waiting = if more && !stopped { queues.free.len() } else { 0 };
    (working + waiting) as u32
}
