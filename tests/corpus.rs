//! The corpus test: every glTF file written by others in tests/data/gltf-samples (Khronos samples;
//! licences in its README) renders without error, NaN or Inf, and not black, lit by the default
//! environment these viewer-made files expect, from the file's camera or the automatic framing.

mod common;

use bevy_ecs::world::World;
use caustica::Renderer;
use caustica::film::Image;
use caustica::lights::area::luminance;
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

#[test]
fn every_sample_renders_lit_without_errors_or_non_finite_pixels() {
    caustica::driver::init_thread_pools(None);
    let mut names = Vec::new();
    for entry in std::fs::read_dir(common::data("gltf-samples")).expect("samples dir") {
        let path = entry.expect("dir entry").path();
        if !path.extension().is_some_and(|e| e == "gltf" || e == "glb") {
            continue;
        }
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
    assert!(names.len() >= 14, "the corpus shrank: {names:?}");
}
