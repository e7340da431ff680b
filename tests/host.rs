//! A host changes a render through the driver's methods, never its World: a moved node renders the
//! bits of a file posed the same way, the identity puts it back, and a scene the plan was not built
//! for is refused.

use crate::common;

use caustica::Renderer;
use caustica::driver::{FrameRun, init_thread_pools};
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
    let mut frame_run = FrameRun::new(scene, &run).unwrap();
    let loaded = rendered(frame_run.renderer_mut());

    let shift = Vec3::new(0.12, 0.0, 0.0);
    frame_run.move_node("short_block", Mat4::from_translation(shift)).unwrap();
    assert_eq!(frame_run.renderer().units_done(), 0, "a move starts the image over");
    let moved = rendered(frame_run.renderer_mut());
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

    frame_run.move_node("short_block", Mat4::IDENTITY).unwrap();
    assert_eq!(rendered(frame_run.renderer_mut()), loaded, "the identity does not restore the loaded scene");
}

#[test]
fn bad_moves_and_scenes_the_plan_was_not_built_for_are_refused() {
    init_thread_pools(None);
    let (scene, run) = setup(&common::data("cornell-box.gltf"));
    let mut frame_run = FrameRun::new(scene.clone(), &run).unwrap();
    let message = frame_run.move_node("no_such_node", Mat4::IDENTITY).unwrap_err().to_string();
    assert!(message.contains("no_such_node"), "{message}");
    let message = frame_run.move_node("short_block", Mat4::ZERO).unwrap_err().to_string();
    assert!(message.contains("invertible"), "{message}");
    let mut fixed = Renderer::new(scene.clone(), &run).unwrap();

    // Mirrors where there were none: caustics, which the plan was built without.
    let mut mirrored = scene.clone();
    mirrored.materials.iter_mut().for_each(|m| (m.shading.metallic, m.shading.roughness) = (1.0, 0.0));
    let message = fixed.replace_scene(&mirrored).unwrap_err().to_string();
    assert!(message.contains("new renderer"), "{message}");
    // The same scene is taken, and renders what a new renderer renders.
    fixed.replace_scene(&scene).unwrap();
    assert_eq!(rendered(&mut fixed), bits(&common::render(scene, &run)));
}

/// A stop during `pm`'s photon pass ends the render at the end of the photon shards' round (100 ms,
/// at least a bounce of every shard's chunk), not at the end of the pass; the pass is dropped whole,
/// and a host that goes on gets the bits of a render never stopped (the maps are built again, from
/// the same photons).
#[test]
fn a_stop_during_the_photon_pass_drops_it_and_going_on_gives_the_same_bits() {
    use caustica::resources::PhotonStats;
    use std::sync::atomic::Ordering;
    init_thread_pools(None);
    let (scene, mut run) = setup(&common::data("cornell-box.gltf"));
    run.render.integrator = caustica::scene::IntegratorKind::Pm;
    (run.photons.photons, run.photons.caustic_photons) = (600_000, 1_000);
    let mut never_stopped = Renderer::new(scene.clone(), &run).unwrap();
    let whole = rendered(&mut never_stopped);
    let whole_traced = never_stopped.world.resource::<PhotonStats>().traced;

    let mut renderer = Renderer::new(scene, &run).unwrap();
    renderer.interrupt_flag().store(true, Ordering::Relaxed);
    renderer.run(None, |_| {});
    assert_eq!((renderer.passes(), renderer.units_done()), (0, 0), "the dropped pass does not count");
    let traced = renderer.world.resource::<PhotonStats>().traced;
    // One round of the shards is all that ran: fewer bounces than the whole pass traced.
    assert!(
        traced < whole_traced,
        "{traced} photon bounces traced after the stop, {whole_traced} in a whole pass"
    );
    renderer.clear_stop();
    assert_eq!(rendered(&mut renderer), whole);
}

