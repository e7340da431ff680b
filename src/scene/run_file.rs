//! Run files (TOML): which glTF to load, what to add to it, and how to render it.

use super::{MaterialDesc, Scene, Sphere};
use crate::choice::Choice;
use crate::error::{Error, Result};
use glam::Vec3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Which integrator renders the image (the name used in run files and on the command line).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    /// Path tracing with next-event estimation and MIS (power heuristic).
    #[default]
    Pt,
    /// Path tracing with BSDF sampling only; light is found only by hitting it.
    PtNaive,
    /// Photon mapping (Jensen): NEE for direct light, a caustic map, and a global map read directly or
    /// by final gathering.
    Pm,
    /// Progressive photon mapping (Hachisuka, Ogaki & Jensen 2008): hit points traced once, photon
    /// passes shrink their radii; all light but directly seen emission comes from photons.
    Ppm,
    /// Stochastic progressive photon mapping (Hachisuka & Jensen 2009): hit points re-traced every pass
    /// (depth of field, motion blur, antialiasing, glossy surfaces), direct light by NEE.
    Sppm,
    /// Adaptive PPM (Kaplanyan & Dachsbacher 2013): per-pixel radius from estimated variance and bias.
    Appm,
    /// Chi-squared PPM (Lin et al. 2020): keep the radius while photons look uniform in the disc.
    Cppm,
    /// Probabilistic PPM (Knaus & Zwicker 2011): every pass an independent estimate at a global
    /// radius sequence, averaged; no pass depends on another, so passes split across machines.
    Pppm,
}

impl IntegratorKind {
    /// Every integrator.
    pub const ALL: [IntegratorKind; 8] =
        [Self::Pt, Self::PtNaive, Self::Pm, Self::Ppm, Self::Sppm, Self::Appm, Self::Cppm, Self::Pppm];

    /// Whether this integrator runs passes of photons into persistent hit points.
    pub fn is_progressive(self) -> bool {
        matches!(self, Self::Ppm | Self::Sppm | Self::Appm | Self::Cppm | Self::Pppm)
    }
}

/// How next-event estimation picks a light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightSelection {
    /// Every light equally likely.
    Uniform,
    /// In proportion to emitted power.
    #[default]
    Power,
    /// By a light tree: power, distance and orientation towards the shading point (Conty Estevez &
    /// Kulla 2018).
    Tree,
    /// The light tree plus a grid that learns from the first samples' shadow rays which light
    /// clusters actually reach each region after occlusion (mixed with the tree, so unbiased).
    Visibility,
}

/// Pixel reconstruction filter, sampled by importance (each sample lands in one pixel with weight 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterKind {
    /// Box of radius 0.5 pixel (the references' filter).
    #[default]
    Box,
    /// Tent (triangle) of radius 1 pixel.
    Tent,
    /// Gaussian with sigma 0.5 pixel, truncated at radius 1.5.
    Gaussian,
}

impl Choice for IntegratorKind {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Pt, "pt", "path tracing with next-event estimation and MIS"),
        (Self::PtNaive, "pt-naive", "path tracing with BSDF sampling only"),
        (Self::Pm, "pm", "photon mapping (Jensen): NEE, caustic map, global map or final gathering"),
        (Self::Ppm, "ppm", "progressive photon mapping: hit points traced once, radii shrink"),
        (Self::Sppm, "sppm", "stochastic progressive photon mapping: hit points re-traced every pass"),
        (Self::Appm, "appm", "adaptive PPM: per-pixel radius from estimated variance and bias"),
        (Self::Cppm, "cppm", "chi-squared PPM: the radius shrinks when photons are not uniform in the disc"),
        (
            Self::Pppm,
            "pppm",
            "probabilistic PPM: independent passes at a global radius, averaged (splits by pass)",
        ),
    ];
}

impl Choice for LightSelection {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Uniform, "uniform", "every light equally likely"),
        (Self::Power, "power", "in proportion to emitted power"),
        (Self::Tree, "tree", "a light tree: power, distance and orientation"),
        (Self::Visibility, "visibility", "the light tree plus visibility learned from early shadow rays"),
    ];
}

