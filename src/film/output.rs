//! Writing and reading images: linear EXR (float RGB) and sRGB PNG.

use super::Image;
use super::aov::{Aov, AovImages};
use crate::error::{Error, Result};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::Path;

/// Check, before any work is done, that `path` names a format we write (.exr or .png) and a place we
/// can write to: not a directory, in a directory that exists or can be made, where a file can be
/// created (one is, and removed again).
pub fn check_output_path(path: &Path) -> Result<()> {
    let out_err = |message: String| Error::Output { path: path.to_path_buf(), message };
    match extension(path).as_deref() {
        Some("exr" | "png") => {}
        _ => return Err(out_err("unknown image format: use .exr or .png".into())),
    }
    if path.is_dir() {
        return Err(out_err("is a directory: name an image file inside it".into()));
    }
    let dir = output_dir(path);
    std::fs::create_dir_all(dir).map_err(|e| out_err(format!("cannot create its folder: {e}")))?;
    tempfile::Builder::new()
        .prefix(".caustica-check-")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| out_err(format!("cannot write in {}: {e}", dir.display())))
}

/// Largest exposure, in stops: 2^±64 already takes any finite radiance beyond 8 bits either way.
pub const MAX_EXPOSURE_STOPS: f32 = 64.0;

/// Write `image` to `path`, choosing the format by extension (.exr linear, .png sRGB with
/// `exposure` stops). The bytes go to a file of a unique name beside `path`, which is then renamed
/// over it: a failed write leaves the previous file as it was and nothing else, and two runs writing
/// the same output cannot mix their bytes. The same image always gives the same bytes.
pub fn write_image(image: &Image, path: &Path, exposure: f32) -> Result<()> {
    write_image_with_aovs(image, None, path, exposure)
}

/// [`write_image`], with the feature images `aovs` asks for as further channels of an EXR
/// (`albedo.R`, `N.X`, `Z`, …: the layer names compositors and denoisers read); a PNG holds colour
/// alone.
pub fn write_image_with_aovs(
    image: &Image,
    aovs: Option<(&AovImages, &[Aov])>,
    path: &Path,
    exposure: f32,
) -> Result<()> {
    let out_err = |message: String| Error::Output { path: path.to_path_buf(), message };
    // 2^NaN is NaN and 2^inf is inf: a black or white picture, written as if nothing were wrong.
    if !exposure.is_finite() || exposure.abs() > MAX_EXPOSURE_STOPS {
        return Err(out_err(format!(
            "exposure {exposure} stops: it must be a finite number of stops within ±{MAX_EXPOSURE_STOPS}"
        )));
    }
    // The name first: a refused one leaves no folder or partial file behind.
    if !matches!(extension(path).as_deref(), Some("exr" | "png")) {
        return Err(out_err("unknown image format: use .exr or .png".into()));
    }
    let mut partial = super::partial::PartialFile::beside(path).map_err(out_err)?;
    let file = partial.file();
    match extension(path).as_deref() {
        Some("exr") => match aovs {
            Some((features, which)) if !which.is_empty() => write_exr_layers(image, features, which, file),
            _ => write_exr(image, file),
        },
        Some("png") => write_png(image, file, exposure),
        _ => return Err(out_err("unknown image format: use .exr or .png".into())),
    }
    .map_err(out_err)?;
    partial.finish(path).map_err(out_err)
}

/// The lower-case extension of `path`.
fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// The directory an output goes to (the working directory for a bare file name).
fn output_dir(path: &Path) -> &Path {
    path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

fn write_exr(image: &Image, out: &mut (impl std::io::Write + std::io::Seek)) -> Result<(), String> {
    use exr::prelude::{SpecificChannels, Vec2, WritableImage};
    let w = image.width as usize;
    let pixels: &[Vec3] = &image.pixels;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p: Vec3 = pixels[y * w + x];
        (p.x, p.y, p.z)
    });
    // One thread: compressed blocks in a fixed order, so identical images write identical bytes.
    exr::prelude::Image::from_channels((w, image.height as usize), channels)
        .write()
        .non_parallel()
        .to_buffered(out)
        .map_err(|e| e.to_string())
}

/// The EXR channels of `image` and of the feature images `which`, by name.
fn exr_channels(image: &Image, features: &AovImages, which: &[Aov]) -> Vec<(String, Vec<f32>)> {
    let component = |image: &Image, c: usize| image.pixels.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let mut channels: Vec<(String, Vec<f32>)> =
        ["R", "G", "B"].iter().enumerate().map(|(c, n)| (n.to_string(), component(image, c))).collect();
    for &(aov, _, _) in <Aov as crate::choice::Choice>::CHOICES {
        if !which.contains(&aov) {
            continue;
        }
        match aov {
            Aov::Albedo => channels.extend(
                ["albedo.R", "albedo.G", "albedo.B"]
                    .iter()
                    .enumerate()
                    .map(|(c, n)| (n.to_string(), component(&features.albedo, c))),
            ),
            Aov::Normal => channels.extend(
                ["N.X", "N.Y", "N.Z"]
                    .iter()
                    .enumerate()
                    .map(|(c, n)| (n.to_string(), component(&features.normal, c))),
            ),
            Aov::Depth => channels.push(("Z".into(), features.depth.clone())),
            Aov::Spp => channels.push(("spp".into(), features.spp.clone())),
        }
    }
    channels
}

