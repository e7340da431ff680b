//! glTF 2.0 loading: one scene of a .gltf or .glb file flattened to world-space meshes, materials,
//! textures and a camera. By concern: `import.rs` reads the file, its buffers and images;
//! `geometry.rs` accessors and meshes; `materials.rs` materials and textures; `nodes.rs` node
//! transforms and cameras.
//!
//! The result is not validated; [`super::load`] runs [`super::validate::validate`] on it.

mod animation;
mod geometry;
mod import;
mod materials;
mod nodes;

pub use materials::srgb_to_linear;

use super::Scene;
use crate::error::{Error, Result};
use crate::scene::animation::AnimatedLight;
use glam::Mat4;
use import::import;
use nodes::CameraNode;
use std::collections::HashMap;
use std::path::Path;
use tracing::warn;

/// Extensions whose data the loader uses; others listed in `extensionsUsed` are ignored with one warning.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_volume",
    "KHR_node_visibility",
    "KHR_texture_transform",
];

/// Whether KHR_node_visibility sets `node` invisible (`visible: false`; true is its default).
fn hidden_by_extension(node: &gltf::Node) -> bool {
    node.extension_value("KHR_node_visibility")
        .and_then(|v| v.get("visible"))
        .and_then(|v| v.as_bool())
        .is_some_and(|visible| !visible)
}

/// Loads a .gltf or .glb file with its first perspective camera (in node traversal order).
pub fn load_gltf(path: &Path) -> Result<Scene> {
    load_gltf_with_camera(path, None)
}

/// Loads a .gltf or .glb file; `camera` picks the camera whose camera or node name matches.
pub fn load_gltf_with_camera(path: &Path, camera: Option<&str>) -> Result<Scene> {
    load_gltf_within(path, camera, crate::memory::physical_bytes() / 2)
}

/// As [`load_gltf_with_camera`], refusing a file whose meshes need more than `budget` bytes decoded.
pub fn load_gltf_within(path: &Path, camera: Option<&str>, budget: u64) -> Result<Scene> {
    let (document, buffers, images) = import(path, budget)?;
    let mut loader = Loader {
        budget,
        path,
        document: &document,
        buffers: &buffers,
        images: &images,
        scene: Scene { source: path.to_path_buf(), ..Scene::default() },
        textures: HashMap::new(),
        default_material: None,
        cameras: Vec::new(),
        morphed_primitives: 0,
        texture_bytes: 0,
        animation: None,
    };
    loader.warn_unsupported(&document);
    loader.animation = loader.read_animation()?;
    for material in document.materials() {
        let desc = loader.material(&material)?;
        loader.scene.materials.push(desc);
    }
    // glTF allows a file without `scene`: then the first one is the natural choice, but with several it is a guess.
    let scene = document.default_scene().or_else(|| {
        let first = document.scenes().next()?;
        let count = document.scenes().len();
        if count > 1 {
            warn!(
                file = %path.display(),
                "the file has {count} scenes and no default `scene`: loading {}",
                label("scene", first.name(), first.index())
            );
        }
        Some(first)
    });
    match scene {
        Some(scene) => {
            loader.scene.resolution = resolution(&scene, path)?;
            loader.check_geometry_budget()?;
            loader.walk(&scene, document.nodes().len())?;
        }
        None => warn!(file = %path.display(), "the file has no scene: nothing to render"),
    }
    if loader.morphed_primitives > 0 {
        warn!(
            file = %path.display(),
            "{} primitive(s) with morph targets loaded with their default weights (animated weights ignored)",
            loader.morphed_primitives
        );
    }
    loader.pick_camera(camera)?;
    if let Some(mut animation) = loader.animation.take() {
        animation.resolve(&loader.scene.meshes);
        loader.scene.animation = Some(std::sync::Arc::new(animation));
    }
    Ok(loader.scene)
}

/// `kind 'name' (#index)`, or `kind #index` for unnamed objects.
fn label(kind: &str, name: Option<&str>, index: usize) -> String {
    match name {
        Some(name) => format!("{kind} '{name}' (#{index})"),
        None => format!("{kind} #{index}"),
    }
}

/// `scenes[i].extras.width/height`, when given.
fn resolution(scene: &gltf::Scene, path: &Path) -> Result<Option<(u32, u32)>> {
    let Some(raw) = scene.extras() else {
        return Ok(None);
    };
    let object = || format!("{} extras", label("scene", scene.name(), scene.index()));
    let invalid =
        |problem: String| Error::InvalidScene { path: path.to_path_buf(), object: object(), problem };
    let value: gltf::json::Value =
        gltf::json::deserialize::from_str(raw.get()).map_err(|e| invalid(format!("not valid JSON: {e}")))?;
    let dimension = |key: &str| -> Result<Option<u32>> {
        match value.get(key) {
            None => Ok(None),
            Some(v) => match v.as_u64().and_then(|n| u32::try_from(n).ok()).filter(|&n| n > 0) {
                Some(n) => Ok(Some(n)),
                None => Err(invalid(format!("{key} is {v}, expected a positive integer"))),
            },
        }
    };
    match (dimension("width")?, dimension("height")?) {
        (Some(w), Some(h)) => Ok(Some((w, h))),
        (None, None) => Ok(None),
        _ => Err(invalid("gives only one of width and height".to_owned())),
    }
}

