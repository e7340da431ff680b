//! Load-time checks, so that the systems downstream can take the scene as valid: user errors become
//! [`Error::InvalidScene`], harmless defects (degenerate triangles, empty meshes) are dropped with one warning each.

use super::punctual::PunctualKind;
use super::{MaterialDesc, Mesh, Scene, TextureRef};
use crate::error::{Error, Result};
use glam::{Vec2, Vec3};
use std::path::Path;
use tracing::{info, warn};

/// What validation kept and dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ValidationSummary {
    /// Meshes kept.
    pub meshes: usize,
    /// Triangles kept.
    pub triangles: usize,
    /// Zero-area or non-finite triangles dropped (emitting ones included).
    pub degenerate_triangles: usize,
    /// Of the dropped triangles, those whose material emits.
    pub degenerate_emitter_triangles: usize,
    /// Meshes removed because no triangle was left.
    pub removed_meshes: usize,
    /// Kept triangles whose material emits.
    pub emitter_triangles: usize,
    /// Spheres whose material emits.
    pub emitter_spheres: usize,
}

/// Largest coordinate a scene may reach, in metres: beyond it f32 positions are coarser than 6 cm
/// and the BVH's quantised child boxes no longer nest in their parents (obvhs's validation fails).
pub const MAX_COORDINATE: f32 = 1e6;

/// Largest radiance an emitter or the environment may have, W/(sr·m²) per channel. The sun's is
/// about 2·10⁷; a path's contribution multiplies radiance by throughputs and divides it by pdfs,
/// and lights' powers are summed, all in f32 (up to 3.4·10³⁸): 10²⁰ leaves 10¹⁸ of headroom, so
/// nothing that loads can overflow into an infinite or NaN image.
pub const MAX_RADIANCE: f32 = 1e20;

/// Largest total power of the emitters, W (the sum light selection and photon emission divide by).
pub const MAX_POWER: f64 = 1e30;

