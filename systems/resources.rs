//! Resources shared by the systems: the scene, the settings of this render, the film and statistics.

use crate::camera::Camera;
use crate::film::Film;
use crate::geometry::{Geometry, SurfaceHit};
use crate::lights::Lights;
use crate::materials::ShadingParams;
use crate::scene::{IntegratorKind, MaterialDesc, Texture, TextureRef};
use bevy_ecs::resource::Resource;

/// The camera that `emit` generates rays from.
#[derive(Resource, Clone, Debug)]
pub struct RenderCamera(pub Camera);

impl std::ops::Deref for RenderCamera {
    type Target = Camera;
    fn deref(&self) -> &Camera {
        &self.0
    }
}

/// The film that `gather` splats finished samples onto.
#[derive(Resource, Clone, Debug)]
pub struct RenderFilm(pub Film);

impl std::ops::Deref for RenderFilm {
    type Target = Film;
    fn deref(&self) -> &Film {
        &self.0
    }
}

impl std::ops::DerefMut for RenderFilm {
    fn deref_mut(&mut self) -> &mut Film {
        &mut self.0
    }
}

/// The scene as the systems see it: BVHs, lights, materials and textures.
#[derive(Resource, Clone, Debug)]
pub struct SceneGeometry {
    /// Primitives and their BVHs.
    pub geometry: Geometry,
    /// Emitters and light selection.
    pub lights: Lights,
    /// Materials by index.
    pub materials: Vec<MaterialDesc>,
    /// Textures by index.
    pub textures: Vec<Texture>,
}

impl SceneGeometry {
    /// BVHs, lights and materials of `scene`, as `render::scene_world` builds them: what a host
    /// that moves objects between frames re-inserts after editing its `Scene`.
    pub fn build(scene: &crate::scene::Scene, light_selection: crate::scene::LightSelection) -> Self {
        let mut geometry = Geometry::build(scene);
        let lights = scene_lights(&mut geometry, scene, light_selection);
        Self { geometry, lights, materials: scene.materials.clone(), textures: scene.textures.clone() }
    }

    /// Resolve the material at a hit: textures looked up, vertex colour applied.
    #[inline]
    pub fn shading_params(&self, hit: &SurfaceHit) -> ShadingParams {
        let m = &self.materials[hit.material as usize];
        let lookup = |t: &TextureRef| {
            let mut uv = hit.uv[(t.tex_coord as usize).min(1)];
            if let Some([x, y, o]) = t.transform {
                uv = x * uv.x + y * uv.y + o;
            }
            self.textures[t.texture as usize].sample(uv)
        };
        let mut base_color = m.base_color * hit.color;
        if let Some(t) = &m.base_color_texture {
            base_color *= lookup(t).truncate();
        }
        let (mut metallic, mut roughness) = (m.metallic, m.roughness);
        if let Some(t) = &m.metallic_roughness_texture {
            let texel = lookup(t);
            roughness *= texel.y;
            metallic *= texel.z;
        }
        ShadingParams {
            base_color,
            metallic,
            roughness,
            transmission: m.transmission,
            ior: m.ior,
            specular: m.specular,
            specular_color: m.specular_color,
        }
    }
}

/// The lights of `scene` over its built `geometry`. A scene with no emitter and no environment is lit
/// by a uniform white environment (radiance 1), as glTF viewers light files made for them, with a
/// warning: a black image helps nobody.
pub fn scene_lights(
    geometry: &mut Geometry,
    scene: &crate::scene::Scene,
    light_selection: crate::scene::LightSelection,
) -> Lights {
    let lights = Lights::build(geometry, &scene.materials, scene.environment.as_ref(), light_selection);
    if !lights.is_empty() {
        return lights;
    }
    tracing::warn!(
        "{}: no emitters and no environment: lighting the scene with a uniform white environment \
         (radiance 1); choose one with [environment] or --environment / --environment-color",
        scene.source.display()
    );
    let white = crate::scene::environment::EnvironmentDesc::constant(glam::Vec3::ONE);
    Lights::build(geometry, &scene.materials, Some(&white), light_selection)
}

