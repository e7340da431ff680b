//! Which lanes shade a vertex: its class, decided once per hit from the material's id (a table made
//! once per scene), not by testing what each vertex would need.

use super::super::{CameraPath, PathLimits};
use crate::geometry::bvh::{Hit, NO_LIGHT};
use crate::render_scene::RenderScene;
use crate::scene::MaterialDesc;
use glam::Vec3;

/// The kind of vertex a group of lanes shades together.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaneClass {
    /// Lambert's BSDF (glTF's dielectric base without its specular layer), textured or not.
    Lambert,
    /// glTF's metallic-roughness mixture without transmission or coat: a rough GGX conductor beside
    /// GGX specular over a Fresnel-coupled Lambertian, textured or not.
    MetalRough,
    /// [`LaneClass::Lambert`] under a rough clear coat (KHR_materials_clearcoat).
    LambertCoated,
    /// [`LaneClass::MetalRough`] under a rough clear coat.
    MetalRoughCoated,
    /// What the lanes leave to the scalar kernel: misses, emitters, spheres, moving or vertex-coloured
    /// triangles, paths inside a medium or at their last depth, and materials no lane class holds
    /// (transmission, a coat with a normal map of its own, volumes).
    Scalar,
}

/// The lane classes there are, the scalar kernel's last.
pub const CLASSES: usize = 5;

impl LaneClass {
    /// Every class, in index order.
    pub const ALL: [LaneClass; CLASSES] =
        [Self::Lambert, Self::MetalRough, Self::LambertCoated, Self::MetalRoughCoated, Self::Scalar];

    /// Its index among [`CLASSES`].
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    /// What the profile calls it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Lambert => "lambert",
            Self::MetalRough => "metal-rough",
            Self::LambertCoated => "lambert-coated",
            Self::MetalRoughCoated => "metal-rough-coated",
            Self::Scalar => "scalar",
        }
    }
}

/// What lanes know of each material: its class, whether its hits look textures up, and the albedo
/// of an untextured Lambertian.
#[derive(Clone, Debug, Default)]
pub struct LaneMaterials {
    class: Vec<LaneClass>,
    textured: Vec<bool>,
    albedo: Vec<Vec3>,
}

impl LaneMaterials {
    /// The classes of `materials`.
    pub fn new(materials: &[MaterialDesc]) -> Self {
        let mut lanes = Self::default();
        for m in materials {
            lanes.class.push(class_of(m));
            lanes.textured.push(is_textured(m));
            lanes.albedo.push(m.shading.base_color.max(Vec3::ZERO).min(Vec3::ONE));
        }
        lanes
    }

    /// The class of material `material`.
    #[inline]
    pub fn class(&self, material: u32) -> LaneClass {
        self.class.get(material as usize).copied().unwrap_or(LaneClass::Scalar)
    }

    /// Whether material `material`'s hits look textures up (its parameters or normal vary).
    #[inline]
    pub fn textured(&self, material: u32) -> bool {
        self.textured[material as usize]
    }

    /// The albedo of untextured Lambertian material `material` (`Bsdf::new`'s).
    #[inline]
    pub fn albedo(&self, material: u32) -> Vec3 {
        self.albedo[material as usize]
    }
}

/// Whether a material's hits read any texture that shading uses (the emissive one is the lights').
fn is_textured(m: &MaterialDesc) -> bool {
    m.base_color_texture.is_some()
        || m.metallic_roughness_texture.is_some()
        || m.normal_texture.is_some()
        || m.clearcoat_texture.is_some()
        || m.clearcoat_roughness_texture.is_some()
        || m.clearcoat_normal_texture.is_some()
}

/// A material's class. Textures only multiply factors, so a zero factor stays zero at every hit:
/// metallic, specular, transmission and clear coat all zero is Lambert's BSDF everywhere;
/// transmission and coat zero with metallic or specular not is the metallic-roughness mixture
/// (whose lanes hand back to the scalar kernel a hit whose textures make it Lambertian or mirror
/// smooth); a coat makes either the coated class (whose lanes hand back a hit whose texture takes
/// the coat away or makes it mirror smooth).
fn class_of(m: &MaterialDesc) -> LaneClass {
    let s = &m.shading;
    let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let (metallic, transmission, specular) = (unit(s.metallic), unit(s.transmission), unit(s.specular));
    if transmission > 0.0 || (unit(s.clearcoat) > 0.0 && m.clearcoat_normal_texture.is_some()) {
        return LaneClass::Scalar;
    }
    let lambert = metallic == 0.0 && specular == 0.0;
    match (unit(s.clearcoat) > 0.0, lambert) {
        (false, true) => LaneClass::Lambert,
        (false, false) => LaneClass::MetalRough,
        (true, true) => LaneClass::LambertCoated,
        (true, false) => LaneClass::MetalRoughCoated,
    }
}

/// The albedo of a material whose every hit is a plain Lambertian without textures.
pub fn plain_lambert(m: &MaterialDesc) -> Option<Vec3> {
    (class_of(m) == LaneClass::Lambert && !is_textured(m))
        .then(|| m.shading.base_color.max(Vec3::ZERO).min(Vec3::ONE))
}

/// The class of the vertex where `hit` lands for a camera path in state `path`: a plain triangle
/// (not a sphere, not moving, without vertex colours) that does not emit, reached in air before the
/// path's last depth, takes its material's class; everything else the scalar kernel's.
#[inline]
pub fn classify(scene: &RenderScene, limits: PathLimits, hit: &Hit, path: &CameraPath) -> LaneClass {
    if !hit.is_hit() || path.depth >= limits.max_depth || path.media.current().is_some() {
        return LaneClass::Scalar;
    }
    match scene.geometry.lane_material(hit.prim) {
        Some((material, NO_LIGHT)) => scene.lanes.class(material),
        _ => LaneClass::Scalar,
    }
}
