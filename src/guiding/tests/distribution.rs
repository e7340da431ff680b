//! The directional distributions: sampling against density, normalisation, what training learns,
//! how the quadtree's shape follows the energy.

use super::*;
use crate::sampling::chi2::{Chi2Config, chi2_test};
use crate::sampling::warp::{Frame, uniform_cone};

/// The sampled directions follow the density `pdf` reports: early (a shallow tree) and after five
/// iterations (cells down to the depth limit around the narrow lobe). The χ² test integrates `pdf`
/// over each bin independently of the sampler.
#[test]
fn sampling_matches_the_density_by_chi_square() {
    for iterations in [1, 5] {
        let tree = lobes(GuidingConfig::default(), iterations);
        let leaf = tree.leaf(Vec3::splat(0.5));
        assert!(!leaf.distribution().is_uniform());
        let config = Chi2Config { test_count: 2, ..Chi2Config::default() };
        let result = chi2_test(
            |i| Some(leaf.sample(Sampler::new(11, i, 0).get2d(0)).0),
            |d| leaf.pdf(d),
            400_000,
            &config,
        );
        assert!(result.is_ok(), "after {iterations} iterations: {}", result.unwrap_err());
    }
}

/// A sample's density is the one `pdf` gives its direction, bit for bit, but where rounding the
/// direction moves it across a cell boundary.
#[test]
fn a_samples_density_is_its_directions() {
    let tree = lobes(GuidingConfig::default(), 5);
    let leaf = tree.leaf(Vec3::splat(0.5));
    let n = 100_000;
    let mut differ = 0;
    for i in 0..n {
        let (d, pdf) = leaf.sample(Sampler::new(5, i, 0).get2d(0));
        assert!(pdf > 0.0 && pdf.is_finite() && (d.length() - 1.0).abs() < 1e-5, "{d} {pdf}");
        differ += (leaf.pdf(d) != pdf) as u32;
    }
    assert!(differ < n / 1000, "{differ} of {n} samples disagree with pdf");
}

/// The density integrates to one over the sphere. With the depth limited to 11, a 2048² grid of
/// the square resolves every cell, so the quadrature is exact up to rounding; at the full depth the
/// cells finer than the grid are sampled at a point, which still averages out closely.
#[test]
fn the_density_integrates_to_one() {
    let shallow = lobes(GuidingConfig { max_depth: 11, ..GuidingConfig::default() }, 5);
    let leaf = shallow.leaf(Vec3::ZERO);
    assert!(depth(leaf.distribution()) >= 6, "the test wants a deep tree: {}", depth(leaf.distribution()));
    let i = integral(leaf, 2048);
    assert!((i - 1.0).abs() < 1e-4, "{i}");
    let deep = lobes(GuidingConfig::default(), 5);
    let i = integral(deep.leaf(Vec3::ZERO), 1024);
    assert!((i - 1.0).abs() < 1e-2, "{i}");
    let uniform = SdTree::new(Vec3::ZERO, Vec3::ONE);
    assert!((integral(uniform.leaf(Vec3::ZERO), 64) - 1.0).abs() < 1e-6);
}

/// Light from a cone of 10° (0.76% of the sphere) only: after six iterations the guide sends most of
/// its samples into it, and the debug image is brightest along its axis.
#[test]
fn a_trained_guide_concentrates_on_the_light() {
    let mut tree = one_leaf(GuidingConfig::default());
    let light = cone(AXIS, 10.0);
    train(&mut tree, 6, 2000, |_| Vec3::splat(0.5), &light);
    let leaf = tree.leaf(Vec3::splat(0.5));
    let inside = mass_where(leaf, 100_000, |d| light(d) > 0.0);
    assert!(inside > 0.85, "{inside} of the guide's samples in the cone");
    let wider_cone = cone(AXIS, 14.0);
    let wider = mass_where(leaf, 100_000, |d| wider_cone(d) > 0.0);
    assert!(wider > 0.99, "{wider} of the guide's samples within 14°");

    let (w, h) = (128, 64);
    let image = tree.directional_image(Vec3::splat(0.5), w, h);
    assert_eq!(image.len(), (w * h) as usize);
    let brightest = (0..image.len()).max_by(|&a, &b| image[a].total_cmp(&image[b])).unwrap() as u32;
    let (x, y) = (brightest % w, brightest / w);
    let pixel = from_square(Vec2::new(1.0 - (y as f32 + 0.5) / h as f32, (x as f32 + 0.5) / w as f32));
    assert!(light(pixel) > 0.0, "brightest pixel {x}, {y} looks along {pixel}");
    // Pixels are equal areas of the square: their mean is the density's mean, 1 / 4π.
    let mean = image.iter().map(|&p| p as f64).sum::<f64>() / image.len() as f64;
    assert!((mean * 4.0 * std::f64::consts::PI - 1.0).abs() < 0.2, "{mean}");
}