/// Checks `scene` (read from `path`) and drops degenerate triangles and empty meshes. A scene that
/// emits nothing is not an error: `systems::resources::scene_lights` lights it with a default
/// environment when it is built.
///
/// Messages about meshes and their materials name `scene.source` (the glTF), others name `path`.
pub fn validate(scene: &mut Scene, path: &Path) -> Result<ValidationSummary> {
    let mesh_file = if scene.source.as_os_str().is_empty() { path } else { scene.source.as_path() };
    let invalid = |file: &Path, object: &str, problem: String| Error::InvalidScene {
        path: file.to_path_buf(),
        object: object.to_owned(),
        problem,
    };

    for light in &scene.punctual_lights {
        if let Some(problem) = light.problem() {
            return Err(invalid(path, &light.name, problem));
        }
        let brightest = light.radiometric().max_element();
        if brightest > MAX_RADIANCE {
            return Err(invalid(
                path,
                &light.name,
                format!(
                    "intensity {} ({brightest:e} W/sr or W/m²) is above {MAX_RADIANCE:e}, the most Caustica accepts",
                    light.intensity
                ),
            ));
        }
    }

    // Check spheres first: a bad radius also makes a bad thickness of its material
    for s in &scene.spheres {
        let object = format!("sphere '{}'", s.name);
        if !(s.radius > 0.0 && s.radius.is_finite()) {
            return Err(invalid(
                path,
                &object,
                format!("radius is {}, must be positive and finite", s.radius),
            ));
        }
        if !s.center.is_finite() || !s.motion.unwrap_or_default().is_finite() {
            return Err(invalid(path, &object, "centre or motion is not finite".to_owned()));
        }
        let reach =
            s.center.abs().max_element() + s.radius + s.motion.unwrap_or_default().abs().max_element();
        if reach > MAX_COORDINATE {
            return Err(invalid(
                path,
                &object,
                format!(
                    "reaches {reach} m from the origin, beyond the ±{MAX_COORDINATE} m f32 geometry supports"
                ),
            ));
        }
        if s.material as usize >= scene.materials.len() {
            return Err(invalid(path, &object, format!("material index {} out of range", s.material)));
        }
    }

    // Check materials and textures
    let mut used_by_sphere = vec![false; scene.materials.len()];
    for s in &scene.spheres {
        if let Some(used) = used_by_sphere.get_mut(s.material as usize) {
            *used = true;
        }
    }
    for (i, texture) in scene.textures.iter().enumerate() {
        if texture.width == 0
            || texture.height == 0
            || texture.len() != texture.width as usize * texture.height as usize
            || !(texture.texels.is_empty() || texture.bytes.is_empty())
        {
            let problem = format!("has {} texels for {}x{}", texture.len(), texture.width, texture.height);
            return Err(invalid(mesh_file, &format!("texture '{}' (#{i})", texture.name), problem));
        }
    }
    for (i, m) in scene.materials.iter().enumerate() {
        let file = if used_by_sphere[i] { path } else { mesh_file };
        check_material(m, scene.textures.len())
            .map_err(|problem| invalid(file, &format!("material '{}' (#{i})", m.name), problem))?;
    }
    let emits = |material: u32| {
        scene.materials.get(material as usize).is_some_and(|m| m.emission.max_element() > 0.0)
    };
    let mut summary = ValidationSummary {
        emitter_spheres: scene.spheres.iter().filter(|s| emits(s.material)).count(),
        ..ValidationSummary::default()
    };

    // Check meshes and drop degenerate triangles; one warning for each kind of defect, however many
    // meshes have it (a file of 98 meshes each with two degenerate triangles said so 98 times).
    let (mut degenerate, mut zero_area_emitters) = (Defects::default(), Defects::default());
    let mut empty = Vec::new();
    for mesh in &mut scene.meshes {
        check_mesh(mesh, &scene.materials, mesh_file)
            .map_err(|problem| invalid(mesh_file, &mesh.name, problem))?;
        let emitter = emits(mesh.material);
        let before = mesh.indices.len();
        let dropped = drop_degenerate_triangles(mesh);
        if dropped > 0 {
            let defects = if emitter { &mut zero_area_emitters } else { &mut degenerate };
            defects.add(&mesh.name, dropped, mesh.indices.is_empty());
        } else if before == 0 {
            empty.push(mesh.name.clone());
        }
        summary.degenerate_triangles += dropped;
        if emitter {
            summary.degenerate_emitter_triangles += dropped;
            summary.emitter_triangles += mesh.indices.len();
        }
    }
    degenerate.warn(mesh_file, "degenerate triangle(s)", "zero area or not finite");
    zero_area_emitters.warn(mesh_file, "zero-area emitting triangle(s)", "they would be lights of no area");
    match empty.as_slice() {
        [] => {}
        [mesh] => warn!(file = %mesh_file.display(), "{mesh}: has no triangles, removed"),
        meshes => warn!(
            file = %mesh_file.display(),
            "{} meshes have no triangles, removed: {}",
            meshes.len(),
            first_few(meshes.iter().cloned(), meshes.len())
        ),
    }
    check_emitted_power(scene).map_err(|(object, problem)| invalid(mesh_file, &object, problem))?;
    if let Some(environment) = &scene.environment {
        let brightest = environment.max_radiance();
        if brightest.is_nan() || brightest > MAX_RADIANCE as f64 {
            let object = format!("environment '{}'", environment.name);
            return Err(invalid(
                path,
                &object,
                format!(
                    "radiance up to {brightest:.3e} (with its strength), above {MAX_RADIANCE:e} W/(sr·m²), the \
                     most Caustica accepts: scale the map or its strength down"
                ),
            ));
        }
    }
    let before = scene.meshes.len();
    // A mesh an animation poses stays, empty or not: a frame can give it its triangles back.
    let posed: std::collections::HashSet<&str> =
        scene.animation.iter().flat_map(|a| a.meshes.iter().map(|m| m.local.name.as_str())).collect();
    scene.meshes.retain(|m| !m.indices.is_empty() || posed.contains(m.name.as_str()));
    summary.removed_meshes = before - scene.meshes.len();
    summary.meshes = scene.meshes.len();
    summary.triangles = scene.meshes.iter().map(|m| m.indices.len()).sum();

    // Check camera and film
    if let Some(camera) = &scene.camera {
        let object = format!("camera '{}'", camera.name);
        if !(camera.yfov > 0.0 && camera.yfov < std::f32::consts::PI) {
            return Err(invalid(
                mesh_file,
                &object,
                format!("yfov is {} rad, must be in (0, π)", camera.yfov),
            ));
        }
        if camera.aspect_ratio.is_some_and(|a| !(a > 0.0 && a.is_finite())) {
            return Err(invalid(mesh_file, &object, "aspectRatio must be positive and finite".to_owned()));
        }
        if !camera.camera_to_world.is_finite() {
            return Err(invalid(mesh_file, &object, "transform is not finite".to_owned()));
        }
    }
    if scene.resolution.is_some_and(|(w, h)| w == 0 || h == 0) {
        return Err(invalid(mesh_file, "resolution", "width and height must be at least 1".to_owned()));
    }

    info!(
        file = %path.display(),
        meshes = summary.meshes,
        triangles = summary.triangles,
        spheres = scene.spheres.len(),
        emitter_triangles = summary.emitter_triangles,
        emitter_spheres = summary.emitter_spheres,
        degenerate_triangles = summary.degenerate_triangles,
        removed_meshes = summary.removed_meshes,
        "scene validated"
    );
    Ok(summary)
}

