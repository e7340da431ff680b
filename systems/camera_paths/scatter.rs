//! Scatter: what each active row does where its ray landed — the kernel's camera vertex (emission
//! weighted by MIS, a light sample, the BSDF continuation with Russian roulette) — and which queue
//! it goes to next. Each hit's class is read from its material (`kernel::lanes::classify`); the rows
//! of a lane class are queued together and shaded in lanes, which read and write the columns
//! themselves (the scalar kernel's bits); the others are shaded one by one.

use super::guide::{Guide, PathGuide};
use super::{PathQueues, PathSampler, PathShadow, PathThroughput, ShadowLearning};
use crate::components::{PathAov, PathHit, PathRay};
use crate::resources::{RenderConfig, SceneResource};
use crate::trace::TraceStatistics;
use bevy_ecs::prelude::*;
use caustica_core::geometry::Ray;
use caustica_core::geometry::bvh::Hit;
use caustica_core::kernel::guided::{GuidedStep, guided_path_vertex};
use caustica_core::kernel::lanes::{CLASSES, CameraColumns, LaneClass, classify, shade_class};
use caustica_core::kernel::path_vertex::path_vertex;
use caustica_core::kernel::{CameraPath, PathLimits, ShadowSample};
use caustica_core::sampling::Sampler;
use glam::Vec3;

/// What scatter reads and writes.
type ScatterColumns = (
    &'static PathHit,
    &'static PathSampler,
    &'static mut PathRay,
    &'static mut PathThroughput,
    &'static mut PathShadow,
    Option<&'static mut ShadowLearning>,
    Option<&'static mut PathAov>,
    Option<&'static mut PathGuide>,
);

/// The rows of each lane class, kept from step to step (no allocation per step).
#[derive(Default)]
pub struct ClassQueues {
    rows: [Vec<u32>; CLASSES],
}

/// What the class queues hold a row at most: an entry in each.
pub const LANE_SCRATCH_BYTES_PER_ROW: usize = CLASSES * size_of::<u32>();

/// A shard's paths as the columns the lanes read and write, with the queues a shaded row goes to.
struct Columns<'a, const NEE: bool> {
    scene: &'a SceneResource,
    limits: PathLimits,
    guide: Option<&'a Guide>,
    hits: &'a [PathHit],
    samplers: &'a [PathSampler],
    rays: &'a mut [PathRay],
    states: &'a mut [PathThroughput],
    shadows: &'a mut [PathShadow],
    learning: Option<&'a mut [ShadowLearning]>,
    aovs: Option<&'a mut [PathAov]>,
    /// The guide's memory of each path, while it trains.
    training: Option<&'a mut [PathGuide]>,
    queues: &'a mut PathQueues,
    next: &'a mut Vec<u32>,
}

impl<const NEE: bool> Columns<'_, NEE> {
    /// Queue `row`'s light sample for the shadow stage.
    fn queue_shadow(&mut self, row: u32, sample: ShadowSample) {
        let i = row as usize;
        self.shadows[i] = PathShadow { ray: sample.ray, contribution: sample.contribution };
        if let Some(learning) = self.learning.as_deref_mut() {
            learning[i] = ShadowLearning { light: sample.light, normal: sample.normal };
        }
        self.queues.shadow.push(row);
    }

    /// `row` goes on to the next trace, or is finished.
    fn queue(&mut self, row: u32, continues: bool) {
        if continues { self.next.push(row) } else { self.queues.finished.push(row) }
    }
}

impl<const NEE: bool> CameraColumns for Columns<'_, NEE> {
    #[inline(always)]
    fn ray(&mut self, row: u32) -> &mut Ray {
        &mut self.rays[row as usize].0
    }

    #[inline(always)]
    fn hit(&self, row: u32) -> &Hit {
        &self.hits[row as usize].0
    }

    #[inline(always)]
    fn path(&mut self, row: u32) -> &mut CameraPath {
        &mut self.states[row as usize].0
    }

    #[inline(always)]
    fn sampler(&self, row: u32) -> Sampler {
        self.samplers[row as usize].0
    }

    #[inline(always)]
    fn vertex_done(&mut self, row: u32, continues: bool, light_sample: Option<ShadowSample>) {
        let i = row as usize;
        if let Some(remembered) = self.training.as_deref_mut() {
            // A lane's vertex emits nothing and its light sample is not yet counted, so the
            // radiance gathered now is what its previous vertex waits for. Its continuation is the
            // BSDF's: the cosine lobe, whose pdf the path now holds.
            let (remembered, path) = (&mut remembered[i], &self.states[i].0);
            remembered.arrive(path.l);
            if continues {
                let (p, pdf) = (path.prev_p, path.prev_pdf);
                let step = GuidedStep { p, wi: self.rays[i].0.d, pdf, bsdf_pdf: pdf };
                remembered.remember(step, path.beta);
            }
        }
        if let Some(sample) = light_sample {
            self.queue_shadow(row, sample);
        }
        self.queue(row, continues);
    }

    fn scalar_vertex(&mut self, row: u32) {
        let i = row as usize;
        let (continues, light_sample) = match self.guide {
            None => {
                let aov = self.aovs.as_deref_mut().map(|a| &mut a[i].0);
                let (hit, sampler) = (&self.hits[i].0, self.samplers[i].0);
                path_vertex::<NEE>(
                    self.scene,
                    self.limits,
                    hit,
                    &mut self.rays[i].0,
                    &mut self.states[i].0,
                    sampler,
                    aov,
                )
            }
            Some(guide) => guided_vertex::<NEE>(self, row, guide),
        };
        if let Some(sample) = light_sample {
            self.queue_shadow(row, sample);
        }
        self.queue(row, continues);
    }

    #[inline(always)]
    fn records_features(&self) -> bool {
        self.aovs.is_some()
    }

    #[inline(always)]
    fn reached(&mut self, row: u32, t: f32, albedo: Vec3, normal: Vec3, beta: Vec3) {
        if let Some(aovs) = self.aovs.as_deref_mut() {
            aovs[row as usize].0.reached_surface(t, albedo, normal, beta);
        }
    }
}

