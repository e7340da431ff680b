//! Whole-frame throughput: one sample per pixel of the Cornell box at 256×256, every step of the
//! schedule included (emit, trace, scatter, shadow, gather).

// criterion_group! generates an undocumented public fn.
#![allow(missing_docs)]

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::scene::{IntegratorKind, load};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::path::Path;

fn bench_frame(c: &mut Criterion) {
    init_thread_pools(None);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf");
    let mut group = c.benchmark_group("frame");
    group.sample_size(10);
    for kind in [IntegratorKind::Pt, IntegratorKind::PtNaive] {
        let (scene, mut run) = load(&path).expect("scene loads");
        run.render.integrator = kind;
        run.render.spp = 1;
        let pixels = 256 * 256;
        group.throughput(Throughput::Elements(pixels));
        group.bench_function(BenchmarkId::new(format!("{kind:?}"), "cornell-box 1spp"), |b| {
            b.iter_batched(
                || Renderer::new(scene.clone(), &run).expect("prepares"),
                |mut renderer| renderer.run(None, |_| {}),
                criterion::BatchSize::PerIteration,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, bench_frame);
criterion_main!(benches);
