//! The scene as the integrators see it: the BVHs, the lights with their selection, and the
//! materials and textures, with the one place where a hit's material becomes BSDF parameters.

use crate::geometry::{Geometry, SurfaceHit};
use crate::kernel::lanes::LaneMaterials;
use crate::lights::{LightShape, Lights};
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
    /// Which lanes shade each material (`kernel::lanes`).
    pub lanes: LaneMaterials,
}

/// How the BVHs follow meshes that moved between frames ([`RenderScene::update`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhUpdate {
    /// The meshes frames move are in a set of their own, rebuilt alone; the static set's tree is
    /// kept (the default: the cheapest, and the trees stay as good as built).
    #[default]
    TwoLevel,
    /// One set; the moved triangles written into it and every box refit, the tree's shape kept.
    Refit,
    /// One set, built anew.
    Rebuild,
}

impl BvhUpdate {
    /// The meshes that go to the dynamic set, of those a frame can move.
    pub fn partition(self, dynamic: &[bool]) -> &[bool] {
        if self == Self::TwoLevel { dynamic } else { &[] }
    }
}

/// What following a frame cost ([`RenderScene::update`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneUpdate {
    /// Seconds spent on the BVHs.
    pub geometry_seconds: f64,
    /// Seconds spent on the lights and their selection.
    pub lights_seconds: f64,
    /// Whether every BVH was built anew (not only the dynamic set's).
    pub whole_build: bool,
}

impl RenderScene {
    /// BVHs, lights and materials of `scene`: also what a host that moves objects between frames
    /// rebuilds after editing its `Scene`.
    pub fn build(scene: &Scene, light_selection: LightSelection) -> Self {
        Self::build_dynamic(scene, light_selection, &[])
    }

    /// As [`RenderScene::build`], the meshes `dynamic` marks in the geometry's dynamic set.
    pub fn build_dynamic(scene: &Scene, light_selection: LightSelection, dynamic: &[bool]) -> Self {
        let mut geometry = Geometry::build_dynamic(scene, dynamic);
        let lights = scene_lights(&mut geometry, scene, light_selection);
        let lanes = LaneMaterials::new(&scene.materials);
        Self { geometry, lights, materials: scene.materials.clone(), textures: scene.textures.clone(), lanes }
    }

    /// As [`RenderScene::build`], taking the materials and textures instead of copying them.
    pub fn from_scene(scene: Scene, light_selection: LightSelection) -> Self {
        Self::from_scene_dynamic(scene, light_selection, &[])
    }

    /// As [`RenderScene::from_scene`], the meshes `dynamic` marks in the geometry's dynamic set.
    pub fn from_scene_dynamic(mut scene: Scene, light_selection: LightSelection, dynamic: &[bool]) -> Self {
        let mut geometry = Geometry::build_dynamic(&scene, dynamic);
        let lights = scene_lights(&mut geometry, &scene, light_selection);
        let (materials, textures) =
            (std::mem::take(&mut scene.materials), std::mem::take(&mut scene.textures));
        let lanes = LaneMaterials::new(&materials);
        Self { geometry, lights, materials, textures, lanes }
    }

    /// Follow a frame of `scene` (the scene this was built from, its meshes `changed` moved, its
    /// lights maybe too): the geometry's dynamic set rebuilt alone when it can stand for a whole build,
    /// else all of it with the meshes `dynamic` marks in that set; the lights and their selection
    /// anew (emitters may have moved). Where the time went.
    pub fn update(
        &mut self,
        scene: &Scene,
        changed: &[usize],
        dynamic: &[bool],
        light_selection: LightSelection,
        how: BvhUpdate,
    ) -> SceneUpdate {
        let start = std::time::Instant::now();
        let kept = match how {
            BvhUpdate::TwoLevel => self.geometry.update_dynamic(scene, changed),
            BvhUpdate::Refit => self.geometry.refit(scene, changed),
            BvhUpdate::Rebuild => false,
        };
        if !kept {
            self.geometry = Geometry::build_dynamic(scene, how.partition(dynamic));
        }
        let geometry_seconds = start.elapsed().as_secs_f64();
        let start = std::time::Instant::now();
        // The white environment stands in for the lights of a scene that has none; a frame whose
        // emitters are gone (scaled to nothing, moved away) is dark, not lit by it.
        let lit_by_stand_in = scene.environment.is_none() && self.lights.environment.is_some();
        self.lights = if lit_by_stand_in {
            lights_of(&mut self.geometry, scene, light_selection, false)
        } else {
            own_lights(&mut self.geometry, scene, light_selection)
        };
        SceneUpdate { geometry_seconds, lights_seconds: start.elapsed().as_secs_f64(), whole_build: !kept }
    }

