//! The tree around the distributions: the same bits from any order and thread count, spatial
//! splits where the samples are, bad input, and the memory it reports.

use super::*;

/// Samples spread over a 4-unit box, denser near one corner, with light from a few directions and
/// values over eleven orders of magnitude (the bright quadrants' sums pass 2^32 and carry into the
/// high word).
fn samples(n: u32) -> Vec<(Vec3, Vec3, f32)> {
    (0..n)
        .map(|i| {
            let s = Sampler::new(31, i, 0);
            let p = s.get2d(0).extend(s.get1d(2));
            let p = if i % 3 == 0 { p * 4.0 } else { p * p * 1.5 };
            let d = from_square(s.get2d(3));
            let radiance = if d.z > 0.7 { 1e8 * s.get1d(5) } else { s.get1d(5) * 1e-3 };
            (p, d, radiance)
        })
        .collect()
}

fn record_all(tree: &SdTree, samples: &[(Vec3, Vec3, f32)]) {
    samples.iter().for_each(|&(p, d, l)| tree.record(p, d, l));
}

fn tree() -> SdTree {
    let config = GuidingConfig { spatial_threshold: 500.0, ..GuidingConfig::default() };
    SdTree::with_config(Vec3::ZERO, Vec3::new(4.0, 3.0, 4.0), config)
}

/// Recorded forwards, backwards, or by four threads at once, and refined under one rayon thread or
/// three: the same fingerprint after recording, after refining, and after a second iteration.
#[test]
fn the_order_and_the_thread_count_do_not_change_the_bits() {
    let first = samples(30_000);
    let second = samples(60_000);
    let mut reversed = first.clone();
    reversed.reverse();
    let mut forward = tree();
    let mut backward = tree();
    let mut threaded = tree();
    record_all(&forward, &first);
    record_all(&backward, &reversed);
    std::thread::scope(|s| {
        for t in 0..4 {
            let (tree, first) = (&threaded, &first);
            s.spawn(move || first.iter().skip(t).step_by(4).for_each(|&(p, d, l)| tree.record(p, d, l)));
        }
    });
    let recorded = forward.fingerprint();
    assert_eq!(backward.fingerprint(), recorded);
    assert_eq!(threaded.fingerprint(), recorded);

    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    forward.refine(0);
    pool(1).install(|| backward.refine(0));
    pool(3).install(|| threaded.refine(0));
    let refined = forward.fingerprint();
    assert_ne!(refined, recorded);
    assert!(forward.node_counts().leaves > 4, "the test wants spatial splits");
    assert_eq!(backward.fingerprint(), refined);
    assert_eq!(threaded.fingerprint(), refined);

    for tree in [&mut forward, &mut backward, &mut threaded] {
        std::thread::scope(|s| {
            for t in 0..3 {
                let (tree, second) = (&*tree, &second);
                s.spawn(move || second.iter().skip(t).step_by(3).for_each(|&(p, d, l)| tree.record(p, d, l)));
            }
        });
        tree.refine(1);
    }
    assert_eq!(backward.fingerprint(), forward.fingerprint());
    assert_eq!(threaded.fingerprint(), forward.fingerprint());
}

