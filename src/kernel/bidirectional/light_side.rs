//! The light subpath of bidirectional path tracing: its emission, each vertex's weights, the
//! vertices kept for the camera subpaths, and the t = 1 strategy (the vertex seen by the camera).

use super::mis::{MisFactors, SubpathMis, positive, weight};
use crate::camera::Camera;
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::kernel::Vertex;
use crate::kernel::light_path::{CameraConnection, connect};
use crate::kernel::photon::{
    PhotonPassSettings, PhotonPath, arrive, continue_photon_sampled, sample_emission,
};
use crate::lights::bidirectional::EmitterKind;
use crate::materials::Bsdf;
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;
use crate::sampling::warp::Frame;
use glam::{Vec2, Vec3};

/// Where a light subpath started: what the weights of its first vertex need, known only once the
/// vertex is (light sampling from there picks the origin with a density that depends on it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightOrigin {
    /// The light.
    pub light: u32,
    /// The point it left from, and the light's normal there.
    pub p: Vec3,
    /// The light's normal at `p`.
    pub n: Vec3,
    /// Emission's density of the start (selection included).
    pub emission_pdf: f32,
    /// The cosine at the origin (1 for an infinite light).
    pub cos: f32,
    /// Delta, finite.
    pub kind: EmitterKind,
}

impl Default for LightOrigin {
    fn default() -> Self {
        Self {
            light: 0,
            p: Vec3::ZERO,
            n: Vec3::ZERO,
            emission_pdf: 0.0,
            cos: 0.0,
            kind: EmitterKind { delta: false, finite: true },
        }
    }
}

/// A non-delta vertex of a light subpath, kept for the camera subpaths to connect to: what a
/// connection reads of it. 128 bytes: the whole [`Vertex`], with the hit's texture coordinates and
/// the material's parameters, is 384, and a pass at 1200² keeps three million; the BSDF, 168 of
/// those bytes, is kept whole only where it is not Lambertian ([`KeptBsdf`]).
#[derive(Clone, Copy, Debug)]
pub struct LightVertex {
    /// The point.
    pub p: Vec3,
    /// Its floating-point error bound (to offset the connection's end).
    pub p_error: Vec3,
    /// The geometric normal.
    pub ng: Vec3,
    /// The shading frame.
    pub frame: Frame,
    /// Towards where the subpath came from, in the shading frame.
    pub wo: Vec3,
    /// The BSDF there.
    pub bsdf: KeptBsdf,
    /// The subpath's throughput arriving there.
    pub beta: Vec3,
    /// Its running sums there.
    pub mis: SubpathMis,
    /// Bounces before it (0: the first hit).
    pub depth: u32,
}

/// What a merge reads of a kept light vertex (52 bytes of its 128): vcm's grid holds these in its
/// cells, so a camera vertex tests and merges the candidates of a cell from one contiguous run
/// instead of fetching each from the vertex table (a cache miss a merge, the larger part of vcm's
/// connection stage).
#[derive(Clone, Copy, Debug, Default)]
pub struct MergeVertex {
    /// The point.
    pub p: Vec3,
    /// Bounces before it.
    pub depth: u32,
    /// Towards where the subpath came from, in world space.
    pub wi: Vec3,
    /// The subpath's throughput arriving there.
    pub beta: Vec3,
    /// Its running sums there.
    pub mis: SubpathMis,
}

impl crate::photon::hash_grid::GridPoint for MergeVertex {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// The BSDF of a kept light vertex: a Lambertian one by its albedo (most surfaces of most scenes),
/// any other by its place in the pass's table of kept BSDFs.
#[derive(Clone, Copy, Debug)]
pub enum KeptBsdf {
    /// A plain Lambertian BSDF of this albedo.
    Lambert(Vec3),
    /// The BSDF at this index of the table.
    InTable(u32),
}

/// A light vertex just made, with its BSDF whole: what a subpath hands to the store that keeps it
/// ([`NewLightVertex::keep`]).
#[derive(Clone, Copy, Debug)]
pub struct NewLightVertex {
    /// The vertex (its BSDF not yet placed when it is not Lambertian).
    pub vertex: LightVertex,
    /// Its BSDF.
    pub bsdf: Bsdf,
}

impl NewLightVertex {
    /// Vertex `v` reached with throughput `beta` and sums `mis` after `depth` bounces, with its
    /// BSDF whole until it is kept.
    #[inline]
    pub fn new(v: &Vertex, beta: Vec3, mis: SubpathMis, depth: u32) -> Self {
        let bsdf = match v.bsdf.lambert_albedo() {
            Some(albedo) => KeptBsdf::Lambert(albedo),
            None => KeptBsdf::InTable(u32::MAX),
        };
        let vertex = LightVertex {
            p: v.si.p,
            p_error: v.si.p_error,
            ng: v.si.ng,
            frame: v.frame,
            wo: v.wo,
            bsdf,
            beta,
            mis,
            depth,
        };
        Self { vertex, bsdf: v.bsdf }
    }

