//! glTF 2.0 loading: one scene of a .gltf or .glb file flattened to world-space meshes, materials, textures and a
//! camera.
//!
//! The result is not validated; [`super::load`] runs [`super::validate::validate`] on it.

use super::{CameraDesc, MaterialDesc, Mesh, Scene, Texture, TextureRef, Wrap};
use crate::error::{Error, Result};
use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::Semantic;
use gltf::accessor::{Accessor, DataType, Dimensions};
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::Path;
use tracing::warn;

/// Extensions whose data the loader uses; others listed in `extensionsUsed` are ignored with one warning.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// Loads a .gltf or .glb file with its first perspective camera (in node traversal order).
pub fn load_gltf(path: &Path) -> Result<Scene> {
    load_gltf_with_camera(path, None)
}

/// Loads a .gltf or .glb file; `camera` picks the camera whose camera or node name matches.
pub fn load_gltf_with_camera(path: &Path, camera: Option<&str>) -> Result<Scene> {
    let (document, buffers, images) = import(path)?;
    let mut loader = Loader {
        path,
        buffers: &buffers,
        images: &images,
        scene: Scene { source: path.to_path_buf(), ..Scene::default() },
        textures: HashMap::new(),
        default_material: None,
        cameras: Vec::new(),
        morphed_primitives: 0,
    };
    loader.warn_unsupported(&document);
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
    Ok(loader.scene)
}

/// Reads the file, its buffers and its images, naming the buffer or image that fails.
fn import(path: &Path) -> Result<(gltf::Document, Vec<gltf::buffer::Data>, Vec<gltf::image::Data>)> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let gltf_error = |message: String| Error::Gltf { path: path.to_path_buf(), message };
    let gltf::Gltf { document, mut blob } =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| gltf_error(describe(&e)))?;
    // gltf-json 1.4's validation indexes `accessors` with each POSITION index before checking it
    // (a panic on an index out of range), so check those first, then validate.
    let json = document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position =
                primitive.attributes.get(&gltf::json::validation::Checked::Valid(gltf::Semantic::Positions));
            if let Some(index) = position
                && index.value() >= json.accessors.len()
            {
                return Err(gltf_error(format!(
                    "{} primitive {p}: POSITION is accessor {}, but the file has {} accessors",
                    label("mesh", mesh.name.as_deref(), m),
                    index.value(),
                    json.accessors.len()
                )));
            }
        }
    }
    let document = validate(document.into_json()).map_err(|e| gltf_error(describe(&e)))?;
    let version = &document.as_json().asset.version;
    if !version.starts_with("2.") {
        return Err(gltf_error(format!("asset.version is \"{version}\", only 2.x is supported")));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut buffers = Vec::with_capacity(document.buffers().len());
    for buffer in document.buffers() {
        let object = label("buffer", buffer.name(), buffer.index());
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            check_uri(uri).map_err(|problem| gltf_error(format!("{object}: {problem}")))?;
        }
        let data = gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), &mut blob).map_err(
            |e| {
                let source = match buffer.source() {
                    gltf::buffer::Source::Uri(uri) => describe_uri(uri, base),
                    gltf::buffer::Source::Bin => "the GLB BIN chunk".to_owned(),
                };
                gltf_error(format!("{object} ({source}): {}", describe(&e)))
            },
        )?;
        if data.len() < buffer.length() {
            return Err(gltf_error(format!(
                "{object}: holds {} bytes but byteLength says {}",
                data.len(),
                buffer.length()
            )));
        }
        buffers.push(data);
    }
    // The gltf crate computes view ends unchecked and slices image views without a bounds check.
    for view in document.views() {
        let buffer = view.buffer();
        if view.offset().checked_add(view.length()).is_none_or(|end| end > buffer.length()) {
            return Err(gltf_error(format!(
                "{}: byteOffset {} + byteLength {} is past the end of {} ({} bytes)",
                label("bufferView", view.name(), view.index()),
                view.offset(),
                view.length(),
                label("buffer", buffer.name(), buffer.index()),
                buffer.length()
            )));
        }
    }
    // The gltf crate unwraps these (its validation does not check them), so reject them before it panics.
    for (index, image) in document.as_json().images.iter().enumerate() {
        let object = label("image", image.name.as_deref(), index);
        let problem = match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => "has neither uri nor bufferView",
            (Some(_), Some(_), _) => "has both uri and bufferView",
            (None, Some(_), None) => "has a bufferView but no mimeType",
            (Some(uri), None, _) => match check_uri(uri) {
                Ok(()) => continue,
                Err(problem) => return Err(gltf_error(format!("{object}: {problem}"))),
            },
            _ => continue,
        };
        return Err(gltf_error(format!("{object} {problem}")));
    }
    let mut images = Vec::with_capacity(document.images().len());
    for image in document.images() {
        let data = gltf::image::Data::from_source(image.source(), Some(base), &buffers).map_err(|e| {
            let source = match image.source() {
                gltf::image::Source::Uri { uri, .. } => describe_uri(uri, base),
                gltf::image::Source::View { view, .. } => {
                    format!("bufferView #{}", view.index())
                }
            };
            gltf_error(format!(
                "{} ({source}): {}",
                label("image", image.name(), image.index()),
                describe(&e)
            ))
        })?;
        images.push(data);
    }
    Ok((document, buffers, images))
}

