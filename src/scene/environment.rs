//! The environment as the user describes it: a `[environment]` table or `--environment` flags, resolved
//! into a constant colour or a decoded equirectangular map.
//!
//! Map convention (as Mitsuba 3's `envmap`, world +Y up): row 0 is the zenith (+Y), the bottom row
//! the nadir; the image's horizontal centre looks along +Z, its left edge along −Z, and u = 1/4 along
//! +X. `rotation_degrees` turns the map about the world X, Y and Z axes, in that order.

use crate::error::{Error, Result};
use crate::film::Image;
use glam::{EulerRot, Quat, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The `[environment]` table of a run file; the command line's `--environment*` flags set the same
/// fields.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct EnvironmentSettings {
    /// Equirectangular radiance map (.exr, or Radiance .hdr), relative to the run file.
    pub file: Option<PathBuf>,
    /// Constant radiance (linear RGB), instead of a map.
    pub color: Option<[f32; 3]>,
    /// Multiplies the radiance (default 1).
    pub strength: Option<f32>,
    /// Rotation of the map about world X, then Y, then Z, in degrees.
    pub rotation_degrees: Option<[f32; 3]>,
}

/// What the environment radiates, before strength and rotation.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentRadiance {
    /// The same radiance from every direction.
    Constant(Vec3),
    /// An equirectangular map in linear RGB (see the module docs for its orientation).
    Map(Image),
}

/// An infinite environment light, ready to be built into the light set.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentDesc {
    /// The map's file or "constant (r, g, b)", for messages.
    pub name: String,
    /// Radiance by direction.
    pub radiance: EnvironmentRadiance,
    /// Multiplies the radiance.
    pub strength: f32,
    /// World-from-map rotation.
    pub rotation: Quat,
}

impl EnvironmentDesc {
    /// The largest radiance in any direction, strength included (in f64, so that it cannot overflow
    /// on the way).
    pub fn max_radiance(&self) -> f64 {
        let brightest = match &self.radiance {
            EnvironmentRadiance::Constant(c) => c.max_element(),
            EnvironmentRadiance::Map(image) => {
                image.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max)
            }
        };
        brightest as f64 * self.strength as f64
    }

    /// A uniform environment of radiance `color`.
    pub fn constant(color: Vec3) -> Self {
        Self {
            name: format!("constant ({:?}, {:?}, {:?})", color.x, color.y, color.z),
            radiance: EnvironmentRadiance::Constant(color),
            strength: 1.0,
            rotation: Quat::IDENTITY,
        }
    }

    /// Read an equirectangular map: OpenEXR (first RGB layer) or Radiance HDR. Non-finite or negative
    /// texels are refused, naming the file and the texel.
    pub fn from_file(path: &Path) -> Result<Self> {
        let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let image = match extension.as_deref() {
            Some("exr") => crate::film::output::read_exr(path)?,
            Some("hdr") => read_hdr(path)?,
            _ => {
                return Err(Error::Image {
                    path: path.to_path_buf(),
                    message: "an environment map must be OpenEXR (.exr) or Radiance HDR (.hdr)".into(),
                });
            }
        };
        if image.width < 2 || image.height < 1 {
            return Err(Error::Image {
                path: path.to_path_buf(),
                message: format!("{}x{} is too small for an environment map", image.width, image.height),
            });
        }
        if let Some(i) = image.pixels.iter().position(|p| !p.is_finite() || p.min_element() < 0.0) {
            let (x, y) = (i as u32 % image.width, i as u32 / image.width);
            return Err(Error::InvalidScene {
                path: path.to_path_buf(),
                object: format!("environment map texel ({x}, {y})"),
                problem: format!("radiance {} is not finite and non-negative", image.pixels[i]),
            });
        }
        Ok(Self {
            name: path.display().to_string(),
            radiance: EnvironmentRadiance::Map(image),
            strength: 1.0,
            rotation: Quat::IDENTITY,
        })
    }
}

fn read_hdr(path: &Path) -> Result<Image> {
    let reader = image::ImageReader::open(path)
        .map_err(|source| Error::Io { path: path.to_path_buf(), source })?
        .with_guessed_format()
        .map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    // Guessing from the content would decode a PNG renamed .hdr as an 8-bit map, clipped at 1.
    if let Some(format) = reader.format().filter(|&f| f != image::ImageFormat::Hdr) {
        return Err(Error::Image {
            path: path.to_path_buf(),
            message: format!("named .hdr but its content is {format:?}, not a Radiance HDR image"),
        });
    }
    let decoded = reader
        .decode()
        .map_err(|e| Error::Image { path: path.to_path_buf(), message: format!("not a readable HDR: {e}") })?
        .into_rgb32f();
    let (width, height) = decoded.dimensions();
    let pixels = decoded.pixels().map(|p| Vec3::from(p.0)).collect();
    Ok(Image { width, height, pixels })
}