    /// The vertex as kept: a BSDF that is not Lambertian goes into `table`.
    #[inline]
    pub fn keep(self, table: &mut Vec<Bsdf>) -> LightVertex {
        let mut vertex = self.vertex;
        if let KeptBsdf::InTable(_) = vertex.bsdf {
            vertex.bsdf = KeptBsdf::InTable(table.len() as u32);
            table.push(self.bsdf);
        }
        vertex
    }
}

impl LightVertex {
    /// Its BSDF, from `table` (the pass's kept BSDFs) when it is not Lambertian.
    #[inline]
    pub fn bsdf(&self, table: &[Bsdf]) -> Bsdf {
        match self.bsdf {
            KeptBsdf::Lambert(albedo) => Bsdf::lambert(albedo),
            KeptBsdf::InTable(index) => table[index as usize],
        }
    }

    /// What a merge reads of it, for the merging grid to hold in its own cells.
    #[inline]
    pub fn merge_vertex(&self) -> MergeVertex {
        MergeVertex {
            p: self.p,
            depth: self.depth,
            wi: self.frame.to_world(self.wo),
            beta: self.beta,
            mis: self.mis,
        }
    }

    /// Whether `wi` (world and local) leaves on one side by the shading normal and the other by
    /// the geometric one, relative to where the subpath arrived (as
    /// [`crate::kernel::continuation::crosses_inconsistently`]).
    #[inline]
    pub fn crosses_inconsistently(&self, wi_world: Vec3, wi_local: Vec3) -> bool {
        let wo_world = self.frame.to_world(self.wo);
        wi_world.dot(self.ng) * wo_world.dot(self.ng) * wi_local.z * self.wo.z < 0.0
    }
}

/// Start a light subpath with `sampler`'s numbers at shutter time `time`: its first ray, its
/// photon path (power undivided: each subpath is a whole estimate) and its origin.
#[inline]
pub fn emit_light_subpath(
    scene: &RenderScene,
    sampler: &Sampler,
    time: f32,
) -> Option<(Ray, PhotonPath, LightOrigin)> {
    let (light, e, ray) = sample_emission(scene, sampler, time)?;
    let kind = scene.lights.emitter_kind(light);
    let emission_pdf = scene.lights.emission_pdf(light, e.n, e.d);
    if !positive(emission_pdf) {
        return None;
    }
    let cos = if kind.finite && !kind.delta { e.n.dot(e.d).abs() } else { 1.0 };
    let origin = LightOrigin { light, p: e.p, n: e.n, emission_pdf, cos, kind };
    Some((ray, PhotonPath { power: e.weight, ..PhotonPath::default() }, origin))
}

/// What a light subpath did at a hit, beside the vertex it kept.
#[derive(Clone, Copy, Debug)]
pub struct LightStep {
    /// Its connection to the camera, weighted.
    pub connection: Option<CameraConnection>,
    /// The next ray, if the subpath goes on.
    pub next: Option<Ray>,
    /// Whether Russian roulette ended it.
    pub roulette_kill: bool,
}

/// One vertex of a light subpath: its weights, the vertex kept for connections, its weighted
/// connection to the lens point `u_lens` (paths of at most `max_depth` bounces), then its
/// continuation. `mis` holds the sums of the subpath's last vertex (unset before the first hit);
/// `kept` receives the vertex if it is not a delta one (written in place: 300 bytes that a return
/// would copy twice).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn light_subpath_vertex(
    scene: &RenderScene,
    camera: &Camera,
    factors: &MisFactors,
    settings: &PhotonPassSettings,
    origin: &LightOrigin,
    mis: &mut SubpathMis,
    path: &mut PhotonPath,
    ray: &Ray,
    hit: &Hit,
    sampler: &Sampler,
    u_lens: Vec2,
    kept: &mut Option<NewLightVertex>,
) -> LightStep {
    let mut step = LightStep { connection: None, next: None, roulette_kill: false };
    *kept = None;
    let Some(v) = arrive(scene, path, ray, hit) else { return step };
    let dist2 = (hit.t * ray.d.length()).powi(2);
    let cos_in = v.wo.z.abs();
    if path.depth == 0 {
        *mis = first_vertex_mis(scene, factors, origin, v.si.p, ray, dist2, ray.time);
        mis.arrive(origin.kind.finite.then_some(dist2), cos_in);
    } else {
        mis.arrive(Some(dist2), cos_in);
    }
    if !v.bsdf.is_delta() {
        if v.bsdf.reflects_nothing() {
            return step;
        }
        *kept = Some(NewLightVertex::new(&v, path.power, *mis, path.depth));
        // The t = 1 path has this vertex's bounces and the one towards the camera.
        if path.depth < settings.max_depth {
            step.connection = connect(scene, camera, &v, path, u_lens, ray.time)
                .and_then(|c| weigh_camera_connection(camera, factors, &v, mis, c));
        }
    }
    let (next, killed) = continue_photon_sampled(settings, path, &v, ray, sampler);
    step.roulette_kill = killed;
    if let Some((next, bs)) = next {
        let pdf_rev = if bs.is_specular { bs.pdf } else { v.bsdf.pdf(bs.wi, v.wo) };
        mis.scatter(factors, bs.wi.z.abs(), bs.pdf, pdf_rev, bs.is_specular);
        step.next = Some(next);
    }
    step
}

