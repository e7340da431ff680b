//! Light selection cost against the number of lights (10 to 100 000): the tree's descent is
//! O(log n), the CDF's binary search too but blind to position; both timed per selection.

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use caustica::lights::{Light, LightSelector, LightTree};
use caustica::sampling::Sampler;
use caustica::sampling::warp::uniform_sphere;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;

fn bench_selection(c: &mut Criterion) {
    let mut group = c.benchmark_group("light_selection");
    const QUERIES: u32 = 1024;
    let points: Vec<(Vec3, Vec3, f32)> = (0..QUERIES)
        .map(|i| {
            let s = Sampler::new(9, i, 0);
            (Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) * 100.0, uniform_sphere(s.get2d(3)), s.get1d(5))
        })
        .collect();
    group.throughput(Throughput::Elements(QUERIES as u64));
    for n in [10, 100, 1_000, 10_000, 100_000] {
        let lights = caustica::test_scenes::scattered_lights(n, 100.0);
        let tree = LightTree::build(&lights);
        let power: Vec<f32> = lights.iter().map(Light::power).collect();
        let cdf = LightSelector::new(&power);
        group.bench_function(BenchmarkId::new("tree", n), |b| {
            b.iter(|| {
                points.iter().filter_map(|&(p, nrm, u)| tree.sample(p, nrm, u)).map(|s| s.1).sum::<f32>()
            })
        });
        group.bench_function(BenchmarkId::new("power", n), |b| {
            b.iter(|| points.iter().filter_map(|&(_, _, u)| cdf.sample(u)).map(|s| s.1).sum::<f32>())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_selection);
criterion_main!(benches);
