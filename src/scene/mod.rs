//! Scene description: what the loaders produce and the renderer consumes.
//!
//! Everything here is plain data in world space. Loaders (`gltf`, `run_file`) fill it and `validate`
//! checks it, so that the systems downstream can take it as valid and return nothing.

pub mod animation;
pub mod environment;
pub mod fingerprint;
pub mod gltf;
pub mod pose;
pub mod punctual;
pub mod run_file;
pub mod schedule;
pub mod tangents;
pub mod validate;

use crate::error::{Error, Result};
use crate::materials::ShadingParams;
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::path::{Path, PathBuf};

pub use run_file::{
    FilterKind, IntegratorKind, LightSelection, PhotonSettings, ProgressiveSettings, RenderSettings, RunFile,
};
pub use validate::{ValidationSummary, validate};

/// Loads and validates a scene: a run file (.toml) with the glTF it names and its additions, or a bare .gltf/.glb
/// with the default settings.
pub fn load(path: &Path) -> Result<(Scene, RunFile)> {
    load_with(path, |_| {})
}

/// As [`load`], with `overrides` (the command line's) applied to the run file before the scene is
/// read: they can pick the glTF's camera or the environment.
pub fn load_with(path: &Path, overrides: impl FnOnce(&mut RunFile)) -> Result<(Scene, RunFile)> {
    load_with_sets(path, &[], overrides)
}

/// As [`load_with`], with `sets` first: `KEY=VALUE` assignments of any run-file key (`render.spp=16`,
/// `camera.eye=[0, 1, 3]`; a value that is not TOML is a string), as if the run file had them.
pub fn load_with_sets(
    path: &Path,
    sets: &[String],
    overrides: impl FnOnce(&mut RunFile),
) -> Result<(Scene, RunFile)> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let text = match extension.as_deref() {
        Some("toml") => {
            std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?
        }
        Some("gltf" | "glb") => String::new(),
        _ => {
            return Err(Error::UnknownFormat { path: path.to_path_buf() });
        }
    };
    let mut run = RunFile::parse(&text, path)?;
    if !sets.is_empty() {
        run = RunFile::parse_with_sets(&text, sets).map_err(|problem| Error::Override { problem })?;
    }
    overrides(&mut run);
    // The run file's own values were checked as it was read; what fails now came with the overrides.
    run.check_settings().map_err(|problem| Error::Override { problem })?;
    let mut scene = match extension.as_deref() {
        Some("toml") => run.load_scene(path)?,
        _ => {
            let budget = run.memory_budget_bytes();
            let mut scene = self::gltf::load_gltf_within(path, run.camera.name.as_deref(), budget)?;
            // A bare glTF has no run file: environment paths come from the command line, relative
            // to the working directory.
            scene.environment = run.environment.load(Path::new(""), "the command line")?;
            scene
        }
    };
    validate(&mut scene, path)?;
    if let Some(animation) = &mut scene.animation {
        std::sync::Arc::make_mut(animation).resolve(&scene.meshes);
    }
    Ok((scene, run))
}

/// A whole scene, flattened to world space.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The file the scene was read from (for messages).
    pub source: PathBuf,
    /// Triangle meshes with node transforms applied.
    pub meshes: Vec<Mesh>,
    /// Analytic spheres (from run files).
    pub spheres: Vec<Sphere>,
    /// Materials referenced by index from meshes and spheres.
    pub materials: Vec<MaterialDesc>,
    /// Textures referenced from materials.
    pub textures: Vec<Texture>,
    /// The camera, if the file has one.
    pub camera: Option<CameraDesc>,
    /// Resolution suggested by the file (glTF `scenes[i].extras.width/height`).
    pub resolution: Option<(u32, u32)>,
    /// The environment light, if the run file or command line gives one.
    pub environment: Option<environment::EnvironmentDesc>,
    /// Point, spot and sun lights (KHR_lights_punctual, run files' `[[light]]`).
    pub punctual_lights: Vec<punctual::PunctualLightDesc>,
    /// The glTF file's animations, when it has some: what [`animation::Animation::pose`] moves.
    pub animation: Option<std::sync::Arc<animation::Animation>>,
}