/// Settings of the path integrators.
#[derive(Resource, Clone, Debug)]
pub struct RenderConfig {
    /// `pt` or `pt-naive`.
    pub integrator: IntegratorKind,
    /// Sampler seed.
    pub seed: u64,
    /// Maximum bounces (`u32::MAX` = unbounded).
    pub max_depth: u32,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
    /// One shutter time for every camera ray of this pass (stochastic PPM), instead of one per sample.
    pub pass_time: Option<f32>,
}

/// Which pixels and samples this render covers, and how the wavefront is laid over them.
///
/// The camera samples still to hand out. Work item `k` is sample `spp_begin + k / pixels` of pixel
/// `k % pixels` (sample-major, so the whole image fills in evenly). A path that finishes takes the next
/// item, so every entity stays busy until the work runs out and only the last paths form a tail.
/// `gather` hands items out on one thread in entity order, so which entity renders what, and the order
/// in which a pixel's samples reach the film, do not depend on the thread count.
#[derive(Resource, Clone, Copy, Debug)]
pub struct Workload {
    /// Number of pixels.
    pub pixels: u32,
    /// First sample index.
    pub spp_begin: u32,
    /// One past the last sample index.
    pub spp_end: u32,
    /// Number of path entities.
    pub wavefront: u32,
    /// Next work item to hand out.
    pub next: u64,
}

impl Workload {
    /// Work for `pixels` pixels and samples `spp_begin..spp_end` on `wavefront` entities, none handed out yet.
    pub fn new(pixels: u32, spp_begin: u32, spp_end: u32, wavefront: u32) -> Self {
        Self { pixels, spp_begin, spp_end, wavefront, next: 0 }
    }

    /// Total camera samples.
    pub fn total_samples(&self) -> u64 {
        self.pixels as u64 * (self.spp_end - self.spp_begin) as u64
    }

    /// The next (pixel, sample) to render, if any is left.
    pub fn take(&mut self) -> Option<(u32, u32)> {
        if self.next >= self.total_samples() {
            return None;
        }
        let k = self.next;
        self.next += 1;
        Some(((k % self.pixels as u64) as u32, self.spp_begin + (k / self.pixels as u64) as u32))
    }
}

/// Counters, summed in `gather` (no atomics in the hot systems).
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Camera samples splatted.
    pub samples: u64,
    /// Closest-hit rays traced.
    pub rays: u64,
    /// Shadow rays traced.
    pub shadow_rays: u64,
    /// Photon-map k-nearest lookups (photon mapping).
    pub lookups: u64,
    /// Samples whose radiance was NaN or infinite, dropped (counted as black).
    pub nan_samples: u64,
    /// Paths still working (not idle) after the last step.
    pub active_paths: u32,
    /// Schedule runs (bounce steps).
    pub steps: u64,
}

/// Whether the camera needs lens and time samples (decided from the scene, once).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneFeatures {
    /// The camera has an aperture.
    pub lens: bool,
    /// Something moves over the shutter.
    pub motion: bool,
    /// There is at least one emitter (otherwise NEE is skipped).
    pub lights: bool,
    /// Light selection learns visibility from shadow rays (then a learning system runs).
    pub learns_visibility: bool,
}

impl SceneFeatures {
    /// Features of a camera and scene.
    pub fn of(camera: &Camera, scene: &SceneGeometry) -> Self {
        Self {
            lens: camera.has_lens(),
            motion: scene.geometry.has_motion(),
            lights: !scene.lights.is_empty(),
            learns_visibility: scene.lights.is_learning(),
        }
    }
}

/// How bevy splits a wavefront among the workers: many small batches per thread, because the work
/// per path varies (a path that ended costs nothing, a glass hit costs more) and a thread that
/// finishes its share early would otherwise wait idle at the end of every stage.
pub fn wavefront_batching() -> bevy_ecs::batching::BatchingStrategy {
    bevy_ecs::batching::BatchingStrategy::new().batches_per_thread(16)
}

/// Which photons a pass keeps (Jensen 2001, §7.2, in path notation from the light).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotonMapKind {
    /// Every photon at a non-specular surface, L(S|D)*D: looked up by final-gather rays.
    Global,
    /// Photons after at least one diffuse bounce, L(S|D)*D(S|D)*D minus caustics: looked up directly
    /// at the first diffuse camera hit, where direct light and caustics come from elsewhere.
    Indirect,
    /// L S+ D: caustics, looked up directly at every diffuse camera hit.
    Caustic,
    /// Every photon after its first bounce, L(S|D)+D: progressive photon mapping with next-event
    /// estimation, where direct light comes from light sampling instead.
    Bounced,
}

