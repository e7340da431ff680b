//! Error metrics between an image and a reference, over linear RGB, all pixels and channels.

use super::Image;

/// Errors against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Root mean squared error.
    pub rmse: f64,
    /// Relative MSE: mean of (a − b)² / (b² + 0.01) (the references' README definition).
    pub relmse: f64,
    /// Mean absolute error.
    pub mae: f64,
}

/// Compare `image` with `reference`; `None` when the sizes differ.
pub fn compare(image: &Image, reference: &Image) -> Option<ImageError> {
    if image.width != reference.width || image.height != reference.height {
        return None;
    }
    let (mut se, mut rel, mut ae) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, y) = (a[c] as f64, b[c] as f64);
            let d = x - y;
            se += d * d;
            rel += d * d / (y * y + 0.01);
            ae += d.abs();
        }
    }
    let n = (image.pixels.len() * 3).max(1) as f64;
    Some(ImageError { rmse: (se / n).sqrt(), relmse: rel / n, mae: ae / n })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn metrics_match_hand_computation() {
        let a = Image { width: 2, height: 1, pixels: vec![Vec3::splat(1.0), Vec3::splat(0.0)] };
        let b = Image { width: 2, height: 1, pixels: vec![Vec3::splat(0.9), Vec3::splat(0.0)] };
        let e = compare(&a, &b).unwrap();
        assert!((e.mae - 0.05).abs() < 1e-6);
        assert!((e.rmse - (0.005f64).sqrt()).abs() < 1e-6);
        assert!((e.relmse - 0.01 / (0.81 + 0.01) / 2.0).abs() < 1e-6);
        assert!(compare(&a, &Image { width: 1, height: 2, pixels: b.pixels.clone() }).is_none());
    }
}
