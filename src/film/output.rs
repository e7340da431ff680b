//! Writing and reading images: linear EXR (float RGB) and sRGB PNG.

use super::Image;
use crate::error::{Error, Result};
use glam::Vec3;
use std::path::Path;

/// Check that `path` names a format we write (.exr or .png), before any work is done.
pub fn check_output_path(path: &Path) -> Result<()> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("exr" | "png") => Ok(()),
        _ => Err(Error::Output {
            path: path.to_path_buf(),
            message: "unknown image format: use .exr or .png".into(),
        }),
    }
}

/// Write `image` to `path`, choosing the format by extension (.exr linear, .png sRGB with
/// `exposure` stops). The file is written to a temporary name first and renamed, so a failed write
/// leaves no partial file behind.
pub fn write_image(image: &Image, path: &Path, exposure: f32) -> Result<()> {
    let out_err = |message: String| Error::Output { path: path.to_path_buf(), message };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| out_err(format!("cannot create folder: {e}")))?;
    }
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let tmp = path.with_extension(format!("partial.{}", ext.as_deref().unwrap_or("tmp")));
    let result = match ext.as_deref() {
        Some("exr") => write_exr(image, &tmp),
        Some("png") => write_png(image, &tmp, exposure),
        _ => return Err(out_err("unknown image format: use .exr or .png".into())),
    };
    result.map_err(out_err)?;
    std::fs::rename(&tmp, path).map_err(|e| out_err(e.to_string()))
}

fn write_exr(image: &Image, path: &Path) -> Result<(), String> {
    let w = image.width as usize;
    exr::prelude::write_rgb_file(path, w, image.height as usize, |x, y| {
        let p = image.pixels[y * w + x];
        (p.x, p.y, p.z)
    })
    .map_err(|e| e.to_string())
}

/// The sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

fn write_png(image: &Image, path: &Path, exposure: f32) -> Result<(), String> {
    let scale = 2f32.powf(exposure);
    let bytes: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| {
            let c = *p * scale;
            [c.x, c.y, c.z].map(|v| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8)
        })
        .collect();
    image::save_buffer_with_format(
        path,
        &bytes,
        image.width,
        image.height,
        image::ColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| e.to_string())
}

/// Read the first RGB(A) layer of an EXR file as linear RGB.
pub fn read_exr(path: &Path) -> Result<Image> {
    use exr::prelude::read_first_rgba_layer_from_file;
    let read = read_first_rgba_layer_from_file(
        path,
        |resolution, _| (resolution.width(), vec![Vec3::ZERO; resolution.width() * resolution.height()]),
        |(w, pixels): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| match e {
        exr::error::Error::Io(source) => Error::Io { path: path.to_path_buf(), source },
        other => Error::Image { path: path.to_path_buf(), message: format!("not a readable EXR: {other}") },
    })?;
    let size = read.layer_data.size;
    let (_, pixels) = read.layer_data.channel_data.pixels;
    Ok(Image { width: size.width() as u32, height: size.height() as u32, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_keeps_linear_values() {
        let image =
            Image { width: 3, height: 2, pixels: (0..6).map(|i| Vec3::new(i as f32, 0.5, 1e3)).collect() };
        let dir = std::env::temp_dir().join(format!("caustica-exr-{}", std::process::id()));
        let path = dir.join("round.exr");
        write_image(&image, &path, 0.0).unwrap();
        assert_eq!(read_exr(&path).unwrap(), image);
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn srgb_curve_hits_its_end_points() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((linear_to_srgb(0.18) - 0.4613).abs() < 1e-3);
    }
}
