//! Feature images (`--aov`): albedo, normal and depth at the first non-specular surface, written as
//! layers of the EXR, checked on planes where each is known exactly, through a perfect mirror, and on
//! the Cornell box's Lambertian walls.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Where the front plane stands in front of the camera, and where the back one stands behind it.
const FRONT_Z: f32 = -3.0;
const BACK_Z: f32 = 2.0;
const HALF: f32 = 40.0;

/// A glTF of a camera at the origin looking down −Z, a plane facing it at z = `FRONT_Z` of
/// material `front`, and a plane at z = `BACK_Z` facing −Z (behind the camera) of material `back`;
/// the buffer beside it.
fn planes(dir: &Path, front: &str, back: &str) -> PathBuf {
    let quad = |z: f32, facing_camera: bool| {
        let corners = [[-HALF, -HALF], [HALF, -HALF], [HALF, HALF], [-HALF, HALF]];
        let p: Vec<[f32; 3]> = corners.iter().map(|&[x, y]| [x, y, z]).collect();
        let n = [0.0, 0.0, if facing_camera { 1.0 } else { -1.0 }];
        (p, n)
    };
    let mut bytes = Vec::new();
    for (p, n) in [quad(FRONT_Z, true), quad(BACK_Z, false)] {
        p.iter().flatten().for_each(|v| bytes.extend(v.to_le_bytes()));
        (0..4).for_each(|_| n.iter().for_each(|v: &f32| bytes.extend(v.to_le_bytes())));
    }
    // Counter-clockwise seen from the side the normal points to.
    for index in [0u16, 1, 2, 0, 2, 3, 0, 2, 1, 0, 3, 2] {
        bytes.extend(index.to_le_bytes());
    }
    std::fs::write(dir.join("planes.bin"), &bytes).unwrap();
    let view = |offset: usize, length: usize| {
        format!(r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{length}}}"#)
    };
    let vec3 = |view: usize, z: f32| {
        format!(
            r#"{{"bufferView":{view},"componentType":5126,"count":4,"type":"VEC3","min":[{m},{m},{z}],"max":[{h},{h},{z}]}}"#,
            m = -HALF,
            h = HALF
        )
    };
    let normal =
        |view: usize| format!(r#"{{"bufferView":{view},"componentType":5126,"count":4,"type":"VEC3"}}"#);
    let gltf = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_specular"],
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2]}}],
  "nodes": [{{"name": "camera", "camera": 0}}, {{"name": "front", "mesh": 0}}, {{"name": "back", "mesh": 1}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.9, "znear": 0.01, "aspectRatio": 1.0}}}}],
  "meshes": [
    {{"name": "front", "primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 4, "material": 0}}]}},
    {{"name": "back", "primitives": [{{"attributes": {{"POSITION": 2, "NORMAL": 3}}, "indices": 5, "material": 1}}]}}
  ],
  "materials": [{front}, {back}],
  "buffers": [{{"uri": "planes.bin", "byteLength": {len}}}],
  "bufferViews": [{v0}, {v1}, {v2}, {v3}, {v4}, {v5}],
  "accessors": [{a0}, {a1}, {a2}, {a3},
    {{"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 5, "componentType": 5123, "count": 6, "type": "SCALAR"}}]
}}"#,
        len = bytes.len(),
        v0 = view(0, 48),
        v1 = view(48, 48),
        v2 = view(96, 48),
        v3 = view(144, 48),
        v4 = view(192, 12),
        v5 = view(204, 12),
        a0 = vec3(0, FRONT_Z),
        a1 = normal(1),
        a2 = vec3(2, BACK_Z),
        a3 = normal(3),
    );
    let path = dir.join("planes.gltf");
    std::fs::write(&path, gltf).unwrap();
    path
}

/// A Lambertian material of base colour `rgb` (no specular layer).
fn lambertian(rgb: [f32; 3]) -> String {
    format!(
        r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [{}, {}, {}, 1], "metallicFactor": 0, "roughnessFactor": 1}},
           "extensions": {{"KHR_materials_specular": {{"specularFactor": 0}}}}}}"#,
        rgb[0], rgb[1], rgb[2]
    )
}

/// A perfect white mirror (a smooth conductor whose Fresnel is one at every angle).
const MIRROR: &str = r#"{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1, "roughnessFactor": 0}}"#;

/// Render `scene` with every feature image into `dir/out.exr` and read its channels.
fn render_aovs(scene: &Path, dir: &Path, extra: &[&str]) -> BTreeMap<String, Vec<f32>> {
    let out = dir.join("out.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-q", "--aov", "albedo,normal,depth"];
    args.extend(["--width", "24", "--height", "24", "--spp", "8", "-o", out.to_str().unwrap()]);
    args.extend(extra);
    let run = Command::new(env!("CARGO_BIN_EXE_caustica")).args(&args).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let (w, h, channels) = caustica::film::output::read_exr_channels(&out).unwrap();
    assert_eq!((w, h), (24, 24));
    channels
}

/// The pixels of three channels as triples.
fn triples(channels: &BTreeMap<String, Vec<f32>>, names: [&str; 3]) -> Vec<[f32; 3]> {
    let [x, y, z] = names.map(|n| &channels[n]);
    (0..x.len()).map(|i| [x[i], y[i], z[i]]).collect()
}