impl EnvironmentSettings {
    /// Whether any field is set.
    pub fn is_set(&self) -> bool {
        *self != Self::default()
    }

    /// Ranges serde cannot express; the message names the key.
    pub fn check(&self) -> Result<(), String> {
        if self.file.is_some() && self.color.is_some() {
            return Err("environment.file and environment.color are both set: choose one".into());
        }
        if self.file.as_ref().is_some_and(|f| f.as_os_str().is_empty()) {
            return Err("environment.file is empty: name an .exr or .hdr map".into());
        }
        if let Some(c) = self.color
            && !c.iter().all(|v| v.is_finite() && *v >= 0.0)
        {
            return Err(format!("environment.color is {c:?}, must be finite and >= 0"));
        }
        if let Some(s) = self.strength
            && !(s.is_finite() && s >= 0.0)
        {
            return Err(format!("environment.strength is {s}, must be finite and >= 0"));
        }
        if let Some(r) = self.rotation_degrees
            && !r.iter().all(|v| v.is_finite())
        {
            return Err(format!("environment.rotation_degrees is {r:?}, must be finite"));
        }
        Ok(())
    }

    /// The environment these settings describe, with `file` resolved against `base` (the run file's
    /// directory); `None` when neither a file nor a colour is given. `origin` says where the settings
    /// came from (the run file, or the command line), for messages.
    pub fn load(&self, base: &Path, origin: &str) -> Result<Option<EnvironmentDesc>> {
        let mut desc = match (&self.file, self.color) {
            (Some(file), _) => {
                // Say which setting named the map: the path alone hides whether a run file or a flag was wrong.
                let named = |message: String| {
                    format!("{message} (environment.file = \"{}\" in {origin})", file.display())
                };
                let resolved = base.join(file);
                let loaded = std::fs::metadata(&resolved)
                    .map_err(|source| Error::Io { path: resolved.clone(), source })
                    .and_then(|_| EnvironmentDesc::from_file(&resolved));
                match loaded {
                    Ok(desc) => desc,
                    Err(Error::Io { path, source }) => {
                        let source = std::io::Error::new(source.kind(), named(source.to_string()));
                        return Err(Error::Io { path, source });
                    }
                    Err(Error::Image { path, message }) => {
                        return Err(Error::Image { path, message: named(message) });
                    }
                    Err(other) => return Err(other),
                }
            }
            (None, Some(color)) => EnvironmentDesc::constant(Vec3::from(color)),
            (None, None) => return Ok(None),
        };
        desc.strength = self.strength.unwrap_or(1.0);
        if let Some([x, y, z]) = self.rotation_degrees {
            // Extrinsic X, then Y, then Z: the intrinsic Z-Y-X composition.
            desc.rotation = Quat::from_euler(EulerRot::ZYX, z.to_radians(), y.to_radians(), x.to_radians());
        }
        Ok(Some(desc))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_about_y_by_ninety_degrees_turns_z_into_x() {
        let settings = EnvironmentSettings {
            color: Some([1.0, 1.0, 1.0]),
            rotation_degrees: Some([0.0, 90.0, 0.0]),
            ..Default::default()
        };
        let desc = settings.load(Path::new("."), "a test").unwrap().unwrap();
        assert!((desc.rotation * Vec3::Z - Vec3::X).length() < 1e-6);
        // X first, then Y: a quarter turn about X takes +Y to +Z, one about Y takes +Z on to +X (the
        // other order would leave +Y at +Z).
        let settings = EnvironmentSettings { rotation_degrees: Some([90.0, 90.0, 0.0]), ..settings };
        let desc = settings.load(Path::new("."), "a test").unwrap().unwrap();
        assert!((desc.rotation * Vec3::Y - Vec3::X).length() < 1e-6, "{}", desc.rotation * Vec3::Y);
    }

    #[test]
    fn file_and_colour_together_are_refused() {
        let settings =
            EnvironmentSettings { file: Some("a.exr".into()), color: Some([1.0; 3]), ..Default::default() };
        assert!(settings.check().unwrap_err().contains("choose one"));
        let settings = EnvironmentSettings { strength: Some(f32::NAN), ..Default::default() };
        assert!(settings.check().unwrap_err().contains("environment.strength"));
    }
}