/// The emitters' total power, Σ max(Le) · π · area, must stay below [`MAX_POWER`]: light selection and
/// photon emission sum and divide by it. The error names the brightest emitter.
fn check_emitted_power(scene: &Scene) -> Result<(), (String, String)> {
    let radiance = |material: u32| {
        scene.materials.get(material as usize).map_or(0.0, |m| m.emission.max_element() as f64)
    };
    let mut total = 0.0f64;
    let mut brightest = (0.0f64, String::new());
    let mut add = |power: f64, name: &str| {
        total += power;
        if power > brightest.0 {
            brightest = (power, name.to_owned());
        }
    };
    for mesh in &scene.meshes {
        let le = radiance(mesh.material);
        if le > 0.0 {
            let area: f64 = mesh
                .indices
                .iter()
                .map(|&[a, b, c]| {
                    let (a, b, c) =
                        (mesh.positions[a as usize], mesh.positions[b as usize], mesh.positions[c as usize]);
                    0.5 * (b - a).as_dvec3().cross((c - a).as_dvec3()).length()
                })
                .sum();
            add(le * std::f64::consts::PI * area, &mesh.name);
        }
    }
    for sphere in &scene.spheres {
        let area = 4.0 * std::f64::consts::PI * (sphere.radius as f64).powi(2);
        add(radiance(sphere.material) * std::f64::consts::PI * area, &format!("sphere '{}'", sphere.name));
    }
    // A sun's power depends on the scene's extent; its irradiance is bounded in `validate`.
    for light in scene.punctual_lights.iter().filter(|l| l.kind != PunctualKind::Sun) {
        add(4.0 * std::f64::consts::PI * light.radiometric().max_element() as f64, &light.name);
    }
    if total > MAX_POWER {
        return Err((
            brightest.1,
            format!(
                "the emitters' total power is {total:.3e} W, above {MAX_POWER:e} W, the most Caustica accepts; \
                 this emitter alone radiates {:.3e} W: scale the radiance or the scene down",
                brightest.0
            ),
        ));
    }
    Ok(())
}