fn assert_all_near(values: &[[f32; 3]], expected: [f32; 3], tolerance: f32, what: &str) {
    for (i, v) in values.iter().enumerate() {
        let off = (0..3).map(|c| (v[c] - expected[c]).abs()).fold(0.0f32, f32::max);
        assert!(off <= tolerance, "{what} of pixel {i} is {v:?}, not {expected:?}");
    }
}

#[test]
fn a_lambertian_plane_has_its_base_colour_a_unit_normal_facing_the_camera_and_its_distance() {
    let dir = tempfile::tempdir().unwrap();
    let base = [0.6, 0.3, 0.2];
    let scene = planes(dir.path(), &lambertian(base), &lambertian([0.9, 0.9, 0.9]));
    let channels = render_aovs(&scene, dir.path(), &[]);
    let names: Vec<&str> = channels.keys().map(String::as_str).collect();
    assert_eq!(names, ["B", "G", "N.X", "N.Y", "N.Z", "R", "Z", "albedo.B", "albedo.G", "albedo.R"]);
    // The fixed-point film rounds to 2^-40 per sample: equal to f32 precision.
    assert_all_near(&triples(&channels, ["albedo.R", "albedo.G", "albedo.B"]), base, 1e-6, "albedo");
    assert_all_near(&triples(&channels, ["N.X", "N.Y", "N.Z"]), [0.0, 0.0, 1.0], 1e-6, "normal");
    // Planar depth: the whole plane is at the same distance from the image plane.
    for (i, z) in channels["Z"].iter().enumerate() {
        assert!((z - -FRONT_Z).abs() < 1e-4, "depth of pixel {i} is {z}, not {}", -FRONT_Z);
    }
}

#[test]
fn through_a_perfect_mirror_the_features_are_those_of_the_surface_it_shows() {
    let dir = tempfile::tempdir().unwrap();
    let behind = [0.25, 0.5, 0.75];
    let scene = planes(dir.path(), MIRROR, &lambertian(behind));
    // sppm's camera passes, lt's camera rays (which follow delta bounces only) and bdpt's.
    for integrator in
        [&["--integrator", "sppm", "--passes", "2"][..], &["--integrator", "lt"], &["--integrator", "bdpt"]]
    {
        let channels = render_aovs(&scene, dir.path(), integrator);
        assert_all_near(&triples(&channels, ["albedo.R", "albedo.G", "albedo.B"]), behind, 1e-6, "albedo");
        // The plane behind the camera faces −Z, towards the mirror and so towards the reflected camera.
        assert_all_near(&triples(&channels, ["N.X", "N.Y", "N.Z"]), [0.0, 0.0, -1.0], 1e-6, "normal");
        // The unfolded path: to the mirror, then back past the camera to the plane behind it.
        let unfolded = -FRONT_Z + (BACK_Z - FRONT_Z);
        for (i, z) in channels["Z"].iter().enumerate() {
            assert!((z - unfolded).abs() < 1e-4, "depth of pixel {i} is {z}, not {unfolded}");
        }
    }
}

#[test]
fn the_cornell_box_walls_have_their_base_colours_and_every_normal_is_at_most_unit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::data("cornell-box.gltf");
    let channels = render_aovs(&scene, dir.path(), &["--integrator", "pm"]);
    let gltf: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&scene).unwrap()).unwrap();
    let bases: Vec<[f32; 3]> = gltf["materials"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["extensions"]["KHR_materials_specular"]["specularFactor"] == 0.0)
        .map(|m| {
            let c = &m["pbrMetallicRoughness"]["baseColorFactor"];
            [0, 1, 2].map(|i| c[i].as_f64().unwrap() as f32)
        })
        .collect();
    assert!(bases.len() >= 3, "the Cornell box's walls are Lambertian");
    let albedos = triples(&channels, ["albedo.R", "albedo.G", "albedo.B"]);
    // Pixels inside one wall see only it: most pixels are exactly one of the walls' colours.
    let on_a_wall =
        albedos.iter().filter(|a| bases.iter().any(|b| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-6))).count();
    assert!(
        on_a_wall * 10 >= albedos.len() * 7,
        "{on_a_wall} of {} pixels show a wall's colour",
        albedos.len()
    );
    for n in triples(&channels, ["N.X", "N.Y", "N.Z"]) {
        let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!(length <= 1.0 + 1e-5, "a mean of unit normals is at most unit: {length}");
    }
    // The box is closed: every sample finds a surface at a positive depth.
    assert!(channels["Z"].iter().all(|&z| z > 0.0));
}

#[test]
fn feature_images_need_an_exr_output_and_refuse_a_part() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::data("cornell-box.gltf");
    let png = dir.path().join("out.png");
    let run = |extra: &[&str]| {
        let mut args =
            vec!["render", scene.to_str().unwrap(), "-q", "--spp", "2", "--width", "8", "--height", "8"];
        args.extend(extra);
        Command::new(env!("CARGO_BIN_EXE_caustica")).args(&args).output().unwrap()
    };
    let out = run(&["--aov", "albedo", "-o", png.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("EXR") && stderr.contains("out.png"), "{stderr}");
    assert!(!png.exists());
    let part = dir.path().join("part.exr");
    let out = run(&["--aov", "depth", "--part", "1/2", "-o", part.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("--aov"), "{stderr}");
    let out = run(&["--aov", "shadows"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("shadows"));
}
