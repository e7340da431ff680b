//! Point, spot and sun lights as emitters. They are Dirac deltas in position (point, spot) or
//! direction (sun): no ray can hit them, so next-event estimation is the only way a camera path
//! sees them (weight 1, no MIS), and photons start from them.

use super::sample::{EmissionSample, LightSample};
use crate::sampling::warp::{Frame, concentric_disk, uniform_cone, uniform_sphere};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The smallest `cos_inner − cos_outer` KHR_lights_punctual's reference falloff divides by.
pub(crate) const MIN_FALLOFF_WIDTH: f32 = 0.001;

/// A spot's cone as cosines of its half-angles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotCone {
    /// Unit axis, the way the light travels.
    pub axis: Vec3,
    /// Cosine of the half-angle where the falloff starts.
    pub cos_inner: f32,
    /// Cosine of the half-angle where it reaches zero.
    pub cos_outer: f32,
}

impl SpotCone {
    /// The extension's smooth falloff at `cos_theta` from the axis: the squared linear ramp in cos θ
    /// from the outer cone (0) to the inner one (1), as its reference implementation computes it.
    #[inline]
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        let scale = 1.0 / (self.cos_inner - self.cos_outer).max(MIN_FALLOFF_WIDTH);
        let t = ((cos_theta - self.cos_outer) * scale).clamp(0.0, 1.0);
        t * t
    }

    /// ∫ falloff dω over the sphere, in closed form: the solid angle a unit intensity fills.
    pub fn solid_angle(&self) -> f32 {
        let width = (self.cos_inner - self.cos_outer).max(MIN_FALLOFF_WIDTH);
        let ramp_end = self.cos_outer + width;
        let integral_over_cos = if ramp_end <= 1.0 {
            // The ramp ∫ t² = width / 3, then full intensity up to the axis.
            width / 3.0 + (1.0 - ramp_end)
        } else {
            // A cone narrower than the minimum width: the ramp is cut off at the axis.
            (1.0 - self.cos_outer).powi(3) / (3.0 * width * width)
        };
        2.0 * PI * integral_over_cos
    }
}

/// A point light of radiant intensity `intensity` (W/sr) at `position`, seen from `p_ref`.
#[inline]
pub fn sample_point(
    position: Vec3,
    intensity: Vec3,
    spot: Option<&SpotCone>,
    p_ref: Vec3,
) -> Option<LightSample> {
    let to_ref = p_ref - position;
    let dist2 = to_ref.length_squared();
    if dist2 <= 0.0 || dist2.is_nan() {
        return None;
    }
    let n = to_ref / dist2.sqrt();
    let falloff = spot.map_or(1.0, |s| s.falloff(s.axis.dot(n)));
    if falloff <= 0.0 {
        return None;
    }
    Some(LightSample { p: position, n, le: intensity * (falloff / dist2), pdf: 1.0, delta: true })
}

/// A sun of irradiance `irradiance` (W/m² on a surface facing it) whose rays travel along
/// `direction`, seen from `p_ref`: the shadow ray runs to a point beyond the scene's bounding sphere
/// (`center`, `radius`).
#[inline]
pub fn sample_sun(direction: Vec3, irradiance: Vec3, center: Vec3, radius: f32, p_ref: Vec3) -> LightSample {
    let beyond = 2.0 * radius + (p_ref - center).length();
    LightSample { p: p_ref - direction * beyond, n: direction, le: irradiance, pdf: 1.0, delta: true }
}

/// A photon from a point light: a uniform direction over the sphere, or over the spot's outer cone
/// (weighted by the falloff).
#[inline]
pub fn emit_point(
    position: Vec3,
    intensity: Vec3,
    spot: Option<&SpotCone>,
    u_dir: Vec2,
) -> Option<EmissionSample> {
    let (d, weight) = match spot {
        None => (uniform_sphere(u_dir), intensity * (4.0 * PI)),
        Some(s) => {
            let local = uniform_cone(u_dir, s.cos_outer);
            let falloff = s.falloff(local.z);
            if falloff <= 0.0 {
                return None;
            }
            (Frame::from_z(s.axis).to_world(local), intensity * (falloff * 2.0 * PI * (1.0 - s.cos_outer)))
        }
    };
    Some(EmissionSample { p: position, n: d, d, weight })
}