/// gltf-json's validation, except that it requires a bufferView on every accessor that is not sparse, where glTF 2.0
/// defines an accessor without one as all zeros (which [`read`] supplies).
fn validate(json: gltf::json::Root) -> Result<gltf::Document, gltf::Error> {
    use gltf::json::validation::{Error as Invalid, Validate};
    let mut errors = Vec::new();
    json.validate(&json, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let zeros = matches!(error, Invalid::Missing)
            && path.as_str().starts_with("accessors[")
            && path.as_str().ends_with("].bufferView");
        if !zeros {
            errors.push((path, error));
        }
    });
    if errors.is_empty() {
        Ok(gltf::Document::from_json_without_validation(json))
    } else {
        Err(gltf::Error::Validation(errors))
    }
}

fn describe(error: &gltf::Error) -> String {
    match error {
        gltf::Error::Deserialize(e) => format!("invalid JSON or wrong glTF structure: {e}"),
        gltf::Error::Validation(errors) => {
            let first: Vec<String> = errors.iter().take(5).map(|(path, e)| format!("{path}: {e}")).collect();
            let more = errors.len().saturating_sub(first.len());
            let more = if more > 0 { format!(" (and {more} more)") } else { String::new() };
            format!("invalid glTF: {}{more}", first.join("; "))
        }
        other => other.to_string(),
    }
}

/// The gltf crate unwraps the UTF-8 decoding of a percent-encoded relative URI, so reject those it would panic on.
fn check_uri(uri: &str) -> Result<(), String> {
    // Only relative references are percent-decoded; `data:` and `file:` URIs are taken as they are.
    if uri.contains(':') {
        return Ok(());
    }
    let (bytes, mut decoded) = (uri.as_bytes(), Vec::with_capacity(uri.len()));
    let hex = |i: usize| bytes.get(i).and_then(|&b| char::from(b).to_digit(16));
    let mut i = 0;
    while i < bytes.len() {
        match (bytes[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(high), Some(low)) => {
                decoded.push((high * 16 + low) as u8);
                i += 3;
            }
            (b, _, _) => {
                decoded.push(b);
                i += 1;
            }
        }
    }
    match String::from_utf8(decoded) {
        Ok(_) => Ok(()),
        Err(_) => Err(format!("URI '{uri}' percent-decodes to bytes that are not UTF-8")),
    }
}

