//! Scene loader: the test scenes, Khronos samples, run files, and one test per kind of bad input.

use caustica::Error;
use caustica::scene::gltf::{load_gltf, load_gltf_with_camera};
use caustica::scene::{self, RunFile, Scene, Wrap, validate};
use glam::{Vec2, Vec3};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

fn data(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data")).join(name)
}

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

/// Collects what `tracing` logs while `f` runs.
fn capture_logs<T>(f: impl FnOnce() -> T) -> (T, String) {
    #[derive(Clone, Default)]
    struct Buffer(Arc<Mutex<Vec<u8>>>);
    impl Write for Buffer {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0.lock().expect("log buffer").extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let buffer = Buffer::default();
    let writer = buffer.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_ansi(false)
        .without_time()
        .finish();
    let result = tracing::subscriber::with_default(subscriber, f);
    let logs = String::from_utf8(buffer.0.lock().expect("log buffer").clone()).expect("utf-8 logs");
    (result, logs)
}

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
    assert_eq!((white.metallic, white.roughness, white.specular), (0.0, 1.0, 0.0), "diffuse encoding");
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
    assert_eq!((glass.transmission, glass.ior), (1.0, 1.5));
    assert!(glass.thickness > 0.0, "glass is a closed solid");
    assert_eq!((glass.metallic, glass.roughness), (0.0, 0.0));
    let mirror = scene.materials.iter().find(|m| m.name == "mirror").expect("material 'mirror'");
    assert_eq!((mirror.metallic, mirror.roughness, mirror.base_color), (1.0, 0.0, Vec3::ONE));

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
    assert_eq!((material.metallic, material.roughness, material.base_color), (1.0, 1.0, Vec3::ONE));
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
    assert!(close(material.base_color, Vec3::new(0.8, 0.0, 0.0)));
    assert_eq!((material.metallic, material.roughness), (1.0, 1.0), "glTF defaults");
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
    let (scene, logs) = capture_logs(|| load_gltf(&sample("Cameras.gltf")).expect("Cameras loads"));
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
    assert_eq!(texture.texels.len(), 256 * 256);
    assert_eq!((texture.wrap_s, texture.wrap_t), (Wrap::Repeat, Wrap::Repeat));
    assert!(texture.texels.iter().all(|t| t.is_finite() && t.min_element() >= 0.0 && t.max_element() <= 1.0));
    let mesh = &scene.meshes[0];
    let material = &scene.materials[mesh.material as usize];
    let reference = material.base_color_texture.expect("base colour texture");
    assert_eq!((reference.texture, reference.tex_coord, reference.transform), (0, 0, None));
    assert_eq!(material.metallic, 0.0);
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
    let srgb = scene.textures[color.texture as usize].texels[0];
    let linear = scene.textures[data.texture as usize].texels[0];
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
fn animated_skinned_and_morphed_samples_load_in_rest_pose() {
    for name in [
        "AnimatedTriangle.gltf",
        "SimpleSkin.gltf",
        "SimpleMorph.gltf",
        "BoxAnimated.gltf",
        "RiggedSimple.gltf",
    ] {
        let (result, logs) = capture_logs(|| scene::load(&sample(name)));
        let (scene, _) = result.unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!scene.meshes.is_empty(), "{name}: has meshes");
        assert!(logs.contains("rest pose") || logs.contains("default weights"), "{name}: warns: {logs}");
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
        capture_logs(|| validate(&mut scene, &path).expect("degenerate triangles are not errors"));
    assert_eq!(summary.degenerate_triangles, 4);
    assert_eq!(summary.degenerate_emitter_triangles, 4);
    assert_eq!((summary.triangles, summary.emitter_triangles), (1, 1));
    assert_eq!((summary.meshes, summary.removed_meshes), (1, 1), "the all-degenerate primitive is removed");
    assert_eq!(scene.meshes.len(), 1);
    assert_eq!(scene.meshes[0].indices, vec![[0, 1, 2]]);
    assert_eq!(logs.matches("dropped").count(), 2, "one warning per mesh: {logs}");
    assert!(logs.contains("node 'junk' (#0) mesh 'm' (#0) primitive 1"), "names the mesh: {logs}");
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
    assert_eq!((material.name.as_str(), material.transmission, material.ior), ("ball", 1.0, 1.33));
    assert!(material.double_sided && material.thickness > 0.0);
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
