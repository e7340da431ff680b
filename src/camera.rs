//! The camera's 5D sample: a position in the pixel under the reconstruction filter, a point on the
//! lens (thin lens, depth of field) and a time in the shutter interval (motion blur).
//!
//! Filters are sampled by importance (pbrt-v4 `FilterSampler`): the sample's offset is drawn from the
//! filter itself, so every sample lands in exactly one pixel with weight one. That keeps film
//! accumulation a per-pixel sum that needs no locks and gives the same bits for any thread count.

use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::sampling::warp::concentric_disk;
use crate::scene::run_file::CameraOverrides;
use crate::scene::{CameraDesc, FilterKind};
use glam::{Mat4, Vec2, Vec3};

/// A perspective thin-lens camera.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Position of the lens centre.
    pub origin: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    tan_half_y: f32,
    aspect: f32,
    /// Lens radius (0: pinhole, no lens sampling).
    pub lens_radius: f32,
    /// Distance of the plane in focus.
    pub focus_distance: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Reconstruction filter.
    pub filter: FilterKind,
}

impl Camera {
    /// Build the camera from the file's camera and the run file's overrides.
    pub fn new(
        desc: &CameraDesc,
        overrides: &CameraOverrides,
        width: u32,
        height: u32,
        filter: FilterKind,
    ) -> Result<Self> {
        let m: Mat4 = desc.camera_to_world;
        let mut origin = m.transform_point3(Vec3::ZERO);
        let mut forward = m.transform_vector3(-Vec3::Z).normalize();
        let mut up = m.transform_vector3(Vec3::Y).normalize();
        let mut yfov = desc.yfov;
        let setting = |name: &str, problem: &str| Error::Setting {
            name: format!("camera.{name}"),
            problem: problem.into(),
        };
        if let Some(eye) = overrides.eye {
            origin = Vec3::from(eye);
        }
        if let Some(target) = overrides.target {
            let dir = Vec3::from(target) - origin;
            if !dir.is_finite() || dir.length() == 0.0 {
                return Err(setting("target", "must differ from the eye and be finite"));
            }
            forward = dir.normalize();
            up = Vec3::from(overrides.up.unwrap_or([0.0, 1.0, 0.0]));
        } else if let Some(u) = overrides.up {
            up = Vec3::from(u);
        }
        if let Some(deg) = overrides.yfov_degrees {
            if !(deg > 0.0 && deg < 180.0) {
                return Err(setting("yfov_degrees", "must be in (0, 180)"));
            }
            yfov = deg.to_radians();
        }
        if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
            return Err(setting(
                "yfov",
                &format!("camera '{}' has field of view {yfov} rad, outside (0, π)", desc.name),
            ));
        }
        let right = forward.cross(up);
        if !right.is_finite() || right.length() <= 1e-6 || !origin.is_finite() {
            return Err(setting("up", "is parallel to the view direction or not finite"));
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let lens_radius = overrides.aperture_radius;
        if !(lens_radius >= 0.0 && lens_radius.is_finite()) {
            return Err(setting("aperture_radius", "must be a finite number ≥ 0"));
        }
        let focus_distance = match (overrides.focus_distance, overrides.target) {
            (Some(f), _) => f,
            (None, Some(t)) => (Vec3::from(t) - origin).length(),
            (None, None) if lens_radius > 0.0 => {
                return Err(setting("focus_distance", "an aperture needs focus_distance or target"));
            }
            (None, None) => 1.0,
        };
        if !(focus_distance > 0.0 && focus_distance.is_finite()) {
            return Err(setting("focus_distance", "must be a finite number > 0"));
        }
        Ok(Self {
            origin,
            right,
            up,
            forward,
            tan_half_y: (0.5 * yfov).tan(),
            aspect: width as f32 / height as f32,
            lens_radius,
            focus_distance,
            width,
            height,
            filter,
        })
    }

    /// Where a camera-less file is seen from, from the centre of its bounds: a three-quarter view,
    /// 45° round from glTF's front (+Z) towards +X and 30° above the horizon. Straight along −Z a
    /// box showed one face and looked flat.
    pub fn framing_direction() -> Vec3 {
        let (yaw, elevation) = (45f32.to_radians(), 30f32.to_radians());
        Vec3::new(yaw.sin() * elevation.cos(), elevation.sin(), yaw.cos() * elevation.cos())
    }

