//! Scene loader: the test scenes, Khronos samples, run files, and one test per kind of bad input.

use crate::common;

use caustica::Error;
use caustica::geometry::{Ray, SurfaceHit};
use caustica::materials::ShadingParams;
use caustica::scene::gltf::{load_gltf, load_gltf_with_camera, load_gltf_within, srgb_to_linear};
use caustica::scene::{self, LightSelection, RunFile, Scene, Wrap, validate};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

use common::data;

fn sample(name: &str) -> PathBuf {
    data("gltf-samples").join(name)
}

/// A fresh directory per test, so that tests running in parallel do not share files.
fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-loader-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write temp file");
    path
}

fn assert_names_file(error: &Error, file: &Path) {
    let message = error.to_string();
    assert!(
        message.contains(&file.display().to_string()),
        "message does not name {}: {message}",
        file.display()
    );
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

/// Positions (0,0,0), (1,0,0), (0,1,0), then NORMAL (0,0,1) three times, float32.
const TRIANGLE_BUFFER: &str =
    "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/";

/// One CCW triangle with NORMAL +Z on node 'tri'; `node` and `primitive` add JSON members, `rest` adds top-level ones
/// (each ending with a comma).
fn triangle_gltf(node: &str, primitive: &str, rest: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"name":"tri","mesh":0{node}}}],
        "meshes":[{{"name":"m","primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}}{primitive}}}]}}],
        {rest}
        "buffers":[{{"byteLength":72,"uri":"data:application/octet-stream;base64,{TRIANGLE_BUFFER}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":72}}],
        "accessors":[
          {{"bufferView":0,"byteOffset":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
          {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC3"}}]}}"#
    )
}

const EMISSIVE: &str = r#""materials":[{"name":"lamp","emissiveFactor":[1,1,1]}],"#;

fn triangle_count(scene: &Scene) -> usize {
    scene.meshes.iter().map(|m| m.indices.len()).sum()
}

// ---------------------------------------------------------------------------------------------------------------
// The test scenes

#[test]
fn cornell_box_loads_with_its_light_camera_and_resolution() {
    let (scene, run) = scene::load(&data("cornell-box.gltf")).expect("cornell-box loads");
    assert_eq!(triangle_count(&scene), 36, "36 triangles, none dropped");
    assert_eq!(run.render.spp, RunFile::default().render.spp, "a bare glTF gets the default settings");

    let emitters: Vec<_> = scene.materials.iter().filter(|m| m.emission.max_element() > 0.0).collect();
    assert_eq!(emitters.len(), 1, "exactly one emitting material");
    let expected = Vec3::new(1.0, 0.760_716_8, 0.367_301_35) * 18.387;
    assert!(close(emitters[0].emission, expected), "emission {} != {expected}", emitters[0].emission);
    let radiance = Vec3::new(18.387, 13.9873, 6.75357); // the file's extras, rounded
    assert!(
        (emitters[0].emission - radiance).abs().max_element() < 1e-3,
        "matches the file's stated radiance"
    );
    assert!(!emitters[0].double_sided, "the light is one-sided");

    let white = scene.materials.iter().find(|m| m.name == "white").expect("material 'white'");
    assert_eq!(
        (white.shading.metallic, white.shading.roughness, white.shading.specular),
        (0.0, 1.0, 0.0),
        "diffuse encoding"
    );
    assert!(white.double_sided);

    let camera = scene.camera.as_ref().expect("a camera");
    assert!((camera.yfov - 0.686_047_9).abs() < 1e-6, "yfov {}", camera.yfov);
    assert_eq!(camera.aspect_ratio, Some(1.0));
    assert!(close(camera.camera_to_world.w_axis.truncate(), Vec3::new(0.0, 0.273, 0.8)), "camera position");
    assert!(close(camera.camera_to_world.transform_vector3(-Vec3::Z), -Vec3::Z), "camera looks down -Z");
    assert_eq!(scene.resolution, Some((256, 256)));

    let light = scene.meshes.iter().find(|m| m.node_name.as_deref() == Some("light")).expect("light mesh");
    assert_eq!(light.name, "node 'light' (#5) mesh 'light' (#5) primitive 0");
    assert_eq!(light.node, Some(5));
    assert!(light.normals.is_some(), "the file has NORMAL");
}

#[test]
fn cornell_spheres_has_a_solid_glass_and_a_perfect_mirror() {
    let (scene, _) = scene::load(&data("cornell-spheres.gltf")).expect("cornell-spheres loads");
    let glass = scene.materials.iter().find(|m| m.name == "glass").expect("material 'glass'");
    assert_eq!((glass.shading.transmission, glass.shading.ior), (1.0, 1.5));
    assert!(glass.shading.thickness > 0.0, "glass is a closed solid");
    assert_eq!((glass.shading.metallic, glass.shading.roughness), (0.0, 0.0));
    let mirror = scene.materials.iter().find(|m| m.name == "mirror").expect("material 'mirror'");
    assert_eq!(
        (mirror.shading.metallic, mirror.shading.roughness, mirror.shading.base_color),
        (1.0, 0.0, Vec3::ONE)
    );

    // The sphere nodes scale a unit sphere by 0.1: world normals must stay unit length.
    let sphere =
        scene.meshes.iter().find(|m| m.node_name.as_deref() == Some("glass_sphere")).expect("glass sphere");
    let normals = sphere.normals.as_ref().expect("sphere normals");
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4), "renormalized normals");
    let center = Vec3::new(0.12, 0.101, -0.17);
    for (p, n) in sphere.positions.iter().zip(normals) {
        assert!((p.distance(center) - 0.1).abs() < 1e-3, "vertex {p} off the sphere");
        assert!(n.dot((*p - center).normalize()) > 0.99, "normal {n} not radial at {p}");
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Khronos samples

#[test]
fn triangle_without_normals_has_flat_normals_and_the_default_material() {
    let scene = load_gltf(&sample("Triangle.gltf")).expect("Triangle loads");
    assert_eq!(scene.meshes.len(), 1);
    let mesh = &scene.meshes[0];
    assert!(mesh.normals.is_none(), "no NORMAL means flat normals");
    assert_eq!(mesh.indices, vec![[0, 1, 2]]);
    assert_eq!(mesh.name, "node #0 mesh #0 primitive 0");
    let material = &scene.materials[mesh.material as usize];
    assert_eq!(
        (material.shading.metallic, material.shading.roughness, material.shading.base_color),
        (1.0, 1.0, Vec3::ONE)
    );
    assert!(scene.camera.is_none() && scene.resolution.is_none());
}

#[test]
fn triangle_without_indices_draws_its_vertices_in_order() {
    let scene = load_gltf(&sample("TriangleWithoutIndices.gltf")).expect("TriangleWithoutIndices loads");
    assert_eq!(scene.meshes[0].indices, vec![[0, 1, 2]]);
    assert_eq!(scene.meshes[0].positions.len(), 3);
}

#[test]
fn one_mesh_instanced_by_two_nodes_becomes_two_meshes() {
    let scene = load_gltf(&sample("SimpleMeshes.gltf")).expect("SimpleMeshes loads");
    assert_eq!(scene.meshes.len(), 2);
    let (a, b) = (&scene.meshes[0], &scene.meshes[1]);
    assert_eq!((a.node, b.node), (Some(0), Some(1)));
    for (pa, pb) in a.positions.iter().zip(&b.positions) {
        assert!(close(*pb, *pa + Vec3::X), "second instance is translated by +X: {pa} vs {pb}");
    }
    assert_eq!(a.normals, b.normals, "a translation does not change normals");
}

#[test]
fn box_root_matrix_turns_z_up_into_y_up() {
    let scene = load_gltf(&sample("Box.gltf")).expect("Box loads despite the stray byteStride: 0");
    let mesh = &scene.meshes[0];
    assert_eq!((mesh.positions.len(), mesh.indices.len()), (24, 12));
    // (x, y, z) -> (x, z, -y): vertex 0 (-0.5, -0.5, 0.5) and its normal +Z.
    assert!(close(mesh.positions[0], Vec3::new(-0.5, 0.5, 0.5)), "vertex 0 is {}", mesh.positions[0]);
    assert!(close(mesh.normals.as_ref().expect("normals")[0], Vec3::Y));
    let material = &scene.materials[mesh.material as usize];
    assert!(close(material.shading.base_color, Vec3::new(0.8, 0.0, 0.0)));
    assert_eq!((material.shading.metallic, material.shading.roughness), (1.0, 1.0), "glTF defaults");
}

#[test]
fn sparse_accessor_substitutes_its_values() {
    let scene = load_gltf(&sample("SimpleSparseAccessor.gltf")).expect("SimpleSparseAccessor loads");
    let p = &scene.meshes[0].positions;
    assert_eq!(p.len(), 14);
    assert_eq!(p[8], Vec3::new(1.0, 2.0, 0.0));
    assert_eq!(p[10], Vec3::new(3.0, 3.0, 0.0));
    assert_eq!(p[12], Vec3::new(5.0, 4.0, 0.0));
    assert_eq!(p[9], Vec3::new(2.0, 1.0, 0.0), "vertices outside the sparse set keep their base value");
}

#[test]
fn perspective_camera_is_picked_over_the_orthographic_one() {
    let (scene, logs) = common::capture_logs(|| load_gltf(&sample("Cameras.gltf")).expect("Cameras loads"));
    let camera = scene.camera.expect("the perspective camera");
    assert_eq!(camera.aspect_ratio, Some(1.0));
    assert!((camera.yfov - 0.7).abs() < 1e-6);
    assert!(close(camera.camera_to_world.w_axis.truncate(), Vec3::new(0.5, 0.5, 3.0)));
    assert!(logs.contains("orthographic"), "orthographic camera skipped with a warning: {logs}");
}

#[test]
fn camera_is_picked_by_name_and_unknown_names_list_the_available_ones() {
    let path = data("cornell-box.gltf");
    let scene = load_gltf_with_camera(&path, Some("camera")).expect("camera 'camera' exists");
    assert_eq!(scene.camera.expect("camera").name, "camera");
    let error = load_gltf_with_camera(&path, Some("nope")).expect_err("unknown camera");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    assert!(error.to_string().contains("'camera'"), "lists the available cameras: {error}");
}

#[test]
fn box_textured_decodes_its_texture_with_repeat_wrap() {
    let scene = load_gltf(&sample("BoxTextured.gltf")).expect("BoxTextured loads");
    assert_eq!(scene.textures.len(), 1);
    let texture = &scene.textures[0];
    assert_eq!((texture.width, texture.height), (256, 256));
    assert_eq!(texture.len(), 256 * 256);
    assert_eq!((texture.wrap_s, texture.wrap_t), (Wrap::Repeat, Wrap::Repeat));
    assert!(texture.texels().all(|t| t.is_finite() && t.min_element() >= 0.0 && t.max_element() <= 1.0));
    let mesh = &scene.meshes[0];
    let material = &scene.materials[mesh.material as usize];
    let reference = material.base_color_texture.expect("base colour texture");
    assert_eq!((reference.texture, reference.tex_coord, reference.transform), (0, 0, None));
    assert_eq!(material.shading.metallic, 0.0);
    assert!(!mesh.uvs.is_empty() && mesh.uvs[0].len() == mesh.positions.len(), "TEXCOORD_0 read");
    assert!(mesh.uvs[0].iter().any(|uv| uv.x > 1.0), "uvs outside [0, 1] are kept for Repeat");
    assert!(mesh.uvs[0].iter().all(|uv| uv.cmpge(Vec2::ZERO).all()));
}

#[test]
fn texture_used_as_colour_and_as_data_is_decoded_twice() {
    // A 1×1 grey PNG (value 128): sRGB-decoded for base colour, read as is for metallic-roughness.
    const PNG: &str =
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAAAAAA6fptVAAAACklEQVR4nGNoAAAAggCBd81ytgAAAABJRU5ErkJggg==";
    let rest = format!(
        r#""materials":[{{"name":"textured","pbrMetallicRoughness":{{
            "baseColorTexture":{{"index":0,"texCoord":1,
                "extensions":{{"KHR_texture_transform":{{"offset":[0.5,0],"scale":[2,2],"texCoord":0}}}}}},
            "metallicRoughnessTexture":{{"index":0}}}}}}],
        "extensionsUsed":["KHR_texture_transform"],
        "textures":[{{"source":0,"sampler":0}}],
        "samplers":[{{"wrapS":33071,"wrapT":33648}}],
        "images":[{{"uri":"data:image/png;base64,{PNG}"}}],"#
    );
    let path = write(&temp_dir("shared-image"), "shared.gltf", &triangle_gltf("", r#","material":0"#, &rest));
    let scene = load_gltf(&path).expect("loads");
    assert_eq!(scene.textures.len(), 2, "one decoded copy per use");
    let material = &scene.materials[0];
    let color = material.base_color_texture.expect("base colour texture");
    let data = material.metallic_roughness_texture.expect("metallic-roughness texture");
    let srgb = scene.textures[color.texture as usize].texel(0);
    let linear = scene.textures[data.texture as usize].texel(0);
    assert!((srgb.x - 0.2158605).abs() < 1e-4, "sRGB 128 decodes to 0.2159, got {srgb}");
    assert!((linear.x - 128.0 / 255.0).abs() < 1e-6, "data stays linear, got {linear}");
    assert_eq!((srgb.y, srgb.z, srgb.w), (srgb.x, srgb.x, 1.0), "grey replicates, alpha 1");
    let texture = &scene.textures[color.texture as usize];
    assert_eq!((texture.wrap_s, texture.wrap_t), (Wrap::ClampToEdge, Wrap::MirroredRepeat));

    assert_eq!(color.tex_coord, 0, "KHR_texture_transform's texCoord overrides");
    let [x, y, offset] = color.transform.expect("KHR_texture_transform");
    assert_eq!((x, y, offset), (Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0), Vec2::new(0.5, 0.0)));

    // The triangle has no TEXCOORD_0, so validation must refuse the material's texture.
    let error = scene::load(&path).expect_err("texture without uvs");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    assert!(error.to_string().contains("TEXCOORD_0"), "{error}");
}

#[test]
fn box_vertex_colors_are_read() {
    let scene = load_gltf(&sample("BoxVertexColors.gltf")).expect("BoxVertexColors loads");
    let mesh = &scene.meshes[0];
    let colors = mesh.colors.as_ref().expect("COLOR_0");
    assert_eq!(colors.len(), mesh.positions.len());
    assert!(colors.iter().any(|c| *c != colors[0]), "colours vary");
}

#[test]
fn animated_samples_load_their_channels_and_rigged_ones_their_rest_pose_with_a_warning() {
    for name in ["AnimatedTriangle.gltf", "BoxAnimated.gltf"] {
        let (scene, _) = scene::load(&sample(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let animation = scene.animation.as_ref().unwrap_or_else(|| panic!("{name}: animated"));
        assert!(animation.duration > 0.0, "{name}: {}", animation.duration);
    }
    for (name, warning) in [
        ("SimpleSkin.gltf", "loaded in their bind pose"),
        ("RiggedSimple.gltf", "loaded in their bind pose"),
        ("SimpleMorph.gltf", "default weights"),
    ] {
        let (result, logs) = common::capture_logs(|| scene::load(&sample(name)));
        let (scene, _) = result.unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!scene.meshes.is_empty(), "{name}: has meshes");
        assert!(logs.contains(warning), "{name}: warns: {logs}");
    }
    // SimpleMorph's rest pose is the base plus 0.5 × each of its two targets.
    let scene = load_gltf(&sample("SimpleMorph.gltf")).expect("SimpleMorph loads");
    assert!(
        close(scene.meshes[0].positions[2], Vec3::new(0.5, 1.5, 0.0)),
        "{}",
        scene.meshes[0].positions[2]
    );
}

#[test]
fn every_sample_loads_and_validates() {
    for entry in std::fs::read_dir(data("gltf-samples")).expect("samples dir") {
        let path = entry.expect("dir entry").path();
        if path.extension().is_some_and(|e| e == "gltf") {
            let (scene, _) = scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(triangle_count(&scene) > 0, "{}: no triangles", path.display());
        }
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Geometry handling

#[test]
fn mirroring_transform_flips_winding_so_the_front_face_stays_with_the_normal() {
    let dir = temp_dir("mirror");
    let path = write(&dir, "mirror.gltf", &triangle_gltf(r#","scale":[-1,1,1]"#, "", ""));
    let scene = load_gltf(&path).expect("mirrored triangle loads");
    let mesh = &scene.meshes[0];
    let [a, b, c] = mesh.indices[0].map(|i| mesh.positions[i as usize]);
    let geometric = (b - a).cross(c - a).normalize();
    let shading = mesh.normals.as_ref().expect("normals")[0];
    assert!(close(geometric, shading), "CCW normal {geometric} agrees with NORMAL {shading}");
    assert!(close(shading, Vec3::Z));
}

#[test]
fn triangle_strips_and_fans_become_triangle_lists() {
    const QUAD: &str = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAACAPwAAgD8AAAAAAAABAAMAAgA=";
    let dir = temp_dir("strips");
    for (mode, indices) in [(5, ""), (6, r#","indices":1"#)] {
        let text = format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":{mode}{indices}}}]}}],
            "buffers":[{{"byteLength":56,"uri":"data:application/octet-stream;base64,{QUAD}"}}],
            "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":8}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":4,"type":"SCALAR"}}]}}"#
        );
        let path = write(&dir, &format!("mode{mode}.gltf"), &text);
        let scene = load_gltf(&path).unwrap_or_else(|e| panic!("mode {mode}: {e}"));
        let mesh = &scene.meshes[0];
        assert_eq!(mesh.indices.len(), 2, "mode {mode}: a quad is two triangles");
        for t in &mesh.indices {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            assert!(close((b - a).cross(c - a), Vec3::Z), "mode {mode}: triangle {t:?} is CCW seen from +Z");
        }
    }
}

#[test]
fn glb_file_with_a_bin_chunk_loads() {
    let json = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"buffers":[{"byteLength":36}],
        "bufferViews":[{"buffer":0,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}"#;
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let bin: Vec<u8> =
        [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let path = temp_dir("glb").join("triangle.glb");
    std::fs::write(&path, glb).expect("write glb");
    let scene = load_gltf(&path).expect("glb loads");
    assert_eq!(scene.meshes[0].positions[1], Vec3::X);
}

#[test]
fn external_buffer_is_read_next_to_the_file() {
    let dir = temp_dir("external");
    let bytes: Vec<u8> =
        [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    std::fs::write(dir.join("tri.bin"), bytes).expect("write bin");
    let text = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"buffers":[{"byteLength":36,"uri":"tri.bin"}],
        "bufferViews":[{"buffer":0,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}"#;
    let scene = load_gltf(&write(&dir, "external.gltf", text)).expect("external buffer loads");
    assert_eq!(scene.meshes[0].positions[2], Vec3::Y);

    let missing = write(&dir, "missing.gltf", &text.replace("tri.bin", "missing.bin"));
    let error = load_gltf(&missing).expect_err("missing buffer");
    assert!(matches!(error, Error::Gltf { .. }), "{error:?}");
    assert_names_file(&error, &missing);
    assert!(error.to_string().contains("missing.bin"), "names the buffer: {error}");
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    // Three triangles: a good one, one with a repeated vertex, one with collinear vertices.
    const BUFFER: &str = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAACAPwAAgD8AAIA/AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAQAAAAAAAAAAA";
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"name":"junk","mesh":0}}],
        "meshes":[{{"name":"m","primitives":[{{"attributes":{{"POSITION":0}},"material":0}},{{"attributes":{{"POSITION":1}},"material":0}}]}}],
        "materials":[{{"emissiveFactor":[1,1,1]}}],
        "buffers":[{{"byteLength":108,"uri":"data:application/octet-stream;base64,{BUFFER}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":108}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":9,"type":"VEC3","min":[0,0,0],"max":[2,1,1]}},
                     {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":6,"type":"VEC3","min":[0,0,0],"max":[2,1,1]}}]}}"#
    );
    let path = write(&temp_dir("degenerate"), "degenerate.gltf", &text);
    let mut scene = load_gltf(&path).expect("loads");
    assert_eq!(scene.meshes.len(), 2);
    let (summary, logs) =
        common::capture_logs(|| validate(&mut scene, &path).expect("degenerate triangles are not errors"));
    assert_eq!(summary.degenerate_triangles, 4);
    assert_eq!(summary.degenerate_emitter_triangles, 4);
    assert_eq!((summary.triangles, summary.emitter_triangles), (1, 1));
    assert_eq!((summary.meshes, summary.removed_meshes), (1, 1), "the all-degenerate primitive is removed");
    assert_eq!(scene.meshes.len(), 1);
    assert_eq!(scene.meshes[0].indices, vec![[0, 1, 2]]);
    assert_eq!(logs.matches("dropped").count(), 1, "one warning for both meshes: {logs}");
    assert!(
        logs.contains("dropped 4 zero-area emitting triangle(s) (they would be lights of no area) in 2 meshes, 1 of them left empty"),
        "{logs}"
    );
    assert!(logs.contains("node 'junk' (#0) mesh 'm' (#0) primitive 1 (2)"), "names the mesh: {logs}");
}

/// Many meshes with the same defect give one warning that counts them and names the first few, not a
/// line each (Khronos' MetalRoughSpheresNoTextures: 98 meshes, two degenerate triangles each).
#[test]
fn many_meshes_with_degenerate_triangles_give_one_warning() {
    use caustica::scene::{Mesh, Scene};
    use caustica::test_scenes::diffuse;
    use glam::Vec3;
    let mesh = |i: usize| Mesh {
        name: format!("sphere {i}"),
        // A good triangle, then two with a repeated vertex.
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        indices: vec![[0, 1, 2], [0, 0, 1], [1, 2, 2]],
        material: 0,
        ..Mesh::default()
    };
    let empty = |i: usize| Mesh { name: format!("empty {i}"), indices: vec![], ..mesh(i) };
    let mut scene = Scene {
        meshes: (0..98).map(mesh).chain((0..2).map(empty)).collect(),
        materials: vec![diffuse("grey", Vec3::splat(0.5), Vec3::ZERO)],
        ..Scene::default()
    };
    let path = std::path::Path::new("spheres.gltf");
    let (summary, logs) = common::capture_logs(|| validate(&mut scene, path).expect("not an error"));
    assert_eq!(summary.degenerate_triangles, 196);
    assert_eq!(logs.matches("dropped").count(), 1, "one warning: {logs}");
    assert!(logs.contains("2 meshes have no triangles, removed: empty 0; empty 1"), "{logs}");
    assert!(logs.contains("dropped 196 degenerate triangle(s) (zero area or not finite) in 98 meshes: sphere 0 (2); sphere 1 (2); sphere 2 (2); 95 more"), "{logs}");
}

#[test]
fn scene_without_emitters_loads() {
    // Lighting it is the world build's business (tests/environment.rs): loading is not an error.
    let path = write(&temp_dir("no-lights"), "dark.gltf", &triangle_gltf("", "", ""));
    let (scene, _) = scene::load(&path).expect("a dark scene is not an error");
    assert_eq!(triangle_count(&scene), 1);
    assert!(scene.environment.is_none());
    let lit = write(&temp_dir("lit"), "lit.gltf", &triangle_gltf("", r#","material":0"#, EMISSIVE));
    let (scene, _) = scene::load(&lit).expect("lit scene loads");
    assert!(scene.materials[0].emission.max_element() > 0.0);
}

// ---------------------------------------------------------------------------------------------------------------
// Run files

#[test]
fn run_file_loads_its_gltf_adds_spheres_and_applies_motion() {
    let dir = temp_dir("run-ok");
    let run = format!(
        r#"gltf = "{}"
[render]
spp = 4
[camera]
name = "camera"
[[sphere]]
name = "ball"
center = [0.0, 0.2, 0.0]
radius = 0.1
material = {{ transmission = 1.0, ior = 1.33, roughness = 0.0, specular = 1.0 }}
motion = [0.0, 0.1, 0.0]
[[motion]]
node = "short_block"
translate = [0.05, 0.0, 0.0]
"#,
        data("cornell-box.gltf").display()
    );
    let path = write(&dir, "run.toml", &run);
    let (scene, run) = scene::load(&path).expect("run file loads");
    assert_eq!(run.render.spp, 4);
    assert_eq!(scene.spheres.len(), 1);
    let sphere = &scene.spheres[0];
    assert_eq!(
        (sphere.name.as_str(), sphere.radius, sphere.motion),
        ("ball", 0.1, Some(Vec3::new(0.0, 0.1, 0.0)))
    );
    let material = &scene.materials[sphere.material as usize];
    assert_eq!(
        (material.name.as_str(), material.shading.transmission, material.shading.ior),
        ("ball", 1.0, 1.33)
    );
    assert!(material.double_sided && material.shading.thickness > 0.0);
    let moving: Vec<_> = scene.meshes.iter().filter(|m| m.motion.is_some()).collect();
    assert_eq!(moving.len(), 1);
    assert_eq!(moving[0].node_name.as_deref(), Some("short_block"));
    assert_eq!(moving[0].motion, Some(Vec3::new(0.05, 0.0, 0.0)));
    assert_eq!(triangle_count(&scene), 36);
}

#[test]
fn run_file_with_only_spheres_needs_no_gltf() {
    let dir = temp_dir("run-spheres");
    let path = write(
        &dir,
        "spheres.toml",
        "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = { emission = [1, 1, 1] }\n",
    );
    let (scene, _) = scene::load(&path).expect("spheres-only run file loads");
    assert!(scene.meshes.is_empty() && scene.camera.is_none());
    assert_eq!(scene.spheres[0].name, "sphere #0");
}

// ---------------------------------------------------------------------------------------------------------------
// Bad input: the variant, and a message that names the file

#[test]
fn missing_file_is_an_io_error() {
    let path = temp_dir("missing").join("nothing-here.gltf");
    let error = scene::load(&path).expect_err("missing file");
    assert!(matches!(error, Error::Io { .. }), "{error:?}");
    assert_names_file(&error, &path);
}

#[test]
fn text_file_that_is_not_gltf_is_rejected() {
    let path = write(&temp_dir("not-gltf"), "notes.gltf", "These are my shopping notes, not a scene.\n");
    let error = scene::load(&path).expect_err("not glTF");
    assert!(matches!(error, Error::Gltf { .. }), "{error:?}");
    assert_names_file(&error, &path);
}

#[test]
fn truncated_json_is_rejected() {
    let full = triangle_gltf("", "", "");
    let path = write(&temp_dir("truncated"), "truncated.gltf", &full[..full.len() / 2]);
    let error = scene::load(&path).expect_err("truncated JSON");
    assert!(matches!(error, Error::Gltf { .. }), "{error:?}");
    assert_names_file(&error, &path);
}

#[test]
fn non_finite_node_transforms_are_rejected() {
    // JSON has no NaN; 1e39 overflows float32 to infinity, and two finite 1e30 scales overflow when composed.
    let dir = temp_dir("non-finite");
    let matrix = r#","matrix":[1e39,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]"#;
    let overflow = triangle_gltf(r#","scale":[1e30,1e30,1e30]"#, "", "").replace(
        r#""nodes":[{"name":"tri""#,
        r#""nodes":[{"name":"outer","children":[1],"scale":[1e30,1e30,1e30]},{"name":"tri""#,
    );
    for (name, text) in [("matrix.gltf", triangle_gltf(matrix, "", "")), ("overflow.gltf", overflow)] {
        let path = write(&dir, name, &text);
        let error = load_gltf(&path).expect_err(name);
        assert!(matches!(error, Error::InvalidScene { .. }), "{name}: {error:?}");
        assert_names_file(&error, &path);
        assert!(error.to_string().contains("node 'tri'"), "{name}: names the node: {error}");
    }
}

#[test]
fn zero_scale_transform_is_rejected_as_singular() {
    let path = write(&temp_dir("singular"), "flat.gltf", &triangle_gltf(r#","scale":[1,0,1]"#, "", ""));
    let error = load_gltf(&path).expect_err("singular transform");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(message.contains("node 'tri' (#0)") && message.contains("singular"), "{message}");
}

#[test]
fn points_primitive_is_rejected_naming_mesh_and_primitive() {
    let path = write(&temp_dir("points"), "points.gltf", &triangle_gltf("", r#","mode":0"#, ""));
    let error = load_gltf(&path).expect_err("POINTS");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(
        message.contains("mesh 'm' (#0) primitive 0") && message.contains("unsupported primitive mode"),
        "{message}"
    );
}

#[test]
fn run_file_with_bad_toml_is_rejected() {
    let path = write(&temp_dir("bad-toml"), "bad.toml", "gltf = \"scene.gltf\n[render\nspp = \n");
    let error = scene::load(&path).expect_err("bad TOML");
    assert!(matches!(error, Error::RunFile { .. }), "{error:?}");
    assert_names_file(&error, &path);
}

#[test]
fn run_file_with_an_unknown_key_names_the_key() {
    let path = write(&temp_dir("unknown-key"), "typo.toml", "[render]\nspp = 4\nsamples_per_pixel = 16\n");
    let error = scene::load(&path).expect_err("unknown key");
    assert!(matches!(error, Error::RunFile { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(message.contains("samples_per_pixel") && message.contains("[render]"), "{message}");
}

#[test]
fn run_file_whose_gltf_is_missing_names_both_paths() {
    let dir = temp_dir("missing-gltf");
    let path = write(&dir, "run.toml", "gltf = \"scenes/absent.gltf\"\n");
    let error = scene::load(&path).expect_err("missing glTF");
    assert!(matches!(error, Error::Io { .. }), "{error:?}");
    let message = error.to_string();
    assert!(message.contains("\"scenes/absent.gltf\""), "path as written: {message}");
    assert!(
        message.contains(&dir.join("scenes/absent.gltf").display().to_string()),
        "resolved path: {message}"
    );
    assert_names_file(&error, &path);
}

#[test]
fn motion_naming_an_unknown_node_lists_the_nodes() {
    let run = format!(
        "gltf = \"{}\"\n[[motion]]\nnode = \"big_block\"\ntranslate = [0, 1, 0]\n",
        data("cornell-box.gltf").display()
    );
    let path = write(&temp_dir("unknown-node"), "run.toml", &run);
    let error = scene::load(&path).expect_err("unknown node");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(message.contains("big_block") && message.contains("tall_block"), "{message}");
}

#[test]
fn sphere_with_negative_radius_is_rejected() {
    let path = write(
        &temp_dir("negative-radius"),
        "run.toml",
        "[[sphere]]\nname = \"bad\"\ncenter = [0, 0, 0]\nradius = -1\n",
    );
    let error = scene::load(&path).expect_err("negative radius");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    assert!(error.to_string().contains("sphere 'bad'"), "{error}");
}

/// Radiance that would overflow single-precision sums is refused at load, naming the object: an
/// emitter of 3e38 once loaded and rendered black where the glass ball should glow.
#[test]
fn radiance_and_power_beyond_what_f32_sums_hold_are_refused_naming_the_object() {
    let dir = temp_dir("overflow");
    let lamp = |emission: &str, radius: &str| {
        format!(
            "[[sphere]]\nname = \"lamp\"\ncenter = [0, 0, 0]\nradius = {radius}\n\
             material = {{ emission = [{emission}, 1, 1] }}\n"
        )
    };
    let path = write(&dir, "hot.toml", &lamp("3e38", "0.1"));
    let error = scene::load(&path).expect_err("radiance 3e38").to_string();
    assert!(error.contains("material 'lamp'") && error.contains("1e20") && error.contains("3e38"), "{error}");
    assert_names_file(&scene::load(&path).unwrap_err(), &path);

    // 1e20 is allowed, but a sphere of 100 km radiating it has a power of 3.9e31 W.
    let path = write(&dir, "big.toml", &lamp("1e20", "1e5"));
    let error = scene::load(&path).expect_err("power").to_string();
    assert!(error.contains("sphere 'lamp'") && error.contains("total power"), "{error}");
    assert!(scene::load(&write(&dir, "ok.toml", &lamp("1e20", "0.1"))).is_ok());

    let path =
        write(&dir, "sky.toml", &format!("{}\n[environment]\ncolor = [1e25, 1, 1]\n", lamp("1", "0.1")));
    let error = scene::load(&path).expect_err("environment 1e25").to_string();
    assert!(error.contains("environment") && error.contains("1e20"), "{error}");
    let path = write(
        &dir,
        "strong.toml",
        &format!("{}\n[environment]\ncolor = [1e10, 1, 1]\nstrength = 1e15\n", lamp("1", "0.1")),
    );
    let error = scene::load(&path).expect_err("strength × colour").to_string();
    assert!(error.contains("with its strength"), "{error}");
}

#[test]
fn unknown_file_extension_is_rejected() {
    let path = write(&temp_dir("extension"), "scene.obj", "v 0 0 0\n");
    let error = scene::load(&path).expect_err("unknown extension");
    assert!(matches!(error, Error::UnknownFormat { .. }), "{error:?}");
    assert_names_file(&error, &path);
}

#[test]
fn negative_emission_is_rejected_naming_the_material() {
    let materials = r#""materials":[{"name":"antilight","emissiveFactor":[1,1,1],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":-2}}}],"#;
    let path =
        write(&temp_dir("negative-emission"), "neg.gltf", &triangle_gltf("", r#","material":0"#, materials));
    let error = scene::load(&path).expect_err("negative emission");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    assert!(error.to_string().contains("material 'antilight'"), "{error}");
}

// ---------------------------------------------------------------------------------------------------------------
// Loader cases, each on the smallest hand-built file that has it

/// Standard padded base64 (RFC 4648), for data URIs.
pub(crate) fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for i in 0..4 {
            out.push(if i <= chunk.len() {
                ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}

/// A buffer built by a test: data appended at 4-byte-aligned offsets, as glTF requires for vertex attributes.
#[derive(Default)]
struct Bin(Vec<u8>);

impl Bin {
    /// Appends `bytes`; returns their offset.
    fn push(&mut self, bytes: &[u8]) -> usize {
        self.0.resize(self.0.len().next_multiple_of(4), 0);
        let offset = self.0.len();
        self.0.extend_from_slice(bytes);
        offset
    }

    fn f32(&mut self, values: &[f32]) -> usize {
        self.push(&values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())
    }

    fn u16(&mut self, values: &[u16]) -> usize {
        self.push(&values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())
    }

    /// `"buffers":[...],` with the data as a base64 data URI.
    fn json(&self) -> String {
        format!(
            r#""buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],"#,
            self.0.len(),
            base64(&self.0)
        )
    }
}

/// The unit triangle (0,0,0), (1,0,0), (0,1,0): counter-clockwise seen from +Z.
const UNIT_TRIANGLE: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// A file whose one scene holds node 'n' with mesh 'm'; `primitives`, `views` and `accessors` are the contents of
/// those JSON arrays, `rest` adds top-level members (each ending with a comma).
fn mesh_gltf(bin: &Bin, views: &str, accessors: &str, primitives: &str, rest: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"name":"n","mesh":0}}],
        "meshes":[{{"name":"m","primitives":[{primitives}]}}],{rest}{buffers}
        "bufferViews":[{views}],"accessors":[{accessors}]}}"#,
        buffers = bin.json()
    )
}

/// POSITION accessor over the unit triangle at `offset` of bufferView `view`.
fn unit_triangle_accessor(view: usize, offset: usize) -> String {
    format!(
        r#"{{"bufferView":{view},"byteOffset":{offset},"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}"#
    )
}

/// An encoded RGB image (`format` png or jpeg) of `width` × `height` texels, row-major from the top.
fn encode_image(width: u32, height: u32, texels: &[[u8; 3]], format: image::ImageFormat) -> Vec<u8> {
    let image = image::RgbImage::from_raw(width, height, texels.concat()).expect("texel count");
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), format).expect("encode image");
    bytes
}

fn png_data_uri(width: u32, height: u32, texels: &[[u8; 3]]) -> String {
    format!("data:image/png;base64,{}", base64(&encode_image(width, height, texels, image::ImageFormat::Png)))
}

/// The surface hit and resolved material where a ray down -Z through (x, y) meets the scene.
fn shade(scene: &Scene, x: f32, y: f32) -> (SurfaceHit, ShadingParams) {
    let geometry = caustica::RenderScene::build(scene, LightSelection::Uniform);
    // Not `-Vec3::Z`: obvhs 0.4 takes a -0.0 component for a positive direction in its octant but a negative one
    // in its inverse direction, and the traversal misses.
    let ray = Ray { o: Vec3::new(x, y, 1.0), d: Vec3::new(0.0, 0.0, -1.0), t_max: f32::INFINITY, time: 0.0 };
    let hit = geometry.geometry.intersect(&ray);
    assert!(hit.is_hit(), "the ray through ({x}, {y}) misses");
    let si = geometry.geometry.surface_hit(&ray, &hit);
    (si, geometry.shading_params(&si))
}

fn close2(a: Vec2, b: Vec2) -> bool {
    (a - b).abs().max_element() < 1e-6
}

#[test]
fn sparse_accessors_substitute_values_over_a_buffer_view_and_over_zeros() {
    let mut bin = Bin::default();
    // Vertex 1 of the base is wrong on purpose: the sparse value must replace it.
    let base = bin.f32(&[0.0, 0.0, 0.0, 9.0, 9.0, 9.0, 0.0, 1.0, 0.0]);
    let position_index = bin.push(&[1]);
    let position_value = bin.f32(&[1.0, 0.0, 0.0]);
    let uv_indices = bin.u16(&[0, 2]);
    let uv_values = bin.f32(&[0.25, 0.5, 0.75, 1.0]);
    let views = format!(
        r#"{{"buffer":0,"byteOffset":{base},"byteLength":36}},{{"buffer":0,"byteOffset":{position_index},"byteLength":1}},
        {{"buffer":0,"byteOffset":{position_value},"byteLength":12}},{{"buffer":0,"byteOffset":{uv_indices},"byteLength":4}},
        {{"buffer":0,"byteOffset":{uv_values},"byteLength":16}}"#
    );
    let accessors = r#"{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0],
            "sparse":{"count":1,"indices":{"bufferView":1,"componentType":5121},"values":{"bufferView":2}}},
        {"componentType":5126,"count":3,"type":"VEC2",
            "sparse":{"count":2,"indices":{"bufferView":3,"componentType":5123},"values":{"bufferView":4}}}"#;
    let text = mesh_gltf(&bin, &views, accessors, r#"{"attributes":{"POSITION":0,"TEXCOORD_0":1}}"#, "");
    let path = write(&temp_dir("sparse"), "sparse.gltf", &text);
    let (scene, _) = scene::load(&path).expect("sparse accessors load");
    let mesh = &scene.meshes[0];
    assert_eq!(
        mesh.positions,
        vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        "base from the view, vertex 1 from sparse"
    );
    assert_eq!(
        mesh.uvs[0],
        vec![Vec2::new(0.25, 0.5), Vec2::ZERO, Vec2::new(0.75, 1.0)],
        "no bufferView: zeros, with the sparse values at indices 0 and 2"
    );
}

#[test]
fn accessor_without_buffer_view_or_sparse_reads_as_zeros() {
    // glTF 2.0 accessor.bufferView: "When undefined, the accessor MUST be initialized with zeros".
    let mut bin = Bin::default();
    bin.f32(&UNIT_TRIANGLE);
    let accessors =
        format!(r#"{},{{"componentType":5126,"count":3,"type":"VEC2"}}"#, unit_triangle_accessor(0, 0));
    let primitives = r#"{"attributes":{"POSITION":0,"TEXCOORD_0":1}}"#;
    let text = mesh_gltf(&bin, r#"{"buffer":0,"byteLength":36}"#, &accessors, primitives, "");
    let path = write(&temp_dir("zeros"), "zeros.gltf", &text);
    let (scene, _) = scene::load(&path).expect("an accessor without bufferView is valid glTF");
    assert_eq!(scene.meshes[0].uvs[0], vec![Vec2::ZERO; 3]);
}

#[test]
fn interleaved_position_normal_and_uv_with_byte_stride_32_are_read() {
    let normals = [Vec3::Z, Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.6, 0.0, 0.8)];
    let uvs = [Vec2::new(0.1, 0.2), Vec2::new(0.3, 0.4), Vec2::new(0.5, 0.6)];
    let mut vertices = Vec::new();
    for i in 0..3 {
        vertices.extend_from_slice(&UNIT_TRIANGLE[3 * i..3 * i + 3]);
        vertices.extend_from_slice(&normals[i].to_array());
        vertices.extend_from_slice(&uvs[i].to_array());
    }
    let mut bin = Bin::default();
    bin.f32(&vertices);
    assert_eq!(bin.0.len(), 96, "three 32-byte vertices");
    let views = r#"{"buffer":0,"byteLength":96,"byteStride":32,"target":34962}"#;
    let accessors = format!(
        r#"{},{{"bufferView":0,"byteOffset":12,"componentType":5126,"count":3,"type":"VEC3"}},
        {{"bufferView":0,"byteOffset":24,"componentType":5126,"count":3,"type":"VEC2"}}"#,
        unit_triangle_accessor(0, 0)
    );
    let primitives = r#"{"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}}"#;
    let path = write(
        &temp_dir("interleaved"),
        "interleaved.gltf",
        &mesh_gltf(&bin, views, &accessors, primitives, ""),
    );
    let (scene, _) = scene::load(&path).expect("interleaved view loads");
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
    let read = mesh.normals.as_ref().expect("NORMAL");
    assert!(read.iter().zip(normals).all(|(a, b)| close(*a, b)), "normals {read:?}");
    assert_eq!(mesh.uvs[0], uvs.to_vec());
}

#[test]
fn normalized_integer_uvs_and_colours_come_out_in_the_unit_range() {
    let mut bin = Bin::default();
    let positions = bin.f32(&UNIT_TRIANGLE);
    // Vertex attributes are 4-byte aligned: UNSIGNED_BYTE VEC2 gets byteStride 4, UNSIGNED_SHORT VEC3 byteStride 8.
    let uv8 = bin.push(&[0, 255, 0, 0, 51, 102, 0, 0, 255, 0, 0, 0]);
    let color8 = bin.push(&[255, 0, 51, 255, 0, 255, 102, 0, 128, 128, 128, 128]);
    let uv16 = bin.u16(&[0, 65535, 32768, 13107, 65535, 0]);
    let color16 = bin.u16(&[65535, 0, 13107, 0, 0, 65535, 32768, 0, 1, 2, 3, 0]);
    let views = format!(
        r#"{{"buffer":0,"byteOffset":{positions},"byteLength":36}},
        {{"buffer":0,"byteOffset":{uv8},"byteLength":12,"byteStride":4}},
        {{"buffer":0,"byteOffset":{color8},"byteLength":12}},
        {{"buffer":0,"byteOffset":{uv16},"byteLength":12}},
        {{"buffer":0,"byteOffset":{color16},"byteLength":24,"byteStride":8}}"#
    );
    let accessors = format!(
        r#"{},
        {{"bufferView":1,"componentType":5121,"normalized":true,"count":3,"type":"VEC2"}},
        {{"bufferView":2,"componentType":5121,"normalized":true,"count":3,"type":"VEC4"}},
        {{"bufferView":3,"componentType":5123,"normalized":true,"count":3,"type":"VEC2"}},
        {{"bufferView":4,"componentType":5123,"normalized":true,"count":3,"type":"VEC3"}}"#,
        unit_triangle_accessor(0, 0)
    );
    let primitives = r#"{"attributes":{"POSITION":0,"TEXCOORD_0":1,"COLOR_0":2}},
        {"attributes":{"POSITION":0,"TEXCOORD_0":3,"COLOR_0":4}}"#;
    let path = write(
        &temp_dir("normalized"),
        "normalized.gltf",
        &mesh_gltf(&bin, &views, &accessors, primitives, ""),
    );
    let (scene, _) = scene::load(&path).expect("normalized integer attributes load");
    let (bytes, shorts) = (&scene.meshes[0], &scene.meshes[1]);
    let expect_uvs = |mesh: &scene::Mesh, expected: [Vec2; 3]| {
        assert!(mesh.uvs[0].iter().zip(expected).all(|(a, b)| close2(*a, b)), "uvs {:?}", mesh.uvs[0]);
    };
    expect_uvs(bytes, [Vec2::Y, Vec2::new(0.2, 0.4), Vec2::X]);
    expect_uvs(shorts, [Vec2::Y, Vec2::new(32768.0 / 65535.0, 0.2), Vec2::X]);
    let expect_colors = |mesh: &scene::Mesh, expected: [Vec3; 3]| {
        let colors = mesh.colors.as_ref().expect("COLOR_0");
        assert!(colors.iter().zip(expected).all(|(a, b)| close(*a, b)), "colours {colors:?}");
    };
    expect_colors(bytes, [Vec3::new(1.0, 0.0, 0.2), Vec3::new(0.0, 1.0, 0.4), Vec3::splat(128.0 / 255.0)]);
    let [a, b, c] = [1.0, 2.0, 3.0].map(|v| v / 65535.0);
    expect_colors(
        shorts,
        [Vec3::new(1.0, 0.0, 0.2), Vec3::new(0.0, 1.0, 32768.0 / 65535.0), Vec3::new(a, b, c)],
    );
    for mesh in &scene.meshes {
        let values = mesh.uvs[0].iter().flat_map(|v| v.to_array());
        let values = values.chain(mesh.colors.iter().flatten().flat_map(|c| c.to_array()));
        assert!(values.clone().all(|v| (0.0..=1.0).contains(&v)), "{:?}", values.collect::<Vec<_>>());
    }
}

#[test]
fn integer_attribute_not_marked_normalized_is_rejected() {
    let mut bin = Bin::default();
    bin.f32(&UNIT_TRIANGLE);
    let uv = bin.push(&[0, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0]);
    let views = format!(
        r#"{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":{uv},"byteLength":12,"byteStride":4}}"#
    );
    let accessors = format!(
        r#"{},{{"name":"raw","bufferView":1,"componentType":5121,"count":3,"type":"VEC2"}}"#,
        unit_triangle_accessor(0, 0)
    );
    let primitives = r#"{"attributes":{"POSITION":0,"TEXCOORD_0":1}}"#;
    let path =
        write(&temp_dir("unnormalized"), "raw.gltf", &mesh_gltf(&bin, &views, &accessors, primitives, ""));
    let error = load_gltf(&path).expect_err("unnormalized UNSIGNED_BYTE texture coordinates");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(
        message.contains("TEXCOORD_0") && message.contains("'raw'") && message.contains("normalized"),
        "{message}"
    );
}

#[test]
fn primitive_without_indices_draws_its_vertices_in_order() {
    let mut bin = Bin::default();
    // Two triangles and one vertex too many.
    bin.f32(&[
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 3.0, 0.0, 0.0, 2.0, 1.0, 0.0, 5.0, 5.0,
        0.0,
    ]);
    let accessors =
        r#"{"bufferView":0,"componentType":5126,"count":7,"type":"VEC3","min":[0,0,0],"max":[5,5,0]}"#;
    let text =
        mesh_gltf(&bin, r#"{"buffer":0,"byteLength":84}"#, accessors, r#"{"attributes":{"POSITION":0}}"#, "");
    let path = write(&temp_dir("no-indices"), "no-indices.gltf", &text);
    let (scene, logs) = common::capture_logs(|| load_gltf(&path).expect("loads"));
    assert_eq!(scene.meshes[0].indices, vec![[0, 1, 2], [3, 4, 5]]);
    assert!(logs.contains("1 trailing index(es)"), "the seventh vertex is reported: {logs}");
}

#[test]
fn primitive_without_normals_is_shaded_with_flat_normals() {
    let mut bin = Bin::default();
    bin.f32(&UNIT_TRIANGLE);
    let text = mesh_gltf(
        &bin,
        r#"{"buffer":0,"byteLength":36}"#,
        &unit_triangle_accessor(0, 0),
        r#"{"attributes":{"POSITION":0}}"#,
        "",
    );
    let path = write(&temp_dir("no-normals"), "flat.gltf", &text);
    let (scene, _) = scene::load(&path).expect("loads");
    assert!(scene.meshes[0].normals.is_none(), "no NORMAL means flat normals");
    let (si, _) = shade(&scene, 0.25, 0.25);
    assert!(close(si.ng, Vec3::Z) && si.ns == si.ng, "flat: ns {} = ng {}", si.ns, si.ng);
}

#[test]
fn base_color_texture_with_tex_coord_1_is_shaded_from_texcoord_1() {
    // Texel 0 red, texel 1 blue; TEXCOORD_0 points at red, TEXCOORD_1 at blue.
    let uri = png_data_uri(2, 1, &[[255, 0, 0], [0, 0, 255]]);
    let mut bin = Bin::default();
    bin.f32(&UNIT_TRIANGLE);
    let uv0 = bin.f32(&[0.25, 0.5, 0.25, 0.5, 0.25, 0.5]);
    let uv1 = bin.f32(&[0.75, 0.5, 0.75, 0.5, 0.75, 0.5]);
    let views = format!(
        r#"{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":{uv0},"byteLength":24}},
        {{"buffer":0,"byteOffset":{uv1},"byteLength":24}}"#
    );
    let accessors = format!(
        r#"{},{{"bufferView":1,"componentType":5126,"count":3,"type":"VEC2"}},
        {{"bufferView":2,"componentType":5126,"count":3,"type":"VEC2"}}"#,
        unit_triangle_accessor(0, 0)
    );
    let rest = format!(
        r#""materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"texCoord":1}}}}}}],
        "textures":[{{"source":0,"sampler":0}}],"samplers":[{{"wrapS":33071,"wrapT":33071}}],
        "images":[{{"uri":"{uri}"}}],"#
    );
    let primitives = r#"{"attributes":{"POSITION":0,"TEXCOORD_0":1,"TEXCOORD_1":2},"material":0}"#;
    let path =
        write(&temp_dir("uv-sets"), "uv1.gltf", &mesh_gltf(&bin, &views, &accessors, primitives, &rest));
    let (scene, _) = scene::load(&path).expect("two uv sets load");
    assert_eq!(scene.materials[0].base_color_texture.expect("texture").tex_coord, 1);
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.uvs.len(), 2, "both sets read");
    assert_eq!(mesh.uvs[1], vec![Vec2::new(0.75, 0.5); 3]);
    let (si, params) = shade(&scene, 0.25, 0.25);
    assert!(close2(si.uv[0], Vec2::new(0.25, 0.5)) && close2(si.uv[1], Vec2::new(0.75, 0.5)), "{:?}", si.uv);
    assert!(
        close(params.base_color, Vec3::Z),
        "blue from TEXCOORD_1, not red from TEXCOORD_0: {}",
        params.base_color
    );
}

#[test]
fn texture_reading_a_uv_set_shading_does_not_carry_is_rejected() {
    let uri = png_data_uri(1, 1, &[[255, 255, 255]]);
    let rest = format!(
        r#""materials":[{{"name":"third","pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"texCoord":2}}}}}}],
        "textures":[{{"source":0}}],"images":[{{"uri":"{uri}"}}],"#
    );
    let path = write(&temp_dir("uv-set-2"), "uv2.gltf", &triangle_gltf("", r#","material":0"#, &rest));
    let error = load_gltf(&path).expect_err("TEXCOORD_2");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(message.contains("material 'third'") && message.contains("TEXCOORD_2"), "{message}");
}

#[test]
fn vertex_colour_multiplies_the_base_colour_factor() {
    let mut bin = Bin::default();
    bin.f32(&UNIT_TRIANGLE);
    let colors = bin.f32(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    let views =
        format!(r#"{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":{colors},"byteLength":36}}"#);
    let accessors = format!(
        r#"{},{{"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"}}"#,
        unit_triangle_accessor(0, 0)
    );
    let rest = r#""materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.5,0.8,1.0,1.0]}}],"#;
    let primitives = r#"{"attributes":{"POSITION":0,"COLOR_0":1},"material":0}"#;
    let path = write(
        &temp_dir("vertex-colors"),
        "colors.gltf",
        &mesh_gltf(&bin, &views, &accessors, primitives, rest),
    );
    let (scene, _) = scene::load(&path).expect("loads");
    // At (0.25, 0.25) the barycentric weights are 0.5, 0.25, 0.25.
    let (si, params) = shade(&scene, 0.25, 0.25);
    let color = Vec3::new(0.5, 0.25, 0.25);
    assert!(close(si.color, color), "interpolated colour {}", si.color);
    assert!(
        close(params.base_color, Vec3::new(0.5, 0.8, 1.0) * color),
        "factor × vertex colour, got {}",
        params.base_color
    );
}

#[test]
fn texture_transform_and_its_tex_coord_override_reach_the_texture_ref() {
    let uri = png_data_uri(1, 1, &[[255, 255, 255]]);
    let rest = format!(
        r#""materials":[{{"pbrMetallicRoughness":{{
            "baseColorTexture":{{"index":0,"texCoord":0,"extensions":{{"KHR_texture_transform":{{
                "offset":[0.25,0.5],"rotation":1.5707964,"scale":[2,3],"texCoord":1}}}}}},
            "metallicRoughnessTexture":{{"index":0,"texCoord":1,"extensions":{{"KHR_texture_transform":{{
                "offset":[0.5,0]}}}}}}}}}}],
        "extensionsUsed":["KHR_texture_transform"],
        "textures":[{{"source":0}}],"images":[{{"uri":"{uri}"}}],"#
    );
    let path = write(
        &temp_dir("texture-transform"),
        "transform.gltf",
        &triangle_gltf("", r#","material":0"#, &rest),
    );
    let scene = load_gltf(&path).expect("loads");
    let material = &scene.materials[0];
    let color = material.base_color_texture.expect("base colour texture");
    assert_eq!(color.tex_coord, 1, "the extension's texCoord overrides the textureInfo's");
    // T · R · S with R rotating counter-clockwise in uv space, whose v axis points down (KhronosGroup/glTF#1563).
    let [x, y, offset] = color.transform.expect("transform");
    assert!(close2(x, Vec2::new(0.0, -2.0)) && close2(y, Vec2::new(3.0, 0.0)), "axes {x} {y}");
    assert_eq!(offset, Vec2::new(0.25, 0.5));
    let data = material.metallic_roughness_texture.expect("metallic-roughness texture");
    assert_eq!(data.tex_coord, 1, "without an override the textureInfo's texCoord stays");
    assert_eq!(
        data.transform,
        Some([Vec2::X, Vec2::Y, Vec2::new(0.5, 0.0)]),
        "defaults: no rotation, unit scale"
    );
}

#[test]
fn sampler_wrap_modes_are_read_per_axis_and_honoured_by_sample() {
    // 2×2: red, green / blue, white; 0 and 255 are the same in sRGB and linear.
    let uri = png_data_uri(2, 2, &[[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]);
    let materials: Vec<String> = (0..4)
        .map(|i| format!(r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":{i}}}}}}}"#))
        .collect();
    let rest = format!(
        r#""materials":[{}],
        "textures":[{{"source":0,"sampler":0}},{{"source":0,"sampler":1}},{{"source":0,"sampler":2}},{{"source":0}}],
        "samplers":[{{"wrapS":10497,"wrapT":33071}},{{"wrapS":33071,"wrapT":33648}},{{"wrapS":33648,"wrapT":10497}}],
        "images":[{{"uri":"{uri}"}}],"#,
        materials.join(",")
    );
    let path = write(&temp_dir("wrap"), "wrap.gltf", &triangle_gltf("", r#","material":0"#, &rest));
    let scene = load_gltf(&path).expect("loads");
    let textures: Vec<&scene::Texture> = scene
        .materials
        .iter()
        .map(|m| &scene.textures[m.base_color_texture.expect("texture").texture as usize])
        .collect();
    let modes: Vec<(Wrap, Wrap)> = textures.iter().map(|t| (t.wrap_s, t.wrap_t)).collect();
    use Wrap::{ClampToEdge, MirroredRepeat, Repeat};
    assert_eq!(
        modes,
        vec![
            (Repeat, ClampToEdge),
            (ClampToEdge, MirroredRepeat),
            (MirroredRepeat, Repeat),
            (Repeat, Repeat)
        ],
        "per axis, and REPEAT without a sampler"
    );
    // Texel centres past either edge: 1.75 is texel 3 and -0.25 texel -1 of a 2-texel axis.
    let wrapped = |wrap: Wrap| match wrap {
        Repeat => [1, 1],
        ClampToEdge => [1, 0],
        MirroredRepeat => [0, 0],
    };
    for texture in textures {
        for (coordinate, expected) in [1.75, -0.25].into_iter().zip(wrapped(texture.wrap_s)) {
            let got = texture.sample(Vec2::new(coordinate, 0.25));
            assert_eq!(got, texture.texel(expected), "wrap_s {:?} at u = {coordinate}", texture.wrap_s);
        }
        for (coordinate, expected) in [1.75, -0.25].into_iter().zip(wrapped(texture.wrap_t)) {
            let got = texture.sample(Vec2::new(0.25, coordinate));
            assert_eq!(got, texture.texel(2 * expected), "wrap_t {:?} at v = {coordinate}", texture.wrap_t);
        }
    }
}

#[test]
fn embedded_and_external_png_and_jpeg_images_are_decoded_and_a_missing_one_is_named() {
    let dir = temp_dir("images");
    std::fs::write(
        dir.join("checker.png"),
        encode_image(2, 1, &[[255, 0, 0], [0, 0, 255]], image::ImageFormat::Png),
    )
    .expect("write png");
    std::fs::write(dir.join("flat.jpg"), encode_image(8, 8, &[[200, 100, 50]; 64], image::ImageFormat::Jpeg))
        .expect("write jpeg");
    let embedded = png_data_uri(1, 1, &[[0, 255, 0]]);
    let materials: Vec<String> = (0..3)
        .map(|i| format!(r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":{i}}}}}}}"#))
        .collect();
    let rest = format!(
        r#""materials":[{}],"textures":[{{"source":0}},{{"source":1}},{{"source":2}}],
        "images":[{{"uri":"{embedded}"}},{{"uri":"checker.png"}},{{"uri":"flat.jpg"}}],"#,
        materials.join(",")
    );
    let text = triangle_gltf("", r#","material":0"#, &rest);
    let scene = load_gltf(&write(&dir, "images.gltf", &text)).expect("images load");
    let texture = |material: usize| {
        &scene.textures[scene.materials[material].base_color_texture.expect("t").texture as usize]
    };
    let (embedded, png, jpeg) = (texture(0), texture(1), texture(2));
    assert_eq!(embedded.texels().collect::<Vec<_>>(), vec![glam::Vec4::new(0.0, 1.0, 0.0, 1.0)]);
    assert_eq!((png.name.as_str(), png.width, png.height), ("checker.png", 2, 1));
    assert_eq!(
        png.texels().collect::<Vec<_>>(),
        vec![glam::Vec4::new(1.0, 0.0, 0.0, 1.0), glam::Vec4::new(0.0, 0.0, 1.0, 1.0)]
    );
    assert_eq!((jpeg.name.as_str(), jpeg.width, jpeg.height), ("flat.jpg", 8, 8));
    let expected = Vec3::new(200.0, 100.0, 50.0).map(|c| srgb_to_linear(c / 255.0));
    for texel in jpeg.texels() {
        // JPEG is lossy; a flat colour survives to within a few levels.
        assert!((texel.truncate() - expected).abs().max_element() < 0.02, "{texel} vs {expected}");
    }

    let missing = write(&dir, "missing.gltf", &text.replace("flat.jpg", "absent.jpg"));
    let error = load_gltf(&missing).expect_err("missing image");
    assert!(matches!(error, Error::Gltf { .. }), "{error:?}");
    assert_names_file(&error, &missing);
    let message = error.to_string();
    assert!(
        message.contains("image #2") && message.contains(&dir.join("absent.jpg").display().to_string()),
        "{message}"
    );
}

#[test]
fn image_in_a_buffer_view_is_decoded_and_one_outside_its_buffer_is_rejected() {
    let png = encode_image(1, 1, &[[0, 0, 255]], image::ImageFormat::Png);
    let mut bin = Bin::default();
    bin.f32(&UNIT_TRIANGLE);
    let image = bin.push(&png);
    let views = |length: usize| {
        format!(r#"{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":{image},"byteLength":{length}}}"#)
    };
    let rest = r#""materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
        "textures":[{"source":0}],"images":[{"bufferView":1,"mimeType":"image/png"}],"#;
    let primitives = r#"{"attributes":{"POSITION":0},"material":0}"#;
    let dir = temp_dir("image-view");
    let text = mesh_gltf(&bin, &views(png.len()), &unit_triangle_accessor(0, 0), primitives, rest);
    let scene = load_gltf(&write(&dir, "view.gltf", &text)).expect("image in a bufferView loads");
    assert_eq!(scene.textures[0].texels().collect::<Vec<_>>(), vec![glam::Vec4::new(0.0, 0.0, 1.0, 1.0)]);

    let text = mesh_gltf(&bin, &views(png.len() + 100), &unit_triangle_accessor(0, 0), primitives, rest);
    let path = write(&dir, "past-the-end.gltf", &text);
    let error = load_gltf(&path).expect_err("bufferView past the end of its buffer");
    assert!(matches!(error, Error::Gltf { .. }), "{error:?}");
    assert_names_file(&error, &path);
    assert!(error.to_string().contains("bufferView #1"), "{error}");
}

#[test]
fn accessor_past_the_end_of_its_buffer_view_is_rejected_even_with_an_absurd_count() {
    let dir = temp_dir("accessor-range");
    for (name, count) in [("seven.gltf", "7"), ("huge.gltf", "4611686018427387904")] {
        let text = triangle_gltf("", "", "").replacen(r#""count":3"#, &format!(r#""count":{count}"#), 1);
        let path = write(&dir, name, &text);
        let error = load_gltf(&path).expect_err(name);
        assert!(matches!(error, Error::InvalidScene { .. }), "{name}: {error:?}");
        assert_names_file(&error, &path);
        let message = error.to_string();
        assert!(message.contains("POSITION") && message.contains("past the end"), "{name}: {message}");
    }
}

#[test]
fn uri_that_is_not_utf_8_once_percent_decoded_is_rejected() {
    let dir = temp_dir("percent");
    let image = r#""materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
        "textures":[{"source":0}],"images":[{"uri":"tex%FF.png"}],"#;
    // %C3%28 is a UTF-8 lead byte followed by '(': not UTF-8.
    let buffer = triangle_gltf("", "", "")
        .replace(&format!("data:application/octet-stream;base64,{TRIANGLE_BUFFER}"), "tri%C3%28.bin");
    let cases = [
        ("image.gltf", triangle_gltf("", r#","material":0"#, image), "image #0"),
        ("buffer.gltf", buffer, "buffer #0"),
    ];
    for (name, text, object) in cases {
        let path = write(&dir, name, &text);
        let error = load_gltf(&path).expect_err(name);
        assert!(matches!(error, Error::Gltf { .. }), "{name}: {error:?}");
        assert_names_file(&error, &path);
        let message = error.to_string();
        assert!(message.contains(object) && message.contains("not UTF-8"), "{name}: {message}");
    }
}

#[test]
fn the_default_scene_is_loaded_and_without_one_the_first_with_a_warning() {
    let two_scenes = |default: &str| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},{default}"scenes":[{{"name":"a","nodes":[0]}},{{"name":"b","nodes":[1]}}],
            "nodes":[{{"name":"first","mesh":0}},{{"name":"second","mesh":0,"translation":[10,0,0]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "buffers":[{{"byteLength":72,"uri":"data:application/octet-stream;base64,{TRIANGLE_BUFFER}"}}],
            "bufferViews":[{{"buffer":0,"byteLength":72}}],
            "accessors":[{}]}}"#,
            unit_triangle_accessor(0, 0)
        )
    };
    let dir = temp_dir("scenes");
    let (scene, logs) = common::capture_logs(|| {
        load_gltf(&write(&dir, "default.gltf", &two_scenes(r#""scene":1,"#))).expect("loads")
    });
    let nodes: Vec<_> = scene.meshes.iter().map(|m| m.node_name.as_deref()).collect();
    assert_eq!(nodes, vec![Some("second")], "`scene` picks scenes[1], not scenes[0]");
    assert!(!logs.contains("WARN"), "no warning when `scene` is given: {logs}");

    let (scene, logs) =
        common::capture_logs(|| load_gltf(&write(&dir, "no-default.gltf", &two_scenes(""))).expect("loads"));
    let nodes: Vec<_> = scene.meshes.iter().map(|m| m.node_name.as_deref()).collect();
    assert_eq!(nodes, vec![Some("first")], "without `scene`, scenes[0]");
    assert!(
        logs.contains("scene 'a' (#0)") && logs.contains("2 scenes"),
        "warns which scene it chose: {logs}"
    );
}

#[test]
fn cameras_are_picked_by_camera_or_node_name() {
    let rest = r#""cameras":[{"name":"wide","type":"perspective","perspective":{"yfov":1.0,"znear":0.1}},
        {"name":"tele","type":"perspective","perspective":{"yfov":0.3,"aspectRatio":2.0,"znear":0.1}},
        {"name":"plan","type":"orthographic","orthographic":{"xmag":1,"ymag":1,"zfar":10,"znear":0.1}}],"#;
    let text = triangle_gltf("", "", rest)
        .replace(r#""scenes":[{"nodes":[0]}]"#, r#""scenes":[{"nodes":[0,1,2,3]}]"#)
        .replace(
            r#""nodes":[{"name":"tri","mesh":0}]"#,
            r#""nodes":[{"name":"tri","mesh":0},{"name":"left","camera":0,"translation":[-1,0,5]},
                {"name":"right","camera":1,"translation":[1,0,5]},{"name":"top","camera":2}]"#,
        );
    let path = write(&temp_dir("camera-names"), "cameras.gltf", &text);
    let pick = |name: Option<&str>| load_gltf_with_camera(&path, name).map(|s| s.camera.expect("a camera"));
    let first = pick(None).expect("default camera");
    assert_eq!((first.name.as_str(), first.yfov), ("wide", 1.0), "the first perspective camera");
    let tele = pick(Some("tele")).expect("by camera name");
    assert_eq!((tele.name.as_str(), tele.yfov, tele.aspect_ratio), ("tele", 0.3, Some(2.0)));
    assert!(close(tele.camera_to_world.w_axis.truncate(), Vec3::new(1.0, 0.0, 5.0)), "on node 'right'");
    let left = pick(Some("left")).expect("by node name");
    assert_eq!(left.name, "wide", "node 'left' carries camera 'wide'");
    assert!(close(left.camera_to_world.w_axis.truncate(), Vec3::new(-1.0, 0.0, 5.0)));

    let error = pick(Some("plan")).expect_err("orthographic");
    assert_names_file(&error, &path);
    assert!(error.to_string().contains("orthographic"), "{error}");
    let error = pick(Some("zoom")).expect_err("unknown camera");
    assert!(matches!(error, Error::InvalidScene { .. }), "{error:?}");
    assert_names_file(&error, &path);
    let message = error.to_string();
    assert!(
        ["'wide'", "'tele'", "'plan'"].iter().all(|c| message.contains(c)),
        "lists the cameras: {message}"
    );

    // Overrides (the command line's --camera) apply before the file is read.
    let (scene, _) = scene::load_with(&path, |run| run.camera.name = Some("tele".into())).expect("loads");
    assert_eq!(scene.camera.expect("a camera").name, "tele");
}

#[test]
fn skins_and_morph_targets_are_warned_about_once_each_naming_them() {
    let mut bin = Bin::default();
    let positions = bin.f32(&UNIT_TRIANGLE);
    let offsets = bin.f32(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    let times = bin.f32(&[0.0, 1.0]);
    let translations = bin.f32(&[0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let views = format!(
        r#"{{"buffer":0,"byteOffset":{positions},"byteLength":36}},{{"buffer":0,"byteOffset":{offsets},"byteLength":36}},
        {{"buffer":0,"byteOffset":{times},"byteLength":8}},{{"buffer":0,"byteOffset":{translations},"byteLength":24}}"#
    );
    let accessors = format!(
        r#"{},{{"bufferView":1,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,1],"max":[0,0,1]}},
        {{"bufferView":2,"componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[1]}},
        {{"bufferView":3,"componentType":5126,"count":2,"type":"VEC3"}}"#,
        unit_triangle_accessor(0, 0)
    );
    let animation = r#"{"channels":[{"sampler":0,"target":{"node":3,"path":"translation"}}],"samplers":[{"input":2,"output":3}]}"#;
    let wave = r#"{"name":"wave","channels":[{"sampler":0,"target":{"node":4,"path":"weights"}}],"samplers":[{"input":2,"output":2}]}"#;
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1,2,3,4,5,6]}}],
        "nodes":[{{"name":"s0","mesh":0,"skin":0}},{{"name":"s1","mesh":0,"skin":1}},{{"name":"s2","mesh":0,"skin":2}},
            {{"name":"joint"}},{{"name":"morphed","mesh":1}},{{"name":"again","mesh":1}},{{"name":"unweighted","mesh":2}}],
        "skins":[{{"joints":[3]}},{{"joints":[3]}},{{"joints":[3]}}],
        "animations":[{animation},{animation},{wave}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}},
            {{"primitives":[{{"attributes":{{"POSITION":0}},"targets":[{{"POSITION":1}}]}}],"weights":[0.5]}},
            {{"primitives":[{{"attributes":{{"POSITION":0}},"targets":[{{"POSITION":1}}]}}]}}],
        {buffers}"bufferViews":[{views}],"accessors":[{accessors}]}}"#,
        buffers = bin.json()
    );
    let path = write(&temp_dir("skins"), "rigged.gltf", &text);
    let (scene, logs) = common::capture_logs(|| load_gltf(&path).expect("loads"));
    assert_eq!(scene.meshes.len(), 6, "skinned and morphed meshes are kept");
    let lines = |needle: &str| logs.lines().filter(|l| l.contains(needle)).count();
    assert_eq!(lines("loaded in their bind pose"), 1, "one skin warning for three skinned meshes: {logs}");
    assert!(logs.contains("skin #0, skin #1, skin #2 ignored"), "{logs}");
    assert_eq!(lines("morph-target weight channels ignored"), 1, "{logs}");
    assert!(logs.contains("animation 'wave' (#2) on node 'morphed' (#4)"), "{logs}");
    assert!(scene.animation.is_some(), "the joint's translation channels are an animation");
    assert_eq!(lines("morph targets"), 1, "{logs}");
    assert!(logs.contains("3 primitive(s) with morph targets"), "{logs}");
    // The rest pose: the mesh's default weights, none for the mesh without weights.
    let z: Vec<f32> = scene.meshes[3..].iter().map(|m| m.positions[1].z).collect();
    assert_eq!(z, vec![0.5, 0.5, 0.0]);
}

/// Textures are counted against the budget by what they hold (an 8-bit image 4 bytes a texel)
/// before they are made: BoxTextured's 256² image is 256 KiB, refused under a 192 KiB budget
/// naming the texture and the budget (both rounded up to MiB), loaded under 2 MiB.
#[test]
fn textures_are_counted_against_the_budget_before_they_are_decoded() {
    let error = load_gltf_within(&sample("BoxTextured.gltf"), None, 192 << 10).expect_err("over the budget");
    let message = error.to_string();
    assert!(message.contains("texture #0") && message.contains("its 256x256 texels need 1 MiB"), "{message}");
    assert!(message.contains("over the memory budget of 1 MiB"), "{message}");
    let scene = load_gltf_within(&sample("BoxTextured.gltf"), None, 2 << 20).expect("within the budget");
    assert_eq!(scene.textures[0].len(), 256 * 256);
}

/// A `weights` channel on a file without morph targets drives nothing: it is ignored with a warning
/// that names it and says why, like every other unusable channel, not silently.
#[test]
fn a_weights_channel_with_nothing_to_drive_is_warned_about() {
    let mut bin = Bin::default();
    let positions = bin.f32(&UNIT_TRIANGLE);
    let times = bin.f32(&[0.0, 1.0]);
    let views = format!(
        r#"{{"buffer":0,"byteOffset":{positions},"byteLength":36}},{{"buffer":0,"byteOffset":{times},"byteLength":8}}"#
    );
    let accessors = format!(
        r#"{},{{"bufferView":1,"componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[1]}}"#,
        unit_triangle_accessor(0, 0)
    );
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"name":"plain","mesh":0}},{{"name":"empty"}}],
        "animations":[{{"name":"w","channels":[{{"sampler":0,"target":{{"node":0,"path":"weights"}}}},
            {{"sampler":0,"target":{{"node":1,"path":"weights"}}}}],"samplers":[{{"input":1,"output":1}}]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        {buffers}"bufferViews":[{views}],"accessors":[{accessors}]}}"#,
        buffers = bin.json()
    );
    let path = write(&temp_dir("weights"), "unmorphed.gltf", &text);
    let (scene, logs) = common::capture_logs(|| load_gltf(&path).expect("loads"));
    assert!(scene.animation.is_none(), "no channel that moves anything");
    let warned: Vec<&str> = logs.lines().filter(|l| l.contains("weight channels ignored")).collect();
    assert_eq!(warned.len(), 1, "one warning for both channels: {logs}");
    assert!(warned[0].contains("node 'plain' (#0), which has no morph targets"), "{logs}");
    assert!(warned[0].contains("node 'empty' (#1), which has no morph targets"), "{logs}");
}

/// Sizes a small file declares are checked before they are allocated: fifty thousand nodes placing
/// one mesh of a million (all-zero) triangles, 5·10¹⁰ in all, from a file of under a megabyte; and
/// a sparse accessor without a bufferView declaring 2³⁰ elements (it passed the cap of plain ones).
#[test]
fn declared_geometry_beyond_memory_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let nodes: Vec<serde_json::Value> = (0..50_000).map(|_| serde_json::json!({ "mesh": 0 })).collect();
    let gltf = serde_json::json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": (0..50_000).collect::<Vec<u32>>() }],
        "nodes": nodes,
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "accessors": [{ "componentType": 5126, "count": 3_000_000, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0] }]
    });
    let path = dir.path().join("instanced.gltf");
    std::fs::write(&path, gltf.to_string()).unwrap();
    let message = caustica::scene::load(&path).unwrap_err().to_string();
    assert!(message.contains("instanced.gltf") && message.contains("50000000000 triangles"), "{message}");

    let sparse = serde_json::json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "buffers": [{ "byteLength": 16, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAAAAAA==" }],
        "bufferViews": [{ "buffer": 0, "byteOffset": 0, "byteLength": 4 }, { "buffer": 0, "byteOffset": 4, "byteLength": 12 }],
        "accessors": [{
            "componentType": 5126, "count": 1_073_741_824, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0],
            "sparse": { "count": 1, "indices": { "bufferView": 0, "componentType": 5125 }, "values": { "bufferView": 1 } }
        }]
    });
    let path = dir.path().join("sparse.gltf");
    std::fs::write(&path, sparse.to_string()).unwrap();
    let message = caustica::scene::load(&path).unwrap_err().to_string();
    assert!(
        message.contains("sparse.gltf")
            && (message.contains("no bufferView") || message.contains("triangles")),
        "{message}"
    );

    // An external buffer of 64 GiB (a sparse file: it takes no disk) was allocated whole and aborted.
    let big = std::fs::File::create(dir.path().join("big.bin")).unwrap();
    big.set_len(64 << 30).unwrap();
    let external = serde_json::json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "buffers": [{ "byteLength": 64u64 << 30, "uri": "big.bin" }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }]
    });
    let path = dir.path().join("external.gltf");
    std::fs::write(&path, external.to_string()).unwrap();
    let message = caustica::scene::load(&path).unwrap_err().to_string();
    assert!(message.contains("external.gltf") && message.contains("over the memory budget of"), "{message}");
}

/// A run file's glTF that is a device never ends: refused naming it, not read forever.
#[test]
fn a_run_files_gltf_that_is_a_device_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("zero.toml");
    std::fs::write(&run, "gltf = \"/dev/zero\"\n").unwrap();
    let message = caustica::scene::load(&run).unwrap_err().to_string();
    assert!(message.contains("/dev/zero") && message.contains("not a regular file"), "{message}");
}

/// KHR_materials_clearcoat's factors are in [0, 1]; past it the coat would reflect more than it
/// receives. Refused at load, naming the material and the factor.
#[test]
fn clearcoat_factors_outside_zero_to_one_are_refused_naming_the_material() {
    for (factor, value) in [("clearcoat", 1.5f32), ("clearcoat roughness", -0.25)] {
        let mut scene = caustica::test_scenes::furnace(0.5, 1.0);
        let shading = &mut scene.materials[0].shading;
        if factor == "clearcoat" {
            shading.clearcoat = value
        } else {
            shading.clearcoat_roughness = value
        }
        let error = validate(&mut scene, Path::new("coat.gltf")).expect_err("out of range").to_string();
        assert!(error.contains(&format!("{factor} is {value}")) && error.contains("furnace"), "{error}");
    }
}

/// A file that requires an extension Caustica lacks is refused saying so, naming the extension,
/// not as an invalid glTF file.
#[test]
fn a_required_extension_caustica_lacks_is_named_as_such() {
    let dir = temp_dir("required-extension");
    let text = triangle_gltf(
        "",
        "",
        r#""extensionsUsed":["EXT_meshopt_compression","KHR_texture_transform"],"extensionsRequired":["EXT_meshopt_compression","KHR_texture_transform"],"#,
    );
    let path = write(&dir, "required.gltf", &text);
    let error = load_gltf(&path).expect_err("a required extension it lacks");
    let message = error.to_string();
    assert_names_file(&error, &path);
    assert!(
        message.contains("requires EXT_meshopt_compression, which Caustica does not support")
            && !message.contains("not a valid glTF"),
        "{message}"
    );
    // One it has is no reason to refuse.
    let text = triangle_gltf(
        "",
        "",
        r#""extensionsUsed":["KHR_texture_transform"],"extensionsRequired":["KHR_texture_transform"],"#,
    );
    load_gltf(&write(&dir, "supported.gltf", &text)).expect("a required extension it has");
}

/// KHR_materials_volume's attenuation distance must be positive and its colour a fraction of each
/// channel: anything else is refused naming the material and the value, as thickness and ior are.
#[test]
fn volume_attenuation_outside_its_range_is_refused_naming_the_material() {
    let dir = temp_dir("attenuation");
    let volume = |fields: &str| {
        let rest = format!(
            r#""extensionsUsed":["KHR_materials_volume"],"materials":[{{"name":"jade","extensions":{{"KHR_materials_volume":{{"thicknessFactor":0.1,{fields}}}}}}}],"#
        );
        write(&dir, "volume.gltf", &triangle_gltf("", r#","material":0"#, &rest))
    };
    for (fields, needle) in [
        (r#""attenuationDistance":0"#, "attenuationDistance is 0, must be positive"),
        (r#""attenuationDistance":-2"#, "attenuationDistance is -2, must be positive"),
        (r#""attenuationColor":[1.5,0.5,0.5]"#, "attenuationColor is [1.5, 0.5, 0.5]"),
        (r#""attenuationColor":[0.5,-0.1,0.5]"#, "each channel must be in [0, 1]"),
    ] {
        let path = volume(fields);
        let message = load_gltf(&path).expect_err(fields).to_string();
        assert!(message.contains("jade") && message.contains(needle), "{fields}: {message}");
    }
    load_gltf(&volume(r#""attenuationDistance":2,"attenuationColor":[0.9,0.5,0.1]"#)).expect("in range");
}

/// KHR_materials_unlit (required by DiffuseTransmissionTest) loads: the base colour and its texture
/// become the emission, and nothing is reflected; alpha stays.
#[test]
fn an_unlit_material_emits_its_base_colour_and_reflects_nothing() {
    let dir = temp_dir("unlit");
    let material = r#""materials":[{"name":"label","pbrMetallicRoughness":{"baseColorFactor":[0.2,0.5,0.8,0.7]},"alphaMode":"BLEND","extensions":{"KHR_materials_unlit":{}}}],
        "extensionsUsed":["KHR_materials_unlit"],"extensionsRequired":["KHR_materials_unlit"],"#;
    let path = write(&dir, "unlit.gltf", &triangle_gltf("", r#","material":0"#, material));
    let scene = load_gltf(&path).expect("an unlit material loads");
    let m = &scene.materials[0];
    assert!(m.unlit);
    assert!(close(m.emission, Vec3::new(0.2, 0.5, 0.8)), "{}", m.emission);
    assert_eq!(m.shading.base_color, Vec3::ZERO);
    assert_eq!((m.shading.metallic, m.shading.specular, m.alpha), (0.0, 0.0, 0.7));
    assert_eq!(m.alpha_mode, scene::AlphaMode::Blend);
}

/// KHR_animation_pointer channels (LightVisibility's) target no node, which gltf-json cannot parse:
/// they are dropped with one warning naming their animation, and the file loads with its node
/// channels. KHR_node_visibility hides a node's mesh.
#[test]
fn pointer_animations_are_ignored_by_name_and_hidden_nodes_are_not_loaded() {
    let dir = temp_dir("pointer");
    let animation = r#""animations":[{"name":"blink","channels":[{"sampler":0,"target":{"path":"pointer","extensions":{"KHR_animation_pointer":{"pointer":"/materials/0/emissiveFactor"}}}}],"samplers":[{"input":0,"output":1}]}],
        "extensionsUsed":["KHR_animation_pointer"],"#;
    let path = write(&dir, "pointer.gltf", &triangle_gltf("", "", animation));
    let (scene, logs) = common::capture_logs(|| load_gltf(&path));
    let scene = scene.expect("a file with pointer animations loads");
    assert_eq!(triangle_count(&scene), 1);
    assert!(logs.contains("KHR_animation_pointer") && logs.contains("animation 'blink'"), "{logs}");

    let hidden = r#","extensions":{"KHR_node_visibility":{"visible":false}}"#;
    let used = r#""extensionsUsed":["KHR_node_visibility"],"extensionsRequired":["KHR_node_visibility"],"#;
    let scene = load_gltf(&write(&dir, "hidden.gltf", &triangle_gltf(hidden, "", used))).expect("loads");
    assert_eq!(triangle_count(&scene), 0, "a hidden node's mesh was loaded");
    let shown = r#","extensions":{"KHR_node_visibility":{"visible":true}}"#;
    let scene = load_gltf(&write(&dir, "shown.gltf", &triangle_gltf(shown, "", used))).expect("loads");
    assert_eq!(triangle_count(&scene), 1);
}

/// The loader's memory check counts what the meshes become, not only what is decoded: a file whose
/// decoded vertices, indices and triangles fit the budget but whose built geometry and BVH (every
/// placement of a mesh built anew) do not is refused before it is built, naming the budget; with
/// room for the build it loads.
#[test]
fn a_file_whose_decoded_meshes_fit_but_whose_build_does_not_is_refused() {
    let nodes = 5000;
    let placements: Vec<String> = (0..nodes).map(|_| r#"{"mesh":0}"#.to_owned()).collect();
    let scene_nodes: Vec<String> = (0..nodes).map(|i| i.to_string()).collect();
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],
        "meshes":[{{"name":"m","primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}}}}]}}],
        "buffers":[{{"byteLength":72,"uri":"data:application/octet-stream;base64,{TRIANGLE_BUFFER}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":72}}],
        "accessors":[
          {{"bufferView":0,"byteOffset":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
          {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC3"}}]}}"#,
        scene_nodes.join(","),
        placements.join(",")
    );
    let path = write(&temp_dir("built-budget"), "placed.gltf", &text);
    // Decoded, each placement holds three vertices of position and normal (72 bytes), the indices
    // made for it (12) and its triangle (12).
    let decoded = nodes as u64 * (72 + 12 + 12);
    let error = load_gltf_within(&path, None, decoded + 4096).expect_err("the build does not fit");
    let message = error.to_string();
    assert_names_file(&error, &path);
    assert!(message.contains("decoded and built") && message.contains("memory budget"), "{message}");
    let scene = load_gltf_within(&path, None, decoded + nodes as u64 * 1024).expect("room for the build");
    assert_eq!(triangle_count(&scene), nodes);
}