/// A leaf splits when it saw more than c·√(2^k) samples, each half assumed to have seen half, so the
/// tree is deep where samples were dense and shallow where they were sparse.
#[test]
fn space_splits_where_the_samples_are() {
    let config = GuidingConfig { spatial_threshold: 100.0, ..GuidingConfig::default() };
    let new = || SdTree::with_config(Vec3::ZERO, Vec3::splat(10.0), config);
    let d = Vec3::Z;

    // Exactly at the threshold: no split; one more: one split into halves of 50.
    for (n, leaves) in [(100, 1), (101, 2)] {
        let mut tree = new();
        (0..n).for_each(|_| tree.record(Vec3::splat(5.0), d, 1.0));
        tree.refine(0);
        assert_eq!(tree.node_counts().leaves, leaves, "{n} samples");
    }
    // Iteration 3's threshold is 100·√8 ≈ 282.8.
    let mut tree = new();
    assert!((tree.spatial_threshold(3) - 100.0 * 8f64.sqrt()).abs() < 1e-9);
    (0..283).for_each(|_| tree.record(Vec3::splat(5.0), d, 1.0));
    tree.refine(3);
    assert_eq!(tree.node_counts().leaves, 2);

    // One refinement splits evenly (it knows counts, not where in a leaf they fell); the next splits
    // only the leaves that the dense samples went to.
    let mut tree = new();
    for k in 0..2 {
        for i in 0..20_000 {
            let s = Sampler::new(17, i, k);
            let dense = Vec3::splat(2.0) + (s.get2d(0).extend(s.get1d(2)) - 0.5) * 0.2;
            tree.record(dense, d, 1.0);
            if i % 100 == 0 {
                tree.record(s.get2d(3).extend(s.get1d(5)) * 10.0, d, 1.0);
            }
        }
        tree.refine(k);
        if k == 0 {
            assert_eq!(tree.node_counts().leaves, 256, "20 200 samples halved 8 times fall to 79 ≤ 100");
        }
    }
    let (near, far) = (tree.leaf(Vec3::splat(2.0)), tree.leaf(Vec3::splat(8.0)));
    assert!(near.depth() >= far.depth() + 6, "near {} far {}", near.depth(), far.depth());
    // The leaves split from one start from the distribution it recorded: (1.3, 1.3, 0.1) shared the
    // first refinement's leaf [1.25, 2.5) × [1.25, 2.5) × [0, 2.5) with the dense cluster.
    let cousin = tree.leaf(Vec3::new(1.3, 1.3, 0.1));
    assert_ne!(cousin.index(), near.index());
    assert!(!near.distribution().is_uniform() && near.distribution().samples() > 19_000);
    assert_eq!(near.distribution(), cousin.distribution());
    let counts = tree.node_counts();
    assert_eq!(counts.spatial, 2 * counts.leaves - 1);
    assert!(counts.leaves <= 256 + 2 * 20_200 / 141, "{counts:?}");
    assert_eq!(tree.leaf_at(near.index()).unwrap().depth(), near.depth());
    assert!(tree.leaf_at(counts.leaves as u32).is_none());
}

/// Broken samples are dropped whole, zero radiance is counted without energy, huge radiance is
/// clamped, points outside the box land in the nearest leaf, and nothing returns NaN or infinity.
#[test]
fn bad_input_is_dropped_or_clamped() {
    let mut tree = tree();
    record_all(&tree, &samples(5000));
    tree.refine(0);
    let before = tree.fingerprint();
    let p = Vec3::splat(1.0);
    for bad_radiance in [f32::NAN, f32::INFINITY, -1.0, f32::NEG_INFINITY] {
        tree.record(p, Vec3::Z, bad_radiance);
    }
    for bad_direction in
        [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 1.0, 0.0), Vec3::new(0.0, -0.0, 0.0)]
    {
        tree.record(p, bad_direction, 1.0);
    }
    assert_eq!(tree.fingerprint(), before, "broken samples must leave no trace");
    tree.record(p, Vec3::Z, 0.0);
    assert_ne!(tree.fingerprint(), before, "a zero sample is still a visit");

    // Outside the box (and NaN) is clamped onto it: the leaf of the nearest point.
    let corner = Vec3::new(4.0, 4.0, 4.0) - 1e-3;
    for (outside, inside) in [
        (Vec3::splat(-7.0), Vec3::ZERO),
        (Vec3::splat(1e30), corner),
        (Vec3::new(f32::INFINITY, f32::INFINITY, f32::INFINITY), corner),
        (Vec3::NAN, Vec3::ZERO),
        (Vec3::new(f32::NAN, 2.5, -1.0), Vec3::new(0.0, 2.5, 0.0)),
    ] {
        assert_eq!(tree.leaf(outside).index(), tree.leaf(inside).index(), "{outside}");
    }
    tree.record(Vec3::NAN, Vec3::X, f32::MAX);
    tree.record(Vec3::splat(f32::NEG_INFINITY), -Vec3::X, 1e20);
    tree.refine(1);

    for p in [Vec3::NAN, Vec3::splat(f32::INFINITY), Vec3::splat(2.0), Vec3::splat(-1.0)] {
        for u in
            [Vec2::NAN, Vec2::splat(-1.0), Vec2::ONE, Vec2::splat(2.0), Vec2::ZERO, Vec2::splat(0.999_999_9)]
        {
            let (d, pdf) = tree.sample(p, u);
            assert!(
                d.is_finite() && (d.length() - 1.0).abs() < 1e-5 && pdf.is_finite() && pdf >= 0.0,
                "{d} {pdf}"
            );
        }
        for d in [Vec3::ZERO, Vec3::NAN, Vec3::splat(f32::INFINITY)] {
            assert_eq!(tree.pdf(p, d), 0.0);
        }
        assert!(tree.directional_image(p, 16, 8).iter().all(|v| v.is_finite() && *v >= 0.0));
    }

    // Boxes that are empty, reversed or not finite still make a usable tree.
    for (lo, hi) in [
        (Vec3::ONE, Vec3::ONE),
        (Vec3::splat(3.0), Vec3::ZERO),
        (Vec3::NAN, Vec3::ONE),
        (Vec3::ZERO, Vec3::splat(f32::INFINITY)),
    ] {
        let mut tree = SdTree::new(lo, hi);
        tree.record(Vec3::ONE, Vec3::Y, 1.0);
        tree.refine(0);
        let (d, pdf) = tree.sample(Vec3::ONE, Vec2::splat(0.3));
        assert!(d.is_finite() && pdf.is_finite() && pdf > 0.0, "{lo} {hi}: {d} {pdf}");
    }
}

