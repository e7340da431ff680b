//! The film: per-pixel sums, image output, and image comparison metrics.
pub mod accumulator;
pub mod adaptive;
pub mod aov;
pub mod compare;
pub mod denoise;
pub mod fixed;
pub mod flip;
pub mod output;
pub mod partial;

use fixed::PixelSums;

use glam::{DVec3, Vec3};

/// Accumulated radiance per pixel, in fixed point (`fixed`): samples may be added from any thread in
/// any order, and films of disjoint samples merged, with the same bits as one sequential run.
#[derive(Debug)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    pixels: Vec<PixelSums>,
}

impl Clone for Film {
    fn clone(&self) -> Self {
        let copy = Film::new(self.width, self.height);
        for (to, from) in copy.pixels.iter().zip(&self.pixels) {
            let (sums, count) = from.get();
            to.add(sums, count);
        }
        copy
    }
}

impl Film {
    /// Bytes a pixel takes: its fixed-point sums and count.
    pub const BYTES_PER_PIXEL: u64 = size_of::<PixelSums>() as u64;

    /// A black film.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, pixels: (0..n).map(|_| PixelSums::default()).collect() }
    }

    /// As [`Self::new`], or an error naming the film, its size and `budget` where the allocator
    /// has not got its memory ([`fixed::try_pixels`]).
    pub fn try_new(width: u32, height: u32, budget: u64) -> crate::error::Result<Self> {
        let n = width as usize * height as usize;
        let pixels = fixed::try_pixels(n, || format!("the {width}x{height} film"), budget)?;
        Ok(Self { width, height, pixels })
    }

    /// Add one sample of radiance `l` to pixel index `pixel`; `l` must pass [`fixed::accepts`].
    #[inline]
    pub fn add(&self, pixel: u32, l: Vec3) {
        debug_assert!(fixed::accepts(l), "film sample {l} out of range");
        self.pixels[pixel as usize]
            .add([fixed::to_fixed(l.x), fixed::to_fixed(l.y), fixed::to_fixed(l.z)], 1);
    }

    /// Add radiance `l` to pixel index `pixel` without counting a sample: a light path's splat, which
    /// the pass's camera samples count (`l` must pass [`fixed::accepts`]).
    #[inline]
    pub fn splat(&self, pixel: u32, l: Vec3) {
        debug_assert!(fixed::accepts(l), "film splat {l} out of range");
        self.pixels[pixel as usize]
            .add([fixed::to_fixed(l.x), fixed::to_fixed(l.y), fixed::to_fixed(l.z)], 0);
    }

    /// Add another film's sums and counts for one pixel (merging partial renders).
    pub fn add_sums(&self, pixel: u32, sums: [i128; 3], count: u32) {
        self.pixels[pixel as usize].add(sums, count);
    }

    /// Add every pixel of `pass` (a film of the same size) to this one and leave `pass` empty.
    pub fn take_from(&self, pass: &Film) {
        debug_assert_eq!((self.width, self.height), (pass.width, pass.height));
        fixed::take_all(&self.pixels, &pass.pixels);
    }

    /// Make every pixel empty, with no samples.
    pub fn clear(&self) {
        fixed::clear_all(&self.pixels);
    }

    /// A pixel's fixed-point channel sums and its sample count.
    pub fn sums(&self, pixel: u32) -> ([i128; 3], u32) {
        self.pixels[pixel as usize].get()
    }

    /// Number of samples taken in a pixel.
    pub fn samples(&self, pixel: u32) -> u32 {
        self.sums(pixel).1
    }

    /// The mean radiance of `pixel` (black where it has no samples).
    pub fn mean(&self, pixel: u32) -> Vec3 {
        mean_of(&self.pixels[pixel as usize])
    }

    /// The mean radiance per pixel, row-major from the top-left.
    pub fn image(&self) -> Image {
        let pixels = self.pixels.iter().map(mean_of).collect();
        Image { width: self.width, height: self.height, pixels }
    }
}

fn mean_of(pixel: &PixelSums) -> Vec3 {
    let (sums, count) = pixel.get();
    if count == 0 {
        return Vec3::ZERO;
    }
    (DVec3::from_array(sums.map(fixed::from_fixed)) / count as f64).as_vec3()
}

/// A linear RGB image.
#[derive(Clone, Debug, Default, PartialEq)]
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
