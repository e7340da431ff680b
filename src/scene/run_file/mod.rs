//! Run files (TOML): which glTF to load, what to add to it, and how to render it.

mod assembly;
mod checks;
mod guiding;
mod kinds;
mod sets;

pub use checks::{
    DEFAULT_CHUNK, DEFAULT_MIN_SPP, MAX_CHUNK, MAX_HIT_POINTS_PER_PIXEL, MAX_MEMORY_BUDGET_MIB,
};
pub use guiding::GuidingSettings;
pub use kinds::{FilterKind, IntegratorKind, LightSelection};
pub use sets::{SHORT_KEYS, assigns};

use crate::error::{Error, Result};
use glam::Vec3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The `[render]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    /// Integrator.
    pub integrator: IntegratorKind,
    /// Samples per pixel (at least 1).
    pub spp: u32,
    /// Seed of the counter-based sampler.
    pub seed: u64,
    /// Maximum number of bounces; `None` is unbounded (Russian roulette ends paths).
    pub max_depth: Option<u32>,
    /// First depth at which Russian roulette may end a path.
    pub rr_depth: u32,
    /// Light selection for next-event estimation.
    pub light_selection: LightSelection,
    /// How sample numbers are drawn.
    pub sampler: crate::sampling::SamplerKind,
    /// Wall-clock budget in seconds: rendering stops at the first of this and the sample/pass count.
    /// The `caustica` command counts it from its own start (loading and preparing come out of it), a
    /// `Renderer::run` from the call.
    pub time_limit: Option<f64>,
    /// Adaptive sampling (`pt`, `pt-naive`): a pixel whose estimated relative error
    /// (`film::adaptive`) is under this stops taking samples, and `spp` becomes the most a pixel
    /// takes; 0 samples every pixel `spp` times.
    pub noise_threshold: f64,
    /// Samples every pixel takes before adaptive sampling may stop it.
    pub min_spp: u32,
    /// Camera paths (and `lt`'s light subpaths) a worker keeps in flight (`pt`, `pt-naive`, `lt`):
    /// its chunk of the wavefront, whose columns stay in the core's cache from stage to stage. Any
    /// size renders the same image.
    pub chunk: u32,
    /// The process's peak resident memory in MiB (`None`: half the machine's): what it holds once
    /// the scene is built, plus the film, paths, photons, hit points, the written image and
    /// checkpoints, counted before any of them is allocated.
    pub memory_budget_mib: Option<u64>,
}

impl Default for RenderSettings {
    /// 64 spp of `pt`, unbounded depth with Russian roulette from depth 5 (as the references).
    fn default() -> Self {
        Self {
            integrator: IntegratorKind::Pt,
            spp: 64,
            seed: 0,
            max_depth: None,
            rr_depth: 5,
            light_selection: LightSelection::Tree,
            sampler: crate::sampling::SamplerKind::Sobol,
            time_limit: None,
            noise_threshold: 0.0,
            min_spp: DEFAULT_MIN_SPP,
            chunk: DEFAULT_CHUNK,
            memory_budget_mib: None,
        }
    }
}

/// The `[film]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilmSettings {
    /// Image width in pixels (glTF extras or 512 when absent).
    pub width: Option<u32>,
    /// Image height in pixels.
    pub height: Option<u32>,
    /// Reconstruction filter.
    pub filter: FilterKind,
    /// PNG exposure in stops (EXR is always written unscaled).
    pub exposure: f32,
    /// Feature images to render beside colour (`film::aov`), written as layers of the EXR.
    pub aovs: Vec<crate::film::aov::Aov>,
}

impl Default for FilmSettings {
    fn default() -> Self {
        Self { width: None, height: None, filter: FilterKind::Box, exposure: 0.0, aovs: Vec::new() }
    }
}

/// The `[camera]` table: overrides of the file's camera.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraOverrides {
    /// Pick the glTF camera with this name.
    pub name: Option<String>,
    /// Eye position.
    pub eye: Option<[f32; 3]>,
    /// Look-at target.
    pub target: Option<[f32; 3]>,
    /// Up vector (default +Y).
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    pub yfov_degrees: Option<f32>,
    /// Thin-lens aperture radius in meters (0 = pinhole).
    pub aperture_radius: f32,
    /// Distance to the plane in focus (default: distance from eye to target).
    pub focus_distance: Option<f32>,
    /// Shutter open and close times (motion is given over this interval).
    pub shutter: Option<[f32; 2]>,
}