impl Choice for FilterKind {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Box, "box", "box of radius 0.5 pixel"),
        (Self::Tent, "tent", "tent of radius 1 pixel"),
        (Self::Gaussian, "gaussian", "Gaussian, sigma 0.5 pixel, truncated at 1.5"),
    ];
}

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
    pub time_limit: Option<f64>,
    /// Adaptive sampling (`pt`, `pt-naive`): a pixel whose estimated relative error
    /// (`film::adaptive`) is under this stops taking samples, and `spp` becomes the most a pixel
    /// takes; 0 samples every pixel `spp` times.
    pub noise_threshold: f64,
    /// Samples every pixel takes before adaptive sampling may stop it.
    pub min_spp: u32,
    /// Memory the film, the paths, photons and hit points may take, in MiB; `None` is half the
    /// machine's memory. Checked before anything is allocated.
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
            light_selection: LightSelection::Power,
            sampler: crate::sampling::SamplerKind::Sobol,
            time_limit: None,
            noise_threshold: 0.0,
            min_spp: DEFAULT_MIN_SPP,
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
    /// The environment light.
    pub environment: super::environment::EnvironmentSettings,
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

    /// As [`RunFile::parse`], with `sets` (`KEY=VALUE`, the key dotted through tables) written into
    /// the text's tables first. The error says which assignment failed.
    pub fn parse_with_sets(text: &str, sets: &[String]) -> std::result::Result<RunFile, String> {
        let mut table: toml::Table = toml::from_str(text).map_err(|e| describe_toml_error(&e, text))?;
        for set in sets {
            let (key, value) = set
                .split_once('=')
                .ok_or_else(|| format!("--set {set}: needs KEY=VALUE, as render.spp=16"))?;
            let (key, value) = (key.trim(), value.trim());
            // A TOML value as written (16, true, [0, 1, 3], "pt"), else the text as a string (pt).
            let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
                .ok()
                .and_then(|mut t| t.remove("v"))
                .unwrap_or_else(|| toml::Value::String(value.to_owned()));
            let mut parts: Vec<&str> = key.split('.').collect();
            let last = parts.pop().filter(|p| !p.is_empty()).ok_or_else(|| format!("--set {set}: no key"))?;
            let mut node = &mut table;
            for part in parts {
                node = node
                    .entry(part)
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                    .as_table_mut()
                    .ok_or_else(|| format!("--set {set}: {part} is not a table"))?;
            }
            node.insert(last.to_owned(), value);
        }
        let run: RunFile = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| format!("--set {}: {}", sets.join(" "), e.message().trim_end()))?;
        run.check_settings().map_err(|problem| format!("{problem} (after --set {})", sets.join(" ")))?;
        Ok(run)
    }

    /// The scene this run file (read from `path`) describes, not yet validated: its glTF, resolved against the run
    /// file's directory and with the camera `[camera] name` picks, plus its `[[sphere]]`s and `[[motion]]`s.
    pub fn load_scene(&self, path: &Path) -> Result<Scene> {
        let mut scene = match &self.gltf {
            Some(gltf) => {
                let resolved = path.parent().unwrap_or(Path::new("")).join(gltf);
                // Name the path as written too: the resolved one alone hides which key was wrong.
                if let Err(e) = std::fs::metadata(&resolved) {
                    let context = format!(
                        "{e} (gltf = \"{}\" in {}, relative to the run file's directory)",
                        gltf.display(),
                        path.display()
                    );
                    return Err(Error::Io { path: resolved, source: std::io::Error::new(e.kind(), context) });
                }
                super::gltf::load_gltf_with_camera(&resolved, self.camera.name.as_deref())?
            }
            None => {
                if let Some(name) = &self.camera.name {
                    return Err(Error::RunFile {
                        path: path.to_path_buf(),
                        message: format!(
                            "camera.name = \"{name}\" but the run file loads no glTF to pick it from"
                        ),
                    });
                }
                Scene { source: path.to_path_buf(), ..Scene::default() }
            }
        };
        self.add_spheres(&mut scene);
        for (i, light) in self.lights.iter().enumerate() {
            // Checked when the run file was parsed.
            let desc =
                light.to_desc(i).map_err(|message| Error::RunFile { path: path.to_path_buf(), message })?;
            scene.punctual_lights.push(desc);
        }
        self.apply_motions(&mut scene, path)?;
        let origin = format!("{}, relative to its directory", path.display());
        scene.environment = self.environment.load(path.parent().unwrap_or(Path::new("")), &origin)?;
        Ok(scene)
    }

    fn add_spheres(&self, scene: &mut Scene) {
        for (i, spec) in self.spheres.iter().enumerate() {
            let name = spec.name.clone().unwrap_or_else(|| format!("sphere #{i}"));
            let material = spec.material.to_material(&name, spec.radius);
            scene.materials.push(material);
            scene.spheres.push(Sphere {
                name,
                center: Vec3::from(spec.center),
                radius: spec.radius,
                material: (scene.materials.len() - 1) as u32,
                motion: spec.motion.map(Vec3::from),
            });
        }
    }

    fn apply_motions(&self, scene: &mut Scene, path: &Path) -> Result<()> {
        for motion in &self.motion {
            let mut found = false;
            for mesh in
                scene.meshes.iter_mut().filter(|m| m.node_name.as_deref() == Some(motion.node.as_str()))
            {
                mesh.motion = Some(Vec3::from(motion.translate));
                found = true;
            }
            if !found {
                let mut names: Vec<&str> =
                    scene.meshes.iter().filter_map(|m| m.node_name.as_deref()).collect();
                names.dedup();
                let names = if names.is_empty() { "none".to_owned() } else { names.join(", ") };
                return Err(Error::InvalidScene {
                    path: path.to_path_buf(),
                    object: format!("[[motion]] node = \"{}\"", motion.node),
                    problem: format!("no node of that name carries a mesh; named nodes with meshes: {names}"),
                });
            }
        }
        Ok(())
    }

    /// Ranges serde cannot express; the message names the key. Run after the command line's
    /// overrides too (`scene::load_with`), so a setting is checked the same way however it arrives.
    pub fn check_settings(&self) -> Result<(), String> {
        let finite = |key: &str, values: &[f32]| {
            if values.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(format!("{key} must be finite")) }
        };
        if self.render.spp == 0 {
            return Err("render.spp is 0, must be at least 1".to_owned());
        }
        self.environment.check()?;
        if self.film.width == Some(0) || self.film.height == Some(0) {
            return Err("film.width and film.height must be at least 1".to_owned());
        }
        finite("film.exposure", &[self.film.exposure])?;
        let camera = &self.camera;
        for (key, value) in
            [("camera.eye", camera.eye), ("camera.target", camera.target), ("camera.up", camera.up)]
        {
            finite(key, &value.unwrap_or_default())?;
        }
        if let Some(yfov) = camera.yfov_degrees
            && !(yfov > 0.0 && yfov < 180.0)
        {
            return Err(format!("camera.yfov_degrees is {yfov}, must be in (0, 180)"));
        }
        if !(camera.aperture_radius >= 0.0 && camera.aperture_radius.is_finite()) {
            return Err(format!(
                "camera.aperture_radius is {}, must be finite and >= 0",
                camera.aperture_radius
            ));
        }
        if let Some(focus) = camera.focus_distance
            && !(focus > 0.0 && focus.is_finite())
        {
            return Err(format!("camera.focus_distance is {focus}, must be finite and > 0"));
        }
        if let Some([open, close]) = camera.shutter
            && !(open.is_finite() && close.is_finite() && open <= close)
        {
            return Err(format!("camera.shutter is [{open}, {close}], must be finite with open <= close"));
        }
        for (i, sphere) in self.spheres.iter().enumerate() {
            finite(&format!("sphere[{i}].center"), &sphere.center)?;
            finite(&format!("sphere[{i}].motion"), &sphere.motion.unwrap_or_default())?;
        }
        for (i, motion) in self.motion.iter().enumerate() {
            finite(&format!("motion[{i}].translate"), &motion.translate)?;
        }
        for (i, light) in self.lights.iter().enumerate() {
            light.to_desc(i)?;
        }
        self.progressive.check().map_err(|e| format!("progressive.{e}"))?;
        self.photons.check().map_err(|e| format!("photons.{e}"))?;
        if self.output.write_every == Some(0) {
            return Err("output.write_every is 0, must be at least 1 (or absent)".to_owned());
        }
        self.schedule.check(self.render.integrator)?;
        if let Some(t) = self.render.time_limit
            && !(t.is_finite() && t > 0.0)
        {
            return Err(format!("render.time_limit is {t}, must be finite and > 0"));
        }
        self.check_adaptive_sampling()?;
        if let Some(mib) = self.render.memory_budget_mib
            && mib > MAX_MEMORY_BUDGET_MIB
        {
            return Err(format!(
                "render.memory_budget_mib is {mib}, more than {MAX_MEMORY_BUDGET_MIB} (1 EiB)"
            ));
        }
        Ok(())
    }
}

