//! Photon paths (Jensen 2001): emission in proportion to light power, a deposit at each non-specular
//! hit the map wants, and a continuation by BSDF sampling with Russian roulette on reflectivity, so
//! that surviving photons keep about the power they left with.

use super::Vertex;
use super::dimensions::photon as dim;
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::geometry::offset::{gamma, offset_ray_origin};
use crate::lights::EmissionSample;
use crate::materials::{BsdfSample, TransportMode};
use crate::photon::{Photon, PhotonMapKind};
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;
use glam::Vec3;

/// Highest survival probability once Russian roulette is in force: bounds the length of photon paths
/// trapped between lossless surfaces (glass, mirrors).
const MAX_SURVIVAL: f32 = 0.95;

/// A photon in flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonPath {
    /// Power carried, per channel.
    pub power: Vec3,
    /// Bounces so far.
    pub depth: u32,
    /// Whether every bounce so far was specular (a caustic path L S* while it lasts).
    pub specular_only: bool,
    /// The absorbing solids the photon is inside.
    pub media: super::media::Media,
}

impl Default for PhotonPath {
    fn default() -> Self {
        Self { power: Vec3::ZERO, depth: 0, specular_only: true, media: super::media::Media::AIR }
    }
}

/// What a photon pass is: which photons it keeps, how many it emits, and their limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonPassSettings {
    /// Which photons are stored.
    pub kind: PhotonMapKind,
    /// Photons emitted in the pass (each carries 1/total of the lights' power).
    pub total: u32,
    /// Maximum bounces.
    pub max_depth: u32,
    /// Bounce from which Russian roulette is capped below one.
    pub rr_depth: u32,
}

/// Start a photon on a light with `sampler`'s numbers at shutter time `time`: its first ray and path.
#[inline]
pub fn emit_photon(
    scene: &RenderScene,
    settings: &PhotonPassSettings,
    sampler: &Sampler,
    time: f32,
) -> Option<(Ray, PhotonPath)> {
    let (_, e, ray) = sample_emission(scene, sampler, time)?;
    Some((ray, PhotonPath { power: e.weight / settings.total as f32, ..PhotonPath::default() }))
}

/// A light by power, a point and a direction on it, with `sampler`'s numbers at shutter time
/// `time`: the light, the sample (its weight textured) and the first ray.
#[inline]
pub fn sample_emission(
    scene: &RenderScene,
    sampler: &Sampler,
    time: f32,
) -> Option<(u32, EmissionSample, Ray)> {
    let (light, mut e) = scene.lights.sample_emission(
        time,
        sampler.get1d(dim::LIGHT),
        sampler.get2d(dim::POSITION),
        sampler.get2d(dim::DIRECTION),
    )?;
    e.weight *= scene.emissive_texel(light, e.p, time);
    let ray =
        Ray { o: offset_ray_origin(e.p, e.p.abs() * gamma(4), e.n, e.d), d: e.d, t_max: f32::INFINITY, time };
    Some((light, e, ray))
}

/// The shutter time of a photon: the pass's when it fixes one, else its own when something moves.
#[inline]
pub fn photon_time(pass_time: Option<f32>, motion: bool, sampler: &Sampler) -> f32 {
    match (pass_time, motion) {
        (Some(time), _) => time,
        (None, true) => sampler.get1d(dim::TIME),
        (None, false) => 0.0,
    }
}

/// What happened to a photon at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonBounce {
    /// A photon left at the hit for the map.
    pub deposit: Option<Photon>,
    /// The next ray, if the photon goes on.
    pub next: Option<Ray>,
    /// Whether Russian roulette ended it.
    pub roulette_kill: bool,
}

/// What every photon (and light subpath) does where its ray lands: the medium it crossed absorbs,
/// and the surface there is built; `None` when the ray left the scene.
#[inline]
pub fn arrive(scene: &RenderScene, path: &mut PhotonPath, ray: &Ray, hit: &Hit) -> Option<Vertex> {
    if !hit.is_hit() {
        return None;
    }
    if path.media.current().is_some() {
        path.power *= path.media.transmittance(scene, hit.t);
    }
    Some(Vertex::new(scene, ray, scene.geometry.surface_hit(ray, hit)))
}