/// The photons of the pass that is running and how they are handed out.
#[derive(Resource, Clone, Copy, Debug)]
pub struct PhotonWork {
    /// Which photons are stored.
    pub kind: PhotonMapKind,
    /// Photons to emit.
    pub total: u32,
    /// Next photon to hand out.
    pub next: u32,
    /// Sampler seed.
    pub seed: u64,
    /// Whether anything moves (photons then draw a shutter time).
    pub motion: bool,
    /// One shutter time for the whole pass (stochastic PPM: the camera pass uses the same one).
    pub time: Option<f32>,
    /// Photon pass number (progressive photon mapping): selects the pass's random numbers.
    pub pass: u32,
    /// Maximum bounces.
    pub max_depth: u32,
    /// Bounce from which Russian roulette is capped below one.
    pub rr_depth: u32,
}

impl PhotonWork {
    /// A pass of `total` photons kept by `kind`, none handed out yet, with the path settings of
    /// `config` (seed, depths); `motion` says whether photons draw a shutter time.
    pub fn new(kind: PhotonMapKind, total: u32, config: &RenderConfig, motion: bool) -> Self {
        Self {
            kind,
            total,
            next: 0,
            seed: config.seed,
            motion,
            time: None,
            pass: 0,
            max_depth: config.max_depth,
            rr_depth: config.rr_depth,
        }
    }
}

/// Photons deposited by the running pass, in a thread-independent order.
#[derive(Resource, Clone, Debug, Default)]
pub struct PhotonBuffer {
    /// The deposits.
    pub photons: Vec<crate::photon::Photon>,
}

/// Counters of the photon pass.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct PhotonStats {
    /// Photon rays traced.
    pub traced: u64,
    /// Photons ended by Russian roulette.
    pub roulette_kills: u64,
    /// Photons still in flight after the last step.
    pub active: u32,
    /// Steps run.
    pub steps: u64,
}

/// The photon maps a `pm` render looks up, and how it looks them up.
#[derive(Resource, Debug)]
pub struct PhotonMaps {
    /// Every photon at a non-specular hit (for final gathering), when final gathering is on.
    pub global: Option<crate::photon::PhotonMap>,
    /// Photons after a diffuse bounce (looked up directly), when final gathering is off.
    pub indirect: Option<crate::photon::PhotonMap>,
    /// L S+ D photons; absent when the scene has no specular surface.
    pub caustic: Option<crate::photon::PhotonMap>,
    /// Photons per estimate.
    pub k: usize,
    /// Largest squared gather radius.
    pub max_radius2: f32,
    /// Density-estimation kernel over the gather disc.
    pub kernel: crate::density::kernels::Kernel,
    /// Whether the first diffuse hit shoots a final-gather ray.
    pub final_gather: bool,
}

/// How a progressive integrator turns a hit point's statistics into radiance and a new radius.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RadiusRule {
    /// Hachisuka, Ogaki & Jensen 2008: flux-corrected shrinking with α; L = τ / (π r² passes).
    Shrinking,
    /// Kaplanyan & Dachsbacher 2013: per-pass estimates averaged, radius from estimated bias and
    /// variance; L = τ / (π passes) with τ = Σ Φ_i / r_i².
    Adaptive,
    /// Lin et al. 2020: per-pass estimates averaged, radius kept while the χ² test finds the photons
    /// uniform in the disc; L as for `Adaptive`.
    ChiSquare,
}

/// Settings and progress of a progressive photon-mapping render, read by the gather and update stages.
#[derive(Resource, Clone, Copy, Debug)]
pub struct ProgressiveConfig {
    /// Radius and accumulation rule.
    pub rule: RadiusRule,
    /// Fraction of new photons kept (Hachisuka, Ogaki & Jensen 2008).
    pub alpha: f32,
    /// Starting radius.
    pub r0: f32,
    /// Photons emitted per pass.
    pub photons_per_pass: u32,
    /// The running pass (0-based); after the update, the number of passes done minus one.
    pub pass: u32,
}
