//! Path guiding on the camera paths (`[guiding]`, `pt` and `pt-naive`): the learnt distribution
//! every shard samples by ([`Guide`]), what a path remembers of its guided vertices while it trains
//! it ([`PathGuide`]), the recording of a finished path into it, and the refinement between passes.
//!
//! Training passes have 1, 2, 4, … samples per pixel; each samples by what the passes before it
//! learnt and records what its paths found, and the tree is refined between them (Müller et al.
//! 2017). A finished path gives each guided vertex the light that arrived along its continuation:
//! the radiance the path gathered after it, divided by the throughput up to it, recorded as
//! luminance over the pdf the continuation was drawn with. The recording is fixed-point atomic
//! sums and the refinement reads them in index order, so the image is the same bits for any thread
//! count and chunk size.

use super::{PathQueues, PathThroughput};
use bevy_ecs::prelude::*;
use caustica_core::guiding::SdTree;
use caustica_core::kernel::guided::GuidedStep;
use caustica_core::lights::light::luminance;
use glam::Vec3;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

/// Guided vertices a path remembers while training: the first ones, which see most of the light.
pub const REMEMBERED_VERTICES: usize = 6;

/// The learnt distribution and where training stands.
#[derive(Resource, Clone)]
pub struct Guide {
    /// The SD-tree: sampled by every shard, recorded into during training passes.
    pub tree: Arc<SdTree>,
    /// Training passes in all: fixed by the samples per pixel, or cut short by a time limit, so the
    /// plan's pass sizes read it as it stands.
    pub training_passes: Arc<AtomicU32>,
    /// Training passes done (the tree has been refined this often).
    pub refined: u32,
    /// Some region's guide takes part in sampling: false, and once training ends the render is the
    /// unguided one.
    pub sampling: bool,
    /// The box around the regions that guide ([`SdTree::guiding_bounds`]): outside it no vertex
    /// looks its region up.
    pub guiding_box: (Vec3, Vec3),
    /// Seconds spent refining.
    pub refine_seconds: f64,
    /// With a time limit: training ends before the pass that would end after this many seconds of it
    /// (each pass takes about twice the one before).
    pub training_seconds: Option<f64>,
    /// When training began.
    pub started: Instant,
    /// Seconds from then to the end of the last training pass.
    pub training_took: f64,
    /// The run's memory budget: a refinement that would grow the tree past a quarter of it is not
    /// made, and training ends ([`SdTree::refine_within`]).
    pub budget_bytes: u64,
}

/// The share of a time limit spent training, as of the samples per pixel by default.
pub const TRAINING_SHARE_OF_TIME: f64 = 0.25;

/// The share of the run's memory budget the tree may grow to.
pub const TREE_SHARE_OF_BUDGET: u64 = 4;

/// The most a guided render's tree may hold under a memory budget of `budget_bytes`: refining stops
/// (and training ends) rather than pass it.
pub fn tree_cap(budget_bytes: u64) -> u64 {
    budget_bytes / TREE_SHARE_OF_BUDGET
}

impl Guide {
    /// The most the tree may hold, refining included: a share of the run's memory budget, counted
    /// before the render ([`tree_cap`]).
    pub fn tree_cap(&self) -> u64 {
        tree_cap(self.budget_bytes)
    }

    /// Whether the running pass records into the tree.
    pub fn training(&self) -> bool {
        self.refined < self.training_passes()
    }

    /// Training passes in all, as it stands.
    pub fn training_passes(&self) -> u32 {
        self.training_passes.load(Ordering::Relaxed)
    }

    /// Whether the guide takes part at the vertex where `ray` lands by `hit`: its leaf has learnt
    /// something and kept a share for it (where it did not, the vertex may take the lanes).
    #[inline]
    pub fn takes_part(
        &self,
        ray: &caustica_core::geometry::Ray,
        hit: &caustica_core::geometry::bvh::Hit,
    ) -> bool {
        let p = ray.o + ray.d * hit.t;
        let (lo, hi) = self.guiding_box;
        if !(p.cmpge(lo).all() && p.cmple(hi).all()) {
            return false;
        }
        let leaf = self.tree.leaf(p);
        leaf.bsdf_share() < 1.0 && !leaf.distribution().is_uniform()
    }

