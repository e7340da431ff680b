//! The scene as the integrators see it: the BVHs, the lights with their selection, and the
//! materials and textures, with the one place where a hit's material becomes BSDF parameters.

use crate::geometry::bvh::PrimitiveShape;
use crate::geometry::{Geometry, SurfaceHit};
use crate::lights::Lights;
use crate::materials::{Bsdf, ShadingParams};
use crate::scene::environment::EnvironmentDesc;
use crate::scene::{LightSelection, MaterialDesc, Scene, Texture, TextureRef};
use glam::Vec3;

/// Primitives and their BVHs, emitters and light selection, materials and textures.
#[derive(Clone, Debug)]
pub struct RenderScene {
    /// Primitives and their BVHs.
    pub geometry: Geometry,
    /// Emitters and light selection.
    pub lights: Lights,
    /// Materials by index.
    pub materials: Vec<MaterialDesc>,
    /// Textures by index.
    pub textures: Vec<Texture>,
}

impl RenderScene {
    /// BVHs, lights and materials of `scene`: also what a host that moves objects between frames
    /// rebuilds after editing its `Scene`.
    pub fn build(scene: &Scene, light_selection: LightSelection) -> Self {
        let mut geometry = Geometry::build(scene);
        let lights = scene_lights(&mut geometry, scene, light_selection);
        Self { geometry, lights, materials: scene.materials.clone(), textures: scene.textures.clone() }
    }

    /// As [`RenderScene::build`], taking the materials and textures instead of copying them.
    pub fn from_scene(mut scene: Scene, light_selection: LightSelection) -> Self {
        let mut geometry = Geometry::build(&scene);
        let lights = scene_lights(&mut geometry, &scene, light_selection);
        let (materials, textures) =
            (std::mem::take(&mut scene.materials), std::mem::take(&mut scene.textures));
        Self { geometry, lights, materials, textures }
    }

    /// Resolve the material at a hit: textures looked up, vertex colour applied.
    #[inline]
    pub fn shading_params(&self, hit: &SurfaceHit) -> ShadingParams {
        let m = &self.materials[hit.material as usize];
        let lookup = |t: &TextureRef| {
            let mut uv = hit.uv[(t.tex_coord as usize).min(1)];
            if let Some([x, y, o]) = t.transform {
                uv = x * uv.x + y * uv.y + o;
            }
            self.textures[t.texture as usize].sample(uv)
        };
        let mut base_color = m.base_color * hit.color;
        if let Some(t) = &m.base_color_texture {
            base_color *= lookup(t).truncate();
        }
        let (mut metallic, mut roughness) = (m.metallic, m.roughness);
        if let Some(t) = &m.metallic_roughness_texture {
            let texel = lookup(t);
            roughness *= texel.y;
            metallic *= texel.z;
        }
        m.shading_params(base_color, metallic, roughness)
    }

    /// Whether any material is a pure delta (mirror, smooth glass): only then can caustics form.
    pub fn has_specular(&self) -> bool {
        self.materials
            .iter()
            .any(|m| Bsdf::new(&m.shading_params(m.base_color, m.metallic, m.roughness)).is_delta())
    }

    /// Total surface area of the primitives (for the initial-radius heuristic of progressive photon
    /// mapping); primitives whose area is not finite are left out.
    pub fn surface_area(&self) -> f32 {
        self.geometry
            .primitives()
            .map(|(_, shape, _, _)| match shape {
                PrimitiveShape::Triangle(t) => 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length(),
                PrimitiveShape::Sphere(_, radius) => 4.0 * std::f32::consts::PI * radius * radius,
            })
            .filter(|a| a.is_finite())
            .sum()
    }
}

/// The lights of `scene` over its built `geometry`. A scene with no emitter and no environment is lit
/// by a uniform white environment (radiance 1), as glTF viewers light files made for them, with a
/// warning: a black image helps nobody.
pub fn scene_lights(geometry: &mut Geometry, scene: &Scene, light_selection: LightSelection) -> Lights {
    let lights = Lights::build(
        geometry,
        &scene.materials,
        scene.environment.as_ref(),
        &scene.punctual_lights,
        light_selection,
    );
    if !lights.is_empty() {
        return lights;
    }
    tracing::warn!(
        "{}: no emitters and no environment: lighting the scene with a uniform white environment \
         (radiance 1); choose one with [environment] or --environment / --environment-color",
        scene.source.display()
    );
    let white = EnvironmentDesc::constant(Vec3::ONE);
    Lights::build(geometry, &scene.materials, Some(&white), &scene.punctual_lights, light_selection)
}