    /// A camera for a file that has none, as glTF viewers frame one: looking at the centre of the
    /// bounding box from [`Camera::framing_direction`], with vertical field of view `yfov` (45°, as
    /// viewers use, unless the user chose one), just far enough that the box's bounding sphere fits
    /// both the vertical and the horizontal field at `aspect` (width / height). An empty or
    /// non-finite box is framed as the unit sphere.
    pub fn framing(min: Vec3, max: Vec3, aspect: f32, yfov: f32) -> CameraDesc {
        let (center, radius) = crate::geometry::bounding_sphere(min, max);
        // A single point still needs a camera some distance away.
        let radius = radius.max(1e-3);
        let xfov = 2.0 * (aspect.max(1e-3) * (0.5 * yfov).tan()).atan();
        let distance = radius / (0.5 * yfov.min(xfov)).sin();
        let eye = center + distance * Self::framing_direction();
        CameraDesc {
            name: "auto".into(),
            camera_to_world: look_at(eye, center, Vec3::Y),
            yfov,
            aspect_ratio: None,
        }
    }

    /// The direction the camera looks along (its image plane's normal).
    pub fn view_axis(&self) -> Vec3 {
        self.forward
    }

    /// The vertical field of view, in radians.
    pub fn yfov(&self) -> f32 {
        2.0 * self.tan_half_y.atan()
    }

    /// Whether rays need a lens sample.
    pub fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// The primary ray through pixel (x, y) (row 0 at the top) for filter sample `u_filter`,
    /// lens sample `u_lens` (ignored for a pinhole) and normalized time `time`.
    #[inline]
    pub fn generate_ray(&self, x: u32, y: u32, u_filter: Vec2, u_lens: Vec2, time: f32) -> Ray {
        let offset = sample_filter(self.filter, u_filter);
        let sx = (x as f32 + 0.5 + offset.x) / self.width as f32;
        let sy = (y as f32 + 0.5 + offset.y) / self.height as f32;
        let cx = (2.0 * sx - 1.0) * self.tan_half_y * self.aspect;
        let cy = (1.0 - 2.0 * sy) * self.tan_half_y;
        let dir_cam = Vec3::new(cx, cy, 1.0);
        let (o_cam, d_cam) = if self.lens_radius > 0.0 {
            // Thin lens: every ray through the lens meets the pinhole ray on the plane in focus.
            let lens = self.lens_radius * concentric_disk(u_lens);
            let focus = dir_cam * self.focus_distance;
            let o = Vec3::new(lens.x, lens.y, 0.0);
            (o, (focus - o).normalize())
        } else {
            (Vec3::ZERO, dir_cam.normalize())
        };
        let to_world = |v: Vec3| self.right * v.x + self.up * v.y + self.forward * v.z;
        Ray { o: self.origin + to_world(o_cam), d: to_world(d_cam), t_max: f32::INFINITY, time }
    }
}

/// Where the camera sees a point, and the importance it sends there: light tracing's connection to
/// the camera (pbrt-v4's `PerspectiveCamera::SampleWi`, with its conventions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportanceSample {
    /// The film position, in pixels from the image's top-left corner: within a filter radius of the
    /// image, as the camera rays of its border pixels are.
    pub raster: Vec2,
    /// The point on the lens the connection ends at.
    pub lens: Vec3,
    /// W_e / pdf: the importance over its solid-angle density at the point, 1 / (A cos³θ d²), A the
    /// image's area at unit distance (the lens area cancels out of a thin lens's W_e and pdf).
    pub weight: f32,
}