/// The sums at a light subpath's first vertex `p`, reached along `ray` over `dist2`, before its
/// arrival there: light sampling from `p` picks the origin with a density that depends on `p`.
#[inline]
pub fn first_vertex_mis(
    scene: &RenderScene,
    factors: &MisFactors,
    origin: &LightOrigin,
    p: Vec3,
    ray: &Ray,
    dist2: f32,
    time: f32,
) -> SubpathMis {
    let lights = &scene.lights;
    let direct_pdf = if origin.kind.delta {
        lights.power_pmf(origin.light)
    } else if origin.kind.finite {
        lights.direct_pdf(origin.light, p, origin.p, origin.n, -ray.d, time) * origin.cos / dist2
    } else {
        lights.direct_pdf(origin.light, p, origin.p, origin.n, -ray.d, time)
    };
    SubpathMis::light(factors, direct_pdf, origin.emission_pdf, origin.cos, origin.kind.delta)
}

/// Light tracing's connection `c` from vertex `v` (sums `mis`), weighted.
#[inline]
fn weigh_camera_connection(
    camera: &Camera,
    factors: &MisFactors,
    v: &Vertex,
    mis: &SubpathMis,
    mut c: CameraConnection,
) -> Option<CameraConnection> {
    c.value *= camera_connection_weight(camera, factors, v, mis, c.shadow.o + c.shadow.d);
    (c.value.max_element() > 0.0).then_some(c)
}

/// The weight of light tracing's connection from vertex `v` (sums `mis`) to the lens point `lens`:
/// against the strategies that make the same path from the camera's side.
#[inline]
pub fn camera_connection_weight(
    camera: &Camera,
    factors: &MisFactors,
    v: &Vertex,
    mis: &SubpathMis,
    lens: Vec3,
) -> f32 {
    let to_lens = lens - v.si.p;
    let dist2 = to_lens.length_squared();
    let wi_world = to_lens / dist2.sqrt();
    let wi = v.frame.to_local(wi_world);
    let camera_pdf_a = camera.pdf_w(-wi_world) * wi.z.abs() / dist2;
    weight(mis.towards(factors, camera_pdf_a / factors.light_paths, v.bsdf.pdf(wi, v.wo)), 0.0)
}

const _: () = assert!(size_of::<LightVertex>() == 128 && size_of::<MergeVertex>() == 52);