fn describe_uri(uri: &str, base: &Path) -> String {
    if uri.starts_with("data:") {
        "embedded data URI".to_owned()
    } else {
        format!("'{uri}', resolved to {}", base.join(uri).display())
    }
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

/// A camera node met during traversal.
struct CameraNode {
    node: String,
    camera_name: Option<String>,
    node_name: Option<String>,
    /// `None` for orthographic cameras.
    perspective: Option<(f32, Option<f32>)>,
    world: Mat4,
}

struct Loader<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    images: &'a [gltf::image::Data],
    scene: Scene,
    /// glTF texture index and sRGB decoding -> index into `scene.textures`; one image used as colour and as data
    /// needs two decoded copies.
    textures: HashMap<(usize, bool), u32>,
    default_material: Option<u32>,
    cameras: Vec<CameraNode>,
    morphed_primitives: usize,
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
        let animations = document.animations().len();
        if animations > 0 {
            warn!(file = %file, "{animations} animation(s) ignored: the scene is loaded in its rest pose");
        }
        let skins = document.skins().len();
        if skins > 0 {
            warn!(file = %file, "{skins} skin(s) ignored: skinned meshes are loaded unskinned, with their node transforms");
        }
    }

    /// Depth-first, children in file order, so that "the first camera" is the one a reader of the file expects.
    fn walk(&mut self, scene: &gltf::Scene, node_count: usize) -> Result<()> {
        let mut visited = vec![false; node_count];
        let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
        stack.reverse();
        while let Some((node, parent)) = stack.pop() {
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
            if node.mesh().is_some() || node.camera().is_some() {
                self.check_invertible(&world, &object)?;
            }
            if let Some(mesh) = node.mesh() {
                self.add_mesh(&node, &mesh, world)?;
            }
            if let Some(camera) = node.camera() {
                self.add_camera(&node, &camera, world, object);
            }
            let children: Vec<gltf::Node> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|child| (child, world)));
        }
        Ok(())
    }

    fn local_transform(&self, node: &gltf::Node, object: &str) -> Result<Mat4> {
        let non_finite = || self.invalid(object, "transform has a NaN or infinite entry");
        match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                let m = Mat4::from_cols_array_2d(&matrix);
                if m.is_finite() { Ok(m) } else { Err(non_finite()) }
            }
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                let (t, q, s) = (Vec3::from(translation), Quat::from_array(rotation), Vec3::from(scale));
                if !(t.is_finite() && q.is_finite() && s.is_finite()) {
                    return Err(non_finite());
                }
                // Exporters write quaternions rounded to a few digits; a non-unit one would also scale.
                let length = q.length();
                if length < 1e-6 {
                    return Err(self.invalid(object, "rotation quaternion has zero length"));
                }
                Ok(Mat4::from_scale_rotation_translation(s, q / length, t))
            }
        }
    }

    fn check_invertible(&self, world: &Mat4, object: &str) -> Result<()> {
        let m = Mat3::from_mat4(*world).as_dmat3();
        let scale = m.x_axis.length() * m.y_axis.length() * m.z_axis.length();
        // Relative to the axes' lengths, so that millimetre-scaled scenes are not taken as singular.
        let invertible = m.determinant().abs() > 1e-9 * scale;
        if !invertible {
            return Err(self.invalid(
                object,
                format!(
                    "transform is singular (determinant {:e}): a zero scale or collapsed axis flattens it",
                    m.determinant()
                ),
            ));
        }
        Ok(())
    }

    fn add_camera(&mut self, node: &gltf::Node, camera: &gltf::Camera, world: Mat4, object: String) {
        let perspective = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => Some((p.yfov(), p.aspect_ratio())),
            gltf::camera::Projection::Orthographic(_) => {
                warn!(
                    file = %self.path.display(),
                    "{} on {object}: orthographic cameras are not supported, skipped",
                    label("camera", camera.name(), camera.index())
                );
                None
            }
        };
        self.cameras.push(CameraNode {
            node: object,
            camera_name: camera.name().map(str::to_owned),
            node_name: node.name().map(str::to_owned),
            perspective,
            world,
        });
    }

    fn pick_camera(&mut self, name: Option<&str>) -> Result<()> {
        let chosen = match name {
            None => self.cameras.iter().find(|c| c.perspective.is_some()),
            Some(name) => {
                let named = |c: &&CameraNode| {
                    c.camera_name.as_deref() == Some(name) || c.node_name.as_deref() == Some(name)
                };
                let Some(found) = self.cameras.iter().find(named) else {
                    let available: Vec<String> = self
                        .cameras
                        .iter()
                        .map(|c| {
                            format!("'{}' on {}", c.camera_name.as_deref().unwrap_or("(unnamed)"), c.node)
                        })
                        .collect();
                    let available = if available.is_empty() {
                        "the file has no cameras".to_owned()
                    } else {
                        available.join(", ")
                    };
                    return Err(self.invalid(
                        format!("camera '{name}'"),
                        format!("no such camera; available: {available}"),
                    ));
                };
                if found.perspective.is_none() {
                    return Err(self.invalid(
                        format!("camera '{name}' on {}", found.node),
                        "is orthographic; only perspective cameras are supported",
                    ));
                }
                Some(found)
            }
        };
        self.scene.camera = chosen.and_then(|c| {
            let (yfov, aspect_ratio) = c.perspective?;
            let name =
                c.camera_name.clone().or_else(|| c.node_name.clone()).unwrap_or_else(|| c.node.clone());
            Some(CameraDesc { name, camera_to_world: rigid(&c.world), yfov, aspect_ratio })
        });
        Ok(())
    }

    fn add_mesh(&mut self, node: &gltf::Node, mesh: &gltf::Mesh, world: Mat4) -> Result<()> {
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let flip = world.determinant() < 0.0;
        let weights = node.weights().or(mesh.weights());
        for primitive in mesh.primitives() {
            let name = format!(
                "{} {} primitive {}",
                label("node", node.name(), node.index()),
                label("mesh", mesh.name(), mesh.index()),
                primitive.index()
            );
            let mut out = self.primitive(&primitive, weights, &name)?;
            for p in &mut out.positions {
                *p = world.transform_point3(*p);
            }
            if let Some(normals) = &mut out.normals {
                for n in normals {
                    let m = normal_matrix * *n;
                    // Zero and NaN normals are left for validation to report.
                    let length = m.length();
                    *n = if length > 0.0 && length.is_finite() { m / length } else { m };
                }
            }
            if flip {
                for t in &mut out.indices {
                    t.swap(1, 2);
                }
            }
            out.node = Some(node.index());
            out.node_name = node.name().map(str::to_owned);
            out.name = name;
            self.scene.meshes.push(out);
        }
        Ok(())
    }

    /// One primitive in the mesh's local space.
    fn primitive(
        &mut self,
        primitive: &gltf::Primitive,
        weights: Option<&[f32]>,
        name: &str,
    ) -> Result<Mesh> {
        let path = self.path;
        let bad = |problem: String| Error::InvalidScene {
            path: path.to_path_buf(),
            object: name.to_owned(),
            problem,
        };
        let mode = primitive.mode();
        if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            return Err(bad(format!("unsupported primitive mode {mode:?}: only triangles can be rendered")));
        }
        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));

        let accessor =
            primitive.get(&Semantic::Positions).ok_or_else(|| bad("has no POSITION".to_owned()))?;
        check(&accessor, "POSITION", &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
        let mut positions: Vec<Vec3> = read(&accessor, "POSITION", reader.read_positions())
            .map_err(&bad)?
            .into_iter()
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        let same_count = |what: &str, len: usize| {
            if len == n { Ok(()) } else { Err(bad(format!("{what} has {len} values but POSITION has {n}"))) }
        };

        let mut normals = match primitive.get(&Semantic::Normals) {
            None => None,
            Some(accessor) => {
                check(&accessor, "NORMAL", &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
                let normals: Vec<Vec3> = read(&accessor, "NORMAL", reader.read_normals())
                    .map_err(&bad)?
                    .into_iter()
                    .map(Vec3::from)
                    .collect();
                same_count("NORMAL", normals.len())?;
                Some(normals)
            }
        };

        if primitive.morph_targets().len() > 0 {
            self.morphed_primitives += 1;
        }
        // The rest pose of a morphed mesh is the base plus its default weights times the targets.
        if let Some(weights) = weights.filter(|w| w.iter().any(|&w| w != 0.0)) {
            for ((i, target), (dp, dn, _)) in
                primitive.morph_targets().enumerate().zip(reader.read_morph_targets())
            {
                let w = weights.get(i).copied().unwrap_or(0.0);
                if w == 0.0 {
                    continue;
                }
                if let Some(accessor) = target.positions() {
                    let what = format!("morph target {i} POSITION");
                    check(&accessor, &what, &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
                    let d = read(&accessor, &what, dp).map_err(&bad)?;
                    same_count(&what, d.len())?;
                    positions.iter_mut().zip(d).for_each(|(p, d)| *p += w * Vec3::from(d));
                }
                if let (Some(accessor), Some(normals)) = (target.normals(), normals.as_mut()) {
                    let what = format!("morph target {i} NORMAL");
                    check(&accessor, &what, &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
                    let d = read(&accessor, &what, dn).map_err(&bad)?;
                    same_count(&what, d.len())?;
                    normals.iter_mut().zip(d).for_each(|(n, d)| *n += w * Vec3::from(d));
                }
            }
        }

        let material = match primitive.material().index() {
            Some(index) => index as u32,
            None => self.default_material(),
        };
        // Sets are consecutive from 0; hits carry sets 0 and 1 (`SurfaceHit::uv`), the only ones textures may use.
        let mut uvs = Vec::new();
        for set in 0..2 {
            let Some(accessor) = primitive.get(&Semantic::TexCoords(set)) else {
                break;
            };
            let what = format!("TEXCOORD_{set}");
            check(&accessor, &what, &[Dimensions::Vec2], &[DataType::F32, DataType::U8, DataType::U16])
                .and_then(|()| check_normalized(&accessor, &what))
                .map_err(&bad)?;
            let values =
                read(&accessor, &what, reader.read_tex_coords(set).map(|t| t.into_f32())).map_err(&bad)?;
            same_count(&what, values.len())?;
            uvs.push(values.into_iter().map(Vec2::from).collect());
        }

        let colors = match primitive.get(&Semantic::Colors(0)) {
            None => None,
            Some(accessor) => {
                let types = [DataType::F32, DataType::U8, DataType::U16];
                check(&accessor, "COLOR_0", &[Dimensions::Vec3, Dimensions::Vec4], &types)
                    .and_then(|()| check_normalized(&accessor, "COLOR_0"))
                    .map_err(&bad)?;
                let values = read(&accessor, "COLOR_0", reader.read_colors(0).map(|c| c.into_rgb_f32()))
                    .map_err(&bad)?;
                same_count("COLOR_0", values.len())?;
                Some(values.into_iter().map(Vec3::from).collect())
            }
        };

        let vertex_indices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                check(
                    &accessor,
                    "indices",
                    &[Dimensions::Scalar],
                    &[DataType::U8, DataType::U16, DataType::U32],
                )
                .map_err(&bad)?;
                read(&accessor, "indices", reader.read_indices().map(|i| i.into_u32())).map_err(&bad)?
            }
            None => (0..n as u32).collect(),
        };
        let (indices, leftover) = triangulate(mode, &vertex_indices);
        if leftover > 0 {
            warn!(file = %self.path.display(), "{name}: {leftover} trailing index(es) do not form a triangle, ignored");
        }
        Ok(Mesh { positions, normals, uvs, colors, indices, material, ..Mesh::default() })
    }

    fn default_material(&mut self) -> u32 {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(MaterialDesc::default());
            (self.scene.materials.len() - 1) as u32
        })
    }

    fn material(&mut self, material: &gltf::Material) -> Result<MaterialDesc> {
        let index = material.index().unwrap_or_default();
        let object = label("material", material.name(), index);
        let pbr = material.pbr_metallic_roughness();
        let [r, g, b, _alpha] = pbr.base_color_factor();
        let base_color_texture =
            pbr.base_color_texture().map(|info| self.texture_ref(&info, true)).transpose()?;
        let metallic_roughness_texture =
            pbr.metallic_roughness_texture().map(|info| self.texture_ref(&info, false)).transpose()?;
        for (slot, texture) in [
            ("baseColorTexture", &base_color_texture),
            ("metallicRoughnessTexture", &metallic_roughness_texture),
        ] {
            if let Some(t) = texture.filter(|t| t.tex_coord > 1) {
                return Err(self.invalid(
                    object,
                    format!(
                        "{slot} reads TEXCOORD_{}; only TEXCOORD_0 and TEXCOORD_1 are supported",
                        t.tex_coord
                    ),
                ));
            }
        }
        let specular = material.specular();
        let volume = material.volume();

        let mut ignored = Vec::new();
        if material.normal_texture().is_some() {
            ignored.push("normalTexture");
        }
        if material.occlusion_texture().is_some() {
            ignored.push("occlusionTexture");
        }
        if material.emissive_texture().is_some() {
            ignored.push("emissiveTexture");
        }
        if material.transmission().is_some_and(|t| t.transmission_texture().is_some()) {
            ignored.push("transmissionTexture");
        }
        if specular
            .as_ref()
            .is_some_and(|s| s.specular_texture().is_some() || s.specular_color_texture().is_some())
        {
            ignored.push("specular textures");
        }
        if let Some(v) = &volume {
            if v.thickness_texture().is_some() {
                ignored.push("thicknessTexture");
            }
            if v.attenuation_distance().is_finite() {
                ignored.push("volume attenuation");
            }
        }
        if material.alpha_mode() != gltf::material::AlphaMode::Opaque {
            ignored.push("alphaMode (rendered opaque)");
        }
        if !ignored.is_empty() {
            warn!(file = %self.path.display(), "{object}: not supported, ignored: {}", ignored.join(", "));
        }

        Ok(MaterialDesc {
            name: material.name().map_or_else(|| format!("material #{index}"), str::to_owned),
            base_color: Vec3::new(r, g, b),
            base_color_texture,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            metallic_roughness_texture,
            emission: Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0),
            transmission: material.transmission().map_or(0.0, |t| t.transmission_factor()),
            ior: material.ior().unwrap_or(1.5),
            specular: specular.as_ref().map_or(1.0, |s| s.specular_factor()),
            specular_color: specular.as_ref().map_or(Vec3::ONE, |s| Vec3::from(s.specular_color_factor())),
            thickness: volume.as_ref().map_or(0.0, |v| v.thickness_factor()),
            double_sided: material.double_sided(),
        })
    }

    fn texture_ref(&mut self, info: &gltf::texture::Info, srgb: bool) -> Result<TextureRef> {
        let texture = self.texture(&info.texture(), srgb)?;
        Ok(match info.texture_transform() {
            Some(t) => TextureRef {
                texture,
                tex_coord: t.tex_coord().unwrap_or(info.tex_coord()),
                transform: Some(uv_transform(t.offset(), t.rotation(), t.scale())),
            },
            None => TextureRef { texture, tex_coord: info.tex_coord(), transform: None },
        })
    }

    fn texture(&mut self, texture: &gltf::Texture, srgb: bool) -> Result<u32> {
        if let Some(&index) = self.textures.get(&(texture.index(), srgb)) {
            return Ok(index);
        }
        let image = texture.source();
        let data = self.images.get(image.index()).ok_or_else(|| {
            self.invalid(label("texture", texture.name(), texture.index()), "refers to a missing image")
        })?;
        let name = texture
            .name()
            .or(image.name())
            .map(str::to_owned)
            .or_else(|| match image.source() {
                gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => Some(uri.to_owned()),
                _ => None,
            })
            .unwrap_or_else(|| format!("texture #{}", texture.index()));
        let sampler = texture.sampler();
        self.scene.textures.push(Texture {
            name,
            width: data.width,
            height: data.height,
            texels: decode(data, srgb),
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
        });
        let index = (self.scene.textures.len() - 1) as u32;
        self.textures.insert((texture.index(), srgb), index);
        Ok(index)
    }
}

