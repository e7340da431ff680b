//! The infinite environment light: radiance arriving from every direction at infinity, constant or
//! from an equirectangular map (pbrt-v3 `InfiniteAreaLight`, pbrt-v4 `ImageInfiniteLight`).
//!
//! A map is importance-sampled in proportion to luminance × sin θ over its (u, v) square, the sin θ
//! undoing the equirectangular stretch towards the poles, by a 2-D piecewise-constant distribution:
//! O(log width + log height) per sample. Radiance is looked up per texel (no filtering) so that the
//! density is exactly proportional to what is sampled, wherever the map is not black.
//!
//! Photons leave from a disc of the scene's bounding-sphere radius R, facing the sampled direction
//! from beyond the scene (pbrt-v4 `ImageInfiniteLight::SampleLe`), so the env's power is
//! π R² ∫ L dω: the flux through the scene's cross-section.

use super::area::{EmissionSample, LightSample, luminance};
use crate::sampling::distribution::Distribution2D;
use crate::sampling::warp::{
    Frame, UNIFORM_SPHERE_PDF, concentric_disk, cosine_hemisphere, cosine_hemisphere_pdf, uniform_sphere,
};
use crate::scene::environment::{EnvironmentDesc, EnvironmentRadiance};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// An environment light around a scene with bounding sphere (`center`, `radius`).
#[derive(Clone, Debug)]
pub struct Environment {
    radiance: Radiance,
    to_world: Mat3,
    to_local: Mat3,
    center: Vec3,
    radius: f32,
    power: f32,
}

#[derive(Clone, Debug)]
enum Radiance {
    Constant(Vec3),
    Map(EnvironmentMap),
}

#[derive(Clone, Debug)]
struct EnvironmentMap {
    width: u32,
    height: u32,
    /// Radiance × strength, row 0 at the zenith.
    texels: Vec<Vec3>,
    distribution: Distribution2D,
}

impl EnvironmentMap {
    fn new(image: &crate::film::Image, strength: f32) -> Self {
        let (width, height) = (image.width, image.height);
        let texels: Vec<Vec3> = image.pixels.iter().map(|&p| p * strength).collect();
        let func: Vec<f32> = texels
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let theta = PI * ((i as u32 / width) as f32 + 0.5) / height as f32;
                luminance(t) * theta.sin()
            })
            .collect();
        let distribution = Distribution2D::new(&func, width as usize, height as usize);
        Self { width, height, texels, distribution }
    }

    #[inline]
    fn texel(&self, uv: Vec2) -> Vec3 {
        // NaN (a degenerate direction) becomes texel 0 through the casts.
        let x = ((uv.x * self.width as f32) as u32).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as u32).min(self.height - 1);
        self.texels[(y * self.width + x) as usize]
    }

    /// ∫ luminance dω over the sphere: each texel's luminance times its exact solid angle.
    fn luminance_integral(&self) -> f64 {
        let (w, h) = (self.width as usize, self.height as usize);
        (0..h)
            .map(|y| {
                let (top, bottom) = (PI * y as f32 / h as f32, PI * (y + 1) as f32 / h as f32);
                let solid_angle = (2.0 * PI / w as f32) * (top.cos() - bottom.cos());
                let row: f64 = self.texels[y * w..(y + 1) * w].iter().map(|&t| luminance(t) as f64).sum();
                row * solid_angle as f64
            })
            .sum()
    }
}

/// The (u, v) in [0, 1)² of a unit direction in the map's frame (see `scene::environment`).
#[inline]
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    let theta = d.y.clamp(-1.0, 1.0).acos();
    let phi = d.x.atan2(-d.z);
    let u = phi * (0.5 / PI);
    Vec2::new(if u < 0.0 { u + 1.0 } else { u }, theta / PI)
}

/// The unit direction in the map's frame at (u, v); inverse of [`direction_to_uv`].
#[inline]
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    let (sin_theta, cos_theta) = (PI * uv.y).sin_cos();
    let (sin_phi, cos_phi) = (2.0 * PI * uv.x).sin_cos();
    Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi)
}

