//! Light tracing (Veach's t = 1 strategy): every vertex of a light subpath that the camera can see
//! sends the camera what it reflects towards it, added to the film where it lands. Emission, the
//! BSDFs and Russian roulette are the photons' ([`super::photon`]); what is new is the connection.

use super::Vertex;
use super::photon::{PhotonPassSettings, PhotonPath, arrive, continue_photon};
use crate::camera::Camera;
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::geometry::offset::{SHADOW_EPSILON, offset_ray_origin};
use crate::materials::TransportMode;
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;
use glam::{Vec2, Vec3};

/// A light subpath's vertex seen by the camera: what it adds to the film at `raster` if the segment
/// to the lens is free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraConnection {
    /// The segment from the vertex to the lens point (`t_max` just short of 1).
    pub shadow: Ray,
    /// Where on the film it lands, in pixels from the top-left corner.
    pub raster: Vec2,
    /// β · f · |cos θ| · W_e / pdf: the radiance it adds there (before the filter's share).
    pub value: Vec3,
}

/// What happened to a light subpath at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounce {
    /// The connection to the camera, if the vertex can send it anything.
    pub connection: Option<CameraConnection>,
    /// The next ray, if the subpath goes on.
    pub next: Option<Ray>,
    /// Whether Russian roulette ended it.
    pub roulette_kill: bool,
}

/// One vertex of a light subpath: its connection to the camera (for the lens point `u_lens`), then
/// its continuation. `path.power` is the subpath's own estimate (emitted with a total of one, not
/// divided among the pass's subpaths: the pass's camera samples, one a pixel per unit, divide the
/// film's sums, whatever passes the units are grouped in).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn light_vertex(
    scene: &RenderScene,
    camera: &Camera,
    settings: &PhotonPassSettings,
    path: &mut PhotonPath,
    ray: &Ray,
    hit: &Hit,
    sampler: &Sampler,
    u_lens: Vec2,
) -> LightBounce {
    let mut bounce = LightBounce { connection: None, next: None, roulette_kill: false };
    let Some(v) = arrive(scene, path, ray, hit) else { return bounce };
    if !v.bsdf.is_delta() {
        // A black surface sends nothing, to the camera or further.
        if v.bsdf.reflects_nothing() {
            return bounce;
        }
        bounce.connection = connect(scene, camera, &v, path, u_lens, ray.time);
    }
    (bounce.next, bounce.roulette_kill) = continue_photon(settings, path, &v, ray, sampler);
    bounce
}

/// The connection of vertex `v` to the camera, or `None` when the camera cannot see it or it sends
/// the camera nothing.
pub fn connect(
    scene: &RenderScene,
    camera: &Camera,
    v: &Vertex,
    path: &PhotonPath,
    u_lens: Vec2,
    time: f32,
) -> Option<CameraConnection> {
    let si = &v.si;
    let importance = camera.sample_importance(si.p, u_lens)?;
    let to_lens = importance.lens - si.p;
    let wi_world = to_lens.normalize();
    let wi = v.frame.to_local(wi_world);
    // As for a light sample: the camera on the far side of the geometric surface sees nothing of
    // this side, whatever the shading normal says.
    if super::continuation::crosses_inconsistently(v, wi_world, wi) {
        return None;
    }
    // Importance transport: the photon came along `wo`, the camera is along `wi`.
    let f = v.bsdf.eval(v.wo, wi, TransportMode::Importance) * wi.z.abs();
    let beta = path.power * path.media.transmittance(scene, to_lens.length());
    let value = beta * f * importance.weight;
    if value.max_element() <= 0.0 || !value.is_finite() {
        return None;
    }
    let origin = offset_ray_origin(si.p, si.p_error, si.ng, wi_world);
    let shadow = Ray { o: origin, d: importance.lens - origin, t_max: 1.0 - SHADOW_EPSILON, time };
    Some(CameraConnection { shadow, raster: importance.raster, value })
}
