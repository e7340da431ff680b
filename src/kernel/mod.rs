//! The camera-vertex kernel that every integrator shares, as pure functions on plain data.
//!
//! A camera path is a [`CameraPath`] (throughput, radiance so far, and what MIS and Russian roulette
//! remember of the last bounce). At each hit an integrator builds a [`Vertex`] and calls, in its own
//! order:
//! - [`emission::add_surface_emission`] / [`emission::add_escaped_radiance`]: light the path found by
//!   BSDF sampling, weighted by the integrator's [`emission::EmissionWeight`];
//! - [`direct::sample_light`]: next-event estimation, with or without MIS, as a shadow ray to trace;
//! - [`continuation::continue_path`]: the BSDF sample that continues the path, with the one
//!   Russian-roulette rule (`β · η-scale`, survival capped);
//! - photons have theirs in [`photon`].
//!
//! Every random number comes from [`dimensions`], the one layout of the sampler's dimensions. The ECS
//! systems in `systems/` are thin queries over these functions.

pub mod aov;
pub mod arrival;
pub mod bidirectional;
pub mod camera_sample;
pub mod continuation;
pub mod dimensions;
pub mod direct;
pub mod emission;
pub mod guided;
pub mod lanes;
pub mod light_path;
pub mod media;
pub mod mis;
pub mod path_vertex;
pub mod photon;

#[cfg(test)]
mod tests;

use crate::geometry::{Ray, SurfaceHit};
use crate::materials::{Bsdf, ShadingParams};
use crate::render_scene::RenderScene;
use crate::sampling::warp::Frame;
use glam::Vec3;

pub use arrival::Arrival;
pub use continuation::{PathLimits, continue_path};
pub use dimensions::VertexSampler;
pub use direct::{ShadowSample, sample_light};
pub use emission::EmissionWeight;
pub use mis::power_heuristic;

/// The state of a camera path between bounces (names as in pbrt-v4's `PathIntegrator::Li`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPath {
    /// Throughput β.
    pub beta: Vec3,
    /// Radiance gathered so far.
    pub l: Vec3,
    /// Product of the squared relative IORs crossed (Russian roulette divides it out).
    pub eta_scale: f32,
    /// BSDF pdf of the last bounce (MIS weight of emission found next).
    pub prev_pdf: f32,
    /// Position of the last scattering vertex.
    pub prev_p: Vec3,
    /// Shading normal there, on the side the path left from (light selection depends on it, and
    /// MIS must see the same selection).
    pub prev_n: Vec3,
    /// Bounces so far.
    pub depth: u32,
    /// Whether the last bounce was a delta lobe (emission found next is counted fully).
    pub specular_bounce: bool,
    /// What first went NaN or infinite on this path, and at which depth (for the report).
    pub first_bad: Option<(Quantity, u8)>,
    /// The absorbing solids the path is inside.
    pub media: media::Media,
}

/// A quantity a path adds or carries, named when it goes NaN or infinite so that the report can say
/// what broke (pbrt-v4 reports the pixel and sample of a bad radiance value; this also says where).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Emission found on a surface.
    Emission,
    /// The environment found by a ray that left the scene.
    Environment,
    /// A light sample's contribution (NEE).
    LightSample,
    /// The throughput after a BSDF sample.
    Throughput,
    /// A photon-map radiance estimate.
    PhotonEstimate,
    /// A connection to a light subpath's vertex.
    Connection,
    /// Light subpaths' vertices merged at a camera vertex.
    Merge,
}

impl Quantity {
    /// What the report calls it.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Emission => "the emission of a surface it hit",
            Self::Environment => "the environment's radiance",
            Self::LightSample => "a light sample's contribution",
            Self::Throughput => "the throughput after a BSDF sample",
            Self::PhotonEstimate => "a photon-map estimate",
            Self::Connection => "a connection to a light subpath's vertex",
            Self::Merge => "light subpaths' vertices merged at a camera vertex",
        }
    }
}

impl CameraPath {
    /// A path at the camera: throughput one, no radiance yet.
    pub const START: Self = Self {
        beta: Vec3::ONE,
        l: Vec3::ZERO,
        eta_scale: 1.0,
        prev_pdf: 0.0,
        prev_p: Vec3::ZERO,
        prev_n: Vec3::ZERO,
        depth: 0,
        specular_bounce: false,
        first_bad: None,
        media: media::Media::AIR,
    };

    /// The path arrives at `hit` (a miss: leaves the scene): what the medium it travelled through
    /// absorbed on the way.
    #[inline]
    pub fn travel(&mut self, scene: &RenderScene, hit: &crate::geometry::bvh::Hit) {
        if self.media.current().is_some() {
            self.beta *= self.media.transmittance(scene, hit.t);
        }
    }

    /// Add `radiance` (already weighted by the throughput) to the path; the first that is not
    /// finite is remembered as `what`, at the current depth.
    #[inline]
    pub fn add(&mut self, radiance: Vec3, what: Quantity) {
        self.l += radiance;
        if !radiance.is_finite() {
            self.mark_bad(what);
        }
    }

    /// Remember `what` as the first quantity that went bad, unless one already did.
    #[cold]
    pub fn mark_bad(&mut self, what: Quantity) {
        if self.first_bad.is_none() {
            self.first_bad = Some((what, self.depth.min(u8::MAX as u32) as u8));
        }
    }

    /// Whether the last vertex was the camera or a delta bounce: emission found now was not
    /// reachable by light sampling, nor by photons stored at non-specular surfaces.
    #[inline]
    pub fn seen_directly(&self) -> bool {
        self.depth == 0 || self.specular_bounce
    }
}

impl Default for CameraPath {
    fn default() -> Self {
        Self::START
    }
}

/// A shading point: the surface hit, its resolved BSDF and shading frame, and the outgoing direction.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    /// The hit.
    pub si: SurfaceHit,
    /// The material's parameters after textures.
    pub params: ShadingParams,
    /// Its BSDF.
    pub bsdf: Bsdf,
    /// The shading frame (z = shading normal).
    pub frame: Frame,
    /// Towards where the ray came from, in the shading frame.
    pub wo: Vec3,
    /// Whether the surface bounds a volume (a refraction through it enters or leaves a medium).
    pub volume: bool,
}

impl Vertex {
    /// The vertex where `ray` hit `si`.
    #[inline]
    pub fn new(scene: &RenderScene, ray: &Ray, mut si: SurfaceHit) -> Self {
        si.ns = scene.shading_normal(&si, -ray.d);
        let params = scene.shading_params(&si);
        let mut bsdf = Bsdf::new(&params);
        let frame = Frame::from_z(si.ns);
        if let Some(n) = scene.coat_normal(&si, -ray.d) {
            bsdf.set_coat_normal(frame.to_local(n));
        }
        let wo = frame.to_local(-ray.d);
        let volume = scene.is_volume(si.material);
        Self { si, params, bsdf, frame, wo, volume }
    }

    /// The shading normal on the side the path arrived from: how light selection and MIS see this
    /// point.
    #[inline]
    pub fn n_side(&self) -> Vec3 {
        if self.wo.z >= 0.0 { self.si.ns } else { -self.si.ns }
    }
}