/// A triangle mesh in world space.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// A name that identifies the object in messages: `node 'name' (#3) mesh 'name' (#1) primitive 0`.
    pub name: String,
    /// The glTF node this mesh instance came from (for motion in run files).
    pub node: Option<usize>,
    /// The glTF node's name, if any.
    pub node_name: Option<String>,
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// World-space unit normals per vertex; `None` means flat (geometric) normals.
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinate sets (TEXCOORD_0, TEXCOORD_1, ...), each one per vertex.
    pub uvs: Vec<Vec<Vec2>>,
    /// Per-vertex colour (COLOR_0, linear RGB) multiplying the base colour.
    pub colors: Option<Vec<Vec3>>,
    /// World-space unit tangents (TANGENT, or MikkTSpace's) with the bitangent sign in w, for normal
    /// maps.
    pub tangents: Option<Vec<Vec4>>,
    /// Triangles as vertex indices, counter-clockwise = front face (winding already fixed for
    /// negative-determinant transforms).
    pub indices: Vec<[u32; 3]>,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Displacement over the shutter interval (linear motion); `None` for static meshes.
    pub motion: Option<Vec3>,
}

/// An analytic sphere.
#[derive(Clone, Debug)]
pub struct Sphere {
    /// Name for messages.
    pub name: String,
    /// Centre at shutter open.
    pub center: Vec3,
    /// Radius (positive).
    pub radius: f32,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Displacement over the shutter interval.
    pub motion: Option<Vec3>,
}

/// A reference to a texture and the UV set it reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// Which TEXCOORD_n set.
    pub tex_coord: u32,
    /// KHR_texture_transform as a 2x3 affine map applied to uv (columns: x axis, y axis, offset).
    pub transform: Option<[Vec2; 3]>,
}

impl TextureRef {
    /// The texel at `uv` (of the set this reference reads), its transform applied.
    #[inline]
    pub fn lookup(&self, textures: &[Texture], uv: Vec2) -> Vec4 {
        textures[self.texture as usize].sample(self.transformed(uv))
    }

    /// Ask for the texels [`TextureRef::lookup`] will read at `uv` ([`Texture::prefetch`]).
    #[inline]
    pub fn prefetch(&self, textures: &[Texture], uv: Vec2) {
        textures[self.texture as usize].prefetch(self.transformed(uv));
    }

    /// `uv` through the reference's KHR_texture_transform.
    #[inline]
    fn transformed(&self, uv: Vec2) -> Vec2 {
        match self.transform {
            Some([x, y, o]) => x * uv.x + y * uv.y + o,
            None => uv,
        }
    }
}

/// A material as the file describes it (glTF metallic-roughness with extensions); the BSDF is built
/// from it at each hit after textures are looked up.
#[derive(Clone, Debug)]
pub struct MaterialDesc {
    /// Name for messages.
    pub name: String,
    /// The BSDF's factors: base colour, metallic, roughness, transmission, IOR, specular, clear coat
    /// and thickness. The textures below multiply some of them at a hit.
    pub shading: ShadingParams,
    /// sRGB base colour texture (decoded to linear at load), multiplying `shading.base_color`.
    pub base_color_texture: Option<TextureRef>,
    /// Linear texture: roughness in G, metallic in B, multiplying their factors.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Emitted radiance: emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    /// sRGB emissive texture multiplying `emission`.
    pub emissive_texture: Option<TextureRef>,
    /// Tangent-space normal map (linear).
    pub normal_texture: Option<TextureRef>,
    /// Scales the normal map's x and y (glTF `normalTexture.scale`).
    pub normal_scale: f32,
    /// Clearcoat texture: its red channel multiplies `shading.clearcoat`.
    pub clearcoat_texture: Option<TextureRef>,
    /// Clearcoat roughness texture: its green channel multiplies `shading.clearcoat_roughness`.
    pub clearcoat_roughness_texture: Option<TextureRef>,
    /// The coat's own tangent-space normal map, and its scale.
    pub clearcoat_normal_texture: Option<(TextureRef, f32)>,
    /// Absorption coefficient σa (1/m) inside a solid (`shading.thickness` > 0): −ln(attenuationColor) /
    /// attenuationDistance; zero for a clear one.
    pub attenuation: Vec3,
    /// glTF doubleSided.
    pub double_sided: bool,
    /// glTF alphaMode: opaque, cut out below a cutoff, or blended (stochastically).
    pub alpha_mode: AlphaMode,
    /// The base colour factor's alpha (times the base colour texture's where there is one).
    pub alpha: f32,
    /// KHR_materials_unlit: the surface shows its base colour whatever lights it, which a path tracer
    /// renders as emission of that colour with nothing reflected (`emission` and `emissive_texture`
    /// hold it, `shading` reflects nothing). Such emitters light what is near them, but do not count
    /// as the scene's own light when the default white environment is decided.
    pub unlit: bool,
}