/// Rejects accessor layouts the reader would misread or panic on (it only debug-asserts them).
fn check(
    accessor: &Accessor,
    what: &str,
    dimensions: &[Dimensions],
    types: &[DataType],
) -> Result<(), String> {
    let object = format!("{what} ({})", label("accessor", accessor.name(), accessor.index()));
    if !dimensions.contains(&accessor.dimensions()) || !types.contains(&accessor.data_type()) {
        return Err(format!(
            "{object} is {:?} of {:?}, expected one of {dimensions:?} of one of {types:?}",
            accessor.dimensions(),
            accessor.data_type()
        ));
    }
    if accessor.count() == 0 || accessor.sparse().is_some_and(|s| s.count() == 0) {
        return Err(format!("{object} has a count of 0"));
    }
    if let Some(stride) = accessor.view().and_then(|v| v.stride())
        && stride < accessor.size()
    {
        return Err(format!(
            "{object} has byteStride {stride}, less than its element size {}",
            accessor.size()
        ));
    }
    // The reader computes these extents unchecked, so an absurd count would overflow.
    let past_the_end = |what: &str, view: gltf::buffer::View| {
        format!(
            "{object}{what} reads past the end of its {} ({} bytes)",
            label("bufferView", view.name(), view.index()),
            view.length()
        )
    };
    let size = accessor.size();
    if let Some(view) = accessor.view()
        && !fits(accessor.offset(), view.stride().unwrap_or(size), accessor.count(), size, view.length())
    {
        return Err(past_the_end("", view));
    }
    if let Some(sparse) = accessor.sparse() {
        let (indices, values) = (sparse.indices(), sparse.values());
        let (index_size, view) = (indices.index_type().size(), indices.view());
        if !fits(
            indices.offset(),
            view.stride().unwrap_or(index_size),
            sparse.count(),
            index_size,
            view.length(),
        ) {
            return Err(past_the_end(" sparse indices", view));
        }
        let view = values.view();
        if !fits(values.offset(), view.stride().unwrap_or(size), sparse.count(), size, view.length()) {
            return Err(past_the_end(" sparse values", view));
        }
    }
    Ok(())
}

