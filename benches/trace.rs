//! Trace throughput: closest-hit and any-hit queries on incoherent rays, through our `Geometry`
//! (eight-wide BVH, watertight test on packs of triangles) and through raw obvhs CwBvh traversal
//! with its own (Möller–Trumbore, not watertight) triangle test, on the Cornell box and on the
//! 1.96 M-triangle dense mesh (`python3 scenes/make_dense_mesh.py` writes it; skipped without it).
//! The rays are `../shared/peers/embree_rays.py`'s distribution (origins uniform in the inner 90% of
//! the scene's box, directions uniform on the sphere; shadow segments from each origin to the next),
//! so that the two print comparable rays per second. Before measuring it prints the nodes and leaves
//! our traversal visits per ray.
//!
//! `cargo bench --bench trace` (a filter such as `-- dense-mesh/closest` picks one).

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use caustica::driver::init_thread_pools;
use caustica::geometry::{Geometry, Ray};
use caustica::sampling::Sampler;
use caustica::sampling::warp::uniform_sphere;
use caustica::scene::load;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

const RAYS: u32 = 1 << 16;

/// Rays from random points inside the scene's box in uniformly random directions: the incoherent case.
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

fn bench_scene(c: &mut Criterion, name: &str, file: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    if !path.exists() {
        println!(
            "{name}: {} not found, skipped (python3 scenes/make_dense_mesh.py writes it)",
            path.display()
        );
        return;
    }
    let scene = load(&path).expect("scene loads").0;
    let geometry = Geometry::build(&scene);
    let rays = incoherent_rays(&geometry);
    let shadow: Vec<Ray> = rays
        .iter()
        .zip(rays.iter().cycle().skip(1))
        .map(|(a, b)| Ray { o: a.o, d: b.o - a.o, t_max: 0.9999, time: 0.0 })
        .collect();

    let (packs, nodes, triangles) = geometry.pack_counts();
    println!(
        "{name}: {triangles} triangles in {packs} packs ({:.2} a pack), {nodes} nodes, {:.0} bytes a triangle",
        triangles as f64 / packs.max(1) as f64,
        geometry.acceleration_bytes() as f64 / triangles.max(1) as f64
    );
    let mut counts = caustica::geometry::wide_bvh::TraceCounts::default();
    let hits = rays.iter().filter(|r| geometry.intersect_counted(r, &mut counts).is_hit()).count();
    let per_ray = |n: u32| n as f64 / RAYS as f64;
    println!(
        "{name}: closest hit {:.2} nodes, {:.2} leaves a ray ({:.3} of the rays hit)",
        per_ray(counts.nodes),
        per_ray(counts.leaves),
        hits as f64 / RAYS as f64
    );
    let mut counts = caustica::geometry::wide_bvh::TraceCounts::default();
    let blocked = shadow.iter().filter(|r| geometry.occluded_counted(r, &mut counts)).count();
    println!(
        "{name}: any hit {:.2} nodes, {:.2} leaves a ray ({:.3} of the segments blocked)",
        per_ray(counts.nodes),
        per_ray(counts.leaves),
        blocked as f64 / RAYS as f64
    );

    let mut group = c.benchmark_group(name);
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
    group.finish();
}

fn bench_trace(c: &mut Criterion) {
    init_thread_pools(None);
    bench_scene(c, "cornell-box", "scenes/cornell-box.gltf");
    bench_scene(c, "dense-mesh", "scenes/dense-mesh.gltf");
}

criterion_group!(benches, bench_trace);
criterion_main!(benches);