/// Shade every active row: it stays active with its next ray, or is finished; a light sample
/// queues it for the shadow stage too. `NEE` selects `pt` (light sampling + MIS) over `pt-naive`.
#[allow(clippy::too_many_arguments)]
pub fn scatter_paths<const NEE: bool>(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    statistics: Option<Res<TraceStatistics>>,
    mut queues: ResMut<PathQueues>,
    guide: Option<Res<Guide>>,
    mut classes: Local<ClassQueues>,
    mut paths: Query<ScatterColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    // A guide that trains no more and guides nowhere leaves the render as it would be without one.
    let guide = guide.filter(|guide| guide.training() || guide.sampling);
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((hits, samplers, mut rays, mut states, mut shadows, mut learning, mut aovs, mut remembered)) =
        tables.next()
    else {
        return;
    };
    let training = guide.as_ref().is_some_and(|guide| guide.training());
    let queues = &mut *queues;
    let mut next = std::mem::take(&mut queues.next);
    let active = std::mem::take(&mut queues.active);
    let limits = config.limits;
    let mut columns = Columns::<NEE> {
        scene: &scene,
        limits,
        guide: guide.as_deref(),
        hits,
        samplers,
        rays: rays.bypass_change_detection(),
        states: states.bypass_change_detection(),
        shadows: shadows.bypass_change_detection(),
        learning: learning.as_mut().map(|l| l.bypass_change_detection()),
        aovs: aovs.as_mut().map(|a| a.bypass_change_detection()),
        training: remembered.as_mut().filter(|_| training).map(|r| r.bypass_change_detection()),
        queues,
        next: &mut next,
    };
    let classes = &mut classes.rows;
    for queue in classes.iter_mut() {
        queue.clear();
    }
    for &row in &active {
        let i = row as usize;
        let (ray, hit) = (&columns.rays[i].0, &columns.hits[i].0);
        // Where the guide takes part the vertex is the guided scalar kernel's (the lanes know no
        // guide); while training, the lanes report the steps they took.
        let class = match &columns.guide {
            Some(guide) if guide.takes_part(ray, hit) => LaneClass::Scalar,
            _ => classify(&scene, limits, hit, &columns.states[i].0),
        };
        classes[class.index()].push(row);
        if class == LaneClass::Scalar {
            columns.scalar_vertex(row);
        }
    }
    for class in LaneClass::ALL {
        shade_class::<NEE, _>(&scene, limits, class, &classes[class.index()], &mut columns);
    }
    if let Some(statistics) = statistics {
        statistics.count_vertices(|counts| {
            for class in LaneClass::ALL {
                let rows = &classes[class.index()];
                // Rows whose ray left the scene are no vertex.
                counts[class.index()] += match class {
                    LaneClass::Scalar => {
                        rows.iter().filter(|&&r| columns.hits[r as usize].0.is_hit()).count()
                    }
                    _ => rows.len(),
                } as u64;
            }
        });
    }
    let mut active = active;
    active.clear();
    queues.active = next;
    queues.next = active;
}

/// One vertex of the guided scalar kernel, remembering its step while the guide trains.
fn guided_vertex<const NEE: bool>(
    columns: &mut Columns<NEE>,
    row: u32,
    guide: &Guide,
) -> (bool, Option<ShadowSample>) {
    let i = row as usize;
    let aov = columns.aovs.as_deref_mut().map(|a| &mut a[i].0);
    let mut training = columns.training.as_deref_mut().map(|r| &mut r[i]);
    let path = &mut columns.states[i].0;
    if let Some(remembered) = training.as_deref_mut().filter(|_| !NEE) {
        remembered.arrive(path.l);
    }
    let (continues, light_sample, step) = guided_path_vertex::<NEE>(
        columns.scene,
        columns.limits,
        &columns.hits[i].0,
        &mut columns.rays[i].0,
        path,
        columns.samplers[i].0,
        aov,
        &guide.tree,
    );
    if let Some(remembered) = training {
        if NEE {
            // The light emitted here is now in `l`; light sampled here is not yet.
            remembered.arrive(path.l);
        }
        if let (Some(step), true) = (step, continues) {
            remembered.remember(step, path.beta);
        }
    }
    (continues, light_sample)
}
