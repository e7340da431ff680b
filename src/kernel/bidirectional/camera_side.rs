//! The camera subpath of bidirectional path tracing: the emission it hits (s = 0) and the light it
//! samples (s = 1), each weighted, the vertex it leaves for connections (s, t ≥ 2), and its
//! continuation.

use super::light_side::{LightVertex, MergeVertex};
use super::mis::{MisFactors, SubpathMis, positive, to_area, weight};
use crate::camera::Camera;
use crate::geometry::Ray;
use crate::geometry::bvh::{Hit, NO_LIGHT};
use crate::geometry::offset::{SHADOW_EPSILON, offset_ray_origin};
use crate::kernel::aov::FirstSurface;
use crate::kernel::continuation::crosses_inconsistently;
use crate::kernel::direct::ShadowSample;
use crate::kernel::{CameraPath, PathLimits, Quantity, Vertex, VertexSampler, continue_path};
use crate::lights::LightSample;
use crate::materials::{Bsdf, TransportMode};
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;
use glam::Vec3;

/// A non-delta camera vertex left for the connection stage.
#[derive(Clone, Copy, Debug)]
pub struct CameraVertex {
    /// The vertex.
    pub v: Vertex,
    /// The path's throughput arriving there.
    pub beta: Vec3,
    /// Its running sums there.
    pub mis: SubpathMis,
    /// Bounces before it (0: the first hit).
    pub depth: u32,
    /// The path's media there (a connection crosses the medium the vertex is in).
    pub media: crate::kernel::media::Media,
}

/// What a camera vertex leaves for the stages after it (written in place: the vertex is 400 bytes).
#[derive(Debug)]
pub struct CameraStep<'a> {
    /// Its light sample, weighted, waiting for the shadow stage.
    pub shadow: Option<ShadowSample>,
    /// The vertex for the connection stage.
    pub vertex: &'a mut Option<CameraVertex>,
}

/// One vertex of a camera subpath that travelled along `ray` to `hit`: the emission there (or the
/// sky), weighted; its light sample and its vertex for connections; then its continuation, into
/// `ray`. False when the path ends. `mis` holds the sums of the path's last vertex (set here at
/// the first).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn camera_vertex(
    scene: &RenderScene,
    camera: &Camera,
    factors: &MisFactors,
    limits: PathLimits,
    ray: &mut Ray,
    hit: &Hit,
    path: &mut CameraPath,
    mis: &mut SubpathMis,
    sampler: Sampler,
    aov: Option<&mut FirstSurface>,
    step: &mut CameraStep<'_>,
) -> bool {
    *step.vertex = None;
    if path.depth == 0 {
        *mis = SubpathMis::camera(factors, camera.pdf_w(ray.d.normalize()));
    }
    path.travel(scene, hit);
    if !hit.is_hit() {
        add_sky(scene, path, mis, ray.d);
        if let Some(aov) = aov {
            aov.escaped(scene, ray.d, path.beta);
        }
        return false;
    }
    let u = VertexSampler::new(sampler, path.depth);
    let si = scene.geometry.surface_hit(ray, hit);
    let v = Vertex::new(scene, ray, si);
    let dist2 = (hit.t * ray.d.length()).powi(2);
    mis.arrive(Some(dist2), v.wo.z.abs());
    add_emission(scene, path, mis, &v, -ray.d.normalize(), dist2, ray.time);
    if path.depth >= limits.max_depth {
        return false;
    }
    if let Some(aov) = aov {
        aov.reached(&v, hit.t, path.beta);
    }
    if !v.bsdf.is_delta() && !v.bsdf.reflects_nothing() {
        step.shadow = sample_light(scene, factors, &v, path, mis, ray.time, &u);
        *step.vertex =
            Some(CameraVertex { v, beta: path.beta, mis: *mis, depth: path.depth, media: path.media });
    }
    let Some(next) = continue_path(path, &v, ray.time, &u, limits) else { return false };
    let wi = v.frame.to_local(next.d);
    let pdf_rev = if path.specular_bounce { path.prev_pdf } else { v.bsdf.pdf(wi, v.wo) };
    mis.scatter(factors, wi.z.abs(), path.prev_pdf, pdf_rev, path.specular_bounce);
    *ray = next;
    true
}

/// The sky a camera path that left the scene along `d` sees, weighted against light sampling and
/// light subpaths leaving the sky.
#[inline]
fn add_sky(scene: &RenderScene, path: &mut CameraPath, mis: &SubpathMis, d: Vec3) {
    let lights = &scene.lights;
    let Some(environment) = &lights.environment else { return };
    let le = environment.le(d);
    let w = sky_weight(scene, path, mis, d);
    path.add(path.beta * le * w, Quantity::Environment);
}