impl Camera {
    /// The connection from `p` to the lens point `u_lens` picks (the pinhole itself without an
    /// aperture); `None` when the point is behind the camera or outside the film and its filter.
    pub fn sample_importance(&self, p: Vec3, u_lens: Vec2) -> Option<ImportanceSample> {
        let lens_cam =
            if self.lens_radius > 0.0 { self.lens_radius * concentric_disk(u_lens) } else { Vec2::ZERO };
        let lens = self.origin + self.right * lens_cam.x + self.up * lens_cam.y;
        let d = p - lens;
        let dc = Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward));
        let dist2 = d.length_squared();
        if !(dc.z > 0.0 && dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        // The pinhole direction of the film point: where the segment crosses the plane in focus.
        let (cx, cy) = if self.lens_radius > 0.0 {
            let t = self.focus_distance / dc.z;
            ((lens_cam.x + dc.x * t) / self.focus_distance, (lens_cam.y + dc.y * t) / self.focus_distance)
        } else {
            (dc.x / dc.z, dc.y / dc.z)
        };
        let sx = 0.5 * (cx / (self.tan_half_y * self.aspect) + 1.0);
        let sy = 0.5 * (1.0 - cy / self.tan_half_y);
        let raster = Vec2::new(sx * self.width as f32, sy * self.height as f32);
        let r = filter_radius(self.filter);
        let (w, h) = (self.width as f32, self.height as f32);
        if !(raster.x > -r && raster.x < w + r && raster.y > -r && raster.y < h + r) {
            return None;
        }
        let cos = dc.z / dist2.sqrt();
        let area = 4.0 * self.tan_half_y * self.tan_half_y * self.aspect;
        Some(ImportanceSample { raster, lens, weight: 1.0 / (area * cos * cos * cos * dist2) })
    }
}

impl Camera {
    /// The density per unit solid angle of a camera ray's direction `d` (unit, leaving the lens)
    /// when the film is sampled at one sample per pixel: d_img² / cos³θ, d_img the film's distance
    /// in pixels (bidirectional weights compare it with the light subpaths, one per pixel). A thin
    /// lens's rays from one lens point have the same density, the lens point's own cancelling
    /// between the strategies that share it. Zero behind the camera.
    #[inline]
    pub fn pdf_w(&self, d: Vec3) -> f32 {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return 0.0;
        }
        let pixels = self.width as f32 * self.height as f32;
        let area = 4.0 * self.tan_half_y * self.tan_half_y * self.aspect;
        pixels / (area * cos * cos * cos)
    }
}

/// How far from a pixel's centre, in pixels, the filter reaches.
pub fn filter_radius(filter: FilterKind) -> f32 {
    match filter {
        FilterKind::Box => 0.5,
        FilterKind::Tent => 1.0,
        FilterKind::Gaussian => GAUSSIAN_RADIUS,
    }
}

/// The filter's normalized density at `offset` from a pixel's centre: what a point on the film
/// gives that pixel, the weight a splat shares out (the density [`sample_filter`] draws from, so a
/// splat and a camera sample estimate the same pixel). The box is half-open, as its samples are.
pub fn filter_weight(filter: FilterKind, offset: Vec2) -> f32 {
    match filter {
        FilterKind::Box => {
            let inside = |x: f32| (-0.5..0.5).contains(&x);
            if inside(offset.x) && inside(offset.y) { 1.0 } else { 0.0 }
        }
        FilterKind::Tent => (1.0 - offset.x.abs()).max(0.0) * (1.0 - offset.y.abs()).max(0.0),
        FilterKind::Gaussian => truncated_gaussian(offset.x) * truncated_gaussian(offset.y),
    }
}

/// The density of the normal distribution (σ = 0.5) truncated to ±1.5.
fn truncated_gaussian(x: f32) -> f32 {
    if x.abs() > GAUSSIAN_RADIUS {
        return 0.0;
    }
    let k = (GAUSSIAN_RADIUS / GAUSSIAN_SIGMA) as f64;
    let mass = 1.0 - 2.0 * normal_cdf(-k);
    let sigma = GAUSSIAN_SIGMA as f64;
    let z = x as f64 / sigma;
    ((-0.5 * z * z).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt() * mass)) as f32
}

/// Camera-to-world transform of a camera at `eye` looking at `target` (camera looks down -Z).
pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let forward = (target - eye).normalize();
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    Mat4::from_cols(right.extend(0.0), up.extend(0.0), (-forward).extend(0.0), eye.extend(1.0))
}