/// Whether `count` elements of `size` bytes, `stride` apart from `offset`, end within `length` bytes.
fn fits(offset: usize, stride: usize, count: usize, size: usize, length: usize) -> bool {
    count
        .checked_sub(1)
        .and_then(|n| n.checked_mul(stride))
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(offset))
        .is_some_and(|end| end <= length)
}

/// The reader normalizes integer texture coordinates and colours whether or not the accessor says so; unnormalized
/// ones (KHR_mesh_quantization) would come out wrong.
fn check_normalized(accessor: &Accessor, what: &str) -> Result<(), String> {
    if accessor.data_type() == DataType::F32 || accessor.normalized() {
        return Ok(());
    }
    Err(format!(
        "{what} ({}) is {:?} but not normalized; only normalized integers are supported (KHR_mesh_quantization is not)",
        label("accessor", accessor.name(), accessor.index()),
        accessor.data_type()
    ))
}

/// Collects an accessor's values; `values` is `None` when its data lies outside its buffer, or when it has no
/// bufferView, which glTF defines as all zeros.
fn read<T: Default + Clone>(
    accessor: &Accessor,
    what: &str,
    values: Option<impl Iterator<Item = T>>,
) -> Result<Vec<T>, String> {
    match values {
        Some(values) => Ok(values.collect()),
        None if accessor.view().is_none() && accessor.sparse().is_none() => {
            Ok(vec![T::default(); accessor.count()])
        }
        None => Err(format!(
            "{what} ({}) reads past the end of its bufferView or buffer",
            label("accessor", accessor.name(), accessor.index())
        )),
    }
}

