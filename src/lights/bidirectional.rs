//! What bidirectional MIS asks of the lights (Georgiev et al. 2012's `directPdf` and
//! `emissionPdf`): the density with which light sampling at a shading point picks a point on a
//! light, and the density with which emission starts a light subpath there along a direction, both
//! with the light chosen in proportion to power. Light sampling here ignores the receiver's normal
//! (no cosine-warped triangles, no cosine-weighted constant sky): the weight of a strategy must not
//! depend on which side a later vertex sees the surface from, or the weights of a path would not
//! sum to one.

use super::{LightSample, LightShape, Lights};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// How a light's points and directions are distributed: what the weights must treat specially.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmitterKind {
    /// A point of no size or a single direction: no ray finds it (a point, a spot, a sun).
    pub delta: bool,
    /// At a finite distance (area lights, points, spots): densities convert to area with the
    /// squared distance.
    pub finite: bool,
}

impl Lights {
    /// Probability that emission (and bidirectional light sampling) picks light `index`.
    #[inline]
    pub fn power_pmf(&self, index: u32) -> f32 {
        self.by_power.pmf(index)
    }

    /// What kind of emitter light `index` (the environment: one past the others) is.
    #[inline]
    pub fn emitter_kind(&self, index: u32) -> EmitterKind {
        match self.lights.get(index as usize).map(|l| l.shape) {
            Some(LightShape::Triangle { .. } | LightShape::Sphere { .. }) => {
                EmitterKind { delta: false, finite: true }
            }
            Some(LightShape::Point { .. }) => EmitterKind { delta: true, finite: true },
            Some(LightShape::Sun { .. }) => EmitterKind { delta: true, finite: false },
            None => EmitterKind { delta: false, finite: false },
        }
    }

    /// Light sampling for bidirectional strategies: a light by power and a point on it as seen
    /// from `p_ref`, whatever the receiver's normal. The pdf is per unit solid angle at `p_ref`
    /// (the selection's probability alone for a delta light), selection included.
    #[inline]
    pub fn sample_by_power(
        &self,
        p_ref: Vec3,
        time: f32,
        u_select: f32,
        u: Vec2,
    ) -> Option<(u32, LightSample)> {
        let (index, pmf) = self.by_power.sample(u_select)?;
        self.sample_chosen(index, pmf, p_ref, Vec3::ZERO, time, u)
    }

    /// Solid-angle density (selection included) with which [`Lights::sample_by_power`] from
    /// `p_ref` picks the point `p` (normal `n`) of the finite, non-delta light `index`, or the
    /// direction `d` from `p_ref` of the environment.
    #[inline]
    pub fn direct_pdf(&self, index: u32, p_ref: Vec3, p: Vec3, n: Vec3, d: Vec3, time: f32) -> f32 {
        let pmf = self.by_power.pmf(index);
        match self.lights.get(index as usize) {
            Some(light) => pmf * light.pdf(p_ref, Vec3::ZERO, p, n, time),
            None => self.environment.as_ref().map_or(0.0, |env| pmf * env.pdf(Vec3::ZERO, d)),
        }
    }

    /// Density (selection included) with which emission starts a subpath on light `index` at `p`
    /// (normal `n`) along `d`: per unit area and solid angle for a finite light, per unit area of
    /// the disc the subpath starts on and solid angle for the sky, per unit solid angle for a
    /// point, per unit area of its disc for a sun. Zero where it emits nothing.
    #[inline]
    pub fn emission_pdf(&self, index: u32, n: Vec3, d: Vec3) -> f32 {
        let pmf = self.by_power.pmf(index);
        let Some(light) = self.lights.get(index as usize) else {
            return self.environment.as_ref().map_or(0.0, |env| pmf * env.emission_pdf(-d));
        };
        let cos = n.dot(d).max(0.0);
        pmf * match light.shape {
            LightShape::Triangle { area, .. } => cos / (PI * area),
            LightShape::Sphere { radius, .. } => cos / (PI * 4.0 * PI * radius * radius),
            LightShape::Point { spot: None, .. } => 1.0 / (4.0 * PI),
            LightShape::Point { spot: Some(s), .. } => {
                if s.axis.dot(d) >= s.cos_outer {
                    1.0 / (2.0 * PI * (1.0 - s.cos_outer))
                } else {
                    0.0
                }
            }
            LightShape::Sun { radius, .. } => 1.0 / (PI * radius * radius),
        }
    }
}