    /// Where the pass that starts at `done` samples per pixel ends, of `target`: training pass k
    /// has 2^k samples per pixel; after them, the rest at once.
    pub fn pass_end(training_passes: u32, done: u32, target: u32) -> u32 {
        let trained = (1u64 << training_passes.min(31)) - 1;
        if u64::from(done) < trained { done.saturating_mul(2).saturating_add(1).min(target) } else { target }
    }
}

/// Put the run's guide into `world` (which holds the scene), if the run asks for one and has samples
/// to train it with: whether it did.
pub fn begin(world: &mut World, run: &caustica_core::scene::RunFile) -> bool {
    let settings = run.guiding;
    if !settings.enabled {
        return false;
    }
    let training_passes = settings.training_passes(run.render.spp);
    if training_passes == 0 {
        tracing::warn!(
            "path guiding: {} sample(s) per pixel leave none to train with; rendering unguided",
            run.render.spp
        );
        return false;
    }
    let (min, max) = world.resource::<crate::resources::SceneResource>().geometry.bounds();
    let config = caustica_core::guiding::GuidingConfig {
        spatial_threshold: settings.spatial_threshold,
        directional_threshold: settings.directional_threshold,
        fixed_bsdf_share: settings.bsdf_fraction,
        ..Default::default()
    };
    world.insert_resource(Guide {
        tree: Arc::new(SdTree::with_config(min, max, config)),
        training_passes: Arc::new(AtomicU32::new(training_passes)),
        refined: 0,
        sampling: false,
        guiding_box: (Vec3::INFINITY, Vec3::NEG_INFINITY),
        refine_seconds: 0.0,
        // An explicit training budget is in samples; the default follows a time limit if there is one.
        training_seconds: run
            .render
            .time_limit
            .filter(|_| settings.training_spp.is_none())
            .map(|limit| limit * TRAINING_SHARE_OF_TIME),
        started: Instant::now(),
        training_took: 0.0,
        budget_bytes: run.memory_budget_bytes(),
    });
    true
}

/// A guided vertex, remembered until its path ends.
#[derive(Clone, Copy, Debug, Default)]
struct RememberedVertex {
    p: Vec3,
    wi: Vec3,
    pdf: f32,
    bsdf_pdf: f32,
    /// The path's throughput after the continuation (radiance gathered later, divided by it, is
    /// what arrived along `wi`).
    beta: Vec3,
    /// Radiance the path had gathered when it reached its next vertex: light sampled here included,
    /// and, where light sampling (NEE) covers it, the light emitted there too (`arrive`).
    before: Vec3,
}

/// What a training path remembers of its guided vertices.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PathGuide {
    vertices: [RememberedVertex; REMEMBERED_VERTICES],
    count: u8,
    /// The last vertex waits for the radiance gathered before the path's next vertex.
    awaiting: bool,
}

impl PathGuide {
    /// The path reached its next vertex having gathered `l`. With light sampling, call it once the
    /// light emitted there is counted: that light is light sampling's to find, and a guide that
    /// learnt it would spend its samples where MIS then gives them little weight. Without, call it
    /// before: the guide is then the only way to find the lights.
    #[inline]
    pub fn arrive(&mut self, l: Vec3) {
        if self.awaiting {
            self.vertices[self.count as usize - 1].before = l;
            self.awaiting = false;
        }
    }

    /// The path went on from a guided vertex by `step`, with throughput `beta` after it.
    #[inline]
    pub fn remember(&mut self, step: GuidedStep, beta: Vec3) {
        if (self.count as usize) < REMEMBERED_VERTICES {
            let GuidedStep { p, wi, pdf, bsdf_pdf } = step;
            self.vertices[self.count as usize] =
                RememberedVertex { p, wi, pdf, bsdf_pdf, beta, before: Vec3::ZERO };
            self.count += 1;
            self.awaiting = true;
        }
    }

