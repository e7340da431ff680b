//! The cost of a frame outside sampling on a big scene with one moving object: scenes/dense-mesh.gltf
//! (1.96 M triangles; `python3 scenes/make_dense_mesh.py` writes it) with its light moving, a
//! 16-spp 256² `pt` frame beside it. The three ways to follow a move (`BvhUpdate`), side by side in
//! one run, each with the render time of its frames (that its trees trace as fast):
//! - two-level: the moving meshes in a dynamic set of their own, rebuilt alone, the static set's
//!   tree kept (the default);
//! - refit: one tree, the moved triangles written in and every box recomputed;
//! - rebuild: every BVH built anew.
//!
//! Run: `cargo bench --bench animation`.

use caustica::driver::{FrameRun, init_thread_pools};
use caustica::render_scene::BvhUpdate;
use caustica::scene::load;
use glam::{Mat4, Vec3};
use std::path::Path;

fn main() {
    init_thread_pools(None);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dense-mesh.gltf");
    if !path.exists() {
        println!("{} is missing: run `python3 scenes/make_dense_mesh.py` first", path.display());
        return;
    }
    let (scene, mut run) = load(&path).expect("the dense mesh loads");
    run.render.spp = 16;
    (run.film.width, run.film.height) = (Some(256), Some(256));
    let triangles: usize = scene.meshes.iter().map(|m| m.indices.len()).sum();
    println!("scene {} ({triangles} triangles), moving node 'light', pt 16 spp 256x256", path.display());
    let ways = [BvhUpdate::TwoLevel, BvhUpdate::Refit, BvhUpdate::Rebuild];
    let mut frame_runs: Vec<FrameRun> = ways
        .iter()
        .map(|&how| {
            let mut frame_run = FrameRun::new(scene.clone(), &run).expect("prepares");
            frame_run.set_bvh_update(how).expect("sets");
            // The first move may build anew (the light joins the dynamic set); the frames after it count.
            frame_run.move_node("light", Mat4::IDENTITY).expect("moves");
            frame_run
        })
        .collect();
    let frames = 12;
    // Per way: pose, BVH, lights, render (seconds, summed over the frames), whole builds.
    let mut totals = vec![([0.0f64; 4], 0u32); ways.len()];
    for frame in 1..=frames {
        let m = Mat4::from_translation(Vec3::new(0.01 * frame as f32, 0.0, -0.01 * frame as f32));
        // Interleaved, each way first in turn, so that the machine's drift falls on every way alike.
        let mut order: Vec<usize> = (0..ways.len()).collect();
        order.rotate_left(frame % ways.len());
        for w in order {
            let (frame_run, (sums, builds)) = (&mut frame_runs[w], &mut totals[w]);
            let update = frame_run.move_node("light", m).expect("moves");
            sums[0] += update.pose_seconds;
            sums[1] += update.scene.geometry_seconds;
            sums[2] += update.scene.lights_seconds;
            sums[3] += frame_run.renderer_mut().run(None, |_| {}).seconds;
            *builds += update.scene.whole_build as u32;
        }
    }
    let n = frames as f64;
    println!("per frame, mean of {frames} frames (ms; % of the two-level frame's render):");
    println!(
        "  {:<10} {:>8} {:>10} {:>8} {:>10} {:>14}",
        "way", "pose", "BVH", "lights", "render", "outside/render"
    );
    let base_render = totals[0].0[3] / n;
    for (how, (sums, builds)) in ways.iter().zip(&totals) {
        let ms = |s: f64| 1e3 * s / n;
        let outside = (sums[0] + sums[1] + sums[2]) / n;
        println!(
            "  {:<10} {:>8.3} {:>10.3} {:>8.3} {:>10.1} {:>13.2}%  ({builds} whole builds; render {:+.1}%)",
            format!("{how:?}"),
            ms(sums[0]),
            ms(sums[1]),
            ms(sums[2]),
            ms(sums[3]),
            100.0 * outside / (sums[3] / n),
            100.0 * (sums[3] / n / base_render - 1.0)
        );
    }
}