fn check_material(m: &MaterialDesc, textures: usize) -> Result<(), String> {
    let unit = |name: &str, v: f32| {
        if (0.0..=1.0).contains(&v) { Ok(()) } else { Err(format!("{name} is {v}, must be in [0, 1]")) }
    };
    let non_negative = |name: &str, v: Vec3| {
        if v.is_finite() && v.min_element() >= 0.0 {
            Ok(())
        } else {
            Err(format!("{name} is {v}, must be finite and non-negative"))
        }
    };
    let shading = &m.shading;
    non_negative("base colour", shading.base_color)?;
    unit("metallic", shading.metallic)?;
    unit("roughness", shading.roughness)?;
    unit("transmission", shading.transmission)?;
    unit("specular", shading.specular)?;
    unit("clearcoat", shading.clearcoat)?;
    unit("clearcoat roughness", shading.clearcoat_roughness)?;
    non_negative("specular colour", shading.specular_color)?;
    non_negative("emission", m.emission)?;
    unit("base colour alpha", m.alpha)?;
    if let super::AlphaMode::Mask { cutoff } = m.alpha_mode
        && !(cutoff.is_finite() && cutoff >= 0.0)
    {
        return Err(format!("alphaCutoff is {cutoff}, must be finite and >= 0"));
    }
    if m.emission.max_element() > MAX_RADIANCE {
        return Err(format!(
            "emission is [{:e}, {:e}, {:e}], above {MAX_RADIANCE:e} W/(sr·m²), the most Caustica accepts: \
             sums of it would overflow single precision; scale the scene's radiance down",
            m.emission.x, m.emission.y, m.emission.z
        ));
    }
    if !(shading.ior > 0.0 && shading.ior.is_finite()) {
        return Err(format!("ior is {}, must be positive and finite", shading.ior));
    }
    if !(shading.thickness >= 0.0 && shading.thickness.is_finite()) {
        return Err(format!("thickness is {}, must be finite and non-negative", shading.thickness));
    }
    for (name, texture) in textures_of(m) {
        if texture.texture as usize >= textures {
            return Err(format!("{name} refers to texture {} of {textures}", texture.texture));
        }
        if texture.transform.is_some_and(|t| !t.iter().all(|c| c.is_finite())) {
            return Err(format!("{name} has a non-finite KHR_texture_transform"));
        }
    }
    Ok(())
}

fn textures_of(m: &MaterialDesc) -> impl Iterator<Item = (&'static str, TextureRef)> {
    [
        ("baseColorTexture", m.base_color_texture),
        ("metallicRoughnessTexture", m.metallic_roughness_texture),
        ("emissiveTexture", m.emissive_texture),
        ("normalTexture", m.normal_texture),
        ("clearcoatTexture", m.clearcoat_texture),
        ("clearcoatRoughnessTexture", m.clearcoat_roughness_texture),
    ]
    .into_iter()
    .filter_map(|(name, t)| Some((name, t?)))
}

/// Errors on what the renderer cannot take; zero normals are not an error but fall back to flat normals.
/// Drop the triangles of zero or non-finite area (a ray cannot hit them, a light on them has no
/// area); how many. Validation does it to a loaded mesh, an animation to each posed one, and
/// clears the normals of a mesh with a zero-length one (flat shading) as validation does.
pub fn drop_degenerate_triangles(mesh: &mut Mesh) -> usize {
    if mesh.normals.as_ref().is_some_and(|n| n.iter().any(|v| v.length_squared() == 0.0)) {
        mesh.normals = None;
    }
    let before = mesh.indices.len();
    let positions = &mesh.positions;
    mesh.indices.retain(|&[a, b, c]| {
        let (a, b, c) = (positions[a as usize], positions[b as usize], positions[c as usize]);
        let area2 = (b - a).cross(c - a).length_squared();
        area2 > 0.0 && area2.is_finite()
    });
    before - mesh.indices.len()
}

