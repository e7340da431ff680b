//! Feature images (AOVs, "arbitrary output variables"): albedo, shading normal and depth at the first
//! non-specular surface a camera sample finds, the inputs a denoiser such as Open Image Denoise asks
//! for and what sensor simulators read beside colour. They are averaged per pixel over the same
//! samples as colour, in the same fixed point (`fixed`), so they are filtered like colour and their
//! bits do not depend on the thread count.

use super::Image;
use super::fixed::{self, PixelSums};
use glam::{DVec3, Vec3};

/// One feature image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Aov {
    /// The surface's reflectance (`Bsdf::albedo_hint`) times what perfect mirrors and glass in front
    /// of it pass: EXR channels `albedo.R`, `albedo.G`, `albedo.B`.
    Albedo,
    /// The shading normal in world space, on the side the camera ray arrived from: `N.X`, `N.Y`, `N.Z`.
    Normal,
    /// The distance from the camera's image plane along its view axis (as Cycles' Z pass), through
    /// perfect mirrors and glass the length of the unfolded path; 0 where the sample leaves the scene
    /// (as Mitsuba's depth AOV): `Z`.
    Depth,
    /// The samples the pixel took: where adaptive sampling sent them (`render.noise_threshold`),
    /// and fewer where a time limit cut the last pass: `spp`.
    Spp,
}

impl Aov {
    /// Whether it is recorded at the first surface each camera sample finds (it needs the
    /// feature-image film); `spp` is the colour film's own sample count.
    pub fn needs_surface(self) -> bool {
        !matches!(self, Aov::Spp)
    }
}

impl crate::choice::Choice for Aov {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Aov::Albedo, "albedo", "reflectance at the first non-specular surface (EXR albedo.R, .G, .B)"),
        (Aov::Normal, "normal", "world-space shading normal there, facing the camera (N.X, .Y, .Z)"),
        (Aov::Depth, "depth", "distance from the image plane along the view axis (Z)"),
        (Aov::Spp, "spp", "samples the pixel took, where adaptive sampling sent them (spp)"),
    ];
}

/// What one camera sample saw at its first non-specular surface.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AovSample {
    /// Reflectance, in [0, 1] per channel.
    pub albedo: Vec3,
    /// Unit shading normal (zero where the sample left the scene).
    pub normal: Vec3,
    /// Depth along the view axis.
    pub depth: f32,
}

impl AovSample {
    /// Whether the sample can go to the film (finite and in the fixed-point range).
    #[inline]
    pub fn is_valid(&self) -> bool {
        fixed::accepts(self.albedo)
            && fixed::accepts(self.normal)
            && fixed::accepts(Vec3::new(self.depth, 0.0, 0.0))
    }
}

/// Channels of an [`AovFilm`] pixel: albedo (3), normal (3), depth (1).
const CHANNELS: usize = 7;

/// Per-pixel sums of the feature images, added to from any thread in any order with the same bits.
#[derive(Debug)]
pub struct AovFilm {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    pixels: Vec<PixelSums<CHANNELS>>,
}

impl Clone for AovFilm {
    fn clone(&self) -> Self {
        let copy = AovFilm::new(self.width, self.height);
        for (to, from) in copy.pixels.iter().zip(&self.pixels) {
            let (sums, count) = from.get();
            to.add(sums, count);
        }
        copy
    }
}

impl AovFilm {
    /// Bytes a pixel takes: its fixed-point sums and count.
    pub const BYTES_PER_PIXEL: u64 = size_of::<PixelSums<CHANNELS>>() as u64;