/// `lt`, `bdpt` and `vcm` render a pass into films of its own: a stop inside a pass drops it within
/// a round (the film keeps exactly the whole passes before it, to the bit), the time limit is kept
/// however long a pass is, and a host that goes on gets the bits of a render never stopped.
#[test]
fn a_stop_inside_a_whole_pass_drops_it_and_going_on_gives_the_same_bits() {
    use caustica::scene::IntegratorKind;
    use std::sync::atomic::Ordering;
    init_thread_pools(None);
    for integrator in [IntegratorKind::Lt, IntegratorKind::Bdpt, IntegratorKind::Vcm] {
        let (scene, mut run) = setup(&common::data("cornell-box.gltf"));
        run.render.integrator = integrator;
        let one_pass = {
            run.render.spp = 1;
            rendered(&mut Renderer::new(scene.clone(), &run).unwrap())
        };
        run.render.spp = 3;
        let whole = rendered(&mut Renderer::new(scene.clone(), &run).unwrap());

        let mut renderer = Renderer::new(scene.clone(), &run).unwrap();
        renderer.set_max_pass(Some(1));
        renderer.set_target(1);
        renderer.run(None, |_| {});
        // Raised before the second pass: its first round runs, then the stop drops it.
        renderer.set_target(3);
        renderer.interrupt_flag().store(true, Ordering::Relaxed);
        let report = renderer.run(None, |_| {});
        assert_eq!(report.stopped_by, Some(caustica::report::StopReason::Interrupted), "{integrator:?}");
        assert_eq!(
            (renderer.passes(), renderer.units_done()),
            (1, 1),
            "{integrator:?}: the dropped pass counts"
        );
        assert_eq!(bits(&renderer.image()), one_pass, "{integrator:?}: not the one whole pass");
        assert_eq!(renderer.progress().done, 1.0, "{integrator:?}: the dropped pass's samples count");
        renderer.clear_stop();
        assert_eq!(rendered(&mut renderer), whole, "{integrator:?}: going on");

        // A limit far shorter than a pass: nothing of it is in the image, and it ends at once.
        let mut limited = Renderer::new(scene.clone(), &run).unwrap();
        let report = limited.run(Some(1e-9), |_| {});
        assert_eq!(report.stopped_by, Some(caustica::report::StopReason::TimeLimit), "{integrator:?}");
        assert_eq!(limited.units_done(), 0, "{integrator:?}: rendered all its samples under a 1 ns limit");
        assert!(limited.image().pixels.iter().all(|p| *p == Vec3::ZERO), "{integrator:?}");
    }
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
        let mut frame_run = FrameRun::new(scene.clone(), &run).unwrap();
        frame_run.set_bvh_update(how).unwrap();
        // Twice: the first move may build anew (the node joins the dynamic set); the second cannot.
        frame_run.move_node("tall_block", Mat4::from_translation(-shift)).unwrap();
        let update = frame_run.move_node("tall_block", Mat4::from_translation(shift)).unwrap();
        assert_eq!(update.scene.whole_build, how == BvhUpdate::Rebuild, "{how:?}");
        assert_eq!(rendered(frame_run.renderer_mut()), expected, "{how:?}");
    }
}

/// The Cornell box with an animation scaling `node` from 1 at 0 s to `to` at 1 s (STEP), in `dir`.
fn cornell_scaling(dir: &std::path::Path, node: &str, to: Vec3) -> std::path::PathBuf {
    let name = format!("scaling-{node}.gltf");
    common::keyframed_cornell(dir, &name, (node, "scale"), [[1.0; 3], to.to_array()], "STEP", |_| {})
}