    /// The path ended with radiance `l`: record what each remembered vertex received (the light
    /// that arrived along its continuation, for its leaf's distribution; what that brought the
    /// pixel, for its leaf's BSDF share), and forget.
    pub fn record(&mut self, tree: &SdTree, l: Vec3) {
        let settled = self.count as usize - usize::from(self.awaiting);
        if l.is_finite() {
            for v in &self.vertices[..settled] {
                let arrived = (l - v.before).max(Vec3::ZERO);
                let incident = Vec3::select(v.beta.cmpgt(Vec3::ZERO), arrived / v.beta, Vec3::ZERO);
                let leaf = tree.leaf(v.p);
                leaf.record(v.wi, luminance(incident) / v.pdf);
                leaf.record_selection(v.wi, luminance(arrived), v.pdf, v.bsdf_pdf);
            }
        }
        *self = Self::default();
    }
}

/// Record the finished training paths into the tree (before the splat frees their rows).
pub fn record_guided_paths(
    guide: Res<Guide>,
    queues: Res<PathQueues>,
    mut paths: Query<(&PathThroughput, &mut PathGuide)>,
) {
    if !guide.training() || queues.finished.is_empty() {
        return;
    }
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((states, mut remembered)) = tables.next() else { return };
    let remembered = remembered.bypass_change_detection();
    for &row in &queues.finished {
        let i = row as usize;
        remembered[i].record(&guide.tree, states[i].0.l);
    }
}

/// After a training pass: refine the tree by what the pass recorded (its shards have returned their
/// shares of it, so the main World's is the only one).
pub fn refine_guide(mut guide: ResMut<Guide>) {
    if !guide.training() {
        return;
    }
    let start = std::time::Instant::now();
    let (iteration, cap) = (guide.refined, usize::try_from(guide.tree_cap()).unwrap_or(usize::MAX));
    let Some(tree) = Arc::get_mut(&mut guide.tree) else {
        // A host holding the tree keeps it unrefined rather than refining a copy it does not see.
        tracing::warn!("path guiding: the tree is shared beyond the render, so it is not refined");
        return;
    };
    let refined = tree.refine_within(iteration, cap);
    let tree = &guide.tree;
    let counts = tree.node_counts();
    let bounds = tree.guiding_bounds();
    tracing::info!(
        "path guiding: training pass {iteration} refined: {} leaves ({} guiding), {} sampling nodes, {} KiB",
        counts.leaves,
        counts.guiding,
        counts.sampling,
        tree.memory_bytes() >> 10
    );
    guide.refined += 1;
    guide.sampling = counts.guiding > 0;
    guide.guiding_box = bounds.unwrap_or((Vec3::INFINITY, Vec3::NEG_INFINITY));
    guide.refine_seconds += start.elapsed().as_secs_f64();
    let last_pass = guide.started.elapsed().as_secs_f64() - guide.training_took;
    guide.training_took = guide.started.elapsed().as_secs_f64();
    if let Some(budget) = guide.training_seconds
        && guide.training()
        && guide.training_took + 2.0 * last_pass > budget
    {
        tracing::info!(
            "path guiding: training ends after {} passes, its share of the time limit spent",
            guide.refined
        );
        guide.training_passes.store(guide.refined, Ordering::Relaxed);
    }
    if refined == caustica_core::guiding::Refined::Capped && guide.training() {
        tracing::warn!(
            "path guiding: refining the tree after training pass {iteration} would take it past {} MiB, \
             a quarter of the memory budget: training ends after {} passes, the tree as it stands (raise \
             --memory-budget-mib, or guiding.spatial_threshold and guiding.directional_threshold)",
            guide.tree_cap() >> 20,
            guide.refined
        );
        guide.training_passes.store(guide.refined, Ordering::Relaxed);
    }
}