    /// An empty film.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, pixels: (0..n).map(|_| PixelSums::default()).collect() }
    }

    /// As [`Self::new`], or an error naming the feature images' film, its size and `budget` where
    /// the allocator has not got its memory ([`fixed::try_pixels`]).
    pub fn try_new(width: u32, height: u32, budget: u64) -> crate::error::Result<Self> {
        let n = width as usize * height as usize;
        let pixels = fixed::try_pixels(n, || format!("the {width}x{height} feature images' film"), budget)?;
        Ok(Self { width, height, pixels })
    }

    /// Add one sample to pixel index `pixel`; an invalid one counts as a sample that saw nothing (as
    /// a NaN colour sample counts and adds nothing).
    #[inline]
    pub fn add(&self, pixel: u32, sample: &AovSample) {
        let s = if sample.is_valid() { *sample } else { AovSample::default() };
        let [a, n] = [s.albedo, s.normal].map(|v| v.to_array().map(fixed::to_fixed));
        let values = [a[0], a[1], a[2], n[0], n[1], n[2], fixed::to_fixed(s.depth)];
        self.pixels[pixel as usize].add(values, 1);
    }

    /// Add every pixel of `pass` (a film of the same size) to this one and leave `pass` empty.
    pub fn take_from(&self, pass: &AovFilm) {
        debug_assert_eq!((self.width, self.height), (pass.width, pass.height));
        fixed::take_all(&self.pixels, &pass.pixels);
    }

    /// Make every pixel empty, with no samples.
    pub fn clear(&self) {
        fixed::clear_all(&self.pixels);
    }

    /// The mean of every feature image per pixel.
    pub fn images(&self) -> AovImages {
        let (w, h) = (self.width, self.height);
        let n = self.pixels.len();
        let mut albedo = Image { width: w, height: h, pixels: Vec::with_capacity(n) };
        let mut normal = Image { width: w, height: h, pixels: Vec::with_capacity(n) };
        let mut depth = Vec::with_capacity(n);
        for p in &self.pixels {
            let (sums, count) = p.get();
            let mean = |c: usize| if count == 0 { 0.0 } else { fixed::from_fixed(sums[c]) / count as f64 };
            let vec = |c: usize| DVec3::new(mean(c), mean(c + 1), mean(c + 2)).as_vec3();
            albedo.pixels.push(vec(0));
            normal.pixels.push(vec(3));
            depth.push(mean(6) as f32);
        }
        AovImages { albedo, normal, depth, spp: Vec::new() }
    }
}

/// The feature images of a render.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AovImages {
    /// Albedo, linear RGB.
    pub albedo: Image,
    /// Mean shading normal (shorter than unit where a pixel's samples see different surfaces).
    pub normal: Image,
    /// Depth per pixel, row-major from the top-left.
    pub depth: Vec<f32>,
    /// Samples per pixel, row-major from the top-left (empty unless asked for).
    pub spp: Vec<f32>,
}

#[cfg(test)]
mod tests {
    #[test]
    fn command_line_names_are_the_run_file_names() {
        crate::choice::assert_names_match_serde::<super::Aov>();
    }

    use super::*;

    #[test]
    fn a_pixel_is_the_mean_of_its_samples_and_bad_ones_count_as_nothing() {
        let film = AovFilm::new(2, 1);
        let a = AovSample { albedo: Vec3::new(0.2, 0.4, 0.6), normal: Vec3::Z, depth: 3.0 };
        let b = AovSample { albedo: Vec3::new(0.4, 0.4, 0.2), normal: Vec3::X, depth: 5.0 };
        film.add(0, &a);
        film.add(0, &b);
        film.add(1, &a);
        film.add(1, &AovSample { depth: f32::NAN, ..b });
        let images = film.images();
        let close = |x: Vec3, y: Vec3| (x - y).abs().max_element() < 1e-6;
        assert!(close(images.albedo.pixels[0], Vec3::new(0.3, 0.4, 0.4)));
        assert!(close(images.normal.pixels[0], Vec3::new(0.5, 0.0, 0.5)));
        assert!((images.depth[0] - 4.0).abs() < 1e-6);
        assert!(close(images.albedo.pixels[1], a.albedo / 2.0));
        assert!((images.depth[1] - 1.5).abs() < 1e-6);
    }
}