/// Deposit the photon where the map wants it, then continue it by BSDF sampling or end it by
/// Russian roulette.
#[inline]
pub fn scatter_photon(
    scene: &RenderScene,
    settings: &PhotonPassSettings,
    path: &mut PhotonPath,
    ray: &Ray,
    hit: &Hit,
    sampler: &Sampler,
) -> PhotonBounce {
    let mut bounce = PhotonBounce { deposit: None, next: None, roulette_kill: false };
    let Some(v) = arrive(scene, path, ray, hit) else { return bounce };
    let (si, bsdf) = (&v.si, &v.bsdf);
    let wo_world = -ray.d;
    let diffuse = !bsdf.is_delta();
    // A photon on a black surface lights nothing there, and stored it would only leak into the
    // estimates of surfaces within a gather radius (the front of a thin wall with a light behind it).
    if diffuse && bsdf.reflects_nothing() {
        return bounce;
    }
    if diffuse {
        // Photons are stored only where the BSDF is not a pure delta (Jensen 2001, §7.2).
        let store = match settings.kind {
            PhotonMapKind::Caustic => path.depth > 0 && path.specular_only,
            PhotonMapKind::Indirect => path.depth > 0 && !path.specular_only,
            PhotonMapKind::Global => true,
            PhotonMapKind::Bounced => path.depth > 0,
        };
        if store {
            // The normal of the side the photon arrived on, so the estimate can tell the two sides apart.
            let n = if wo_world.dot(si.ng) >= 0.0 { si.ng } else { -si.ng };
            bounce.deposit = Some(Photon::new(si.p, wo_world, n, path.power));
        }
        if settings.kind == PhotonMapKind::Caustic {
            // L S+ D ends at its first diffuse vertex.
            return bounce;
        }
    }
    (bounce.next, bounce.roulette_kill) = continue_photon(settings, path, &v, ray, sampler);
    bounce
}

/// Continue a photon (or a light subpath) from vertex `v` by BSDF sampling, or end it by Russian
/// roulette on reflectivity: the next ray, if any, and whether roulette ended it.
#[inline]
pub fn continue_photon(
    settings: &PhotonPassSettings,
    path: &mut PhotonPath,
    v: &Vertex,
    ray: &Ray,
    sampler: &Sampler,
) -> (Option<Ray>, bool) {
    let (next, killed) = continue_photon_sampled(settings, path, v, ray, sampler);
    (next.map(|(ray, _)| ray), killed)
}

/// [`continue_photon`], with the BSDF sample the next ray follows (bidirectional weights need its
/// densities).
#[inline]
pub fn continue_photon_sampled(
    settings: &PhotonPassSettings,
    path: &mut PhotonPath,
    v: &Vertex,
    ray: &Ray,
    sampler: &Sampler,
) -> (Option<(Ray, BsdfSample)>, bool) {
    let (si, bsdf) = (&v.si, &v.bsdf);
    if path.depth + 1 >= settings.max_depth {
        return (None, false);
    }
    let base = super::dimensions::photon_bounce_dimension(path.depth);
    let Some(bs) = bsdf.sample(
        v.wo,
        sampler.get1d(base + dim::LOBE),
        sampler.get2d(base + dim::BSDF),
        TransportMode::Importance,
    ) else {
        return (None, false);
    };
    // Survive with the surface's reflectivity (capped after rr_depth so lossless loops end).
    let reflectivity = bsdf.albedo_hint().max_element();
    let survive =
        if path.depth >= settings.rr_depth { reflectivity.min(MAX_SURVIVAL) } else { reflectivity.min(1.0) };
    if sampler.get1d(base + dim::ROULETTE) >= survive {
        return (None, true);
    }
    let power = path.power * bs.f * (bs.wi.z.abs() / (bs.pdf * survive));
    if !power.is_finite() || power.max_element() <= 0.0 {
        return (None, false);
    }
    path.power = power;
    path.specular_only &= bs.is_specular;
    path.depth += 1;
    let wi_world = v.frame.to_world(bs.wi);
    if super::continuation::crosses_inconsistently(v, wi_world, bs.wi) {
        return (None, false);
    }
    if bs.is_transmission && v.volume {
        path.media.cross_volume(si.material, wi_world.dot(si.ng) < 0.0);
    }
    let next = Ray {
        o: offset_ray_origin(si.p, si.p_error, si.ng, wi_world),
        d: wi_world,
        t_max: f32::INFINITY,
        time: ray.time,
    };
    (Some((next, bs)), false)
}
