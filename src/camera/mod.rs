//! The camera's 5D sample: a position in the pixel under the reconstruction filter, a point on the
//! lens (thin lens, depth of field) and a time in the shutter interval (motion blur).
//!
//! Filters are sampled by importance (pbrt-v4 `FilterSampler`; `filter.rs`): the sample's offset is
//! drawn from the filter itself, so every sample lands in exactly one pixel with weight one. That
//! keeps film accumulation a per-pixel sum that needs no locks and gives the same bits for any
//! thread count.

mod filter;

pub use filter::{GAUSSIAN_RADIUS, GAUSSIAN_SIGMA, filter_radius, filter_weight, sample_filter};

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

/// Camera-to-world transform of a camera at `eye` looking at `target` (camera looks down -Z).
pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let forward = (target - eye).normalize();
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    Mat4::from_cols(right.extend(0.0), up.extend(0.0), (-forward).extend(0.0), eye.extend(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

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
}
