//! Environment-light sampling cost against the map's size (32 × 16 to 4096 × 2048 texels): the 2-D
//! CDF's two binary searches are O(log n) per sample, and the pdf lookup O(1). Timed per sample
//! (direction, pdf and radiance) and per pdf evaluation, with a constant environment for scale.

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use caustica::film::Image;
use caustica::lights::Environment;
use caustica::sampling::Sampler;
use caustica::sampling::warp::uniform_sphere;
use caustica::scene::environment::{EnvironmentDesc, EnvironmentRadiance};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Quat, Vec2, Vec3};

/// A sky-like map: a smooth gradient and a bright sun texel, so the CDF is far from uniform.
fn map(width: u32) -> Environment {
    let height = width / 2;
    let pixels = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            if x == width / 3 && y == height / 4 {
                Vec3::splat(1e5)
            } else {
                Vec3::splat(1.0 + (x ^ y) as f32 / width as f32)
            }
        })
        .collect();
    let desc = EnvironmentDesc {
        name: format!("{width}x{height}"),
        radiance: EnvironmentRadiance::Map(Image { width, height, pixels }),
        strength: 1.0,
        rotation: Quat::from_rotation_y(0.3),
    };
    Environment::new(&desc, Vec3::splat(-1.0), Vec3::splat(1.0))
}

fn bench_environment(c: &mut Criterion) {
    let mut group = c.benchmark_group("environment");
    const QUERIES: u32 = 4096;
    let us: Vec<Vec2> = (0..QUERIES).map(|i| Sampler::new(3, i, 0).get2d(0)).collect();
    let dirs: Vec<Vec3> = us.iter().map(|&u| uniform_sphere(u)).collect();
    group.throughput(Throughput::Elements(QUERIES as u64));
    let constant =
        Environment::new(&EnvironmentDesc::constant(Vec3::ONE), Vec3::splat(-1.0), Vec3::splat(1.0));
    group.bench_function(BenchmarkId::new("sample", "constant"), |b| {
        b.iter(|| {
            us.iter().filter_map(|&u| constant.sample(Vec3::ZERO, Vec3::Y, u)).map(|s| s.pdf).sum::<f32>()
        })
    });
    for width in [32, 256, 1024, 4096] {
        let env = map(width);
        let texels = width * width / 2;
        group.bench_function(BenchmarkId::new("sample", texels), |b| {
            b.iter(|| {
                us.iter().filter_map(|&u| env.sample(Vec3::ZERO, Vec3::ZERO, u)).map(|s| s.pdf).sum::<f32>()
            })
        });
        group.bench_function(BenchmarkId::new("pdf", texels), |b| {
            b.iter(|| dirs.iter().map(|&d| env.pdf(Vec3::ZERO, d)).sum::<f32>())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_environment);
criterion_main!(benches);