/// The weight of the sky that camera path `path` (sums `mis`) sees along `d`: against light
/// sampling at its previous vertex and light subpaths leaving the sky.
#[inline]
pub fn sky_weight(scene: &RenderScene, path: &CameraPath, mis: &SubpathMis, d: Vec3) -> f32 {
    if path.depth == 0 {
        return 1.0;
    }
    let lights = &scene.lights;
    let index = lights.environment_index();
    let direct_pdf = lights.direct_pdf(index, path.prev_p, Vec3::ZERO, Vec3::ZERO, d, 0.0);
    let emission_pdf = lights.emission_pdf(index, Vec3::ZERO, -d.normalize());
    weight(0.0, mis.hitting_light(direct_pdf, emission_pdf))
}

/// The emission of vertex `v`'s surface seen from `wo` (world, unit) over `dist2`, weighted
/// against light sampling at the previous vertex and light subpaths leaving this point.
#[inline]
fn add_emission(
    scene: &RenderScene,
    path: &mut CameraPath,
    mis: &SubpathMis,
    v: &Vertex,
    wo: Vec3,
    dist2: f32,
    time: f32,
) {
    let si = &v.si;
    // Written as a positive test so that a NaN normal adds nothing.
    if !(si.light != NO_LIGHT && si.ng.dot(wo) > 0.0) {
        return;
    }
    let w = emission_weight(scene, path, mis, v, wo, dist2, time);
    path.add(path.beta * scene.emission(si) * w, Quantity::Emission);
}

/// The weight of the emission of vertex `v` (a light's front, seen from `wo` over `dist2`) that
/// camera path `path` (sums `mis` there) hit: against light sampling at its previous vertex and
/// light subpaths leaving the point.
#[inline]
pub fn emission_weight(
    scene: &RenderScene,
    path: &CameraPath,
    mis: &SubpathMis,
    v: &Vertex,
    wo: Vec3,
    dist2: f32,
    time: f32,
) -> f32 {
    if path.depth == 0 {
        // Seen directly: no light subpath reaches the lens, so the camera is the only strategy.
        return 1.0;
    }
    let (si, lights) = (&v.si, &scene.lights);
    let direct_pdf_a =
        to_area(lights.direct_pdf(si.light, path.prev_p, si.p, si.ng, -wo, time), dist2, v.wo.z.abs());
    let emission_pdf = lights.emission_pdf(si.light, si.ng, wo);
    weight(0.0, mis.hitting_light(direct_pdf_a, emission_pdf))
}

/// The s = 1 strategy at vertex `v`: a light by power and a point on it, weighted against the
/// camera subpath hitting it and against light subpaths that leave it.
#[inline]
fn sample_light(
    scene: &RenderScene,
    factors: &MisFactors,
    v: &Vertex,
    path: &CameraPath,
    mis: &SubpathMis,
    time: f32,
    u: &VertexSampler,
) -> Option<ShadowSample> {
    let si = &v.si;
    let lights = &scene.lights;
    let (light, mut ls) = lights.sample_by_power(si.p, time, u.light_select(), u.light_point())?;
    if light == si.light || !positive(ls.pdf) {
        return None;
    }
    ls.le *= scene.emissive_texel(light, ls.p, time);
    let to_light = ls.p - si.p;
    let dist2 = to_light.length_squared();
    let wi_world = to_light / dist2.sqrt();
    let wi = v.frame.to_local(wi_world);
    if crosses_inconsistently(v, wi_world, wi) {
        return None;
    }
    let f = v.bsdf.eval(v.wo, wi, TransportMode::Radiance) * wi.z.abs();
    if !positive(f.max_element()) {
        return None;
    }
    let w = light_sample_weight(scene, factors, v, mis, light, &ls);
    let beta = path.beta * path.media.transmittance(scene, dist2.sqrt());
    let contribution = beta * f * ls.le * (w / ls.pdf);
    if !positive(contribution.max_element()) {
        return None;
    }
    let origin = offset_ray_origin(si.p, si.p_error, si.ng, wi_world);
    let ray = Ray { o: origin, d: ls.p - origin, t_max: 1.0 - SHADOW_EPSILON, time };
    Some(ShadowSample { ray, contribution, light, normal: v.n_side() })
}

