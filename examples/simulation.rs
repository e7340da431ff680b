//! A host application that owns its bevy_ecs World and Schedule and renders with Caustica inside it.
//!
//! It loads the Cornell box, puts Caustica's resources and path-tracing systems into its own World
//! and Schedule next to one system of its own (a bounce counter), slides the short block across the
//! floor from frame to frame, and writes each frame to out/simulation-N.png.
//!
//! ```sh
//! cargo run --release --example simulation
//! ```

use bevy_ecs::prelude::*;
use caustica::film::Film;
use caustica::film::output::write_image;
use caustica::scene::{IntegratorKind, load};
use caustica::systems::PassSystems;
use caustica::systems::components::PathState;
use caustica::systems::integrators;
use caustica::systems::render::{init_thread_pools, scene_world, spawn_wavefront};
use caustica::systems::resources::{RenderStats, SceneGeometry, Workload};
use glam::Vec3;
use std::path::Path;

/// The host's own state, a resource of the same World.
#[derive(Resource, Default)]
struct Simulation {
    /// Bounce steps run in this frame.
    bounces: u32,
}

/// The host's system, run in the same Schedule after Caustica's gather stage.
fn count_bounces(mut sim: ResMut<Simulation>, stats: Res<RenderStats>) {
    if stats.active_paths > 0 {
        sim.bounces += 1;
    }
}

const FRAMES: u32 = 4;
const SIZE: u32 = 96;
const SPP: u32 = 16;

fn main() -> anyhow::Result<()> {
    init_thread_pools(None);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf");
    let (scene, mut run) = load(&path)?;
    run.render.integrator = IntegratorKind::Pt;
    run.render.spp = SPP;
    run.film.width = Some(SIZE);
    run.film.height = Some(SIZE);

    // Caustica's resources (SceneGeometry, Camera, Film, RenderConfig, RenderStats) in the host's World.
    let (mut world, features) = scene_world(scene.clone(), &run)?;
    world.insert_resource(Simulation::default());
    let mut schedule = Schedule::default();
    integrators::path::build(&mut schedule, features, run.render.integrator);
    schedule.add_systems(count_bounces.after(PassSystems::Gather));

    std::fs::create_dir_all("out")?;
    for frame in 0..FRAMES {
        // Move the short block along +x and rebuild the geometry the systems trace against.
        let mut moved = scene.clone();
        let offset = Vec3::new(0.04 * frame as f32 - 0.06, 0.0, 0.0);
        for mesh in moved.meshes.iter_mut().filter(|m| m.node_name.as_deref() == Some("short_block")) {
            mesh.positions.iter_mut().for_each(|p| *p += offset);
        }
        world.insert_resource(SceneGeometry::build(&moved, run.render.light_selection));

        // A fresh film and work list, and one wavefront of path entities for this frame.
        world.insert_resource(Film::new(SIZE, SIZE));
        world.insert_resource(RenderStats::default());
        world.resource_mut::<Simulation>().bounces = 0;
        let old: Vec<Entity> = world.query_filtered::<Entity, With<PathState>>().iter(&world).collect();
        old.into_iter().for_each(|e| {
            world.despawn(e);
        });
        let mut workload = Workload::new(SIZE * SIZE, 0, SPP, SIZE * SIZE);
        spawn_wavefront(&mut world, &mut workload);
        world.insert_resource(workload);

        // The host's loop: one schedule run advances every path by a bounce.
        loop {
            schedule.run(&mut world);
            if world.resource::<RenderStats>().active_paths == 0 {
                break;
            }
        }
        let image = world.resource::<Film>().image();
        let out = format!("out/simulation-{frame}.png");
        write_image(&image, Path::new(&out), 0.0)?;
        println!(
            "frame {frame}: block at x {:+.2} m, {} bounces, mean radiance {:.3} -> {out}",
            offset.x,
            world.resource::<Simulation>().bounces,
            image.mean().x
        );
    }
    Ok(())
}