/// Offset from the pixel centre, drawn with density equal to the normalized filter.
#[inline]
pub fn sample_filter(filter: FilterKind, u: Vec2) -> Vec2 {
    match filter {
        FilterKind::Box => u - Vec2::splat(0.5),
        FilterKind::Tent => Vec2::new(sample_tent(u.x), sample_tent(u.y)),
        FilterKind::Gaussian => Vec2::new(sample_truncated_gaussian(u.x), sample_truncated_gaussian(u.y)),
    }
}

/// Inverse CDF of the tent of radius 1.
#[inline]
fn sample_tent(u: f32) -> f32 {
    if u < 0.5 { -1.0 + (2.0 * u).sqrt() } else { 1.0 - (2.0 - 2.0 * u).sqrt() }
}

/// Gaussian filter standard deviation in pixels.
pub const GAUSSIAN_SIGMA: f32 = 0.5;
/// Gaussian filter radius in pixels (3 σ).
pub const GAUSSIAN_RADIUS: f32 = 1.5;

/// Inverse CDF of the normal distribution (σ = 0.5) truncated to ±1.5: exact, so weights stay one.
#[inline]
fn sample_truncated_gaussian(u: f32) -> f32 {
    let k = (GAUSSIAN_RADIUS / GAUSSIAN_SIGMA) as f64;
    let lo = normal_cdf(-k);
    let p = lo + (1.0 - 2.0 * lo) * u as f64;
    (inverse_normal_cdf(p) * GAUSSIAN_SIGMA as f64) as f32
}

/// Standard normal CDF (erfc via Numerical Recipes' Chebyshev fit, relative error < 1.2e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 { 1.0 - 0.5 * erfc } else { 0.5 * erfc }
}

