//! Next-event estimation: one light sample at a vertex, as a shadow ray and what it adds if nothing
//! blocks it.

use super::{CameraPath, Vertex, VertexSampler, mis::power_heuristic};
use crate::geometry::Ray;
use crate::geometry::offset::{SHADOW_EPSILON, offset_ray_origin};
use crate::materials::TransportMode;
use crate::render_scene::RenderScene;
use glam::Vec3;

/// A light sample waiting for its visibility test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSample {
    /// The segment from the vertex to the point on the light (`t_max` just short of 1).
    pub ray: Ray,
    /// β · f · |cos θ| · Le · w / pdf: what the path gains when the segment is free.
    pub contribution: Vec3,
    /// The light sampled.
    pub light: u32,
    /// The shading normal at the vertex, on the side it is seen from.
    pub normal: Vec3,
}

/// Sample a light for vertex `v` of `path` (its throughput and the medium it is in) at shutter
/// time `time`. With
/// `mis`, the contribution carries the power-heuristic weight against BSDF sampling (which then
/// counts emission it hits with the complementary weight); without, light sampling is the only way
/// this vertex sees direct light. None when no light is picked, the BSDF sends nothing towards it,
/// or its pdf is zero.
#[inline]
pub fn sample_light(
    scene: &RenderScene,
    v: &Vertex,
    path: &CameraPath,
    time: f32,
    u: &VertexSampler,
    mis: bool,
) -> Option<ShadowSample> {
    sample_light_against(scene, v, path, time, u, mis, |wi, _| v.bsdf.pdf(v.wo, wi))
}

/// [`sample_light`] weighed by MIS against a continuation whose pdf towards a direction (local,
/// then world) is `scatter_pdf`: the BSDF's, or path guiding's mixture of the BSDF and the guide.
#[inline]
pub fn sample_light_against(
    scene: &RenderScene,
    v: &Vertex,
    path: &CameraPath,
    time: f32,
    u: &VertexSampler,
    mis: bool,
    scatter_pdf: impl FnOnce(Vec3, Vec3) -> f32,
) -> Option<ShadowSample> {
    let si = &v.si;
    let normal = v.n_side();
    let (light, mut ls) = scene.lights.sample(si.p, normal, time, u.light_select(), u.light_point())?;
    ls.le *= scene.emissive_texel(light, ls.p, time);
    // A light never lights its own surface: a sphere is convex and a triangle flat, so the sample's
    // contribution is zero. Sampled from its own surface a sphere's cone is the whole hemisphere and
    // every sample collapses onto the shading point itself (a zero-length, NaN direction).
    if light == si.light {
        return None;
    }
    let wi_world = (ls.p - si.p).normalize();
    debug_assert!(wi_world.is_finite(), "light {light} sampled at the shading point {} itself", si.p);
    let wi = v.frame.to_local(wi_world);
    // A shading normal (interpolated or mapped) must not let light through the surface: a light on
    // the far side of the geometric surface lights nothing here, whatever side of the shading
    // normal it is on (Mitsuba's rule; without it a normal map leaks light from behind a wall).
    if super::continuation::crosses_inconsistently(v, wi_world, wi) {
        return None;
    }
    let f = v.bsdf.eval(v.wo, wi, TransportMode::Radiance) * wi.z.abs();
    if !(f.max_element() > 0.0 && ls.pdf > 0.0) {
        return None;
    }
    // A delta light: no BSDF sample can find it, so light sampling takes all of it.
    // The medium the vertex is in absorbs along the shadow ray (a light outside it is behind its
    // interface, which blocks shadow rays).
    let beta = path.beta * path.media.transmittance(scene, (ls.p - si.p).length());
    let contribution = if mis && !ls.delta {
        let weight = power_heuristic(ls.pdf, scatter_pdf(wi, wi_world));
        beta * f * ls.le * (weight / ls.pdf)
    } else {
        beta * f * ls.le / ls.pdf
    };
    let origin = offset_ray_origin(si.p, si.p_error, si.ng, wi_world);
    let ray = Ray { o: origin, d: ls.p - origin, t_max: 1.0 - SHADOW_EPSILON, time };
    Some(ShadowSample { ray, contribution, light, normal })
}