/// A frame whose only emitter an animation scales to nothing is dark, for every integrator: not
/// lit by the white environment that stands in for the lights of a file that has none, and with no
/// NaN; a flattening scale (singular, so the normals' inverse transpose is infinite) leaves no
/// NaN normal.
#[test]
fn a_frame_whose_emitters_are_gone_is_dark_and_a_flattened_mesh_keeps_finite_normals() {
    use caustica::scene::IntegratorKind;
    init_thread_pools(None);
    let dir = tempfile::tempdir().unwrap();
    let (scene, mut run) = setup(&cornell_scaling(dir.path(), "light", Vec3::ZERO));
    for integrator in [IntegratorKind::Pt, IntegratorKind::Pm, IntegratorKind::Sppm, IntegratorKind::Bdpt] {
        run.render.integrator = integrator;
        let mut frame_run = FrameRun::new(scene.clone(), &run).unwrap();
        frame_run.set_time(1.0).unwrap();
        let report = frame_run.renderer_mut().run(None, |_| {});
        assert_eq!(report.paths.nan_samples, 0, "{integrator:?}");
        let lit = frame_run.renderer().image().pixels.iter().filter(|p| **p != Vec3::ZERO).count();
        assert_eq!(lit, 0, "{integrator:?}: {lit} pixels lit with the light gone");
    }

    let (scene, mut run) = setup(&cornell_scaling(dir.path(), "short_block", Vec3::new(1.0, 0.0, 1.0)));
    let mut frames = caustica::scene::pose::FrameScene::new(scene.clone());
    frames.set_time(1.0).unwrap();
    let blocks: Vec<_> =
        frames.scene().meshes.iter().filter(|m| m.node_name.as_deref() == Some("short_block")).collect();
    assert!(!blocks.is_empty() && blocks.iter().all(|m| !m.indices.is_empty()), "its top and bottom remain");
    // The collapsed sides' vertices get zero normals, so the mesh falls back to flat shading, as
    // validation does; the inverse transpose made them NaN, which no check caught.
    for mesh in blocks {
        for n in mesh.normals.iter().flatten() {
            assert!(n.is_finite(), "{}: normal {n}", mesh.name);
        }
    }
    run.render.integrator = IntegratorKind::Pt;
    let mut frame_run = FrameRun::new(scene, &run).unwrap();
    frame_run.set_time(1.0).unwrap();
    assert_eq!(frame_run.renderer_mut().run(None, |_| {}).paths.nan_samples, 0);
}

/// A pose the loader would have refused in a file (here the camera's node scaled to nothing: no
/// orientation) is refused naming the file, the camera and the time, and the scene stays posed
/// where it was.
#[test]
fn a_pose_without_a_camera_orientation_is_refused_and_the_frame_before_it_stays() {
    init_thread_pools(None);
    let dir = tempfile::tempdir().unwrap();
    let (scene, run) = setup(&cornell_scaling(dir.path(), "camera", Vec3::ZERO));
    let mut frame_run = FrameRun::new(scene, &run).unwrap();
    let before = rendered(frame_run.renderer_mut());
    let error = frame_run.set_time(1.0).expect_err("the camera has no orientation at 1 s").to_string();
    assert!(
        error.contains("scaling-camera.gltf") && error.contains("camera") && error.contains("at 1 s"),
        "{error}"
    );
    frame_run.set_time(0.5).unwrap();
    assert_eq!(rendered(frame_run.renderer_mut()), before, "the pose before the refused one");
}

/// A mesh that rests at scale zero and that an animation scales up (an object that pops in) loads,
/// and its frame_run have its triangles: it was refused as singular, or removed as empty.
#[test]
fn a_mesh_resting_at_scale_zero_appears_when_its_animation_scales_it_up() {
    init_thread_pools(None);
    let dir = tempfile::tempdir().unwrap();
    let rest_at_zero = |gltf: &mut serde_json::Value| {
        let nodes = gltf["nodes"].as_array_mut().unwrap();
        nodes.iter_mut().find(|n| n["name"] == "short_block").unwrap()["scale"] =
            serde_json::json!([0.0, 0.0, 0.0]);
    };
    let path = common::keyframed_cornell(
        dir.path(),
        "pop-in.gltf",
        ("short_block", "scale"),
        [[1.0; 3]; 2],
        "STEP",
        rest_at_zero,
    );
    let (plain, _) = setup(&common::data("cornell-box.gltf"));
    let (scene, run) = setup(&path);
    let triangles = |scene: &Scene| -> usize {
        scene
            .meshes
            .iter()
            .filter(|m| m.node_name.as_deref() == Some("short_block"))
            .map(|m| m.indices.len())
            .sum()
    };
    assert!(triangles(&plain) > 0);
    let mut frames = caustica::scene::pose::FrameScene::new(scene.clone());
    assert_eq!(triangles(frames.scene()), triangles(&plain), "posed at 0 s, scale 1");
    frames.set_time(0.5).unwrap();
    assert_eq!(triangles(frames.scene()), triangles(&plain));
    let mut renderer = Renderer::new(scene, &run).unwrap();
    assert_eq!(renderer.run(None, |_| {}).paths.nan_samples, 0);
}

