//! Light selection: every selector is an unbiased choice of light, so all converge to the same image.

mod common;

use caustica::film::Image;
use caustica::scene::{LightSelection, RunFile, load};
use std::path::PathBuf;

fn scene_path(name: &str) -> PathBuf {
    let test_data = common::data(name);
    if test_data.exists() {
        test_data
    } else {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
    }
}

fn render(name: &str, selection: LightSelection, spp: u32, seed: u64) -> Image {
    let (scene, mut run): (_, RunFile) = load(&scene_path(name)).expect("scene loads");
    run.render.light_selection = selection;
    run.render.spp = spp;
    run.render.seed = seed;
    run.film.width = Some(40);
    run.film.height = Some(30);
    common::render(scene, &run)
}

/// Relative per-pixel variance of a many-lights render, from two independent renders: Var(a − b) =
/// 2σ² per pixel, each over (mean² + 0.01) as relMSE normalises, averaged over pixels and channels.
fn relative_variance(selection: LightSelection) -> f64 {
    let (a, b) = (render("many-lights.gltf", selection, 32, 3), render("many-lights.gltf", selection, 32, 4));
    let n = (a.pixels.len() * 3) as f64;
    let relative = |x: f32, y: f32| ((x - y) as f64).powi(2) / (((x + y) as f64 / 2.0).powi(2) + 0.01);
    let sum: f64 =
        a.pixels.iter().zip(&b.pixels).map(|(x, y)| (0..3).map(|c| relative(x[c], y[c])).sum::<f64>()).sum();
    sum / (2.0 * n)
}

/// Pixels are independent estimates, so the mean of the per-pixel differences between two unbiased
/// renders is zero within a few standard errors (4: p ≈ 6e-5 per comparison); a pmf that does not
/// match the sampling frequency, or an MIS weight computed with another pmf than the one sampled,
/// biases the difference by far more. Different seeds keep the two renders independent.
#[test]
fn uniform_power_tree_and_visibility_selection_converge_to_the_same_image() {
    for (name, spp) in [("cornell-box.gltf", 32), ("many-lights.gltf", 32)] {
        let tree = render(name, LightSelection::Tree, spp, 1);
        for other in [LightSelection::Power, LightSelection::Uniform, LightSelection::Visibility] {
            let image = render(name, other, spp, 2);
            let (mean, se) = common::paired_difference(&image, &tree);
            assert!(mean.abs() < 4.0 * se, "{name}: {other:?} − tree = {mean} ± {se}");
        }
        assert!(tree.mean().max_element() > 0.0, "{name}: black");
    }
}

/// On the many-lights scene most lamps are behind walls, and the tree knows distance and
/// orientation: at equal samples its error must be well below power selection's (measured at
/// 320×240, 64 spp: relMSE 0.020 against 0.172, see the README). Here, at 40×30 and 32 spp, the
/// relative per-pixel variance of the tree render, estimated from two independent renders (relMSE's
/// normalisation, so the pixels that see a lamp, noisy under any selector, do not swamp the rest),
/// must be under half of power's.
#[test]
fn the_tree_has_lower_variance_than_power_selection_among_many_occluded_lights() {
    let (tree, power) = (relative_variance(LightSelection::Tree), relative_variance(LightSelection::Power));
    assert!(tree < 0.5 * power, "variance per pixel: tree {tree}, power {power}");
}

/// Visibility-aware selection learns which light clusters the walls hide from each cell: at equal
/// samples its relative variance must be below the tree's (measured at 320×240: relMSE 0.026 against
/// 0.040 at 32 spp, see the README).
#[test]
fn visibility_aware_selection_has_lower_variance_than_the_tree() {
    let (tree, visibility) =
        (relative_variance(LightSelection::Tree), relative_variance(LightSelection::Visibility));
    assert!(visibility < tree, "relative variance per pixel: visibility {visibility}, tree {tree}");
}
