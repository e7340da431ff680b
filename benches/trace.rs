//! Trace throughput: closest-hit and any-hit queries on incoherent rays in the Cornell box, through
//! our `Geometry` (eight-wide BVH, watertight test on packs of eight triangles), through the ECS
//! `trace_paths` system, and through raw obvhs CwBvh traversal with its own (Möller–Trumbore, not
//! watertight) triangle test: the reference the trace stage is held to. Before measuring it prints
//! the nodes and leaves our traversal visits per ray.

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use bevy_ecs::prelude::*;
use caustica::components::{PathHit, PathRay, PathState, PathStatus};
use caustica::driver::init_thread_pools;
use caustica::geometry::{Geometry, Ray};
use caustica::resources::SceneResource;
use caustica::sampling::Sampler;
use caustica::sampling::warp::uniform_sphere;
use caustica::scene::load;
use caustica::trace::trace_paths;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

const RAYS: u32 = 1 << 16;

fn cornell() -> caustica::scene::Scene {
    load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf")).expect("scene loads").0
}

/// Rays from random points inside the box in uniformly random directions: the incoherent case.
fn incoherent_rays(geometry: &Geometry) -> Vec<Ray> {
    let (min, max) = geometry.bounds();
    (0..RAYS)
        .map(|i| {
            let s = Sampler::new(1, i, 0);
            let o = min
                + (max - min)
                    * Vec3::new(0.05 + 0.9 * s.get1d(0), 0.05 + 0.9 * s.get1d(1), 0.05 + 0.9 * s.get1d(2));
            Ray { o, d: uniform_sphere(s.get2d(3)), t_max: f32::INFINITY, time: 0.0 }
        })
        .collect()
}

fn bench_trace(c: &mut Criterion) {
    init_thread_pools(None);
    let scene = cornell();
    let geometry = Geometry::build(&scene);
    let rays = incoherent_rays(&geometry);
    let shadow: Vec<Ray> = rays
        .iter()
        .zip(rays.iter().skip(1))
        .map(|(a, b)| Ray { o: a.o, d: b.o - a.o, t_max: 1.0, time: 0.0 })
        .collect();

    let mut counts = caustica::geometry::wide_bvh::TraceCounts::default();
    rays.iter().for_each(|r| _ = geometry.intersect_counted(r, &mut counts));
    let per_ray = |n: u32| n as f64 / RAYS as f64;
    println!("closest hit: {:.2} nodes, {:.2} leaves a ray", per_ray(counts.nodes), per_ray(counts.leaves));
    let mut counts = caustica::geometry::wide_bvh::TraceCounts::default();
    shadow.iter().for_each(|r| _ = geometry.occluded_counted(r, &mut counts));
    println!("any hit: {:.2} nodes, {:.2} leaves a ray", per_ray(counts.nodes), per_ray(counts.leaves));

    let mut group = c.benchmark_group("trace");
    group.throughput(Throughput::Elements(RAYS as u64));
    group.bench_function(BenchmarkId::new("closest_hit", RAYS), |b| {
        b.iter(|| rays.par_iter().map(|r| geometry.intersect(r).t.min(1e3)).sum::<f32>())
    });
    group.bench_function(BenchmarkId::new("any_hit", RAYS), |b| {
        b.iter(|| shadow.par_iter().filter(|r| geometry.occluded(r)).count())
    });

    // The same rays through raw obvhs: its triangle test, its traversal, no shading data.
    let tris: Vec<obvhs::triangle::Triangle> = scene
        .meshes
        .iter()
        .flat_map(|m| m.indices.iter().map(|t| t.map(|v| m.positions[v as usize])))
        .map(|[v0, v1, v2]| obvhs::triangle::Triangle { v0: v0.into(), v1: v1.into(), v2: v2.into() })
        .collect();
    let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut Default::default(),
    );
    group.bench_function(BenchmarkId::new("raw_obvhs_closest_hit", RAYS), |b| {
        b.iter(|| {
            rays.par_iter()
                .map(|r| {
                    let ray = obvhs::ray::Ray::new_inf(r.o.into(), r.d.into());
                    let mut hit = obvhs::ray::RayHit::none();
                    bvh.ray_traverse(ray, &mut hit, |ray, id| {
                        tris[bvh.primitive_indices[id] as usize].intersect(ray)
                    });
                    hit.t.min(1e3)
                })
                .sum::<f32>()
        })
    });
    group.bench_function(BenchmarkId::new("raw_obvhs_any_hit", RAYS), |b| {
        b.iter(|| {
            shadow
                .par_iter()
                .filter(|r| {
                    let ray = obvhs::ray::Ray::new(r.o.into(), r.d.into(), 0.0, r.t_max);
                    !bvh.ray_traverse_miss(ray, |ray, id| {
                        tris[bvh.primitive_indices[id] as usize].intersect(ray)
                    })
                })
                .count()
        })
    });

    // The ECS system on a wavefront of the same rays (bevy's heavy_compute pattern).
    let mut world = World::new();
    let lights = caustica::lights::Lights::default();
    world.insert_resource(SceneResource(caustica::RenderScene {
        geometry,
        lights,
        materials: scene.materials.clone(),
        textures: vec![],
    }));
    world.spawn_batch(rays.iter().enumerate().map(|(i, r)| {
        let mut state = PathState::new(i as u32, 0);
        state.status = PathStatus::Active;
        (PathRay(*r), PathHit::default(), state)
    }));
    let mut system = IntoSystem::into_system(trace_paths);
    system.initialize(&mut world);
    group.bench_function(BenchmarkId::new("trace_paths_system", RAYS), |b| {
        b.iter(|| system.run((), &mut world))
    });
    group.finish();
}

criterion_group!(benches, bench_trace);
criterion_main!(benches);
