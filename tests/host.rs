//! A host changes a render through the driver's methods, never its World: a moved node renders the
//! bits of a file posed the same way, the identity puts it back, and a scene the plan was not built
//! for is refused.

use crate::common;

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::film::Image;
use caustica::scene::{RunFile, Scene, load};
use glam::{Mat4, Vec3};

fn setup(path: &std::path::Path) -> (Scene, RunFile) {
    let (scene, mut run) = load(path).unwrap();
    run.render.spp = 3;
    run.render.seed = 5;
    (run.film.width, run.film.height) = (Some(24), Some(24));
    (scene, run)
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn rendered(renderer: &mut Renderer) -> Vec<[u32; 3]> {
    renderer.run(None, |_| {});
    bits(&renderer.image())
}

#[test]
fn a_moved_node_renders_the_file_posed_the_same_way_and_the_identity_puts_it_back() {
    init_thread_pools(None);
    let (scene, run) = setup(&common::data("cornell-box.gltf"));
    let mut renderer = Renderer::movable(scene, &run).unwrap();
    let loaded = rendered(&mut renderer);

    let shift = Vec3::new(0.12, 0.0, 0.0);
    renderer.move_node("short_block", Mat4::from_translation(shift)).unwrap();
    assert_eq!(renderer.units_done(), 0, "a move starts the image over");
    let moved = rendered(&mut renderer);
    assert_ne!(moved, loaded);

    // The same translation written into the file's node, placed by the loader.
    let mut gltf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(common::data("cornell-box.gltf")).unwrap()).unwrap();
    let node = gltf["nodes"].as_array_mut().unwrap().iter_mut().find(|n| n["name"] == "short_block").unwrap();
    node["translation"] = serde_json::json!([shift.x, shift.y, shift.z]);
    let dir = tempfile::tempdir().unwrap();
    let posed_file = dir.path().join("posed.gltf");
    std::fs::write(&posed_file, gltf.to_string()).unwrap();
    let (posed, _) = setup(&posed_file);
    assert_eq!(moved, bits(&common::render(posed, &run)), "not the scene with the block moved");

    renderer.move_node("short_block", Mat4::IDENTITY).unwrap();
    assert_eq!(rendered(&mut renderer), loaded, "the identity does not restore the loaded scene");
}

#[test]
fn bad_moves_and_scenes_the_plan_was_not_built_for_are_refused() {
    init_thread_pools(None);
    let (scene, run) = setup(&common::data("cornell-box.gltf"));
    let mut movable = Renderer::movable(scene.clone(), &run).unwrap();
    let message = movable.move_node("no_such_node", Mat4::IDENTITY).unwrap_err().to_string();
    assert!(message.contains("no_such_node"), "{message}");
    let message = movable.move_node("short_block", Mat4::ZERO).unwrap_err().to_string();
    assert!(message.contains("invertible"), "{message}");
    let mut fixed = Renderer::new(scene.clone(), &run).unwrap();
    let message = fixed.move_node("short_block", Mat4::IDENTITY).unwrap_err().to_string();
    assert!(message.contains("movable"), "{message}");

    // Mirrors where there were none: caustics, which the plan was built without.
    let mut mirrored = scene.clone();
    mirrored.materials.iter_mut().for_each(|m| (m.metallic, m.roughness) = (1.0, 0.0));
    let message = fixed.replace_scene(&mirrored).unwrap_err().to_string();
    assert!(message.contains("new renderer"), "{message}");
    // The same scene is taken, and renders what a new renderer renders.
    fixed.replace_scene(&scene).unwrap();
    assert_eq!(rendered(&mut fixed), bits(&common::render(scene, &run)));
}

/// A stop during `pm`'s photon pass ends the render at the next bounce of the photons, not at the end
/// of the pass; the pass is dropped whole, and a host that goes on gets the bits of a render never
/// stopped (the maps are built again, from the same photons).
#[test]
fn a_stop_during_the_photon_pass_drops_it_and_going_on_gives_the_same_bits() {
    use caustica::resources::PhotonStats;
    use std::sync::atomic::Ordering;
    init_thread_pools(None);
    let (scene, mut run) = setup(&common::data("cornell-box.gltf"));
    run.render.integrator = caustica::scene::IntegratorKind::Pm;
    (run.photons.photons, run.photons.caustic_photons) = (600_000, 1_000);
    let whole = rendered(&mut Renderer::new(scene.clone(), &run).unwrap());

    let mut renderer = Renderer::new(scene, &run).unwrap();
    renderer.interrupt_flag().store(true, Ordering::Relaxed);
    renderer.run(None, |_| {});
    assert_eq!((renderer.passes(), renderer.units_done()), (0, 0), "the dropped pass does not count");
    let traced = renderer.world.resource::<PhotonStats>().traced;
    // One bounce of one wavefront (2^18 photons) is all that ran: at most 2^18 photons traced to
    // their end in it, far from the 600 000 asked.
    assert!(traced <= 1 << 18, "{traced} photon bounces traced after the stop");
    renderer.clear_stop();
    assert_eq!(rendered(&mut renderer), whole);
}

/// However the BVHs follow a move (the dynamic set rebuilt alone, one tree refit, or everything
/// rebuilt), the moved scene renders the bits of the file posed the same way.
#[test]
fn every_way_of_following_a_move_renders_the_posed_file() {
    use caustica::render_scene::BvhUpdate;
    init_thread_pools(None);
    let (scene, run) = setup(&common::data("cornell-box.gltf"));
    let shift = Vec3::new(-0.05, 0.0, 0.07);
    let mut gltf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(common::data("cornell-box.gltf")).unwrap()).unwrap();
    let node = gltf["nodes"].as_array_mut().unwrap().iter_mut().find(|n| n["name"] == "tall_block").unwrap();
    node["translation"] = serde_json::json!([shift.x, shift.y, shift.z]);
    let dir = tempfile::tempdir().unwrap();
    let posed_file = dir.path().join("posed.gltf");
    std::fs::write(&posed_file, gltf.to_string()).unwrap();
    let (posed, _) = setup(&posed_file);
    let expected = bits(&common::render(posed, &run));
    for how in [BvhUpdate::TwoLevel, BvhUpdate::Refit, BvhUpdate::Rebuild] {
        let mut renderer = Renderer::movable(scene.clone(), &run).unwrap();
        renderer.set_bvh_update(how).unwrap();
        // Twice: the first move may build anew (the node joins the dynamic set); the second cannot.
        renderer.move_node("tall_block", Mat4::from_translation(-shift)).unwrap();
        let update = renderer.move_node("tall_block", Mat4::from_translation(shift)).unwrap();
        assert_eq!(update.scene.whole_build, how == BvhUpdate::Rebuild, "{how:?}");
        assert_eq!(rendered(&mut renderer), expected, "{how:?}");
    }
}
