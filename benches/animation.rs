//! The cost of a frame outside sampling on a big scene with one moving object: scenes/dense-mesh.gltf
//! (1.96 M triangles; `python3 scenes/make_dense_mesh.py` writes it) with its light moving, a
//! 16-spp 256² `pt` frame beside it. Three ways to follow a move, side by side in one run:
//! - rebuild: every BVH and the lights built anew from the moved scene (`Renderer::replace_scene`);
//! - two-level: the moving meshes in a dynamic set of their own, rebuilt alone, the static set's
//!   tree kept (`Renderer::move_node` once the node has moved);
//! and the render time of the frame with and without a dynamic set (that tracing two trees costs
//! nothing measurable). Run: `cargo bench --bench animation`.

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::scene::load;
use glam::{Mat4, Vec3};
use std::path::Path;
use std::time::Instant;

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
    let mut fixed = Renderer::new(scene.clone(), &run).expect("prepares");
    let mut moving = Renderer::movable(scene.clone(), &run).expect("prepares");
    // The first move puts the light in the dynamic set (a whole build); the frames after it are timed.
    moving.move_node("light", Mat4::IDENTITY).expect("moves");
    let frames = 8;
    let (mut rebuild, mut two_level, mut render_fixed, mut render_moving) = (0.0, 0.0, 0.0, 0.0);
    let mut whole_builds = 0;
    let mut parts = [0.0f64; 3];
    for frame in 0..frames {
        let m = Mat4::from_translation(Vec3::new(0.02 * frame as f32, 0.0, 0.0));
        let update = moving.move_node("light", m).expect("moves");
        two_level += update.pose_seconds + update.scene.geometry_seconds + update.scene.lights_seconds;
        whole_builds += update.scene.whole_build as u32;
        parts[0] += update.pose_seconds;
        parts[1] += update.scene.geometry_seconds;
        parts[2] += update.scene.lights_seconds;
        let mut moved = scene.clone();
        for mesh in moved.meshes.iter_mut().filter(|mesh| mesh.is_of_node("light")) {
            mesh.transform(m);
        }
        let start = Instant::now();
        fixed.replace_scene(&moved).expect("replaces");
        rebuild += start.elapsed().as_secs_f64();
        render_fixed += fixed.run(None, |_| {}).seconds;
        render_moving += moving.run(None, |_| {}).seconds;
    }
    let n = frames as f64;
    let (render, fixed_render) = (render_moving / n, render_fixed / n);
    println!("per frame, mean of {frames}:");
    println!("  render, one static set        {:8.1} ms", 1e3 * fixed_render);
    println!(
        "  render, static + dynamic sets {:8.1} ms ({:+.1}%)",
        1e3 * render,
        100.0 * (render / fixed_render - 1.0)
    );
    println!(
        "  rebuild everything            {:8.1} ms ({:.1}% of the frame)",
        1e3 * rebuild / n,
        100.0 * rebuild / n / fixed_render
    );
    println!(
        "  two-level (dynamic set alone) {:8.3} ms ({:.3}% of the frame; {whole_builds} whole builds)",
        1e3 * two_level / n,
        100.0 * two_level / n / render
    );
    println!(
        "    of which pose {:.3} ms, dynamic BVH {:.3} ms, lights {:.3} ms",
        1e3 * parts[0] / n,
        1e3 * parts[1] / n,
        1e3 * parts[2] / n
    );
}