fn check_mesh(mesh: &mut Mesh, materials: &[MaterialDesc], file: &Path) -> Result<(), String> {
    let n = mesh.positions.len();
    let material = materials.get(mesh.material as usize).ok_or_else(|| {
        format!("material index {} out of range ({} materials)", mesh.material, materials.len())
    })?;
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("position of vertex {i} is {}, not finite", mesh.positions[i]));
    }
    let reach = |p: &glam::Vec3| p.abs().max_element() + mesh.motion.unwrap_or_default().abs().max_element();
    if let Some(i) = mesh.positions.iter().position(|p| reach(p) > MAX_COORDINATE) {
        return Err(format!(
            "vertex {i} at {} is beyond the ±{MAX_COORDINATE} m f32 geometry supports",
            mesh.positions[i]
        ));
    }
    if let Some(normals) = &mesh.normals {
        if normals.len() != n {
            return Err(format!("{} normals for {n} vertices", normals.len()));
        }
        if let Some(i) = normals.iter().position(|v| !v.is_finite()) {
            return Err(format!("normal of vertex {i} is {}, not finite", normals[i]));
        }
        let zero = normals.iter().filter(|v| v.length_squared() == 0.0).count();
        if zero > 0 {
            warn!(
                file = %file.display(),
                "{}: {zero} zero-length normal(s); using flat normals for the whole mesh",
                mesh.name
            );
            mesh.normals = None;
        }
    }
    for (set, uvs) in mesh.uvs.iter().enumerate() {
        if uvs.len() != n {
            return Err(format!("TEXCOORD_{set} has {} values for {n} vertices", uvs.len()));
        }
        if let Some(i) = uvs.iter().position(|v: &Vec2| !v.is_finite()) {
            return Err(format!("TEXCOORD_{set} of vertex {i} is {}, not finite", uvs[i]));
        }
    }
    if let Some(colors) = &mesh.colors {
        if colors.len() != n {
            return Err(format!("{} colours for {n} vertices", colors.len()));
        }
        if let Some(i) = colors.iter().position(|c| !(c.is_finite() && c.min_element() >= 0.0)) {
            return Err(format!("colour of vertex {i} is {}, must be finite and non-negative", colors[i]));
        }
    }
    if let Some(t) = mesh.indices.iter().position(|t| t.iter().any(|&i| i as usize >= n)) {
        return Err(format!(
            "triangle {t} has vertex indices {:?}, out of range for {n} vertices",
            mesh.indices[t]
        ));
    }
    for (name, texture) in textures_of(material) {
        if texture.tex_coord as usize >= mesh.uvs.len() {
            return Err(format!(
                "material '{}' {name} reads TEXCOORD_{}, which the mesh does not have",
                material.name, texture.tex_coord
            ));
        }
    }
    if mesh.motion.is_some_and(|m| !m.is_finite()) {
        return Err("motion is not finite".to_owned());
    }
    Ok(())
}

/// Meshes whose triangles of one kind were dropped, for a single warning.
#[derive(Default)]
struct Defects {
    /// (mesh, triangles dropped, whether it was left empty and removed), in file order.
    meshes: Vec<(String, usize, bool)>,
}

impl Defects {
    fn add(&mut self, mesh: &str, dropped: usize, removed: bool) {
        self.meshes.push((mesh.to_owned(), dropped, removed));
    }

    /// One warning for them all: the mesh's own line when there is one, else totals and the first
    /// few names. `what` names the dropped triangles and `why` says why.
    fn warn(&self, file: &Path, what: &str, why: &str) {
        match self.meshes.as_slice() {
            [] => {}
            [(mesh, dropped, gone)] => {
                let gone = if *gone { "; no triangle left, mesh removed" } else { "" };
                warn!(file = %file.display(), "{mesh}: dropped {dropped} {what} ({why}){gone}");
            }
            meshes => {
                let total: usize = meshes.iter().map(|m| m.1).sum();
                let removed = meshes.iter().filter(|m| m.2).count();
                let gone = if removed > 0 {
                    format!(", {removed} of them left empty and removed")
                } else {
                    String::new()
                };
                let names = first_few(
                    meshes.iter().map(|(mesh, dropped, _)| format!("{mesh} ({dropped})")),
                    meshes.len(),
                );
                warn!(file = %file.display(), "dropped {total} {what} ({why}) in {} meshes{gone}: {names}", meshes.len());
            }
        }
    }
}

/// The first three of `count` names, then how many more.
fn first_few(names: impl Iterator<Item = String>, count: usize) -> String {
    const NAMED: usize = 3;
    let mut few: Vec<String> = names.take(NAMED).collect();
    if count > NAMED {
        few.push(format!("{} more", count - NAMED));
    }
    few.join("; ")
}
