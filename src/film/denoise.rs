//! Denoising with Intel Open Image Denoise (Áfra et al., the `RT` filter): colour with the albedo and
//! normal feature images (`film::aov`) as guides, in HDR, on the CPU. Behind feature `denoise`, which
//! needs the OIDN 2.x shared libraries (`OIDN_DIR`); without it [`denoise`] says how to get it.
//!
//! The filter is the denoiser's own prefiltering of noisy guides (`cleanAux` off): our albedo and
//! normals are averages over the same samples as colour, nearly noise-free on opaque surfaces but
//! not under depth of field, motion blur or rough glass.

use super::Image;
use super::aov::AovImages;
use crate::error::{Error, Result};

/// Whether this build has the denoiser.
pub const AVAILABLE: bool = cfg!(feature = "denoise");

/// The one command that gets the denoiser's libraries (PyPI's pyoidn wheel carries them; Debian 12
/// packages no OIDN 2) and builds the command line with them, from the repository's root.
pub const BUILD_WITH_DENOISER: &str = "python3 -m venv ~/oidn && ~/oidn/bin/pip install pyoidn==2.5.1.0 && \
     OIDN_DIR=$(~/oidn/bin/python -c 'import os, pyoidn; print(os.path.join(os.path.dirname(pyoidn.__file__), \"oidn\"))') \
     cargo build --release --features denoise";

/// Ok when this build has the denoiser; otherwise the error that says how to get one (checked
/// before a render whose output would be denoised).
pub fn check_available() -> Result<()> {
    if AVAILABLE {
        Ok(())
    } else {
        Err(Error::Denoise {
            problem: format!(
                "this build has no denoiser; this one command builds one with Open Image Denoise 2.5 from PyPI: {BUILD_WITH_DENOISER}"
            ),
        })
    }
}

/// The denoised `color`, guided by the albedo and normal of `features`.
pub fn denoise(color: &Image, features: &AovImages) -> Result<Image> {
    let (w, h) = (color.width, color.height);
    for (name, guide) in [("albedo", &features.albedo), ("normal", &features.normal)] {
        if (guide.width, guide.height) != (w, h) {
            return Err(Error::Denoise {
                problem: format!("the {name} image is {}x{}, the colour {w}x{h}", guide.width, guide.height),
            });
        }
    }
    run(color, features)
}

#[cfg(feature = "denoise")]
fn run(color: &Image, features: &AovImages) -> Result<Image> {
    let flat = |image: &Image| image.pixels.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
    let failed = |e: oidn::Error| Error::Denoise { problem: format!("Open Image Denoise: {e:?}") };
    let (albedo, normal, input) = (flat(&features.albedo), flat(&features.normal), flat(color));
    let mut output = vec![0.0f32; input.len()];
    let device = oidn::Device::cpu().map_err(failed)?;
    oidn::RayTracing::try_new(&device)
        .map_err(failed)?
        .hdr(true)
        .srgb(false)
        .image_dimensions(color.width as usize, color.height as usize)
        .albedo_normal(&albedo, &normal)
        .filter(&input, &mut output)
        .map_err(failed)?;
    device.get_error().map_err(failed)?;
    let pixels = output.chunks_exact(3).map(|c| glam::Vec3::new(c[0], c[1], c[2])).collect();
    Ok(Image { width: color.width, height: color.height, pixels })
}

#[cfg(not(feature = "denoise"))]
fn run(_color: &Image, _features: &AovImages) -> Result<Image> {
    check_available().map(|()| unreachable!("a build without the denoiser has none"))
}