/// Triangles from a triangle list, strip or fan (glTF 2.0 §3.7.2.1), and the number of unused trailing indices.
fn triangulate(mode: Mode, v: &[u32]) -> (Vec<[u32; 3]>, usize) {
    match mode {
        Mode::TriangleStrip => {
            let triangles = (0..v.len().saturating_sub(2))
                .map(|i| if i % 2 == 0 { [v[i], v[i + 1], v[i + 2]] } else { [v[i], v[i + 2], v[i + 1]] })
                .collect();
            (triangles, 0)
        }
        Mode::TriangleFan => (((1..v.len().saturating_sub(1)).map(|i| [v[i], v[i + 1], v[0]])).collect(), 0),
        _ => {
            let chunks = v.chunks_exact(3);
            let leftover = chunks.remainder().len();
            (chunks.map(|t| [t[0], t[1], t[2]]).collect(), leftover)
        }
    }
}

/// The node's world transform without scale or shear: keeps the viewing direction (-Z) and then up (+Y) exact.
fn rigid(world: &Mat4) -> Mat4 {
    let z = world.z_axis.truncate().normalize();
    let y = world.y_axis.truncate().reject_from_normalized(z).normalize();
    let x = y.cross(z);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), world.w_axis.truncate().extend(1.0))
}