/// Quadrants above ρ of the energy split, recursively in one refinement; the depth limit holds; once
/// the light spreads out the fine nodes collapse to the shape of no information (three uniform levels
/// of nodes, 1 + 4 + 16 + 64 of them, where a quadrant's area share first falls to ρ or below).
#[test]
fn quadtrees_split_by_energy_and_collapse_again() {
    let config = GuidingConfig { max_depth: 9, ..GuidingConfig::default() };
    let fresh = one_leaf(config);
    assert_eq!(fresh.node_counts().recording, 85);
    let mut tree = one_leaf(config);
    // Recorded straight from a cone of 0.5°: a light that small is found by chance too rarely for a
    // short test, and recording does not care how its directions were drawn.
    let frame = Frame::from_z(AXIS.normalize());
    for k in 0..4 {
        for i in 0..2000 {
            let d = frame.to_world(uniform_cone(Sampler::new(9, i, k).get2d(0), 0.5f32.to_radians().cos()));
            tree.record(Vec3::ZERO, d, 1.0);
        }
        tree.refine(k);
    }
    let leaf = tree.leaf(Vec3::ZERO);
    assert_eq!(depth(leaf.distribution()), 9, "a point-like light reaches the depth limit");
    let concentrated = tree.node_counts().recording;
    assert!(concentrated < 9 * 100, "at most 1/ρ nodes a level: {concentrated}");
    train(&mut tree, 1, 20_000, |_| Vec3::ZERO, |_| 1.0);
    assert_eq!(tree.node_counts().recording, 85);
    // What is sampled is what was recorded, in the shape it was recorded in: still the deep one, one
    // iteration later the uniform one.
    assert_eq!(depth(tree.leaf(Vec3::ZERO).distribution()), 9);
    train(&mut tree, 1, 20_000, |_| Vec3::ZERO, |_| 1.0);
    assert_eq!(depth(tree.leaf(Vec3::ZERO).distribution()), 4);
}

/// A leaf with nothing recorded, or nothing but zero radiance, samples the uniform sphere; so does a
/// trained leaf after an iteration that recorded nothing (what was recorded is what is sampled).
#[test]
fn a_leaf_without_energy_is_uniform() {
    let mut tree = SdTree::new(Vec3::ZERO, Vec3::ONE);
    let check = |tree: &SdTree| {
        let leaf = tree.leaf(Vec3::splat(0.3));
        assert!(leaf.distribution().is_uniform());
        for i in 0..1000 {
            let (d, pdf) = leaf.sample(Sampler::new(1, i, 0).get2d(0));
            assert_eq!(pdf, INV_FOUR_PI);
            assert_eq!(leaf.pdf(d), INV_FOUR_PI);
            assert_eq!(leaf.pdf(-d * 3.0), INV_FOUR_PI);
        }
    };
    check(&tree);
    tree.refine(0);
    check(&tree);
    for i in 0..100 {
        tree.record(Vec3::splat(0.3), from_square(Sampler::new(2, i, 0).get2d(0)), 0.0);
    }
    tree.refine(1);
    check(&tree);
    assert_eq!(tree.leaf(Vec3::ZERO).distribution().samples(), 100);
    train(&mut tree, 1, 1000, |_| Vec3::ZERO, cone(AXIS, 20.0));
    assert!(!tree.leaf(Vec3::ZERO).distribution().is_uniform());
    tree.refine(2);
    check(&tree);

    let config = Chi2Config::default();
    let leaf = tree.leaf(Vec3::ZERO);
    let result =
        chi2_test(|i| Some(leaf.sample(Sampler::new(3, i, 0).get2d(0)).0), |d| leaf.pdf(d), 100_000, &config);
    assert!(result.is_ok(), "{}", result.unwrap_err());
}
