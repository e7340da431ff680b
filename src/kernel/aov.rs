//! Where a camera sample's feature images come from: its first non-specular vertex. Perfect mirrors
//! and smooth glass are followed (what a denoiser wants to see is the surface behind them, tinted by
//! what they pass), as Open Image Denoise's documentation asks of albedo and normal.

use super::Vertex;
use crate::film::aov::AovSample;
use crate::render_scene::RenderScene;
use glam::Vec3;

/// A camera sample's search for its first non-specular surface.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirstSurface {
    /// What it found (zero until it has).
    pub sample: AovSample,
    /// Length of the path so far, through the specular vertices.
    travelled: f32,
    /// Cosine between the camera ray and the view axis: the unfolded path's length times it is the
    /// depth along the axis.
    view_cos: f32,
    /// Whether the surface (or the sky) has been found.
    pub found: bool,
}

impl FirstSurface {
    /// A search for the camera ray along `primary`, of a camera looking along `view_axis`.
    #[inline]
    pub fn start(primary: Vec3, view_axis: Vec3) -> Self {
        Self { view_cos: primary.dot(view_axis), ..Self::default() }
    }

    /// The path left the scene along `d` carrying throughput `beta` (what the specular vertices
    /// before passed): the sky is what it saw.
    #[inline]
    pub fn escaped(&mut self, scene: &RenderScene, d: Vec3, beta: Vec3) {
        if self.found {
            return;
        }
        // The sky's albedo is its radiance clamped to [0, 1], as a denoiser reads a background.
        let sky = scene.lights.environment.as_ref().map_or(Vec3::ZERO, |e| e.le(d));
        self.sample = AovSample { albedo: (beta * sky).clamp(Vec3::ZERO, Vec3::ONE), ..AovSample::default() };
        self.found = true;
    }

    /// The path reached vertex `v`, `t` along its last ray, carrying `beta`: at a non-specular
    /// surface, record it and stop looking.
    #[inline]
    pub fn reached(&mut self, v: &Vertex, t: f32, beta: Vec3) {
        if self.found {
            return;
        }
        if v.bsdf.is_delta() {
            self.travelled += t;
            return;
        }
        self.reached_surface(t, v.bsdf.albedo_hint(), v.n_side(), beta);
    }

    /// The path reached a non-specular surface `t` along its last ray, whose BSDF's albedo estimate
    /// is `albedo` and whose shading normal on the side seen is `normal`, carrying `beta`: record
    /// it, unless a surface was found before.
    #[inline]
    pub fn reached_surface(&mut self, t: f32, albedo: Vec3, normal: Vec3, beta: Vec3) {
        if self.found {
            return;
        }
        self.travelled += t;
        self.sample = AovSample {
            albedo: (beta * albedo).clamp(Vec3::ZERO, Vec3::ONE),
            normal,
            depth: self.travelled * self.view_cos,
        };
        self.found = true;
    }
}
