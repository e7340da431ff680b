//! Components of the three kinds of entities: camera paths, photons and progressive hit points,
//! split by who reads them (`trace` touches only the rays and hits).

use bevy_ecs::component::Component;
use caustica_core::geometry::{Ray, bvh::Hit};
use caustica_core::kernel::{CameraPath, Vertex};
use caustica_core::photon::estimate::GatherPoint;
use caustica_core::photon::progressive::AdaptiveStatistics;
use caustica_core::photon::visible_point::PackedShading;
use caustica_core::render_scene::RenderScene;
use caustica_core::sampling::Sampler;
use glam::Vec3;

/// The ray a path will trace next (hot: read by `trace_paths`).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PathRay(pub Ray);

/// The closest hit of the last trace.
#[derive(Component, Clone, Copy, Debug)]
pub struct PathHit(pub Hit);

impl Default for PathHit {
    fn default() -> Self {
        Self(Hit::MISS)
    }
}

/// A shadow ray from next-event estimation and what it adds if nothing blocks it.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ShadowRay {
    /// The segment to test (origin to light point, `t_max` just short of 1).
    pub ray: Ray,
    /// β · f · |cos| · Le · w / pdf, added to the path radiance when unoccluded.
    pub contribution: Vec3,
    /// Whether the ray still needs tracing.
    pub pending: bool,
    /// The light it goes to (visibility-aware selection learns from it).
    pub light: u32,
    /// Shading normal at its origin, on the shaded side.
    pub normal: Vec3,
    /// Traced this step and not yet learned from, and whether it was unoccluded.
    pub fresh: bool,
    /// Whether the last trace found the segment free.
    pub visible: bool,
}

impl ShadowRay {
    /// Queue a light sample for the shadow stage.
    #[inline]
    pub fn queue(&mut self, sample: caustica_core::kernel::ShadowSample) {
        self.ray = sample.ray;
        self.contribution = sample.contribution;
        self.light = sample.light;
        self.normal = sample.normal;
        self.pending = true;
    }
}

/// Where a path is in its life.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PathStatus {
    /// Needs its first ray: a camera path's for its next sample, a photon's from a light.
    #[default]
    NeedsStart,
    /// Bouncing.
    Active,
    /// Ended; radiance waits to be splatted.
    Finished,
    /// No samples left for this entity.
    Idle,
}

/// Per-path state read by `scatter` and `gather` (cold for `trace`): which sample the path renders,
/// its physics ([`CameraPath`], the kernel's), and its life cycle and counters.
#[derive(Component, Clone, Copy, Debug)]
pub struct PathState {
    /// Pixel index (row-major from top-left).
    pub pixel: u32,
    /// Sample index within the pixel.
    pub sample: u32,
    /// The sample's random numbers (a function of the seed, the pixel and the sample, set when the
    /// camera ray is made: every vertex draws from it without hashing the pixel again).
    pub sampler: Sampler,
    /// Throughput, radiance so far, and what MIS and Russian roulette remember.
    pub path: CameraPath,
    /// Photon mapping: the path is a final-gather ray that ends at the next diffuse hit.
    pub gathering: bool,
    /// Life-cycle state.
    pub status: PathStatus,
    /// Rays traced by this path since the last splat (for statistics, summed in `gather`).
    pub rays: u32,
    /// Shadow rays traced since the last splat.
    pub shadow_rays: u32,
    /// Photon-map lookups since the last splat.
    pub lookups: u32,
}

impl PathState {
    /// A fresh path for `pixel`, sample `sample`, waiting for its camera ray.
    pub fn new(pixel: u32, sample: u32) -> Self {
        Self {
            pixel,
            sample,
            sampler: Sampler::new(0, pixel, sample),
            path: CameraPath::START,
            gathering: false,
            status: PathStatus::NeedsStart,
            rays: 0,
            shadow_rays: 0,
            lookups: 0,
        }
    }
}

/// A camera path's search for its feature images' surface; only on paths of a render that asks for
/// them (a scene pays for what it uses).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PathAov(pub caustica_core::kernel::aov::FirstSurface);

/// A measurement point of progressive photon mapping: where a camera path first met a non-specular
/// surface, and the photon statistics gathered there (Hachisuka, Ogaki & Jensen 2008, §4).
///
/// Names follow the paper: `r2` is R², `n` is N (photons kept), `tau` is τ (reflected flux), and
/// `m`, `phi` are M and Φ_M of the pass that is running, cleared by the update. The visible point
/// (`p`, `wo`, `ns`, `beta`, material) is rewritten every pass by `sppm`'s camera pass and kept by
/// `ppm`'s. `beta` = 0 marks a pass in which the camera path found no surface to gather on.
/// 96 bytes: N and τ in f64, so 10⁵ passes of small increments neither stall nor drift.
#[derive(Component, Clone, Copy, Debug)]
pub struct HitPoint {
    /// τ: accumulated flux (`ppm`, `sppm`), or Σ Φ_i / r_i² of each pass (`appm`, `cppm`).
    pub tau: glam::DVec3,
    /// N: photons accumulated (after the α reduction).
    pub n: f64,
    /// Visible point.
    pub p: Vec3,
    /// Camera-path throughput up to the visible point.
    pub beta: Vec3,
    /// Φ_M: flux gathered in this pass, already multiplied by β and the BSDF.
    pub phi: Vec3,
    /// R²: squared gather radius.
    pub r2: f32,
    /// M: photons gathered in this pass.
    pub m: u32,
    /// The visible point's direction, normal and BSDF parameters, packed.
    pub shading: PackedShading,
}

const _: () = assert!(size_of::<HitPoint>() <= 96);

impl HitPoint {
    /// A hit point with radius √`r2` and no statistics yet.
    pub fn new(r2: f32) -> Self {
        Self {
            tau: glam::DVec3::ZERO,
            n: 0.0,
            p: Vec3::ZERO,
            beta: Vec3::ZERO,
            phi: Vec3::ZERO,
            r2,
            m: 0,
            shading: PackedShading::default(),
        }
    }

    /// Whether this pass's camera path found a surface to gather on.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.beta != Vec3::ZERO
    }

    /// Make vertex `v`, seen from direction `wo` (world, towards the camera) by a path of throughput
    /// `beta`, this pass's visible point; the statistics stay.
    pub fn record(&mut self, v: &Vertex, wo: Vec3, beta: Vec3) {
        self.p = v.si.p;
        self.beta = beta;
        self.shading = PackedShading::new(wo, v.si.ns, &v.params, v.si.material);
    }

    /// The visible point as the gather sees it: its BSDF rebuilt from the stored parameters.
    #[inline]
    pub fn gather_point(&self, scene: &RenderScene) -> GatherPoint {
        self.shading.gather_point(scene, self.p, self.beta)
    }
}

/// Per-hit-point photon counts over the rings × sectors of the gather disc, for `cppm`'s χ² test
/// (Lin et al. 2020), accumulated over passes since the radius last changed.
#[derive(Component, Clone, Copy, Debug)]
pub struct Chi2Cells {
    /// Photons per cell, ring-major.
    pub counts: [u32; caustica_core::photon::progressive::CHI2_CELLS],
    /// Photons the cells must hold before the test may shrink the radius.
    pub min_photons: f32,
}

/// Per-hit-point estimates behind `appm`'s radius (Kaplanyan & Dachsbacher 2013).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct AdaptiveStats(pub AdaptiveStatistics);