impl Environment {
    /// The environment `desc` around the bounding box [`min`, `max`] (an empty or non-finite box is
    /// taken as the unit sphere at the origin).
    pub fn new(desc: &EnvironmentDesc, min: Vec3, max: Vec3) -> Self {
        let (center, radius) = if (max - min).is_finite() && max.cmpge(min).all() {
            (0.5 * (min + max), (0.5 * (max - min).length()).max(1e-6))
        } else {
            (Vec3::ZERO, 1.0)
        };
        let radiance = match &desc.radiance {
            EnvironmentRadiance::Constant(c) => Radiance::Constant(*c * desc.strength),
            EnvironmentRadiance::Map(image) => Radiance::Map(EnvironmentMap::new(image, desc.strength)),
        };
        let integral = match &radiance {
            Radiance::Constant(c) => 4.0 * PI as f64 * luminance(*c) as f64,
            Radiance::Map(map) => map.luminance_integral(),
        };
        let to_world = Mat3::from_quat(desc.rotation.normalize());
        Self {
            radiance,
            to_world,
            to_local: to_world.transpose(),
            center,
            radius,
            power: (PI as f64 * (radius as f64).powi(2) * integral) as f32,
        }
    }

    /// Emitted power by luminance: the flux through the scene's cross-section, π R² ∫ L dω.
    pub fn power(&self) -> f32 {
        self.power
    }