/// Standard normal quantile (Acklam's rational approximation, relative error < 1.2e-9).
fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] =
        [7.784_695_709_041_462e-3, 3.224_671_290_700_398e-1, 2.445_134_137_142_996, 3.754_408_661_907_416];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn histogram_matches(filter: FilterKind, radius: f32, density: impl Fn(f32) -> f32) {
        let bins = 30;
        let n = 60_000u32;
        let mut counts = vec![0u32; bins];
        for i in 0..n {
            let x = sample_filter(filter, Sampler::new(1, i, 0).get2d(0)).x;
            assert!(x.abs() <= radius + 1e-5, "{filter:?} sample {x} outside radius {radius}");
            let b = (((x + radius) / (2.0 * radius)) * bins as f32) as usize;
            counts[b.min(bins - 1)] += 1;
        }
        let norm: f64 = (0..10_000)
            .map(|k| density(-radius + (k as f32 + 0.5) * 2.0 * radius / 10_000.0) as f64)
            .sum::<f64>()
            * (2.0 * radius as f64 / 10_000.0);
        let mut chi2 = 0.0;
        for (b, &c) in counts.iter().enumerate() {
            let (a, w) = (-radius + b as f32 * 2.0 * radius / bins as f32, 2.0 * radius / bins as f32);
            let mass: f64 = (0..100).map(|k| density(a + (k as f32 + 0.5) * w / 100.0) as f64).sum::<f64>()
                * (w as f64 / 100.0)
                / norm;
            let expected = mass * n as f64;
            chi2 += (c as f64 - expected).powi(2) / expected;
        }
        // 29 degrees of freedom: the 0.999 quantile is 58.3.
        assert!(chi2 < 58.3, "{filter:?}: chi-square {chi2}");
    }

    #[test]
    fn filter_samples_follow_the_filter_shapes() {
        histogram_matches(FilterKind::Box, 0.5, |_| 1.0);
        histogram_matches(FilterKind::Tent, 1.0, |x| 1.0 - x.abs());
        histogram_matches(FilterKind::Gaussian, GAUSSIAN_RADIUS, |x| {
            (-x * x / (2.0 * GAUSSIAN_SIGMA * GAUSSIAN_SIGMA)).exp()
        });
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let desc =
            CameraDesc { name: "c".into(), camera_to_world: Mat4::IDENTITY, yfov: 1.0, aspect_ratio: None };
        let ov = CameraOverrides { aperture_radius: 0.1, focus_distance: Some(3.0), ..Default::default() };
        let cam = Camera::new(&desc, &ov, 64, 64, FilterKind::Box).unwrap();
        let pinhole = cam.generate_ray(10, 20, Vec2::splat(0.5), Vec2::splat(0.5), 0.0);
        for i in 0..16 {
            let s = Sampler::new(0, i, 0);
            let r = cam.generate_ray(10, 20, Vec2::splat(0.5), s.get2d(2), 0.0);
            let t = (-3.0 - r.o.z) / r.d.z;
            let tp = -3.0 / pinhole.d.z;
            assert!((r.o + t * r.d - pinhole.d * tp).length() < 1e-4);
        }
    }

    /// A camera ray through a film point, followed to any distance, is seen by `sample_importance`
    /// at that same film point through the same lens point: the two maps are inverses.
    #[test]
    fn importance_sees_a_point_where_the_camera_ray_through_it_started() {
        let desc =
            CameraDesc { name: "c".into(), camera_to_world: Mat4::IDENTITY, yfov: 0.9, aspect_ratio: None };
        for aperture in [0.0, 0.05] {
            let ov = CameraOverrides {
                aperture_radius: aperture,
                focus_distance: Some(2.5),
                ..Default::default()
            };
            let cam = Camera::new(&desc, &ov, 48, 32, FilterKind::Tent).unwrap();
            for i in 0..200 {
                let s = Sampler::new(3, i, 0);
                let (x, y) = (i % 48, (i * 7) % 32);
                let (u_filter, u_lens) = (s.get2d(0), s.get2d(2));
                let ray = cam.generate_ray(x, y, u_filter, u_lens, 0.0);
                let p = ray.o + ray.d * (0.5 + 4.0 * s.get1d(4));
                let seen = cam.sample_importance(p, u_lens).expect("a point the camera looks at");
                let film =
                    Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + sample_filter(FilterKind::Tent, u_filter);
                assert!(
                    (seen.raster - film).length() < 2e-3,
                    "aperture {aperture}: {} vs {film}",
                    seen.raster
                );
                assert!((seen.lens - ray.o).length() < 1e-5);
            }
        }
    }

    /// pbrt's normalisation: the pinhole's importance W_e = 1 / (A cos⁴θ), projected by the lens's
    /// cos θ, integrates to one over the directions the film sees (W_e = weight × pdf with pdf =
    /// d² / cos θ, so W_e cos θ = weight at distance d = 1).
    #[test]
    fn pinhole_importance_integrates_to_one_over_the_film() {
        let desc =
            CameraDesc { name: "c".into(), camera_to_world: Mat4::IDENTITY, yfov: 1.1, aspect_ratio: None };
        let cam = Camera::new(&desc, &CameraOverrides::default(), 40, 30, FilterKind::Box).unwrap();
        let n = 400_000u32;
        let mut sum = 0.0f64;
        for i in 0..n {
            let w = crate::sampling::warp::uniform_sphere(Sampler::new(9, i, 0).get2d(0));
            let Some(seen) = cam.sample_importance(cam.origin + w, Vec2::ZERO) else { continue };
            let inside =
                seen.raster.x >= 0.0 && seen.raster.x < 40.0 && seen.raster.y >= 0.0 && seen.raster.y < 30.0;
            if inside {
                sum += seen.weight as f64 * 4.0 * std::f64::consts::PI;
            }
        }
        let mean = sum / n as f64;
        // The film holds about 3% of the directions: a binomial count, standard error about 1%.
        assert!((mean - 1.0).abs() < 0.03, "∫ W_e cos θ dω = {mean}");
    }

    /// The weights a splat shares out are the densities the camera samples are drawn from: each
    /// integrates to one over its support.
    #[test]
    fn filter_weights_integrate_to_one() {
        for filter in [FilterKind::Box, FilterKind::Tent, FilterKind::Gaussian] {
            let r = filter_radius(filter);
            let k = 400;
            let step = 2.0 * r / k as f32;
            let mut sum = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    let o = Vec2::new(-r + (i as f32 + 0.5) * step, -r + (j as f32 + 0.5) * step);
                    sum += (filter_weight(filter, o) * step * step) as f64;
                }
            }
            assert!((sum - 1.0).abs() < 2e-3, "{filter:?}: {sum}");
        }
    }
}
