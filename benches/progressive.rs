//! Progressive photon mapping on the Cornell box (256×256, max depth 8, as pbrt-v4's SPPM comparison
//! in the README): a whole pass of 65 536 photons, and within it the photon pass (emit, trace,
//! roulette, store) and the gather + update over every hit point, with photons as the throughput unit.

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::scene::{IntegratorKind, load};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::path::Path;

fn bench_passes(c: &mut Criterion) {
    init_thread_pools(None);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf");
    let mut group = c.benchmark_group("progressive");
    group.sample_size(10);
    for kind in [IntegratorKind::Sppm, IntegratorKind::Cppm] {
        let (scene, mut run) = load(&path).expect("scene loads");
        run.render.integrator = kind;
        run.render.max_depth = Some(8);
        let photons = run.progressive.photons_per_pass as u64;
        run.progressive.passes = u32::MAX;
        let mut renderer = Renderer::new(scene, &run).expect("prepares");
        // Warm up to a typical radius: the gather cost depends on it.
        for _ in 0..8 {
            renderer.run_pass(None, &mut |_| {});
        }
        group.throughput(Throughput::Elements(photons));
        group.bench_function(BenchmarkId::new(format!("{kind:?}"), "whole pass"), |b| {
            b.iter(|| renderer.run_pass(None, &mut |_| {}))
        });
        // The phases alone: each pass is run whole, and only the phase's own time is reported.
        for (name, phase) in [("photon pass", "photons"), ("gather + update", "statistics")] {
            group.bench_function(BenchmarkId::new(format!("{kind:?}"), name), |b| {
                b.iter_custom(|iters| {
                    let before = renderer.report().phase_seconds(phase);
                    (0..iters).for_each(|_| renderer.run_pass(None, &mut |_| {}));
                    std::time::Duration::from_secs_f64(renderer.report().phase_seconds(phase) - before)
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_passes);
criterion_main!(benches);