/// The report's line on the guide: training passes and samples, the tree's size and memory against
/// the budget, and the time spent refining it.
pub fn describe(guide: &Guide) -> String {
    let counts = guide.tree.node_counts();
    let trained_spp = (1u64 << guide.refined.min(63)) - 1;
    format!(
        "{} training pass{} ({trained_spp} spp); tree of {} regions ({} guiding, the rest sampling the BSDF \
         alone), {} directional nodes, {:.1} MiB of the {} MiB budget; training took {:.2} s, {:.3} s of it \
         refining",
        guide.refined,
        if guide.refined == 1 { "" } else { "es" },
        counts.leaves,
        counts.guiding,
        counts.sampling,
        guide.tree.memory_bytes() as f64 / (1u64 << 20) as f64,
        guide.budget_bytes >> 20,
        guide.training_took,
        guide.refine_seconds
    )
}

/// What the guide learnt at the first surface the centre of pixel (`x`, `y`) sees: the point, the
/// BSDF's share of the samples there, and the distribution as an image of the sphere (φ across, cos θ down, +z at the top; each pixel the
/// density at its centre, so a uniform leaf is 1/4π everywhere). None without a guide, for a pixel
/// off the film, or where the pixel sees nothing.
pub fn learnt_at_pixel(world: &World, x: u32, y: u32) -> Option<(Vec3, f32, caustica_core::film::Image)> {
    let guide = world.get_resource::<Guide>()?;
    let camera = &world.resource::<crate::resources::CameraResource>().0;
    if x >= camera.width || y >= camera.height {
        return None;
    }
    let scene = world.resource::<crate::resources::SceneResource>();
    let ray = camera.generate_ray(x, y, glam::Vec2::splat(0.5), glam::Vec2::splat(0.5), 0.0);
    let hit = scene.geometry.intersect(&ray);
    if !hit.is_hit() {
        return None;
    }
    let p = ray.o + ray.d * hit.t;
    let (width, height) = (256, 128);
    let pixels = guide.tree.directional_image(p, width, height).into_iter().map(Vec3::splat).collect();
    Some((p, guide.tree.leaf(p).bsdf_share(), caustica_core::film::Image { width, height, pixels }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn training_passes_double_and_the_rest_renders_at_once() {
        let ends: Vec<u32> = [0, 1, 3, 7, 15].iter().map(|&done| Guide::pass_end(4, done, 64)).collect();
        assert_eq!(ends, [1, 3, 7, 15, 64]);
        assert_eq!(Guide::pass_end(4, 3, 5), 5, "a target inside training ends the pass there");
        assert_eq!(Guide::pass_end(0, 0, 64), 64);
    }

    #[test]
    fn a_vertex_receives_what_the_path_gathered_after_it_over_its_throughput() {
        let mut tree = SdTree::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut guide = PathGuide::default();
        let step = GuidedStep { p: Vec3::ZERO, wi: Vec3::Z, pdf: 0.5, bsdf_pdf: 0.5 };
        guide.remember(step, Vec3::splat(0.25));
        guide.arrive(Vec3::splat(1.0));
        guide.record(&tree, Vec3::splat(3.0));
        assert_eq!(guide.count, 0, "forgotten once recorded");
        tree.refine(0);
        // (3 − 1) / 0.25 = 8 in every channel: luminance 8, over the pdf 0.5.
        let energy = tree.leaf(Vec3::ZERO).distribution().energy();
        assert!((energy - 16.0).abs() < 1e-3, "{energy}");
    }

    #[test]
    fn a_vertex_still_waiting_for_its_next_one_is_not_recorded() {
        let tree = SdTree::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut guide = PathGuide::default();
        let step = GuidedStep { p: Vec3::ZERO, wi: Vec3::Z, pdf: 0.5, bsdf_pdf: 0.5 };
        guide.remember(step, Vec3::ONE);
        let before = tree.fingerprint();
        guide.record(&tree, Vec3::splat(3.0));
        assert_eq!(tree.fingerprint(), before);
    }
}
