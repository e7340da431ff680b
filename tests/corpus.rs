//! The corpus test: every glTF file written by others in tests/data/gltf-samples (Khronos samples;
//! licences in its README) renders without error, NaN or Inf, and not black, lit by the default
//! environment these viewer-made files expect, from the file's camera or the automatic framing.

use crate::common;

use bevy_ecs::world::World;
use caustica::Renderer;
use caustica::film::Image;
use caustica::lights::light::luminance;
use caustica::resources::{CameraResource, SceneResource};
use caustica::scene::{self, IntegratorKind};
use glam::Vec2;

/// Mean luminance the pixels showing the model must exceed: the samples' surfaces have albedos of a
/// few percent or more under a white environment of radiance 1, so a lit model is far above it, and
/// a model that lost its light, or whose surfaces shade to black, is at 0.
const LIT_FLOOR: f32 = 0.02;

/// The pixels whose centre ray hits the model.
fn model_pixels(world: &World) -> Vec<usize> {
    let camera = world.resource::<CameraResource>();
    let geometry = &world.resource::<SceneResource>().geometry;
    (0..camera.width * camera.height)
        .filter(|&i| {
            let ray =
                camera.generate_ray(i % camera.width, i / camera.width, Vec2::splat(0.5), Vec2::ZERO, 0.0);
            geometry.intersect(&ray).is_hit()
        })
        .map(|i| i as usize)
        .collect()
}

fn check(name: &str, kind: IntegratorKind, image: &Image, model: &[usize]) {
    let bad = image.pixels.iter().filter(|p| !p.is_finite() || p.min_element() < 0.0).count();
    assert_eq!(bad, 0, "{name} ({kind:?}): {bad} non-finite or negative pixels");
    // The automatic framing (or the file's camera) puts the model in view.
    assert!(model.len() * 20 >= image.pixels.len(), "{name}: the model covers {} pixels", model.len());
    let mean = model.iter().map(|&i| luminance(image.pixels[i])).sum::<f32>() / model.len() as f32;
    assert!(mean > LIT_FLOOR, "{name} ({kind:?}): the model's mean luminance {mean} is black");
}

/// The glTF files under `dir`, in its folders too.
fn gltf_files(dir: &str) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let mut pending = vec![common::data(dir)];
    while let Some(dir) = pending.pop() {
        for entry in std::fs::read_dir(&dir).expect("samples dir") {
            let path = entry.expect("dir entry").path();
            if path.is_dir() {
                pending.push(path);
            } else if path.extension().is_some_and(|e| e == "gltf" || e == "glb") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn every_sample_renders_lit_without_errors_or_non_finite_pixels() {
    render_corpus(gltf_files("gltf-samples"), 14);
}

/// The second corpus (tests/data/gltf-samples-2: emissive strength, texture transforms,
/// attenuation, specular, clearcoat, rough transmission): as the first, and none of the features
/// the loader now reads (normal maps, emissive textures, alpha, punctual lights, volume
/// attenuation, clearcoat) is reported as ignored.
#[test]
fn the_second_corpus_renders_with_its_features_read() {
    let (_, logs) = common::capture_logs(|| render_corpus(gltf_files("gltf-samples-2"), 6));
    let unsupported: Vec<&str> = logs.lines().filter(|l| l.contains("not supported")).collect();
    assert!(!unsupported.iter().any(|l| l.contains("clearcoat")), "{unsupported:?}");
    for feature in [
        "normalTexture",
        "emissiveTexture",
        "alphaMode",
        "KHR_lights_punctual",
        "volume attenuation",
        "KHR_materials_clearcoat",
    ] {
        assert!(
            !logs.contains(&format!("ignored: {feature}")) && !logs.contains(&format!(", {feature}")),
            "{feature} ignored: {logs}"
        );
    }
}

fn render_corpus(files: Vec<std::path::PathBuf>, at_least: usize) {
    caustica::driver::init_thread_pools(None);
    let mut names = Vec::new();
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        for kind in [IntegratorKind::Pt, IntegratorKind::Sppm] {
            let (scene, mut run) = scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
            run.render.integrator = kind;
            run.render.spp = 4;
            run.film.width = Some(32);
            run.film.height = Some(24);
            run.progressive.passes = 4;
            run.progressive.photons_per_pass = 4096;
            let mut renderer = Renderer::new(scene, &run).unwrap_or_else(|e| panic!("{name}: {e}"));
            renderer.run(None, |_| {});
            check(&name, kind, &renderer.image(), &model_pixels(&renderer.world));
        }
        names.push(name);
    }
    assert!(names.len() >= at_least, "the corpus shrank: {names:?}");
}
