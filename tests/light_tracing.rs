//! Light tracing (`lt`) against an independent renderer: the Mitsuba 3 references of the test
//! scenes, wherever lt finds every path: everywhere in the cornell box; in cornell-spheres (a glass
//! and a mirror sphere, whose caustics lt finds at once) everywhere but the spheres, in which
//! diffuse surfaces are seen through a delta bounce (L…D S E), which neither a connection nor lt's
//! camera rays can make (`bdpt` does: tests/bidirectional.rs). Not cornell-point-rough: its point light's reflection off the
//! mirror sphere onto the walls (L S D E from a point) is light no path tracer finds, so Mitsuba's
//! reference lacks it and lt, which finds it, is 1–3% brighter there.
//!
//! The references are 256×256 with a box filter; a 128×128 render is compared with their 2×2 block
//! averages, region by region, as tests/convergence.rs does for `pt`. A light subpath splats into a
//! few pixels (one a visible vertex), so neighbouring pixels are slightly correlated; the bounds
//! below are the same as `pt`'s, and a lost factor (the lens's cos θ, the BSDF's in importance
//! transport, the subpath count) moves whole regions by far more.

use crate::common;

use caustica::film::output::read_exr;
use caustica::scene::{IntegratorKind, load};

fn render_half(gltf: &str, spp: u32) -> caustica::film::Image {
    let (scene, mut run) = load(&common::data(gltf)).expect("test scene loads");
    run.render.integrator = IntegratorKind::Lt;
    run.render.spp = spp;
    (run.film.width, run.film.height) = (Some(128), Some(128));
    common::render(scene, &run)
}

/// The pixels of a 128×128 render of `gltf` whose camera rays (at the corners and the centre of
/// the pixel) all land first on a surface that is not a delta BSDF.
fn seen_without_a_delta_bounce(gltf: &str) -> Vec<bool> {
    use caustica::kernel::Vertex;
    use caustica::resources::{CameraResource, SceneResource};
    let (scene, mut run) = load(&common::data(gltf)).expect("test scene loads");
    (run.film.width, run.film.height) = (Some(128), Some(128));
    let (world, _) = caustica::driver::scene_world(scene, &run).unwrap();
    let (scene, camera) = (&world.resource::<SceneResource>().0, &world.resource::<CameraResource>().0);
    let offsets = [(0.01, 0.01), (0.99, 0.01), (0.01, 0.99), (0.99, 0.99), (0.5, 0.5)];
    (0..128 * 128)
        .map(|i| {
            offsets.iter().all(|&(u, v)| {
                let ray =
                    camera.generate_ray(i % 128, i / 128, glam::Vec2::new(u, v), glam::Vec2::splat(0.5), 0.0);
                let hit = scene.geometry.intersect(&ray);
                !hit.is_hit()
                    || !Vertex::new(scene, &ray, scene.geometry.surface_hit(&ray, &hit)).bsdf.is_delta()
            })
        })
        .collect()
}

/// `image` with the pixels outside `keep` set to the reference's, so they add nothing to a
/// difference.
fn masked(
    image: &caustica::film::Image,
    reference: &caustica::film::Image,
    keep: &[bool],
) -> caustica::film::Image {
    let mut out = image.clone();
    for (i, keep) in keep.iter().enumerate() {
        if !keep {
            out.pixels[i] = reference.pixels[i];
        }
    }
    out
}

#[test]
fn lt_on_cornell_box_matches_mitsuba() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-box.ref.exr")).unwrap());
    common::assert_blocks_match(&render_half("cornell-box.gltf", 16), &reference);
}

#[test]
fn lt_on_cornell_spheres_matches_mitsuba_outside_the_spheres() {
    let reference = common::downsample2(&read_exr(&common::data("cornell-spheres.ref.exr")).unwrap());
    let keep = seen_without_a_delta_bounce("cornell-spheres.gltf");
    let dropped = keep.iter().filter(|k| !**k).count();
    // The two spheres and nothing else: a few percent of the pixels.
    assert!((600..5000).contains(&dropped), "{dropped} pixels seen through a delta bounce");
    common::assert_blocks_match(
        &masked(&render_half("cornell-spheres.gltf", 16), &reference, &keep),
        &reference,
    );
}

/// The splats share a connection among the pixels the reconstruction filter reaches, with the
/// weights the camera samples are drawn from: under the tent and the Gaussian, lt and pt (whose
/// samples land by the filter) estimate the same pixels. Region by region, as above: the blocks'
/// z-scores come from the paired differences, so both renders' noise counts. A weight that does not
/// integrate to one moves every block (tent weights 10% high: every z above 4); a wrong footprint
/// only blurs within a block, which `camera::tests` checks instead.
#[test]
fn lt_and_pt_agree_under_the_wider_filters() {
    use caustica::scene::FilterKind;
    for filter in [FilterKind::Tent, FilterKind::Gaussian] {
        let render = |kind: IntegratorKind| {
            let (scene, mut run) = load(&common::data("cornell-box.gltf")).expect("test scene loads");
            run.render.integrator = kind;
            run.render.spp = 16;
            run.film.filter = filter;
            (run.film.width, run.film.height) = (Some(96), Some(96));
            common::render(scene, &run)
        };
        common::assert_blocks_match(&render(IntegratorKind::Lt), &render(IntegratorKind::Pt));
    }
}

/// Under point, spot and sun lights alone a camera ray finds no light, so lt counts its samples
/// without tracing them; asking for feature images brings the camera rays back, and the colour
/// must be the same to the bit either way.
#[test]
fn without_area_lights_or_sky_the_skipped_camera_rays_change_no_bit() {
    let render = |aovs: Vec<caustica::film::aov::Aov>| {
        let (scene, mut run) = load(&common::data("punctual-lights.gltf")).expect("test scene loads");
        run.render.integrator = IntegratorKind::Lt;
        run.render.spp = 4;
        run.film.aovs = aovs;
        (run.film.width, run.film.height) = (Some(48), Some(32));
        common::render(scene, &run)
    };
    let counted = render(Vec::new());
    let traced = render(vec![caustica::film::aov::Aov::Albedo]);
    assert!(counted.mean().max_element() > 0.01, "the scene is lit: {}", counted.mean());
    assert_eq!(counted.pixels, traced.pixels);
}

/// lt renders the glass and mirror spheres black but for the light; it says so, naming their
/// materials, and says nothing on a scene without mirrors or glass.
#[test]
fn lt_names_the_mirrors_and_glass_it_cannot_see_through() {
    let warning = "lt cannot see surfaces in a mirror or through smooth glass";
    for (file, said) in [("cornell-spheres.gltf", true), ("cornell-box.gltf", false)] {
        let (scene, mut run) = load(&common::data(file)).expect("test scene loads");
        run.render.integrator = IntegratorKind::Lt;
        run.render.spp = 1;
        (run.film.width, run.film.height) = (Some(8), Some(8));
        let (_, logs) = common::capture_logs(|| common::render(scene, &run));
        assert_eq!(logs.contains(warning), said, "{file}: {logs}");
        if said {
            assert!(logs.contains("'mirror'") && logs.contains("'glass'"), "names both: {logs}");
        }
    }
}