/// The `[frames]` table: an animation rendered frame by frame (`caustica render --frames`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct FrameSettings {
    /// First frame (frame f is at time f / fps).
    pub start: u32,
    /// One past the last frame; `None`: no animation is rendered, one image is.
    pub end: Option<u32>,
    /// Frames per second.
    pub fps: f32,
    /// How long the shutter is open, in frames, centred on the frame's time (0.5: a 180° shutter;
    /// 0: no motion blur): each frame is blurred by the animation over it.
    pub shutter: f32,
}

impl Default for FrameSettings {
    fn default() -> Self {
        Self { start: 0, end: None, fps: 24.0, shutter: 0.0 }
    }
}

impl FrameSettings {
    /// The shutter interval of frame `frame`, in seconds of the animation; `None` without blur.
    pub fn shutter_of(&self, frame: u32) -> Option<(f32, f32)> {
        let (centre, half) = (frame as f32 / self.fps, 0.5 * self.shutter / self.fps);
        (self.shutter > 0.0).then_some((centre - half, centre + half))
    }

    /// The frames to render, when an animation is asked for.
    pub fn range(&self) -> Option<std::ops::Range<u32>> {
        self.end.map(|end| self.start..end)
    }
}

/// The `[output]` table.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSettings {
    /// Linear EXR path (relative to the working directory).
    pub exr: Option<PathBuf>,
    /// sRGB PNG path.
    pub png: Option<PathBuf>,
    /// Progressive integrators: also write the outputs every this many passes.
    pub write_every: Option<u32>,
}

/// A material given inline in a run file (the same parameters as glTF's).
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaterialSpec {
    /// Linear base colour.
    pub base_color: [f32; 3],
    /// Metallic in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// Transmission in [0, 1] (1 = glass).
    pub transmission: f32,
    /// Index of refraction.
    pub ior: f32,
    /// Specular factor of the dielectric layer (0 = pure Lambertian).
    pub specular: f32,
    /// Emitted radiance.
    pub emission: [f32; 3],
    /// KHR_materials_clearcoat: weight of a clear coat in [0, 1].
    pub clearcoat: f32,
    /// KHR_materials_clearcoat: its perceptual roughness.
    pub clearcoat_roughness: f32,
    /// KHR_materials_volume: the colour white light takes after `attenuation_distance` inside.
    pub attenuation_color: [f32; 3],
    /// KHR_materials_volume: the distance (m) at which light has `attenuation_color`; infinite: clear.
    pub attenuation_distance: f32,
}

impl Default for MaterialSpec {
    fn default() -> Self {
        Self {
            base_color: [0.8; 3],
            metallic: 0.0,
            roughness: 1.0,
            transmission: 0.0,
            ior: 1.5,
            specular: 0.0,
            emission: [0.0; 3],
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            attenuation_color: [1.0; 3],
            attenuation_distance: f32::INFINITY,
        }
    }
}

/// A `[[sphere]]` entry.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Name for messages.
    #[serde(default)]
    pub name: Option<String>,
    /// Centre.
    pub center: [f32; 3],
    /// Radius.
    pub radius: f32,
    /// Material.
    #[serde(default)]
    pub material: MaterialSpec,
    /// Displacement over the shutter.
    #[serde(default)]
    pub motion: Option<[f32; 3]>,
}

/// A `[[motion]]` entry: move a glTF node linearly over the shutter.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// Node name in the glTF file.
    pub node: String,
    /// Displacement from shutter open to shutter close, in meters.
    pub translate: [f32; 3],
}

/// The `[photons]` table: photon-mapping settings (`pm`).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhotonSettings {
    /// Photons emitted for the global (or indirect) map.
    pub photons: u32,
    /// Photons emitted for the caustic map (no caustic pass without specular surfaces).
    pub caustic_photons: u32,
    /// Photons per radiance estimate.
    pub k: u32,
    /// Largest gather radius in scene units (default: 5% of the scene's bounding-box diagonal).
    pub max_radius: Option<f32>,
    /// Density kernel over the gather disc.
    pub kernel: crate::density::kernels::Kernel,
    /// Final-gather rays per pixel sample (each with its own camera ray); 0 reads the map directly.
    pub final_gather: u32,
}

impl Default for PhotonSettings {
    /// 200 000 photons per map, k = 100, Epanechnikov kernel, no final gathering.
    fn default() -> Self {
        Self {
            photons: 200_000,
            caustic_photons: 200_000,
            k: 100,
            max_radius: None,
            kernel: crate::density::kernels::Kernel::Epanechnikov,
            final_gather: 0,
        }
    }
}