/// KHR_materials_volume's absorption coefficient σa = −ln(color) / distance, per channel: zero for
/// an infinite distance or a white colour; a black channel absorbs everything within a micrometre.
pub fn absorption(color: Vec3, distance: f32) -> Vec3 {
    if !(distance.is_finite() && distance > 0.0) {
        return Vec3::ZERO;
    }
    -color.clamp(Vec3::splat(1e-6), Vec3::ONE).map(f32::ln) / distance
}

/// How a material's alpha shapes its surface (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    #[default]
    Opaque,
    /// Holes where alpha is below `cutoff`.
    Mask {
        /// glTF `alphaCutoff` (0.5 by default).
        cutoff: f32,
    },
    /// Partly transparent: a ray passes with probability 1 − alpha.
    Blend,
}

impl Default for MaterialDesc {
    /// The glTF 2.0 default material: white, metallic 1, roughness 1, no emission.
    fn default() -> Self {
        Self {
            name: "default".into(),
            shading: ShadingParams::default(),
            base_color_texture: None,
            metallic_roughness_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            attenuation: Vec3::ZERO,
            double_sided: false,
            alpha_mode: AlphaMode::Opaque,
            alpha: 1.0,
            unlit: false,
        }
    }
}

/// Texture wrap mode (glTF sampler).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    /// Tile.
    #[default]
    Repeat,
    /// Clamp to the edge texel.
    ClampToEdge,
    /// Tile, mirroring every other copy.
    MirroredRepeat,
}

/// A texture, row 0 at the top (uv (0,0) is the top-left corner, as in glTF), read as linear RGBA
/// floats ([`Texture::texel`]).
#[derive(Clone, Debug, Default)]
pub struct Texture {
    /// Name or URI for messages.
    pub name: String,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Linear RGBA texels, row-major: a float or 16-bit image's (empty for an 8-bit one's, whose
    /// texels are `bytes`).
    pub texels: Vec<Vec4>,
    /// An 8-bit image's RGBA texels as the file stores them, row-major, decoded when read: a
    /// quarter of the floats' memory, so a cache line holds sixteen texels, not four (a textured
    /// render waits on texel memory more than on anything else).
    pub bytes: Vec<[u8; 4]>,
    /// Whether the colour channels of `bytes` carry the sRGB curve (alpha never does).
    pub srgb: bool,
    /// Wrap mode along u.
    pub wrap_s: Wrap,
    /// Wrap mode along v.
    pub wrap_t: Wrap,
}

/// The linear value of each 8-bit channel value: `v / 255`.
static LINEAR8: std::sync::LazyLock<[f32; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|v| f32::from(v as u8) / 255.0));
/// The linear value of each 8-bit sRGB-encoded value.
static SRGB8: std::sync::LazyLock<[f32; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|v| gltf::srgb_to_linear(LINEAR8[v])));

impl Texture {
    /// Texels in all.
    #[inline]
    pub fn len(&self) -> usize {
        if self.bytes.is_empty() { self.texels.len() } else { self.bytes.len() }
    }

    /// Whether it has no texels.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Texel `i` (row-major) as linear RGBA.
    #[inline]
    pub fn texel(&self, i: usize) -> Vec4 {
        if self.bytes.is_empty() {
            return self.texels[i];
        }
        let [r, g, b, a] = self.bytes[i];
        let colour: &[f32; 256] = if self.srgb { &SRGB8 } else { &LINEAR8 };
        Vec4::new(colour[r as usize], colour[g as usize], colour[b as usize], LINEAR8[a as usize])
    }