/// KHR_texture_transform's `T * R * S` as columns (x axis, y axis, offset); the rotation is counter-clockwise in
/// uv space whose v points down, as the extension's ratified text and its example define it.
fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [Vec2; 3] {
    let (sin, cos) = rotation.sin_cos();
    [Vec2::new(cos, -sin) * scale[0], Vec2::new(sin, cos) * scale[1], Vec2::from(offset)]
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    }
}

/// Linear RGBA texels; grey images replicate to RGB, missing alpha is 1.
fn decode(image: &gltf::image::Data, srgb: bool) -> Vec<Vec4> {
    use gltf::image::Format;
    let (channels, bytes) = match image.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    // Float images are linear already; only integer encodings carry the sRGB curve.
    let srgb = srgb && bytes < 4;
    image
        .pixels
        .chunks_exact(channels * bytes)
        .map(|px| {
            let c = |i: usize| {
                let b = &px[i * bytes..];
                match bytes {
                    1 => f32::from(b[0]) / 255.0,
                    2 => f32::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0,
                    _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
                }
            };
            let (rgb, alpha) = match channels {
                1 => (Vec3::splat(c(0)), 1.0),
                2 => (Vec3::splat(c(0)), c(1)),
                3 => (Vec3::new(c(0), c(1), c(2)), 1.0),
                _ => (Vec3::new(c(0), c(1), c(2)), c(3)),
            };
            let rgb = if srgb { rgb.map(srgb_to_linear) } else { rgb };
            rgb.extend(alpha)
        })
        .collect()
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_hits_its_reference_points() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        // The linear segment and the power segment meet at 0.04045.
        assert!((srgb_to_linear(0.04045) - srgb_to_linear(0.040_450_01)).abs() < 1e-6);
    }

    #[test]
    fn decode_handles_grey_alpha_and_sixteen_bit_images() {
        use gltf::image::{Data, Format};
        let grey_alpha = Data { pixels: vec![255, 51], format: Format::R8G8, width: 1, height: 1 };
        assert_eq!(decode(&grey_alpha, true), vec![Vec4::new(1.0, 1.0, 1.0, 0.2)]);
        let rgb16: Vec<u8> = [65535u16, 0, 32768].iter().flat_map(|v| v.to_ne_bytes()).collect();
        let rgb16 = Data { pixels: rgb16, format: Format::R16G16B16, width: 1, height: 1 };
        let texel = decode(&rgb16, false)[0];
        assert_eq!((texel.x, texel.y, texel.w), (1.0, 0.0, 1.0));
        assert!((texel.z - 0.5).abs() < 1e-4);
    }

    #[test]
    fn strips_alternate_winding_and_fans_pivot_on_the_first_vertex() {
        let v = [10, 11, 12, 13, 14];
        assert_eq!(triangulate(Mode::TriangleStrip, &v).0, vec![[10, 11, 12], [11, 13, 12], [12, 13, 14]]);
        assert_eq!(triangulate(Mode::TriangleFan, &v).0, vec![[11, 12, 10], [12, 13, 10], [13, 14, 10]]);
        assert_eq!(triangulate(Mode::Triangles, &v), (vec![[10, 11, 12]], 2));
        assert!(triangulate(Mode::TriangleStrip, &v[..2]).0.is_empty());
    }

    #[test]
    fn texture_transform_follows_the_extension_example() {
        // KHR_texture_transform README: offset [0, 1], rotation 90°, scale 0.5 uses the lower-left quadrant.
        let [x, y, offset] = uv_transform([0.0, 1.0], std::f32::consts::FRAC_PI_2, [0.5, 0.5]);
        for uv in [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE] {
            let t = x * uv.x + y * uv.y + offset;
            assert!(t.x > -1e-6 && t.x < 0.5 + 1e-6 && t.y > 0.5 - 1e-6 && t.y < 1.0 + 1e-6, "{uv} -> {t}");
        }
    }

    #[test]
    fn rigid_camera_transform_drops_scale_but_keeps_view_direction() {
        let world = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 3.0, 4.0),
            Quat::from_rotation_y(0.5),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let r = rigid(&world);
        let forward = r.transform_vector3(-Vec3::Z);
        assert!((forward - Quat::from_rotation_y(0.5) * -Vec3::Z).length() < 1e-5);
        assert!((Mat3::from_mat4(r).determinant() - 1.0).abs() < 1e-5);
        assert_eq!(r.w_axis.truncate(), Vec3::new(1.0, 2.0, 3.0));
    }
}