/// The `[progressive]` table: passes of the progressive photon mappers (`ppm`, `sppm`, `appm`, `cppm`).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProgressiveSettings {
    /// Photon passes (the render also stops at `render.time_limit`).
    pub passes: u32,
    /// Photons emitted per pass.
    pub photons_per_pass: u32,
    /// Fraction of a pass's photons kept in the hit point statistics (Hachisuka, Ogaki & Jensen 2008).
    pub alpha: f32,
    /// First gather radius in scene units; `None` picks it from the scene's area and the photon count.
    pub initial_radius: Option<f32>,
    /// The same budget as `[render] memory_budget_mib` (kept here for the run files that set it here).
    pub memory_budget_mib: Option<u64>,
    /// Hit points per pixel, a power of two: the points of a (0, m, 2)-net over the pixel filter, each
    /// with its own radius and statistics. `None`: 32 for `ppm`, whose hit points are traced once and
    /// would otherwise converge to a point-sampled image; 1 for the others, which re-trace theirs
    /// with a new filter sample every pass.
    pub hit_points_per_pixel: Option<u32>,
}

impl Default for ProgressiveSettings {
    /// 64 passes of 65 536 photons, α = 2/3, radius from the heuristic, half the memory.
    fn default() -> Self {
        Self {
            passes: 64,
            photons_per_pass: 65_536,
            alpha: 2.0 / 3.0,
            initial_radius: None,
            memory_budget_mib: None,
            hit_points_per_pixel: None,
        }
    }
}

/// A whole run file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunFile {
    /// glTF asset, relative to the run file (absent: only analytic spheres).
    pub gltf: Option<PathBuf>,
    /// Camera overrides.
    pub camera: CameraOverrides,
    /// Film settings.
    pub film: FilmSettings,
    /// Render settings.
    pub render: RenderSettings,
    /// Photon-mapping settings.
    pub photons: PhotonSettings,
    /// Progressive photon mapping.
    pub progressive: ProgressiveSettings,
    /// Stage and pass order, optional systems.
    pub schedule: super::schedule::ScheduleSettings,
    /// Output files.
    pub output: OutputSettings,
    /// An animation's frames.
    pub frames: FrameSettings,
    /// The environment light.
    pub environment: super::environment::EnvironmentSettings,
    /// Path guiding (`pt`).
    pub guiding: GuidingSettings,
    /// Analytic spheres.
    #[serde(rename = "sphere")]
    pub spheres: Vec<SphereSpec>,
    /// Linear node motions.
    pub motion: Vec<MotionSpec>,
    /// Punctual lights added to the scene.
    #[serde(rename = "light")]
    pub lights: Vec<super::punctual::LightSpec>,
}

impl MaterialSpec {
    /// Emission as a vector.
    pub fn emission(&self) -> Vec3 {
        Vec3::from(self.emission)
    }

    /// σa from the attenuation colour and distance, as glTF defines it.
    pub fn attenuation(&self) -> Vec3 {
        super::absorption(Vec3::from(self.attenuation_color), self.attenuation_distance)
    }
}

impl RunFile {
    /// Reads and parses a run file; unknown keys and out-of-range settings are errors naming the key.
    pub fn load(path: &Path) -> Result<RunFile> {
        let text =
            std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        Self::parse(&text, path)
    }

    /// Parses run-file text; `path` is the file named in messages (and nothing is read from it).
    pub fn parse(text: &str, path: &Path) -> Result<RunFile> {
        let run: RunFile = toml::from_str(text).map_err(|e| Error::RunFile {
            path: path.to_path_buf(),
            message: describe_toml_error(&e, text),
        })?;
        run.check_settings().map_err(|message| Error::RunFile { path: path.to_path_buf(), message })?;
        Ok(run)
    }
}

/// `line L, column C in [table]: message`, on one line (toml's own display spans several).
fn describe_toml_error(error: &toml::de::Error, text: &str) -> String {
    let message = error.message().trim_end();
    let Some(span) = error.span() else {
        return message.to_owned();
    };
    let before = text.get(..span.start).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.chars().rev().take_while(|&c| c != '\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let table = before[..line_start]
        .lines()
        .rev()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .find(|l| l.starts_with('['))
        .map(|header| format!(" in {header}"))
        .unwrap_or_default();
    format!("line {line}, column {column}{table}: {message}")
}