    /// Every texel, row-major, as linear RGBA.
    pub fn texels(&self) -> impl Iterator<Item = Vec4> + '_ {
        (0..self.len()).map(|i| self.texel(i))
    }

    /// Bilinear lookup at `uv` with the texture's wrap modes.
    #[inline]
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let Some(Footprint { rows: (row0, row1), columns: (x0, x1), weights: (fx, fy) }) = self.footprint(uv)
        else {
            return Vec4::ONE;
        };
        let texel = |row: usize, column: usize| self.texel(row + column);
        let top = texel(row0, x0).lerp(texel(row0, x1), fx);
        let bottom = texel(row1, x0).lerp(texel(row1, x1), fx);
        top.lerp(bottom, fy)
    }

    /// Ask for the texels [`Texture::sample`] will read at `uv`: a lookup in a large texture waits
    /// on memory, and lanes ask for a group's texels before any of them is needed, so that the
    /// waits overlap.
    #[inline]
    pub fn prefetch(&self, uv: Vec2) {
        if let Some(Footprint { rows: (row0, row1), columns: (x0, _), .. }) = self.footprint(uv) {
            if self.bytes.is_empty() {
                crate::geometry::wide_bvh::prefetch_line(&self.texels[row0 + x0]);
                crate::geometry::wide_bvh::prefetch_line(&self.texels[row1 + x0]);
            } else {
                crate::geometry::wide_bvh::prefetch_line(&self.bytes[row0 + x0]);
                crate::geometry::wide_bvh::prefetch_line(&self.bytes[row1 + x0]);
            }
        }
    }

    /// The first texel of the two rows a lookup at `uv` reads, its two columns, and the weights
    /// between them; `None` for an empty texture.
    #[inline]
    fn footprint(&self, uv: Vec2) -> Option<Footprint> {
        if self.is_empty() {
            return None;
        }
        // An infinite or NaN coordinate (from broken UVs or transforms) has no position in the texture:
        // read it as 0 rather than interpolate with a NaN weight.
        let uv = Vec2::select(uv.is_finite_mask(), uv, Vec2::ZERO);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // Past ±2^40 texels a float has no sub-texel precision left; clamping there keeps the
        // neighbour's index (ix + 1) from overflowing for huge or infinite uv (NaN becomes 0).
        const FAR: f32 = (1u64 << 40) as f32;
        let (ix, iy) = (x0.clamp(-FAR, FAR) as i64, y0.clamp(-FAR, FAR) as i64);
        // Each of the four texels' columns and rows wrapped once: a wrap is an integer division
        // (most of a lookup when it was done per texel), and inside the texture none is needed.
        let columns = wrap_pair(ix, self.width, self.wrap_s);
        let (y0, y1) = wrap_pair(iy, self.height, self.wrap_t);
        Some(Footprint {
            rows: (y0 * self.width as usize, y1 * self.width as usize),
            columns,
            weights: (fx, fy),
        })
    }
}

/// The four texels a bilinear lookup reads: the first texel of its two rows, its two columns, and
/// the weights between them.
struct Footprint {
    rows: (usize, usize),
    columns: (usize, usize),
    weights: (f32, f32),
}

/// The wrapped indices of `i` and `i + 1` along an axis of `n` texels.
#[inline]
fn wrap_pair(i: i64, n: u32, wrap: Wrap) -> (usize, usize) {
    if i >= 0 && i + 1 < n as i64 {
        (i as usize, i as usize + 1)
    } else {
        (wrap_index(i, n, wrap), wrap_index(i + 1, n, wrap))
    }
}

fn wrap_index(i: i64, n: u32, wrap: Wrap) -> usize {
    let n = n as i64;
    let r = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    r as usize
}

/// A perspective camera from the file.
#[derive(Clone, Debug)]
pub struct CameraDesc {
    /// Name for messages and selection.
    pub name: String,
    /// Camera-to-world transform (the camera looks down its local -Z, +Y up).
    pub camera_to_world: Mat4,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Aspect ratio width/height, if the file gives one.
    pub aspect_ratio: Option<f32>,
}