    /// Ask for the texels that [`RenderScene::shading_params`] and
    /// [`RenderScene::shading_normal`] will read at a hit, ahead of the lookups.
    #[inline]
    pub fn prefetch_textures(&self, hit: &SurfaceHit) {
        let m = &self.materials[hit.material as usize];
        let textures = [&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture];
        for t in textures.into_iter().flatten() {
            t.prefetch(&self.textures, hit.uv[(t.tex_coord as usize).min(1)]);
        }
    }

    /// Resolve the material at a hit: textures looked up, vertex colour applied.
    #[inline]
    pub fn shading_params(&self, hit: &SurfaceHit) -> ShadingParams {
        let m = &self.materials[hit.material as usize];
        let lookup = |t: &TextureRef| t.lookup(&self.textures, hit.uv[(t.tex_coord as usize).min(1)]);
        let mut params = m.shading;
        params.base_color *= hit.color;
        if let Some(t) = &m.base_color_texture {
            params.base_color *= lookup(t).truncate();
        }
        if let Some(t) = &m.metallic_roughness_texture {
            let texel = lookup(t);
            params.roughness *= texel.y;
            params.metallic *= texel.z;
        }
        if let Some(t) = &m.clearcoat_texture {
            params.clearcoat *= lookup(t).x;
        }
        if let Some(t) = &m.clearcoat_roughness_texture {
            params.clearcoat_roughness *= lookup(t).y;
        }
        params
    }

    /// The shading normal at a hit seen from `wo` (unit, towards where the ray came from): the
    /// interpolated normal perturbed by the material's normal map (glTF's tangent space: the
    /// bitangent is n × t · w), bent back towards the interpolated normal where the map would
    /// mirror `wo` below the surface: the black spots of normal maps, removed as Cycles does, by
    /// the smallest bend (found by bisection) that keeps the mirror direction above it.
    #[inline]
    pub fn shading_normal(&self, hit: &SurfaceHit, wo: Vec3) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        match &m.normal_texture {
            Some(map) => self.mapped_normal(hit, map, m.normal_scale, wo),
            None => hit.ns,
        }
    }

    /// The clear coat's own shading normal at a hit (its `clearcoatNormalTexture`), if it has one.
    #[inline]
    pub fn coat_normal(&self, hit: &SurfaceHit, wo: Vec3) -> Option<Vec3> {
        let m = &self.materials[hit.material as usize];
        let (map, scale) = m.clearcoat_normal_texture.as_ref()?;
        (m.shading.clearcoat > 0.0).then(|| self.mapped_normal(hit, map, *scale, wo))
    }

    /// The interpolated normal perturbed by tangent-space normal map `map` (x and y scaled by `scale`).
    fn mapped_normal(&self, hit: &SurfaceHit, map: &TextureRef, scale: f32, wo: Vec3) -> Vec3 {
        let tangent = hit.tangent.truncate();
        let n = hit.ns;
        let t = (tangent - n * n.dot(tangent)).normalize_or_zero();
        if t == Vec3::ZERO {
            return n;
        }
        let b = n.cross(t) * if hit.tangent.w < 0.0 { -1.0 } else { 1.0 };
        let texel = map.lookup(&self.textures, hit.uv[(map.tex_coord as usize).min(1)]).truncate();
        let local = (texel * 2.0 - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
        let mapped = (t * local.x + b * local.y + n * local.z).normalize_or_zero();
        if mapped == Vec3::ZERO {
            return n;
        }
        keep_mirror_above(mapped, n, hit.ng, wo)
    }

    /// The radiance a surface emits at a hit: the material's emission times its emissive texture.
    #[inline]
    pub fn emission(&self, hit: &SurfaceHit) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        match &m.emissive_texture {
            Some(t) => {
                m.emission * t.lookup(&self.textures, hit.uv[(t.tex_coord as usize).min(1)]).truncate()
            }
            None => m.emission,
        }
    }

    /// What light `index`'s emissive texture multiplies its radiance by at point `p` (time `time`):
    /// one for lights without a texture. Light sampling and photon emission pick points on a
    /// triangle uniformly and weigh them by this, so a textured light stays unbiased.
    #[inline]
    pub fn emissive_texel(&self, index: u32, p: Vec3, time: f32) -> Vec3 {
        let Some(light) = self.lights.lights.get(index as usize) else { return Vec3::ONE };
        let (Some(t), LightShape::Triangle { p: v, .. }) = (&light.texture, light.shape) else {
            return Vec3::ONE;
        };
        let b = barycentric(p - light.motion * time, v);
        t.texture.lookup(&self.textures, b.x * t.uv[0] + b.y * t.uv[1] + b.z * t.uv[2]).truncate()
    }

    /// Whether `material` bounds a volume a refracted ray is inside of (a transmissive solid, not a
    /// thin-walled sheet).
    #[inline]
    pub fn is_volume(&self, material: u32) -> bool {
        let m = &self.materials[material as usize];
        m.shading.thickness > 0.0 && m.shading.transmission > 0.0
    }

    /// Whether any material is a pure delta (mirror, smooth glass): only then can caustics form.
    pub fn has_specular(&self) -> bool {
        self.specular_materials().next().is_some()
    }

    /// The materials that are pure deltas (mirrors, smooth glass), by name.
    pub fn specular_materials(&self) -> impl Iterator<Item = &str> {
        self.materials.iter().filter(|m| Bsdf::new(&m.shading).is_delta()).map(|m| m.name.as_str())
    }

    /// Total surface area of the primitives (for the initial-radius heuristic of progressive photon
    /// mapping); primitives whose area is not finite are left out.
    pub fn surface_area(&self) -> f32 {
        self.geometry.primitives().map(|(_, shape, _, _)| shape.area()).filter(|a| a.is_finite()).sum()
    }
}