/// The weight of light sample `ls` of light `light` taken at vertex `v` (sums `mis` there):
/// against the camera path hitting the light and light subpaths leaving it.
#[inline]
pub fn light_sample_weight(
    scene: &RenderScene,
    factors: &MisFactors,
    v: &Vertex,
    mis: &SubpathMis,
    light: u32,
    ls: &LightSample,
) -> f32 {
    let lights = &scene.lights;
    let to_light = ls.p - v.si.p;
    let dist2 = to_light.length_squared();
    let wi_world = to_light / dist2.sqrt();
    let wi = v.frame.to_local(wi_world);
    let kind = lights.emitter_kind(light);
    let emission_pdf = lights.emission_pdf(light, ls.n, -wi_world);
    let cos_x = wi.z.abs();
    let (emission_pdf_a, direct_pdf_a) = match (kind.delta, kind.finite) {
        (true, true) => (emission_pdf * cos_x / dist2, ls.pdf),
        (true, false) | (false, false) => (emission_pdf * cos_x, ls.pdf),
        (false, true) => (emission_pdf * cos_x / dist2, to_area(ls.pdf, dist2, ls.n.dot(-wi_world).abs())),
    };
    let w_light = if kind.delta { 0.0 } else { super::mis::mis(v.bsdf.pdf(v.wo, wi) / ls.pdf) };
    let w_camera = mis.towards(factors, emission_pdf_a / direct_pdf_a, v.bsdf.pdf(wi, v.wo));
    weight(w_light, w_camera)
}

/// The weight of the connection of camera vertex `c` to light vertex `l` (BSDF `l_bsdf`) over
/// `dist2`, the segment's direction in each one's shading frame being `wi_c` (towards `l`) and
/// `wi_l` (towards `c`).
#[inline]
pub fn connection_weight(
    factors: &MisFactors,
    c: &CameraVertex,
    (l, l_bsdf): (&LightVertex, &Bsdf),
    (wi_c, wi_l): (Vec3, Vec3),
    dist2: f32,
) -> f32 {
    let (cos_c, cos_l) = (wi_c.z.abs(), wi_l.z.abs());
    let w_light =
        l.mis.towards(factors, to_area(c.v.bsdf.pdf(c.v.wo, wi_c), dist2, cos_l), l_bsdf.pdf(wi_l, l.wo));
    let w_camera =
        c.mis.towards(factors, to_area(l_bsdf.pdf(l.wo, wi_l), dist2, cos_c), c.v.bsdf.pdf(wi_c, c.v.wo));
    weight(w_light, w_camera)
}

/// The connection of camera vertex `c` to light vertex `l` (s, t ≥ 2; its BSDF, if not Lambertian,
/// in `bsdfs`): the segment to trace and what it adds to the camera path if free, weighted; `None`
/// when it adds nothing.
#[inline]
pub fn connect_vertices(
    scene: &RenderScene,
    factors: &MisFactors,
    c: &CameraVertex,
    (l, bsdfs): (&LightVertex, &[Bsdf]),
    time: f32,
) -> Option<(Ray, Vec3)> {
    let d = l.p - c.v.si.p;
    let dist2 = d.length_squared();
    if !positive(dist2) {
        return None;
    }
    let dist = dist2.sqrt();
    let dir = d / dist;
    let wi_c = c.v.frame.to_local(dir);
    let wi_l = l.frame.to_local(-dir);
    if crosses_inconsistently(&c.v, dir, wi_c) || l.crosses_inconsistently(-dir, wi_l) {
        return None;
    }
    let f_c = c.v.bsdf.eval(c.v.wo, wi_c, TransportMode::Radiance);
    let l_bsdf = l.bsdf(bsdfs);
    let f_l = l_bsdf.eval(l.wo, wi_l, TransportMode::Importance);
    let g = wi_c.z.abs() * wi_l.z.abs() / dist2;
    let value = c.beta * l.beta * f_c * f_l * g;
    if !positive(value.max_element()) {
        return None;
    }
    let contribution = value
        * connection_weight(factors, c, (l, &l_bsdf), (wi_c, wi_l), dist2)
        * c.media.transmittance(scene, dist);
    if !positive(contribution.max_element()) || !contribution.is_finite() {
        return None;
    }
    let origin = offset_ray_origin(c.v.si.p, c.v.si.p_error, c.v.si.ng, dir);
    let target = offset_ray_origin(l.p, l.p_error, l.ng, -dir);
    Some((Ray { o: origin, d: target - origin, t_max: 1.0 - SHADOW_EPSILON, time }, contribution))
}

/// The merging of camera vertex `c` with light vertex `l` (within the merging radius): what it adds
/// to the camera path before the kernel's normalization, weighted (Georgiev et al. 2012's vertex
/// merging: the light vertex's flux, through the camera vertex's BSDF).
#[inline]
pub fn merge_vertices(factors: &MisFactors, c: &CameraVertex, l: &MergeVertex) -> Vec3 {
    let wi = c.v.frame.to_local(l.wi);
    let f = c.v.bsdf.eval(c.v.wo, wi, TransportMode::Radiance);
    if !positive(f.max_element()) {
        return Vec3::ZERO;
    }
    let w = super::mis::merging_weight(
        factors,
        &c.mis,
        &l.mis,
        c.v.bsdf.pdf(c.v.wo, wi),
        c.v.bsdf.pdf(wi, c.v.wo),
    );
    let value = c.beta * f * l.beta * w;
    if value.is_finite() { value } else { Vec3::ZERO }
}