fn write_exr_layers(
    image: &Image,
    features: &AovImages,
    which: &[Aov],
    out: &mut (impl std::io::Write + std::io::Seek),
) -> Result<(), String> {
    use exr::prelude::{
        AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, WritableImage,
    };
    let list = exr_channels(image, features, which)
        .into_iter()
        .map(|(name, samples)| AnyChannel::new(name.as_str(), FlatSamples::F32(samples)))
        .collect();
    let size = (image.width as usize, image.height as usize);
    let layer = Layer::new(size, LayerAttributes::default(), Encoding::default(), AnyChannels::sort(list));
    exr::prelude::Image::from_layer(layer).write().non_parallel().to_buffered(out).map_err(|e| e.to_string())
}

/// Every channel of the first layer of an EXR file by name (`R`, `albedo.G`, `Z`, …), each row-major
/// from the top-left, and the image's width and height.
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, BTreeMap<String, Vec<f32>>)> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let read = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(source) => Error::Io { path: path.to_path_buf(), source },
            other => {
                Error::Image { path: path.to_path_buf(), message: format!("not a readable EXR: {other}") }
            }
        })?;
    let size = read.layer_data.size;
    let channels = read
        .layer_data
        .channel_data
        .list
        .into_iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok((size.width() as u32, size.height() as u32, channels))
}

/// The sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// The PNG outputs' tone map: linear × 2^exposure, clamped to [0, 1], the sRGB curve, 8 bits, RGB.
pub fn to_srgb8(image: &Image, exposure: f32) -> Vec<u8> {
    let scale = 2f32.powf(exposure);
    image
        .pixels
        .iter()
        .flat_map(|p| {
            let c = *p * scale;
            [c.x, c.y, c.z].map(|v| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8)
        })
        .collect()
}

fn write_png(
    image: &Image,
    out: &mut (impl std::io::Write + std::io::Seek),
    exposure: f32,
) -> Result<(), String> {
    let bytes = to_srgb8(image, exposure);
    image::write_buffer_with_format(
        &mut std::io::BufWriter::new(out),
        &bytes,
        image.width,
        image.height,
        image::ColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| e.to_string())
}

/// Whether the file begins with OpenEXR's magic number.
fn starts_like_exr(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 4];
    std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut magic)).is_ok()
        && magic == [0x76, 0x2f, 0x31, 0x01]
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
        _ if !starts_like_exr(path) => Error::Image {
            path: path.to_path_buf(),
            message:
                "not an OpenEXR file: images are compared, and references read, as linear EXRs (a PNG is \
                      tone-mapped to 8 bits; compare the render's .exr)"
                    .into(),
        },
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

    /// An exposure of NaN or ±inf once wrote an all-black or all-white PNG and said nothing.
    #[test]
    fn a_non_finite_exposure_is_refused_and_nothing_is_written() {
        let image = Image { width: 1, height: 1, pixels: vec![Vec3::splat(0.5)] };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        for exposure in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e6] {
            let message = write_image(&image, &path, exposure).unwrap_err().to_string();
            assert!(message.contains("out.png") && message.contains("exposure"), "{message}");
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "something was written");
        write_image(&image, &path, -2.0).unwrap();
    }

    #[test]
    fn feature_images_are_named_channels_of_the_exr() {
        let image = Image { width: 2, height: 1, pixels: vec![Vec3::new(1.0, 2.0, 3.0), Vec3::splat(0.5)] };
        let albedo = Image { width: 2, height: 1, pixels: vec![Vec3::new(0.1, 0.2, 0.3), Vec3::ONE] };
        let normal = Image { width: 2, height: 1, pixels: vec![Vec3::Z, -Vec3::X] };
        let features = AovImages { albedo, normal, depth: vec![4.0, 0.0], spp: Vec::new() };
        let dir = std::env::temp_dir().join(format!("caustica-exr-layers-{}", std::process::id()));
        let path = dir.join("layers.exr");
        write_image_with_aovs(&image, Some((&features, &[Aov::Depth, Aov::Albedo])), &path, 0.0).unwrap();
        let (w, h, channels) = read_exr_channels(&path).unwrap();
        assert_eq!((w, h), (2, 1));
        let names: Vec<&str> = channels.keys().map(String::as_str).collect();
        assert_eq!(names, ["B", "G", "R", "Z", "albedo.B", "albedo.G", "albedo.R"]);
        assert_eq!(channels["R"], [1.0, 0.5]);
        assert_eq!(channels["albedo.G"], [0.2, 1.0]);
        assert_eq!(channels["Z"], [4.0, 0.0]);
        // The colour reads back as ever.
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