/// A photon from a sun: a point on a disc as wide as the scene's bounding sphere, upstream of it,
/// travelling along `direction`.
#[inline]
pub fn emit_sun(direction: Vec3, irradiance: Vec3, center: Vec3, radius: f32, u_pos: Vec2) -> EmissionSample {
    let disc = concentric_disk(u_pos) * radius;
    let frame = Frame::from_z(direction);
    let p = center - direction * radius + frame.to_world(disc.extend(0.0));
    EmissionSample { p, n: direction, d: direction, weight: irradiance * (PI * radius * radius) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn cone(inner_degrees: f32, outer_degrees: f32) -> SpotCone {
        SpotCone {
            axis: Vec3::NEG_Y,
            cos_inner: inner_degrees.to_radians().cos(),
            cos_outer: outer_degrees.to_radians().cos(),
        }
    }

    #[test]
    fn the_falloff_is_the_extensions_smooth_ramp() {
        let s = cone(20.0, 40.0);
        assert_eq!(s.falloff(1.0), 1.0);
        assert_eq!(s.falloff(20f32.to_radians().cos()), 1.0);
        assert_eq!(s.falloff(40f32.to_radians().cos()), 0.0);
        assert_eq!(s.falloff(0.0), 0.0);
        let half = 0.5 * (s.cos_inner + s.cos_outer);
        assert!((s.falloff(half) - 0.25).abs() < 1e-5);
    }

    /// The closed-form solid angle against a midpoint sum over cos θ, for wide, narrow and
    /// narrower-than-the-minimum-width cones.
    #[test]
    fn the_spot_solid_angle_matches_quadrature() {
        for (inner, outer) in [(0.0, 45.0), (30.0, 31.0), (89.0, 90.0), (0.0, 1.0), (0.5, 0.6)] {
            let s = cone(inner, outer);
            let n = 1_000_000;
            let sum: f64 = (0..n)
                .map(|i| {
                    let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                    s.falloff(c as f32) as f64
                })
                .sum::<f64>()
                * 2.0
                / n as f64;
            let quadrature = 2.0 * std::f64::consts::PI * sum;
            let closed = s.solid_angle() as f64;
            assert!(
                (closed - quadrature).abs() < 1e-3 * closed.max(1e-4),
                "{inner}–{outer}: {closed} vs {quadrature}"
            );
        }
    }

    /// Photons carry the light's power on average: the mean weight is the intensity times the solid
    /// angle it fills (4π for a point).
    #[test]
    fn emitted_photons_carry_the_power_on_average() {
        let intensity = Vec3::new(1.0, 2.0, 3.0);
        let s = cone(10.0, 35.0);
        for (spot, power) in [(None, 4.0 * PI), (Some(&s), s.solid_angle())] {
            let n = 200_000u32;
            let mut sum = Vec3::ZERO;
            for i in 0..n {
                if let Some(e) = emit_point(Vec3::ZERO, intensity, spot, Sampler::new(3, i, 0).get2d(0)) {
                    sum += e.weight;
                    if let Some(s) = spot {
                        assert!(s.axis.dot(e.d) >= s.cos_outer - 1e-5);
                    }
                }
            }
            let mean = sum / n as f32;
            let expected = intensity * power;
            assert!(((mean - expected) / expected).abs().max_element() < 0.01, "{mean} vs {expected}");
        }
    }

    #[test]
    fn a_point_light_falls_off_with_the_square_of_distance_and_a_spot_outside_its_cone_is_dark() {
        let i = Vec3::splat(8.0);
        let s = sample_point(Vec3::ZERO, i, None, Vec3::new(0.0, 0.0, 2.0)).unwrap();
        assert_eq!((s.le, s.pdf, s.delta, s.n), (Vec3::splat(2.0), 1.0, true, Vec3::Z));
        let spot = cone(10.0, 20.0);
        assert!(sample_point(Vec3::ZERO, i, Some(&spot), Vec3::new(0.0, -1.0, 0.0)).is_some());
        assert!(sample_point(Vec3::ZERO, i, Some(&spot), Vec3::new(1.0, -1.0, 0.0)).is_none());
        assert!(sample_point(Vec3::ZERO, i, None, Vec3::ZERO).is_none());
    }

    #[test]
    fn sun_photons_cross_the_whole_scene_and_shadow_rays_leave_it() {
        let (center, radius, d) = (Vec3::new(1.0, 2.0, 3.0), 5.0, Vec3::new(0.0, -0.6, -0.8));
        for i in 0..1000 {
            let e = emit_sun(d, Vec3::ONE, center, radius, Sampler::new(1, i, 0).get2d(0));
            // Upstream of the sphere, within its shadow cylinder.
            let along = (e.p - center).dot(d);
            assert!((along + radius).abs() < 1e-4 && (e.p - center - along * d).length() <= radius * 1.0001);
        }
        let s = sample_sun(d, Vec3::ONE, center, radius, center + Vec3::X * 4.0);
        assert!(
            (s.p - center).length() > radius && (center + Vec3::X * 4.0 - s.p).normalize().dot(d) > 0.9999
        );
    }
}