impl PhotonSettings {
    /// Which setting is out of range, if any (named as in the run file, without the table).
    pub fn check(&self) -> Result<(), String> {
        // With k = 1 the one photon lies on the rim of its own disc, where every kernel but the
        // uniform one is zero: the estimate would be black.
        if self.k < 2 {
            return Err(format!("k is {}, must be at least 2 (100 by default)", self.k));
        }
        if let Some(r) = self.max_radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("max_radius is {r}, must be finite and > 0"));
        }
        Ok(())
    }
}

/// Samples a pixel takes before adaptive sampling may stop it: enough for a variance estimate that is
/// not fooled by a pixel whose rare bright paths have not turned up yet.
pub const DEFAULT_MIN_SPP: u32 = 16;

impl RunFile {
    /// Whether adaptive sampling is on.
    pub fn is_adaptive(&self) -> bool {
        self.render.noise_threshold > 0.0
    }

    /// What is wrong with the adaptive-sampling settings, if anything.
    fn check_adaptive_sampling(&self) -> Result<(), String> {
        let render = &self.render;
        let t = render.noise_threshold;
        if !(t.is_finite() && t >= 0.0) {
            return Err(format!("render.noise_threshold is {t}, must be finite and >= 0 (0 turns it off)"));
        }
        if !self.is_adaptive() {
            return Ok(());
        }
        if !matches!(render.integrator, IntegratorKind::Pt | IntegratorKind::PtNaive) {
            return Err(format!(
                "render.noise_threshold is {t}, but adaptive sampling is for pt and pt-naive, not {}: \
                 the photon mappers' pixels share their photons, so a pixel cannot stop alone",
                render.integrator.name()
            ));
        }
        if render.min_spp < 2 {
            return Err(format!(
                "render.min_spp is {}, must be at least 2 (a variance needs two samples)",
                render.min_spp
            ));
        }
        Ok(())
    }
}

