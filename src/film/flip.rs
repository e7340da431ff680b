//! FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"), NVIDIA's
//! perceptual image difference, beside RMSE and relMSE: how different two images look to a viewer
//! at a set distance, per pixel in [0, 1]. This is LDR-FLIP, on both images after the tone map the
//! PNG outputs use (linear clamped to [0, 1], the sRGB curve, 8 bits; exposure 0), at FLIP's
//! default 67 pixels per degree (a 0.7 m wide monitor of 3840 pixels seen from 0.7 m).

use super::Image;
use super::output::to_srgb8;

/// A FLIP comparison: the mean over the image, and the per-pixel error map (row-major).
#[derive(Clone, Debug)]
pub struct Flip {
    /// Mean FLIP over all pixels, in [0, 1].
    pub mean: f64,
    /// Per-pixel FLIP, row-major from the top-left.
    pub map: Vec<f32>,
    /// The map's size.
    pub width: u32,
    /// The map's size.
    pub height: u32,
}

impl Flip {
    /// The error map through FLIP's magma colour map, as 8-bit RGB (black: no visible difference).
    pub fn magma(&self) -> Vec<u8> {
        let map = nv_flip::FlipImageFloat::with_data(self.width, self.height, &self.map);
        map.apply_color_lut(&nv_flip::magma_lut()).to_vec()
    }
}

/// FLIP of `image` against `reference`; `None` when the sizes differ.
pub fn flip(image: &Image, reference: &Image) -> Option<Flip> {
    if (image.width, image.height) != (reference.width, reference.height) || image.pixels.is_empty() {
        return None;
    }
    let (width, height) = (image.width, image.height);
    let as_flip = |i: &Image| nv_flip::FlipImageRgb8::with_data(width, height, &to_srgb8(i, 0.0));
    let map = nv_flip::flip(as_flip(reference), as_flip(image), nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut mean = nv_flip::FlipPool::from_image(&map).mean() as f64;
    // The tone map turns NaN into black, which would score an image of NaN as black's twin: a
    // difference that cannot be measured is NaN, as RMSE and relMSE say.
    if !image.pixels.iter().chain(&reference.pixels).all(|p| p.is_finite()) {
        mean = f64::NAN;
    }
    Some(Flip { mean, map: map.to_vec(), width, height })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn flat(width: u32, height: u32, colour: impl Fn(u32, u32) -> Vec3) -> Image {
        Image { width, height, pixels: (0..width * height).map(|i| colour(i % width, i / width)).collect() }
    }

    /// Identical images do not differ; black against white is FLIP's largest difference; an
    /// image nearer the reference scores lower; the sizes must agree.
    #[test]
    fn flip_orders_differences_as_a_viewer_would() {
        let grey = flat(64, 64, |_, _| Vec3::splat(0.2));
        assert_eq!(flip(&grey, &grey).unwrap().mean, 0.0);
        let nan = flat(64, 64, |x, _| if x == 3 { Vec3::NAN } else { Vec3::ZERO });
        assert!(flip(&nan, &flat(64, 64, |_, _| Vec3::ZERO)).unwrap().mean.is_nan());
        let (black, white) = (flat(64, 64, |_, _| Vec3::ZERO), flat(64, 64, |_, _| Vec3::ONE));
        let extreme = flip(&black, &white).unwrap();
        assert!(extreme.mean > 0.9, "black against white: {}", extreme.mean);
        let noisy = |amplitude: f32| {
            flat(64, 64, |x, y| {
                Vec3::splat(0.2 + amplitude * if (x * 7 + y * 13) % 3 == 0 { 1.0 } else { -0.5 })
            })
        };
        let (small, large) =
            (flip(&noisy(0.02), &grey).unwrap().mean, flip(&noisy(0.1), &grey).unwrap().mean);
        assert!(0.0 < small && small < large, "small {small}, large {large}");
        assert!(flip(&grey, &flat(32, 64, |_, _| Vec3::ZERO)).is_none());
        assert_eq!(extreme.magma().len(), 64 * 64 * 3);
    }
}