/// The reported bytes are the arrays' sizes, node by node.
#[test]
fn memory_is_what_the_nodes_hold() {
    let mut tree = tree();
    record_all(&tree, &samples(20_000));
    tree.refine(0);
    let c = tree.node_counts();
    assert_eq!(
        tree.memory_bytes(),
        4 * c.spatial + 152 * c.leaves + 32 * c.sampling + 56 * c.recording,
        "{c:?}"
    );
}

/// Light recorded only in the corner [0, ¼)³ of a tree split into cells of ¼ or less: after a
/// second pass (split cells start from their parent's distribution), only that corner's cells
/// guide, and the bounds are the corner; before any light, there are none.
#[test]
fn the_guiding_bounds_are_the_regions_that_guide() {
    let config =
        GuidingConfig { spatial_threshold: 100.0, fixed_bsdf_share: Some(0.5), ..Default::default() };
    let mut tree = SdTree::with_config(Vec3::ZERO, Vec3::ONE, config);
    assert_eq!(tree.guiding_bounds(), None, "nothing learnt");
    for iteration in 0..2 {
        for i in 0..4000 {
            let t = (i as f32 + 0.5) / 4000.0;
            let p = Vec3::new(t, (t * 7.0).fract(), (t * 13.0).fract());
            tree.record(p, Vec3::Z, if p.max_element() < 0.25 { 1.0 } else { 0.0 });
        }
        tree.refine(iteration);
    }
    assert!(tree.node_counts().leaves >= 64);
    let (lo, hi) = tree.guiding_bounds().expect("the corner guides");
    assert!(lo.abs_diff_eq(Vec3::ZERO, 1e-5) && hi.abs_diff_eq(Vec3::splat(0.25), 1e-5), "{lo} {hi}");
}

/// Hostile settings (split a region at every sample, a quadtree node for every five hundredth of the
/// energy; the ten thousandth grew the tree to gigabytes in one refinement). Under a cap the
/// refinement that would pass it is not made: the distributions are kept, nothing splits, the
/// recording trees go (training ends), and the tree is smaller than before, never past the cap; a
/// cap the grown tree fits under refines as without one, to the bit.
#[test]
fn a_refinement_past_the_cap_is_not_made_and_training_ends() {
    // As hostile, kept small enough to refine freely in a test: a uniform recording tree five
    // levels deep in every one of thousands of regions.
    let config =
        GuidingConfig { spatial_threshold: 1.0, directional_threshold: 2e-3, ..GuidingConfig::default() };
    let fresh = || SdTree::with_config(Vec3::ZERO, Vec3::new(4.0, 3.0, 4.0), config);
    let data = samples(3_000);

    let mut free = fresh();
    record_all(&free, &data);
    assert_eq!(free.refine_within(0, usize::MAX), Refined::Grown);
    let grown = free.memory_bytes();
    assert!(free.node_counts().leaves > 1000, "the test wants a tree that grows far");

    // A cap just above what refining holds: the same tree as without one.
    let mut roomy = fresh();
    record_all(&roomy, &data);
    assert_eq!(roomy.refine_within(0, 4 * grown), Refined::Grown);
    assert_eq!(roomy.fingerprint(), free.fingerprint());

    let mut capped = fresh();
    record_all(&capped, &data);
    let (before, leaves_before) = (capped.memory_bytes(), capped.node_counts().leaves);
    let cap = grown / 10;
    assert!(before < cap);
    assert_eq!(capped.refine_within(0, cap), Refined::Capped);
    assert!(capped.memory_bytes() <= before, "{} bytes after, {before} before", capped.memory_bytes());
    assert_eq!(capped.node_counts().leaves, leaves_before, "a capped refinement split a region");
    assert_eq!(capped.node_counts().recording, 0, "training ended but the recording trees stayed");
    // What was recorded is what is sampled now.
    assert!(!capped.leaf(Vec3::splat(1.0)).distribution().is_uniform());
    // Recording into an ended tree is a no-op, not a panic.
    let ended = capped.memory_bytes();
    record_all(&capped, &data[..100]);
    assert_eq!(capped.memory_bytes(), ended);
}