/// A node moved by its name and then put back by its index is back: the two name one node, so the
/// second move replaces the first rather than adding to it.
#[test]
fn a_node_moved_by_name_is_put_back_by_its_index() {
    let (scene, _) = setup(&common::data("cornell-box.gltf"));
    let index =
        scene.meshes.iter().find(|m| m.node_name.as_deref() == Some("short_block")).unwrap().node.unwrap();
    let mut frames = caustica::scene::pose::FrameScene::new(scene.clone());
    frames.move_node("short_block", Mat4::from_translation(Vec3::new(0.1, 0.0, 0.0))).unwrap();
    frames.move_node(&index.to_string(), Mat4::IDENTITY).unwrap();
    for (moved, loaded) in frames.scene().meshes.iter().zip(&scene.meshes) {
        assert_eq!(moved.positions, loaded.positions, "{}", moved.name);
    }
}

/// A host's system inserted into a stage runs on every shard, every bounce, on every path: placed
/// after the trace stage it sees each camera ray the renderer traced, and before the splat each
/// sample that ends; its counts, folded from the shards into the main World, are the report's.
#[test]
fn a_host_system_in_a_stage_sees_every_path_of_every_shard() {
    use bevy_ecs::prelude::*;
    use caustica::PassSystems;
    use caustica::camera_paths::PathQueues;
    use caustica::shards::ShardLink;

    #[derive(Resource, Default)]
    struct Seen {
        traced: u64,
        ended: u64,
    }
    fn after_trace(mut seen: ResMut<Seen>, queues: Res<PathQueues>) {
        seen.traced += queues.active.len() as u64;
    }
    fn before_splat(mut seen: ResMut<Seen>, queues: Res<PathQueues>) {
        seen.ended += queues.finished.len() as u64;
    }

    init_thread_pools(None);
    let (scene, mut run) = setup(&common::data("cornell-box.gltf"));
    run.render.chunk = 37;
    let mut renderer = Renderer::new(scene, &run).unwrap();
    renderer.world.insert_resource(Seen::default());
    let bounce = renderer.plan.phase_mut("bounce").unwrap();
    bounce.add_path_systems(|schedule| {
        schedule.add_systems(after_trace.after(PassSystems::Trace).before(PassSystems::Scatter));
        schedule.add_systems(before_splat.after(PassSystems::Shadow).before(PassSystems::Gather));
    });
    bounce.add_link(ShardLink::merge::<Seen>(|total, shard| {
        total.traced += shard.traced;
        total.ended += shard.ended;
    }));
    let report = renderer.run(None, |_| {});
    let seen = renderer.world.resource::<Seen>();
    assert_eq!(seen.ended, 24 * 24 * 3, "every sample's path ends once");
    assert_eq!(seen.traced, report.paths.rays, "every traced camera ray");
}

/// A stop at whole samples per pixel (a Python session's Ctrl-C) ends `pt` at the first whole sample
/// per pixel past what was handed out when it came, not later: the shards' one counter keeps what is
/// handed out a prefix of the pass. With more lanes than shards (8 for 2) it ended at about four
/// times that.
#[test]
fn a_whole_sample_stop_ends_pt_just_past_what_was_handed_out() {
    use caustica::resources::RenderStats;
    use std::sync::atomic::Ordering;
    init_thread_pools(None);
    let (scene, mut run) = setup(&common::data("cornell-box.gltf"));
    run.render.spp = 1_000_000;
    let mut renderer = Renderer::new(scene, &run).unwrap();
    renderer.set_whole_passes(true);
    let flag = renderer.interrupt_flag();
    // The driver sees the flag after the round that follows the call that raised it, and cuts the
    // pass there: what was handed out by then is read at the next call.
    let mut calls = 0;
    let mut handed = 0;
    renderer.run(None, |r| {
        calls += 1;
        if calls <= 2 {
            // Finished samples and the paths in flight (rows about to take work count too: a bound
            // from above).
            let stats = r.world.resource::<RenderStats>();
            handed = stats.samples + stats.active_paths as u64;
            flag.store(true, Ordering::Relaxed);
        }
    });
    let pixels = 24 * 24;
    let bound = handed.div_ceil(pixels) as u32;
    let done = renderer.units_done();
    assert!(done <= bound, "stopped at {done} samples per pixel, {bound} at most");
    assert!(done >= 1);
}
