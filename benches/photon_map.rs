//! Photon map: kd-tree build time and k-nearest queries per second, on photons spread over the
//! surfaces of a unit box (2-D manifolds in 3-D, like real photon maps).
//! `CAUSTICA_BENCH_10M=1` adds the 10-million-photon build (about 320 MB).

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use caustica::photon::{Neighbors, Photon, PhotonMap};
use caustica::sampling::Sampler;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;

fn photons(n: u32) -> Vec<Photon> {
    (0..n)
        .map(|i| {
            let s = Sampler::new(5, i, 0);
            // A point on one of the six faces of the unit cube.
            let face = (s.get1d(0) * 6.0) as u32;
            let (u, v) = (s.get1d(1), s.get1d(2));
            let side = (face % 2) as f32;
            let p = match face / 2 {
                0 => Vec3::new(side, u, v),
                1 => Vec3::new(u, side, v),
                _ => Vec3::new(u, v, side),
            };
            Photon::new(p, Vec3::Y, Vec3::Y, Vec3::splat(1e-6))
        })
        .collect()
}

fn bench_photon_map(c: &mut Criterion) {
    let mut group = c.benchmark_group("photon_map");
    group.sample_size(10);
    let mut sizes = vec![1_000_000u32];
    if std::env::var("CAUSTICA_BENCH_10M").is_ok() {
        sizes.push(10_000_000);
    }
    for &n in &sizes {
        let input = photons(n);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("build", n), |b| b.iter(|| PhotonMap::build(input.clone())));
    }
    let map = PhotonMap::build(photons(1_000_000));
    const QUERIES: u32 = 10_000;
    let queries: Vec<Vec3> = photons(QUERIES).iter().map(|p| p.position()).collect();
    for k in [50usize, 200] {
        group.throughput(Throughput::Elements(QUERIES as u64));
        group.bench_function(BenchmarkId::new("knn_1M", k), |b| {
            let mut out = Neighbors::with_capacity(k);
            b.iter(|| {
                let mut found = 0;
                for &q in &queries {
                    map.knn(q, k, f32::INFINITY, &mut out);
                    found += out.len();
                }
                found
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_photon_map);
criterion_main!(benches);