/// `mapped`, or the least bend of it towards `fallback` for which `wo` mirrors to a direction above
/// the geometric surface (on `wo`'s side of `ng`) and `wo` is in front of the normal.
fn keep_mirror_above(mapped: Vec3, fallback: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
    let valid = |c: Vec3| {
        let c = c * side;
        let cos_o = c.dot(wo);
        cos_o > 0.0 && (2.0 * cos_o * c - wo).dot(ng * side) > 1e-4
    };
    if valid(mapped) || !valid(fallback) {
        // A fallback that fails too is the interpolated normal's own, left as it always was.
        return if valid(mapped) { mapped } else { fallback };
    }
    let blend = |s: f32| mapped.lerp(fallback, s).normalize();
    let (mut fails, mut holds) = (0.0f32, 1.0f32);
    for _ in 0..10 {
        let mid = 0.5 * (fails + holds);
        if valid(blend(mid)) {
            holds = mid;
        } else {
            fails = mid;
        }
    }
    blend(holds)
}

/// Barycentric coordinates of `p` in triangle `v` (p on its plane).
fn barycentric(p: Vec3, v: [Vec3; 3]) -> Vec3 {
    let (e1, e2, d) = (v[1] - v[0], v[2] - v[0], p - v[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det <= 0.0 || det.is_nan() {
        return Vec3::new(1.0, 0.0, 0.0);
    }
    let b1 = ((d22 * d1 - d12 * d2) / det).clamp(0.0, 1.0);
    let b2 = ((d11 * d2 - d12 * d1) / det).clamp(0.0, 1.0 - b1);
    Vec3::new(1.0 - b1 - b2, b1, b2)
}

/// The lights of `scene` over its built `geometry`. A scene with no emitter and no environment is lit
/// by a uniform white environment (radiance 1), as glTF viewers light files made for them, with a
/// warning: a black image helps nobody.
pub fn scene_lights(geometry: &mut Geometry, scene: &Scene, light_selection: LightSelection) -> Lights {
    lights_of(geometry, scene, light_selection, true)
}

/// [`scene_lights`], warning of the white environment only when `warn` (once a render, not a frame).
fn lights_of(geometry: &mut Geometry, scene: &Scene, light_selection: LightSelection, warn: bool) -> Lights {
    let lights = own_lights(geometry, scene, light_selection);
    // Unlit surfaces (KHR_materials_unlit) emit only to show their colour: not the scene's light.
    let lit = scene.environment.is_some()
        || !scene.punctual_lights.is_empty()
        || scene.materials.iter().any(|m| !m.unlit && m.emission.max_element() > 0.0);
    if !lights.is_empty() && lit {
        if warn && scene.environment.is_none() && scene.punctual_lights.is_empty() {
            warn_if_emission_is_weak(geometry, scene, &lights);
        }
        return lights;
    }
    if warn {
        let unlit = if lights.is_empty() { "" } else { " (only unlit surfaces, which show their colour)" };
        tracing::warn!(
            "{}: no emitters{unlit} and no environment: lighting the scene with a uniform white \
             environment (radiance 1); choose one with [environment] or --environment / --environment-color",
            scene.source.display()
        );
    }
    let white = EnvironmentDesc::constant(Vec3::ONE);
    Lights::build(
        geometry,
        &scene.materials,
        &scene.textures,
        Some(&white),
        &scene.punctual_lights,
        light_selection,
    )
}

/// Emitters whose power is below this share of what the default white environment (radiance 1)
/// sends through the scene's bounds light it too weakly to be seen: a file made for a viewer,
/// whose emissive marks stand out on lit surfaces there and light nothing here.
const WEAK_EMISSION: f64 = 1e-3;

/// A scene lit by its emitters alone (no environment, no punctual light) keeps them as its light,
/// and the white environment is not added (the rule above); where a file opened alone (not a run
/// file) has emitters far too weak for its size, the render is black but for them: say so, and how
/// to light it.
fn warn_if_emission_is_weak(geometry: &Geometry, scene: &Scene, lights: &Lights) {
    // A run file's author chose its light (and its huge floor spheres stretch the bounds): the
    // warning is for a file made for a viewer, opened alone.
    if scene.source.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
        return;
    }
    let power: f64 = lights.lights.iter().map(|l| l.power() as f64).sum();
    let (min, max) = geometry.bounds();
    let radius = 0.5 * (max - min).length() as f64;
    // A radiance-1 environment's power through the bounding sphere: π (irradiance) × 4πr².
    let environment = 4.0 * std::f64::consts::PI * std::f64::consts::PI * radius * radius;
    if !(environment > 0.0 && power.is_finite()) || power >= WEAK_EMISSION * environment {
        return;
    }
    tracing::warn!(
        "{}: the scene's only light is its emissive surfaces, {:.2e} of the power a white environment \
         would give it: expect a black image but for them. Add light with --environment-color 1,1,1 \
         (or [environment]), or raise their emission (KHR_materials_emissive_strength)",
        scene.source.display(),
        power / environment
    );
}

/// The scene's own emitters, punctual lights and environment, and nothing in their place.
fn own_lights(geometry: &mut Geometry, scene: &Scene, light_selection: LightSelection) -> Lights {
    Lights::build(
        geometry,
        &scene.materials,
        &scene.textures,
        scene.environment.as_ref(),
        &scene.punctual_lights,
        light_selection,
    )
}

#[cfg(test)]
mod tests {
    use super::keep_mirror_above;
    use crate::sampling::Sampler;
    use crate::sampling::warp::uniform_sphere;
    use glam::Vec3;

    /// Whatever a normal map asks for, the bent normal faces the view and mirrors it above the
    /// surface; a mapped normal that already does is kept, and a bent one stays in the plane of the
    /// mapped and the interpolated normal (the least bend, not an arbitrary one).
    #[test]
    fn a_bent_normal_mirrors_the_view_above_the_surface() {
        let ng = Vec3::Y;
        let mut bent = 0;
        for i in 0..20_000 {
            let s = Sampler::new(11, i, 0);
            let mapped = (uniform_sphere(s.get2d(0)) + Vec3::Y * 0.3).normalize();
            let mapped = if mapped.y < 0.0 { mapped * Vec3::new(1.0, -1.0, 1.0) } else { mapped };
            let mut wo = uniform_sphere(s.get2d(2));
            wo.y = wo.y.abs().max(0.01);
            let wo = wo.normalize();
            let n = keep_mirror_above(mapped, ng, ng, wo);
            let cos_o = n.dot(wo);
            assert!(cos_o > 0.0 && (2.0 * cos_o * n - wo).dot(ng) > 0.0, "{mapped} {wo} -> {n}");
            if n != mapped {
                bent += 1;
                assert!(n.dot(mapped.cross(ng)).abs() < 1e-4, "left the plane: {mapped} {wo} -> {n}");
            }
        }
        // Steep maps seen at random angles: a fair share needs the bend, most do not.
        assert!(bent > 500 && bent < 15_000, "{bent} of 20000 bent");
    }
}
