//! A host application that renders with Caustica inside its own bevy_ecs World and Schedule.
//!
//! It loads the Cornell box and builds Caustica's plan for `pt`, puts a resource of its own into the
//! same World and a system of its own (a counter of the bounces of every camera path) into the
//! plan's bounce phase, where it runs on every shard's paths, slides the short block across the
//! floor from frame to frame, and writes each frame to out/simulation-N.png.
//!
//! ```sh
//! cargo run --release --example simulation
//! ```

use bevy_ecs::prelude::*;
use caustica::PassSystems;
use caustica::camera_paths::PathQueues;
use caustica::driver::FrameRun;
use caustica::film::output::write_image;
use caustica::scene::{IntegratorKind, load};
use caustica::shards::ShardLink;
use glam::{Mat4, Vec3};
use std::path::Path;

/// The host's own state, a resource of the same World (and of every shard's, folded back after
/// each round).
#[derive(Resource, Default)]
struct Simulation {
    /// Path vertices shaded in this frame: one per camera path per bounce.
    bounces: u64,
}

/// The host's system, run on every shard's chunk of paths after Caustica's trace stage: it reads
/// the queue of paths whose rays were just traced.
fn count_bounces(mut sim: ResMut<Simulation>, queues: Res<PathQueues>) {
    sim.bounces += queues.active.len() as u64;
}

const FRAMES: u32 = 4;
const SIZE: u32 = 96;
const SPP: u32 = 16;

fn main() -> anyhow::Result<()> {
    caustica::driver::init_thread_pools(None);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf");
    let (scene, mut run) = load(&path)?;
    run.render.integrator = IntegratorKind::Pt;
    run.render.spp = SPP;
    run.film.width = Some(SIZE);
    run.film.height = Some(SIZE);

    // Caustica's World and plan, with the host's resource and system in them; a `FrameRun` keeps the
    // scene as loaded, which `move_node` moves.
    let mut frame_run = FrameRun::new(scene, &run)?;
    let renderer = frame_run.renderer_mut();
    renderer.world.insert_resource(Simulation::default());
    let bounce = renderer.plan.phase_mut("bounce").expect("pt has a bounce phase");
    bounce.add_path_systems(|schedule| {
        schedule.add_systems(count_bounces.after(PassSystems::Trace).before(PassSystems::Scatter));
    });
    bounce.add_link(ShardLink::merge::<Simulation>(|total, shard| total.bounces += shard.bounces));

    std::fs::create_dir_all("out")?;
    for frame in 0..FRAMES {
        // Move the short block along +x: the renderer rebuilds what its systems trace against and
        // starts a black film, on the same entities.
        let offset = Vec3::new(0.04 * frame as f32 - 0.06, 0.0, 0.0);
        frame_run.move_node("short_block", Mat4::from_translation(offset))?;
        let renderer = frame_run.renderer_mut();
        renderer.world.resource_mut::<Simulation>().bounces = 0;
        renderer.run(None, |_| {});
        let image = renderer.image();
        let out = format!("out/simulation-{frame}.png");
        write_image(&image, Path::new(&out), 0.0)?;
        println!(
            "frame {frame}: block at x {:+.2} m, {} bounces, mean radiance {:.3} -> {out}",
            offset.x,
            renderer.world.resource::<Simulation>().bounces,
            image.mean().x
        );
    }
    Ok(())
}
