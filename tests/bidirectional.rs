//! Bidirectional path tracing (`bdpt`) against an independent renderer and against `pt`: the
//! Mitsuba 3 references of the test scenes everywhere (bdpt finds every path pt and lt find,
//! including diffuse surfaces seen through the glass and the mirror), the closed furnace's exact
//! radiance, and pt where the lights are a point, a spot and a sun (whose densities the weights
//! treat apart). A weight that does not sum to one over a path's strategies biases whole regions:
//! the kernel's own test checks the sums path by path (`kernel::bidirectional::tests`); these check
//! the systems that feed them.
//!
//! Bounds as tests/light_tracing.rs's: 128×128 renders against the references' 2×2 block
//! averages, 16 blocks' z-scores from the paired differences.

use crate::common;

use caustica::film::output::read_exr;
use caustica::scene::{FilterKind, IntegratorKind, load};

fn render(gltf: &str, kind: IntegratorKind, spp: u32, size: u32) -> caustica::film::Image {
    let (scene, mut run) = load(&common::data(gltf)).expect("test scene loads");
    run.render.integrator = kind;
    run.render.spp = spp;
    (run.film.width, run.film.height) = (Some(size), Some(size));
    common::render(scene, &run)
}

#[test]
fn bdpt_on_cornell_box_matches_mitsuba() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-box.ref.exr")).unwrap());
    common::assert_blocks_match(&render("cornell-box.gltf", IntegratorKind::Bdpt, 8, 128), &reference);
}

/// Everywhere, the spheres included: the walls seen in the mirror and through the glass are
/// connections from camera vertices behind a delta bounce, which lt cannot make.
#[test]
fn bdpt_on_cornell_spheres_matches_mitsuba_everywhere() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-spheres.ref.exr")).unwrap());
    common::assert_blocks_match(&render("cornell-spheres.gltf", IntegratorKind::Bdpt, 8, 128), &reference);
}

/// Inside a closed sphere whose wall emits 1 and reflects half, every pixel sees exactly 2, and
/// every strategy of every length has paths to make: a weight set that does not sum to one moves
/// the mean. The bound is the estimator's: 4.4 standard errors of the mean over pixels.
#[test]
fn bdpt_in_the_furnace_sees_the_exact_radiance() {
    furnace_mean_is_two(IntegratorKind::Bdpt);
}

fn furnace_mean_is_two(kind: IntegratorKind) {
    let scene = caustica::test_scenes::furnace(0.5, 1.0);
    let mut run = caustica::scene::RunFile::default();
    run.render.integrator = kind;
    run.render.spp = 64;
    let image = common::render(scene, &run);
    common::assert_mean_radiance(&image, 2.0, &format!("{kind:?} in the furnace"));
}

/// A point light, a spot and a sun over rough and diffuse surfaces: delta lights have no s = 0
/// strategy and a density of their own in light sampling's and emission's weights; pt (light
/// sampling alone finds them) is the reference here, its noise counted in the paired z-scores.
#[test]
fn bdpt_and_pt_agree_under_point_spot_and_sun_lights() {
    let bdpt = render("punctual-lights.gltf", IntegratorKind::Bdpt, 16, 64);
    let pt = render("punctual-lights.gltf", IntegratorKind::Pt, 64, 64);
    assert!(pt.mean().max_element() > 0.01, "the scene is lit: {}", pt.mean());
    common::assert_blocks_match(&bdpt, &pt);
}

/// Light tracing's splats share a connection among the pixels the filter reaches: under the tent,
/// bdpt's t = 1 strategy and its camera strategies must still make the same pixels as pt.
#[test]
fn bdpt_and_pt_agree_under_the_tent_filter() {
    let render = |kind: IntegratorKind, spp: u32| {
        let (scene, mut run) = load(&common::data("cornell-box.gltf")).expect("test scene loads");
        run.render.integrator = kind;
        run.render.spp = spp;
        run.film.filter = FilterKind::Tent;
        (run.film.width, run.film.height) = (Some(96), Some(96));
        common::render(scene, &run)
    };
    common::assert_blocks_match(&render(IntegratorKind::Bdpt, 8), &render(IntegratorKind::Pt, 16));
}

/// Through a thin lens: the camera subpaths start on the lens and the light subpaths connect to a
/// lens point of their own, each direction's density that of a pinhole at its lens point.
#[test]
fn bdpt_and_pt_agree_through_a_thin_lens() {
    let render = |kind: IntegratorKind, spp: u32| {
        let (scene, mut run) = load(&common::data("cornell-box.gltf")).expect("test scene loads");
        run.render.integrator = kind;
        run.render.spp = spp;
        run.camera.aperture_radius = 0.02;
        run.camera.focus_distance = Some(0.6);
        (run.film.width, run.film.height) = (Some(96), Some(96));
        common::render(scene, &run)
    };
    common::assert_blocks_match(&render(IntegratorKind::Bdpt, 8), &render(IntegratorKind::Pt, 16));
}

/// A light selection bdpt cannot use is not silently dropped: the warning names the setting.
#[test]
fn a_light_selection_bdpt_does_not_use_is_named_in_a_warning() {
    let (scene, mut run) = load(&common::data("cornell-box.gltf")).expect("test scene loads");
    run.render.integrator = IntegratorKind::Bdpt;
    run.render.light_selection = caustica::scene::LightSelection::Uniform;
    run.render.spp = 1;
    (run.film.width, run.film.height) = (Some(16), Some(16));
    let (_, logs) = common::capture_logs(|| common::render(scene.clone(), &run));
    assert!(logs.contains("render.light_selection = uniform is not used"), "{logs}");
    // The default (the tree) is no choice of the user's: nothing to warn about.
    run.render.light_selection = caustica::scene::LightSelection::default();
    let (_, logs) = common::capture_logs(|| common::render(scene, &run));
    assert!(!logs.contains("is not used"), "{logs}");
}

/// vcm against Mitsuba on cornell-spheres: merging is consistent, not unbiased, but at two pixel
/// footprints shrinking from the first unit its bias is far under the noise of 8 samples; a merge
/// normalized wrongly (πr² or the subpath count) or weighted without the VM terms moves every region.
#[test]
fn vcm_on_cornell_spheres_matches_mitsuba_everywhere() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-spheres.ref.exr")).unwrap());
    common::assert_blocks_match(&render("cornell-spheres.gltf", IntegratorKind::Vcm, 8, 128), &reference);
}

/// vcm in the furnace: every merge and connection of every length at once.
#[test]
fn vcm_in_the_furnace_sees_the_exact_radiance() {
    furnace_mean_is_two(IntegratorKind::Vcm);
}
