//! The film: per-pixel sums, image output, and image comparison metrics.

pub mod compare;
pub mod output;

use glam::{DVec3, Vec3};

/// Accumulated radiance per pixel. Each pixel is written by one path entity in sample order, so the sum
/// is the same whatever the thread count.
#[derive(Clone, Debug)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    sum: Vec<DVec3>,
    count: Vec<u32>,
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self { width, height, sum: vec![DVec3::ZERO; n], count: vec![0; n] }
    }

    /// Add one sample of radiance `l` to pixel index `pixel`.
    #[inline]
    pub fn add(&mut self, pixel: u32, l: Vec3) {
        self.sum[pixel as usize] += l.as_dvec3();
        self.count[pixel as usize] += 1;
    }

    /// Number of samples taken in a pixel.
    pub fn samples(&self, pixel: u32) -> u32 {
        self.count[pixel as usize]
    }

    /// The mean radiance per pixel, row-major from the top-left.
    pub fn image(&self) -> Image {
        let pixels = self
            .sum
            .iter()
            .zip(&self.count)
            .map(|(s, &c)| if c == 0 { Vec3::ZERO } else { (*s / c as f64).as_vec3() })
            .collect();
        Image { width: self.width, height: self.height, pixels }
    }
}

/// A linear RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels from the top-left.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// The pixels of the rectangle [x0, x1) × [y0, y1), clamped to the image.
    pub fn crop(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Image {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        let (x0, y0) = (x0.min(x1), y0.min(y1));
        let pixels = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (y * self.width + x) as usize))
            .map(|i| self.pixels[i])
            .collect();
        Image { width: x1 - x0, height: y1 - y0, pixels }
    }
}

impl Image {
    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        self.pixels.iter().copied().sum::<Vec3>() / self.pixels.len().max(1) as f32
    }
}