    /// Radiance arriving from world direction `d` (travelling along −d).
    #[inline]
    pub fn le(&self, d: Vec3) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(c) => *c,
            Radiance::Map(map) => map.texel(direction_to_uv(self.to_local * d.normalize())),
        }
    }

    /// Sample a direction towards the environment from `p_ref`. A constant environment is sampled by
    /// cosine about `n_ref` (zero: uniformly over the sphere), which is exact importance sampling of a
    /// diffuse surface's direct light; a map by its luminance. The point returned lies beyond the scene
    /// along the direction, for the shadow ray.
    #[inline]
    pub fn sample(&self, p_ref: Vec3, n_ref: Vec3, u: Vec2) -> Option<LightSample> {
        let (wi, pdf, le) = match &self.radiance {
            Radiance::Constant(c) if n_ref != Vec3::ZERO => {
                let local = cosine_hemisphere(u);
                (Frame::from_z(n_ref).to_world(local), cosine_hemisphere_pdf(local.z), *c)
            }
            _ => self.sample_direction(u)?,
        };
        if pdf <= 0.0 {
            return None;
        }
        let beyond = (p_ref - self.center).length() + 2.0 * self.radius;
        Some(LightSample { p: p_ref + wi * beyond, n: -wi, le, pdf })
    }

    /// Solid-angle density with which [`Environment::sample`] picks world direction `d` from a point
    /// with normal `n_ref`.
    #[inline]
    pub fn pdf(&self, n_ref: Vec3, d: Vec3) -> f32 {
        match &self.radiance {
            Radiance::Constant(_) if n_ref != Vec3::ZERO => cosine_hemisphere_pdf(n_ref.dot(d.normalize())),
            Radiance::Constant(_) => UNIFORM_SPHERE_PDF,
            Radiance::Map(map) => {
                let local = self.to_local * d.normalize();
                let sin_theta = (1.0 - local.y * local.y).max(0.0).sqrt();
                if sin_theta == 0.0 {
                    return 0.0;
                }
                map.distribution.pdf(direction_to_uv(local)) / (2.0 * PI * PI * sin_theta)
            }
        }
    }

    /// A direction by the environment's own distribution (no surface to favour), its density and the
    /// radiance from it. A map's radiance comes from the sampled texel itself: recomputed from the
    /// direction, rounding could land a sample on a texel's black neighbour.
    #[inline]
    fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32, Vec3)> {
        match &self.radiance {
            Radiance::Constant(c) => Some((uniform_sphere(u), UNIFORM_SPHERE_PDF, *c)),
            Radiance::Map(map) => {
                let (uv, pdf_uv) = map.distribution.sample(u);
                let sin_theta = (PI * uv.y).sin();
                if sin_theta <= 0.0 || pdf_uv <= 0.0 {
                    return None;
                }
                let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
                Some((self.to_world * uv_to_direction(uv), pdf, map.texel(uv)))
            }
        }
    }

    /// Start a photon: a direction towards the environment, then a point on the disc of radius R
    /// facing it from beyond the scene; the photon travels back along the direction.
    #[inline]
    pub fn sample_emission(&self, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        let (w, pdf_dir, le) = self.sample_direction(u_dir)?;
        let frame = Frame::from_z(w);
        let disc = self.radius * concentric_disk(u_pos);
        let p = self.center + self.radius * w + disc.x * frame.x + disc.y * frame.y;
        let area = PI * self.radius * self.radius;
        Some(EmissionSample { p, n: -w, d: -w, weight: le * (area / pdf_dir) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Image;
    use crate::sampling::Sampler;
    use crate::sampling::chi2::{Chi2Config, chi2_test};
    use glam::Quat;

    /// A 32 × 16 map with a bright "sun" texel, a dim gradient and one black band.
    fn test_map() -> Image {
        let (width, height) = (32, 16);
        let pixels = (0..width * height)
            .map(|i| {
                let (x, y) = (i % width, i / width);
                if (x, y) == (21, 4) {
                    Vec3::new(400.0, 300.0, 200.0)
                } else if y == 11 {
                    Vec3::ZERO
                } else {
                    Vec3::new(0.2, 0.3, 0.5) * (1.0 + x as f32 / 8.0)
                }
            })
            .collect();
        Image { width, height, pixels }
    }

    fn map_environment(rotation: Quat) -> Environment {
        let desc = EnvironmentDesc {
            name: "test".into(),
            radiance: EnvironmentRadiance::Map(test_map()),
            strength: 2.0,
            rotation,
        };
        Environment::new(&desc, Vec3::splat(-1.0), Vec3::splat(1.0))
    }

    #[test]
    fn uv_and_direction_are_inverse_and_follow_the_documented_axes() {
        assert!((uv_to_direction(Vec2::new(0.5, 0.5)) - Vec3::Z).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.0, 0.5)) + Vec3::Z).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
        for i in 0..200 {
            let uv = Sampler::new(1, i, 0).get2d(0) * 0.98 + Vec2::splat(0.01);
            let back = direction_to_uv(uv_to_direction(uv));
            assert!((back - uv).length() < 1e-4, "{uv} -> {back}");
        }
    }

    /// The sampled directions follow the density `pdf` reports, sun, black band and rotation
    /// included (the χ² test integrates `pdf` over each bin independently of the sampler).
    #[test]
    fn map_sampling_matches_its_density_by_chi_square() {
        for rotation in [Quat::IDENTITY, Quat::from_euler(glam::EulerRot::ZYX, 0.3, 1.1, -0.4)] {
            let env = map_environment(rotation);
            let config = Chi2Config { test_count: 2, ..Chi2Config::default() };
            let result = chi2_test(
                |i| {
                    let s = env.sample(Vec3::ZERO, Vec3::ZERO, Sampler::new(11, i, 0).get2d(0))?;
                    Some(s.p.normalize())
                },
                |d| env.pdf(Vec3::ZERO, d),
                400_000,
                &config,
            );
            assert!(result.is_ok(), "rotation {rotation}: {}", result.unwrap_err());
        }
    }

    #[test]
    fn black_band_and_its_radiance_are_never_sampled() {
        let env = map_environment(Quat::IDENTITY);
        for i in 0..20_000 {
            let s = env.sample(Vec3::ZERO, Vec3::ZERO, Sampler::new(4, i, 0).get2d(0)).unwrap();
            assert!(s.le.max_element() > 0.0, "sampled a black texel");
        }
    }

    /// The density is proportional to the radiance's luminance: at texel centres (where the sin θ of
    /// the distribution's rows is exact) pdf / luminance is one constant, 1 / ∫ L dω.
    #[test]
    fn map_density_is_proportional_to_luminance() {
        let env = map_environment(Quat::IDENTITY);
        let integral = env.power() / (PI * 3.0);
        for (x, y) in [(21, 4), (0, 0), (5, 7), (31, 15), (12, 10)] {
            let uv = Vec2::new((x as f32 + 0.5) / 32.0, (y as f32 + 0.5) / 16.0);
            let d = uv_to_direction(uv);
            let ratio = env.pdf(Vec3::ZERO, d) * integral / luminance(env.le(d));
            assert!((ratio - 1.0).abs() < 2e-3, "texel ({x}, {y}): pdf / L × ∫L = {ratio}");
        }
        let black = uv_to_direction(Vec2::new(0.5, 11.5 / 16.0));
        assert_eq!(env.pdf(Vec3::ZERO, black), 0.0);
    }

    /// ∫ pdf dω = 1, estimated by uniform directions.
    #[test]
    fn map_density_integrates_to_one_over_the_sphere() {
        let env = map_environment(Quat::from_rotation_y(0.7));
        let n = 400_000;
        let sum: f64 =
            (0..n).map(|i| env.pdf(Vec3::ZERO, uniform_sphere(Sampler::new(8, i, 0).get2d(0))) as f64).sum();
        let integral = sum / n as f64 / UNIFORM_SPHERE_PDF as f64;
        assert!((integral - 1.0).abs() < 0.03, "∫ pdf = {integral}");
    }

    /// Le / pdf averaged over samples estimates ∫ L dω, which the power divides by π R².
    #[test]
    fn sampled_radiance_over_pdf_estimates_the_power() {
        let env = map_environment(Quat::IDENTITY);
        let n = 100_000;
        let sum: f64 = (0..n)
            .map(|i| {
                let s = env.sample(Vec3::ZERO, Vec3::ZERO, Sampler::new(2, i, 0).get2d(0)).unwrap();
                (luminance(s.le) / s.pdf) as f64
            })
            .sum::<f64>()
            / n as f64;
        let expected = env.power() as f64 / (PI as f64 * 3.0);
        // The ratio Le / pdf varies only with sin θ across a texel: 0.5% is several standard errors.
        assert!((sum / expected - 1.0).abs() < 5e-3, "{sum} vs {expected}");
    }

    #[test]
    fn constant_environment_samples_by_cosine_about_the_normal() {
        let env = Environment::new(&EnvironmentDesc::constant(Vec3::ONE), Vec3::ZERO, Vec3::ONE);
        let n = Vec3::new(0.0, 0.6, 0.8);
        for i in 0..1000 {
            let s = env.sample(Vec3::ZERO, n, Sampler::new(3, i, 0).get2d(0)).unwrap();
            let d = s.p.normalize();
            assert!(d.dot(n) >= 0.0);
            assert!((s.pdf - env.pdf(n, d)).abs() < 1e-4 * s.pdf.max(1.0));
            assert_eq!(s.le, Vec3::ONE);
        }
        let r2 = 0.75f32;
        assert!((env.power() - PI * r2 * 4.0 * PI).abs() < 1e-3 * env.power());
    }

    /// A photon's weight averages to the power it stands for, and it starts outside the scene heading in.
    #[test]
    fn emitted_photons_carry_the_power_from_outside_the_bounds() {
        let env = map_environment(Quat::from_rotation_x(0.4));
        let n = 100_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let s = Sampler::new(6, i, 0);
            let e = env.sample_emission(s.get2d(0), s.get2d(2)).unwrap();
            assert!(e.p.length() >= 3f32.sqrt() * 0.999, "starts inside the bounding sphere");
            assert!(e.p.dot(e.d) < 0.0, "heads away from the scene");
            sum += luminance(e.weight) as f64;
        }
        let mean = sum / n as f64;
        assert!((mean / env.power() as f64 - 1.0).abs() < 5e-3, "{mean} vs {}", env.power());
    }
}
