//! What a trained tree costs in time and memory, on a room-like scene: ignored by default, run
//! optimised with `CARGO_PROFILE_TEST_OPT_LEVEL=3 cargo test -p caustica-core --lib
//! guiding::tests::speed -- --ignored --nocapture` (the test profile already builds the dependencies
//! at level 3, so only this crate is rebuilt).

use super::*;
use std::time::Instant;

/// A point on one of the six faces of the room [0, 4] × [0, 3] × [0, 4].
fn on_a_wall(i: u32) -> Vec3 {
    let s = Sampler::new(41, i, 0);
    let (u, face) = (s.get2d(0), (s.get1d(2) * 6.0) as u32);
    let size = Vec3::new(4.0, 3.0, 4.0);
    let p = match face {
        0 | 1 => Vec3::new(face as f32, u.x, u.y),
        2 | 3 => Vec3::new(u.x, (face - 2) as f32, u.y),
        _ => Vec3::new(u.x, u.y, (face - 4) as f32),
    };
    p * size
}

/// A small bright lamp under the ceiling and a dim sky through a window in the +x wall.
fn radiance_at(p: Vec3, d: Vec3) -> f32 {
    let lamp = Vec3::new(2.0, 2.8, 2.0);
    let to_lamp = lamp - p;
    let lit = d.normalize().dot(to_lamp.normalize()) > (1.0 - 0.02 / to_lamp.length_squared()).max(0.0);
    let sky = d.x > 0.8 && d.y > 0.0;
    1000.0 * lit as u8 as f32 + 2.0 * sky as u8 as f32 + 0.05
}

#[test]
#[ignore = "a measurement, not a check: run optimised with --nocapture"]
fn speed() {
    let mut tree = SdTree::new(Vec3::ZERO, Vec3::new(4.0, 3.0, 4.0));
    // 256² pixels from 1 to 32 paths each, three recorded vertices a path.
    let base = 3 * 256 * 256;
    let start = Instant::now();
    let mut recorded = 0u64;
    for k in 0..6u32 {
        let n = base << k;
        let began = Instant::now();
        for i in 0..n {
            let s = Sampler::new(100 + k as u64, i, 0);
            let p = on_a_wall(i);
            let leaf = tree.leaf(p);
            let u = s.get2d(1);
            let d = if s.get1d(0) < 0.5 { from_square(u) } else { leaf.sample(u).0 };
            let pdf = 0.5 * INV_FOUR_PI + 0.5 * leaf.pdf(d);
            leaf.record(d, radiance_at(p, d) / pdf);
        }
        let per = began.elapsed().as_nanos() as f64 / n as f64;
        recorded += n as u64;
        let refine = Instant::now();
        tree.refine(k);
        let c = tree.node_counts();
        println!(
            "iteration {k}: {n} vertices, {per:.0} ns each (lookup, sample, pdf, record); refine {:.1} ms; \
             {} leaves, {} sampling and {} recording nodes, {:.2} MB",
            refine.elapsed().as_secs_f64() * 1e3,
            c.leaves,
            c.sampling,
            c.recording,
            tree.memory_bytes() as f64 / 1e6
        );
    }
    println!("{recorded} vertices trained in {:.2} s", start.elapsed().as_secs_f64());

    let n = 2_000_000u32;
    let points: Vec<Vec3> = (0..n).map(on_a_wall).collect();
    let numbers: Vec<Vec2> = (0..n).map(|i| Sampler::new(5, i, 0).get2d(0)).collect();
    // The fastest of five runs: the machine is shared, and the others only measure the neighbours.
    let time = |what: &str, f: &dyn Fn(u32) -> f32| {
        let (mut best, mut sum) = (f64::INFINITY, 0.0);
        for _ in 0..5 {
            let began = Instant::now();
            sum = (0..n).map(f).sum::<f32>();
            best = best.min(began.elapsed().as_nanos() as f64 / n as f64);
        }
        println!("{what}: {best:.1} ns ({sum:.3e})");
    };
    // Baselines for a loaded machine: the trigonometry every sample and every pdf needs anyway.
    time("baseline: square to direction (sin_cos, sqrt)", &|i| from_square(numbers[i as usize]).z);
    time("baseline: direction to square (atan2, sqrt)", &|i| {
        to_square(points[i as usize] - 2.0).map_or(0.0, |s| s.x)
    });
    time("leaf lookup", &|i| tree.leaf(points[i as usize]).depth() as f32);
    time("lookup + sample", &|i| tree.sample(points[i as usize], numbers[i as usize]).1);
    time("lookup + pdf", &|i| tree.pdf(points[i as usize], from_square(numbers[i as usize])));
    time("lookup + sample + pdf", &|i| {
        let leaf = tree.leaf(points[i as usize]);
        let (d, pdf) = leaf.sample(numbers[i as usize]);
        pdf + leaf.pdf(d)
    });
    let leaf = tree.leaf(Vec3::new(2.0, 0.0, 2.0));
    println!("a floor leaf: {} quadtree nodes", leaf.distribution().node_count());
    time("sample in one leaf", &|i| leaf.sample(numbers[i as usize]).1);
    time("pdf in one leaf", &|i| leaf.pdf(from_square(numbers[i as usize])));
    time("lookup + record", &|i| {
        tree.record(points[i as usize], from_square(numbers[i as usize]), 1.0);
        0.0
    });
    let deepest = (0..tree.node_counts().leaves as u32)
        .map(|l| depth(tree.leaf_at(l).unwrap().distribution()))
        .max()
        .unwrap();
    println!("deepest quadtree: {deepest}");
}
