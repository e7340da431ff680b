//! The infinite environment light: radiance arriving from every direction at infinity, constant or
//! from an equirectangular map (pbrt-v3 `InfiniteAreaLight`, pbrt-v4 `ImageInfiniteLight`).
//!
//! A map is importance-sampled in proportion to luminance × sin θ over its (u, v) square, the sin θ
//! undoing the equirectangular stretch towards the poles, by a 2-D piecewise-constant distribution:
//! O(log width + log height) per sample. Radiance is interpolated bilinearly; each texel's share of
//! the distribution is the mean of that interpolation over it, so the density is positive wherever
//! the radiance is (unbiased), and proportional to it where the map is smooth.
//!
//! Photons leave from a disc of the scene's bounding-sphere radius R, facing the sampled direction
//! from beyond the scene (pbrt-v4 `ImageInfiniteLight::SampleLe`), so the env's power is
//! π R² ∫ L dω: the flux through the scene's cross-section.

use super::light::{EmissionSample, LightSample, luminance};
use crate::sampling::distribution::Distribution2D;
use crate::sampling::lane_math::sin_cos;
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
        let mut map = Self { width, height, texels, distribution: Distribution2D::default() };
        // Each texel's share is the mean of the bilinear radiance over it, (1, 6, 1) / 8 along each
        // axis, times sin θ: positive wherever the filtered radiance is, so nothing visible is
        // left unsampled.
        let (w, h) = (width as usize, height as usize);
        let lum: Vec<f32> = map.texels.iter().map(|&t| luminance(t)).collect();
        let across: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let at = |x: usize| lum[y * w + x];
                (at((x + w - 1) % w) + 6.0 * at(x) + at((x + 1) % w)) / 8.0
            })
            .collect();
        let func: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let at = |y: usize| across[y * w + x];
                let filtered = (at(y.saturating_sub(1)) + 6.0 * at(y) + at((y + 1).min(h - 1))) / 8.0;
                let theta = PI * (y as f32 + 0.5) / h as f32;
                filtered * theta.sin()
            })
            .collect();
        map.distribution = Distribution2D::new(&func, w, h);
        map
    }

    /// Bilinear radiance at `uv`: texel centres at half-integers, wrapping in u, clamped in v.
    #[inline]
    fn radiance(&self, uv: Vec2) -> Vec3 {
        if !uv.is_finite() {
            // A degenerate (zero or NaN) direction brings nothing back.
            return Vec3::ZERO;
        }
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let texel = |x: i64, y: i64| self.texels[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize];
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// ∫ luminance dω of the bilinear radiance. Along u the bilinear mean of a row is its texels'
    /// mean, so what is left is a 1-D integral over v of the row means (linear between row centres,
    /// flat above the first and below the last) times 2π² sin(πv), by the midpoint rule on 8 steps
    /// per row.
    fn luminance_integral(&self) -> f64 {
        let (w, h) = (self.width as usize, self.height as usize);
        let means: Vec<f64> = (0..h)
            .map(|y| {
                self.texels[y * w..(y + 1) * w].iter().map(|&t| luminance(t) as f64).sum::<f64>() / w as f64
            })
            .collect();
        const STEPS: usize = 8;
        let dv = 1.0 / (h * STEPS) as f64;
        (0..h * STEPS)
            .map(|k| {
                let v = (k as f64 + 0.5) * dv;
                let y = (v * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
                let (y0, f) = (y.floor() as usize, y.fract());
                let mean = means[y0] * (1.0 - f) + means[(y0 + 1).min(h - 1)] * f;
                mean * 2.0 * std::f64::consts::PI.powi(2) * (std::f64::consts::PI * v).sin() * dv
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
    // lane_math's sines, which the lanes (`kernel/lanes/environment_light.rs`) match.
    let (sin_theta, cos_theta) = sin_cos(PI * uv.y);
    let (sin_phi, cos_phi) = sin_cos(2.0 * PI * uv.x);
    Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi)
}

impl Environment {
    /// The environment `desc` around the bounding box [`min`, `max`] (an empty or non-finite box is
    /// taken as the unit sphere at the origin).
    pub fn new(desc: &EnvironmentDesc, min: Vec3, max: Vec3) -> Self {
        let (center, radius) = crate::geometry::bounding_sphere(min, max);
        // A single point still needs a photon disc of some area.
        let radius = radius.max(1e-6);
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
            Radiance::Map(map) => map.radiance(direction_to_uv(self.to_local * d.normalize())),
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
        Some(LightSample { p: p_ref + wi * beyond, n: -wi, le, pdf, delta: false })
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
    /// radiance from it (read at the sampled uv, not recomputed from the direction).
    #[inline]
    fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32, Vec3)> {
        match &self.radiance {
            Radiance::Constant(c) => Some((uniform_sphere(u), UNIFORM_SPHERE_PDF, *c)),
            Radiance::Map(map) => {
                let (uv, pdf_uv) = map.distribution.sample(u);
                let sin_theta = sin_cos(PI * uv.y).0;
                if sin_theta <= 0.0 || pdf_uv <= 0.0 {
                    return None;
                }
                let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
                Some((self.to_world * uv_to_direction(uv), pdf, map.radiance(uv)))
            }
        }
    }

    /// The constant radiance of an environment without a map.
    #[inline]
    pub(crate) fn constant_radiance(&self) -> Option<Vec3> {
        match &self.radiance {
            Radiance::Constant(c) => Some(*c),
            Radiance::Map(_) => None,
        }
    }

    /// The map's frame to the world's.
    #[inline]
    pub(crate) fn to_world(&self) -> Mat3 {
        self.to_world
    }

    /// The scene's bounding sphere (centre, radius), beyond which a sampled point is put.
    #[inline]
    pub(crate) fn bounding_sphere(&self) -> (Vec3, f32) {
        (self.center, self.radius)
    }

    /// For `N` numbers at once, what [`Environment::sample`] reads of a map: the sampled (u, v), its
    /// density over the square and the radiance there; `None` for a constant environment.
    #[inline]
    pub(crate) fn sample_map_many<const N: usize>(&self, u: &[Vec2; N]) -> Option<[(Vec2, f32, Vec3); N]> {
        let Radiance::Map(map) = &self.radiance else { return None };
        let sampled = map.distribution.sample_many(u);
        Some(sampled.map(|(uv, pdf_uv)| (uv, pdf_uv, map.radiance(uv))))
    }

    /// Density with which [`Environment::sample_emission`] starts a subpath whose direction towards
    /// the environment is `w`: that direction's own density over the area of the disc it starts on.
    #[inline]
    pub fn emission_pdf(&self, w: Vec3) -> f32 {
        self.pdf(Vec3::ZERO, w) / (PI * self.radius * self.radius)
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

    /// The sampled texel's share is the mean of its filtered radiance, so a sample never lands where
    /// the radiance is zero: the black band is reached only where its neighbours bleed into it.
    #[test]
    fn samples_never_carry_zero_radiance() {
        let env = map_environment(Quat::IDENTITY);
        for i in 0..20_000 {
            let s = env.sample(Vec3::ZERO, Vec3::ZERO, Sampler::new(4, i, 0).get2d(0)).unwrap();
            assert!(s.le.max_element() > 0.0, "sampled a black texel");
        }
    }

    /// Where the map is linear (the gradient, away from the sun, the black band and the u seam) the
    /// bilinear radiance at a texel centre is the texel's mean, so pdf / luminance is one constant
    /// there, 1 / ∫ L dω up to the sin θ of the row centre against the exact one.
    #[test]
    fn map_density_is_proportional_to_luminance_where_the_map_is_smooth() {
        let env = map_environment(Quat::IDENTITY);
        let integral = env.power() / (PI * 3.0);
        for (x, y) in [(5, 7), (12, 8), (28, 14), (9, 1)] {
            let uv = Vec2::new((x as f32 + 0.5) / 32.0, (y as f32 + 0.5) / 16.0);
            let d = uv_to_direction(uv);
            let ratio = env.pdf(Vec3::ZERO, d) * integral / luminance(env.le(d));
            assert!((ratio - 1.0).abs() < 5e-3, "texel ({x}, {y}): pdf / L × ∫L = {ratio}");
        }
    }

    #[test]
    fn radiance_is_bilinear_between_texel_centres_and_wraps_in_u() {
        let env = map_environment(Quat::IDENTITY);
        let Radiance::Map(map) = &env.radiance else { panic!("a map") };
        let centre = |x: f32, y: f32| Vec2::new((x + 0.5) / 32.0, (y + 0.5) / 16.0);
        assert_eq!(map.radiance(centre(21.0, 4.0)), Vec3::new(800.0, 600.0, 400.0), "strength 2 applied");
        let halfway = map.radiance(centre(21.5, 4.0));
        assert!(
            (halfway - 0.5 * (map.radiance(centre(21.0, 4.0)) + map.radiance(centre(22.0, 4.0)))).length()
                < 1e-3
        );
        let seam = map.radiance(Vec2::new(0.0, centre(0.0, 7.0).y));
        let expected = 0.5 * (map.texels[7 * 32] + map.texels[7 * 32 + 31]);
        assert!((seam - expected).length() < 1e-5, "{seam} vs {expected}");
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