/// The state of one load: the file's data, the scene being filled, and what is shared across it.
struct Loader<'a> {
    /// The memory budget the decoded meshes and textures are checked against, bytes.
    budget: u64,
    /// What the textures decoded so far hold, bytes.
    texture_bytes: u64,
    path: &'a Path,
    /// The file's document, for what the gltf crate does not resolve (extensions it does not parse).
    document: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    images: &'a [gltf::image::Data],
    scene: Scene,
    /// glTF texture index and sRGB decoding -> index into `scene.textures`; one image used as colour and as data
    /// needs two decoded copies.
    textures: HashMap<(usize, bool), u32>,
    default_material: Option<u32>,
    cameras: Vec<CameraNode>,
    morphed_primitives: usize,
    /// The file's animations, filled in as the walk meets what they move.
    animation: Option<crate::scene::animation::Animation>,
}

impl Loader<'_> {
    fn invalid(&self, object: impl Into<String>, problem: impl Into<String>) -> Error {
        Error::InvalidScene { path: self.path.to_path_buf(), object: object.into(), problem: problem.into() }
    }

    fn warn_unsupported(&self, document: &gltf::Document) {
        let file = self.path.display();
        let ignored: Vec<&str> =
            document.extensions_used().filter(|e| !SUPPORTED_EXTENSIONS.contains(e)).collect();
        if !ignored.is_empty() {
            warn!(file = %file, "glTF extensions not supported, ignored: {}", ignored.join(", "));
        }
        let skins: Vec<String> = document.skins().map(|s| label("skin", s.name(), s.index())).collect();
        if !skins.is_empty() {
            warn!(
                file = %file,
                "{} ignored: skinned meshes are loaded in their bind pose, with their node transforms",
                skins.join(", ")
            );
        }
    }

    /// Depth-first, children in file order, so that "the first camera" is the one a reader of the file expects.
    fn walk(&mut self, scene: &gltf::Scene, node_count: usize) -> Result<()> {
        let mut visited = vec![false; node_count];
        // Each node with its parent's world transform, whether an animation moves that parent, and
        // whether KHR_node_visibility hides it.
        let mut stack: Vec<(gltf::Node, Mat4, bool, bool)> =
            scene.nodes().map(|n| (n, Mat4::IDENTITY, false, false)).collect();
        stack.reverse();
        while let Some((node, parent, parent_moves, parent_hidden)) = stack.pop() {
            let object = label("node", node.name(), node.index());
            // A cycle would otherwise loop forever; glTF requires a strict tree.
            if std::mem::replace(&mut visited[node.index()], true) {
                return Err(
                    self.invalid(object, "is reached twice in the node hierarchy (a cycle, or two parents)")
                );
            }
            let world = parent * self.local_transform(&node, &object)?;
            if !world.is_finite() {
                return Err(self.invalid(object, "world transform has a NaN or infinite entry (overflow)"));
            }
            let moves = parent_moves || self.animation.as_ref().is_some_and(|a| a.drives(node.index()));
            // A mesh an animation moves may rest at scale zero (an object that pops in): its frames
            // are checked as they are posed.
            if node.camera().is_some() || (node.mesh().is_some() && !moves) {
                self.check_invertible(&world, &object)?;
            }
            if let Some(animation) = &mut self.animation {
                animation.order.push(node.index());
            }
            // KHR_node_visibility: a hidden node's meshes and lights, and its descendants', are not in
            // the scene (an animation of its visibility is a pointer animation: not followed).
            let hidden = parent_hidden || hidden_by_extension(&node);
            if let Some(mesh) = node.mesh().filter(|_| !hidden) {
                self.add_mesh(&node, &mesh, world, moves)?;
            }
            if let Some(light) = node.light().filter(|_| !hidden) {
                self.add_light(&light, world, &object)?;
                if moves && let Some(animation) = &mut self.animation {
                    let index = self.scene.punctual_lights.len() - 1;
                    animation.lights.push(AnimatedLight { index, node: node.index() });
                }
            }
            if let Some(camera) = node.camera() {
                self.add_camera(&node, &camera, world, object, moves);
            }
            let children: Vec<gltf::Node> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|child| (child, world, moves, hidden)));
        }
        Ok(())
    }
}