/// Largest memory budget, MiB: 2^40 MiB = 1 EiB, so that its bytes fit a u64 (and no machine has more).
pub const MAX_MEMORY_BUDGET_MIB: u64 = 1 << 40;

impl RunFile {
    /// The memory budget in bytes: `[render]`'s, else `[progressive]`'s, else `default`.
    pub fn memory_budget_bytes(&self, default: u64) -> u64 {
        self.render.memory_budget_mib.or(self.progressive.memory_budget_mib).map_or(default, |mib| mib << 20)
    }
}

/// Most hit points a pixel may have.
pub const MAX_HIT_POINTS_PER_PIXEL: u32 = 256;

impl ProgressiveSettings {
    /// Hit points per pixel for `integrator`: the setting, or its default.
    pub fn hit_points_for(&self, integrator: IntegratorKind) -> u32 {
        self.hit_points_per_pixel.unwrap_or(if integrator == IntegratorKind::Ppm { 32 } else { 1 })
    }

    /// Which setting is out of range, if any (named as in the run file, without the table).
    pub fn check(&self) -> Result<(), String> {
        if self.passes == 0 {
            return Err("passes is 0, must be at least 1".into());
        }
        if self.photons_per_pass == 0 {
            return Err("photons_per_pass is 0, must be at least 1".into());
        }
        // α = 0 keeps no photon statistics (the radius collapses at once); α > 1 would grow N faster
        // than photons arrive and the radius would never shrink.
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(format!("alpha is {}, must be in (0, 1]", self.alpha));
        }
        if let Some(r) = self.initial_radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("initial_radius is {r}, must be finite and > 0"));
        }
        if let Some(mib) = self.memory_budget_mib
            && mib > MAX_MEMORY_BUDGET_MIB
        {
            return Err(format!("memory_budget_mib is {mib}, more than {MAX_MEMORY_BUDGET_MIB} (1 EiB)"));
        }
        if let Some(n) = self.hit_points_per_pixel
            && !(n.is_power_of_two() && n <= MAX_HIT_POINTS_PER_PIXEL)
        {
            return Err(format!(
                "hit_points_per_pixel is {n}, must be a power of two from 1 to {MAX_HIT_POINTS_PER_PIXEL} (1, 2, 4, 8, …): \
                 the hit points of a pixel are the points of a (0, m, 2)-net over it"
            ));
        }
        Ok(())
    }
}

impl MaterialSpec {
    /// The material a sphere of this radius gets: double-sided, and a closed solid as thick as the sphere.
    pub fn to_material(&self, name: &str, radius: f32) -> MaterialDesc {
        MaterialDesc {
            name: name.to_owned(),
            base_color: Vec3::from(self.base_color),
            base_color_texture: None,
            metallic: self.metallic,
            roughness: self.roughness,
            metallic_roughness_texture: None,
            emission: self.emission(),
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            transmission: self.transmission,
            ior: self.ior,
            specular: self.specular,
            specular_color: Vec3::ONE,
            clearcoat: self.clearcoat,
            clearcoat_roughness: self.clearcoat_roughness,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            thickness: 2.0 * radius,
            attenuation: self.attenuation(),
            double_sided: true,
            alpha_mode: super::AlphaMode::Opaque,
            alpha: 1.0,
        }
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
