//! The camera's effects against their formulas: the defocus blur of a thin lens (its size from the
//! aperture and the focus distance) and the smear of an object moving while the shutter is open
//! (where it lands and how long it is). A small emitter on black is imaged; the moments of its image
//! are compared with those of the shapes the formulas give.

use crate::common;

use caustica::film::Image;
use caustica::scene::{CameraDesc, RunFile, Scene, Sphere};
use glam::{DVec2, Mat4, Vec3};

const WIDTH: u32 = 96;
const HEIGHT: u32 = 96;
const YFOV: f32 = 0.4;

/// A small emitter of `radius` at `center`, moving by `motion` over the shutter, seen by a camera at
/// the origin looking down −z.
fn emitter(center: Vec3, radius: f32, motion: Option<Vec3>) -> Scene {
    Scene {
        spheres: vec![Sphere { name: "lamp".into(), center, radius, material: 0, motion }],
        materials: vec![caustica::test_scenes::diffuse("lamp", Vec3::ZERO, Vec3::ONE)],
        camera: Some(CameraDesc {
            name: "origin".into(),
            camera_to_world: Mat4::IDENTITY,
            yfov: YFOV,
            aspect_ratio: None,
        }),
        resolution: Some((WIDTH, HEIGHT)),
        source: "camera test (procedural)".into(),
        ..Scene::default()
    }
}

/// A box filter: each pixel is the mean over its square, which adds a pixel's own second moment
/// (1/12 px² an axis) to a shape's.
fn run(spp: u32) -> RunFile {
    let mut run = RunFile::default();
    (run.render.spp, run.render.seed) = (spp, 11);
    (run.film.width, run.film.height) = (Some(WIDTH), Some(HEIGHT));
    run.film.filter = caustica::scene::FilterKind::Box;
    run
}

/// What a pixel's square adds to a shape's second moment along each axis.
const PIXEL: f64 = 1.0 / 12.0;

/// Pixels per unit length on the plane at `depth` in front of the camera.
fn pixels_per_unit(depth: f64) -> f64 {
    HEIGHT as f64 / (2.0 * depth * (YFOV as f64 / 2.0).tan())
}

/// The image's luminance-weighted centroid (pixel centres, x right, y down) and its central second
/// moments along x and y.
fn moments(image: &Image) -> (DVec2, DVec2) {
    let (mut sum, mut first, mut second) = (0.0, DVec2::ZERO, DVec2::ZERO);
    for (i, p) in image.pixels.iter().enumerate() {
        let w = p.x as f64;
        let at = DVec2::new((i as u32 % image.width) as f64 + 0.5, (i as u32 / image.width) as f64 + 0.5);
        sum += w;
        first += w * at;
        second += w * at * at;
    }
    let centroid = first / sum;
    (centroid, second / sum - centroid * centroid)
}

/// A point at depth d seen through a thin lens of radius A focused at f lands on a disk of radius
/// A·|d − f| / d on the focus plane (pbrt-v4's `ThinLensCamera`; a ray through the lens at L and the
/// focus-plane point X crosses depth d at L + (X − L)·d/f). A uniform disk of radius R has the
/// second moment R²/4 along each axis; the emitter's own disk adds its own.
#[test]
fn the_defocus_blur_has_the_thin_lens_size() {
    // An emitter of a few pixels: a point would be hit by too few lens samples to measure.
    let (depth, radius) = (4.0f32, 0.1f32);
    // Focused nearer and farther than the emitter.
    for (aperture, focus) in [(0.2f32, 2.0f32), (0.4, 8.0)] {
        let mut run = run(128);
        run.camera.aperture_radius = aperture;
        run.camera.focus_distance = Some(focus);
        let image = common::render(emitter(Vec3::new(0.0, 0.0, -depth), radius, None), &run);
        let (centroid, spread) = moments(&image);
        let (d, f, a) = (depth as f64, focus as f64, aperture as f64);
        let blur = a * (d - f).abs() / d * pixels_per_unit(f);
        let own = radius as f64 * pixels_per_unit(d);
        assert!(blur > 8.0, "the test wants a blur of many pixels: {blur}");
        let expected = (blur * blur + own * own) / 4.0 + PIXEL;
        for axis in [spread.x, spread.y] {
            let measured_radius = (4.0 * (axis - PIXEL) - own * own).sqrt();
            assert!(
                (measured_radius / blur - 1.0).abs() < 0.03,
                "aperture {aperture}, focus {focus}: a blur of radius {measured_radius:.2} px, the thin lens \
                 gives {blur:.2} (moments {spread}, expected {expected:.2})"
            );
        }
        let centre = DVec2::new(WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0);
        assert!((centroid - centre).length() < 0.2, "the blur is centred at {centroid}");
    }
    // In focus, the emitter is its own size: no blur.
    let mut run = run(64);
    run.camera.aperture_radius = 0.08;
    run.camera.focus_distance = Some(depth);
    let (_, spread) = moments(&common::render(emitter(Vec3::new(0.0, 0.0, -depth), 0.05, None), &run));
    let own = 0.05 * pixels_per_unit(depth as f64);
    let sharp = own * own / 4.0 + PIXEL;
    assert!((spread.x - sharp).abs() < 0.25, "in focus: {spread}, its own disk {sharp}");
}

/// An emitter moving by D over the shutter (times normalised to [0, 1)), every time in it equally
/// likely, smears into a streak:
/// its centroid is where the emitter is halfway, and along the motion the second moment is the
/// uniform segment's L²/12 plus the emitter's own disk's; across it, the disk's alone.
#[test]
fn a_moving_emitter_smears_into_the_streak_of_its_motion() {
    let (depth, radius) = (4.0f32, 0.06f32);
    let (start, motion) = (Vec3::new(-0.2, 0.05, -depth), Vec3::new(0.4, 0.0, 0.0));
    let image = common::render(emitter(start, radius, Some(motion)), &run(256));
    let (centroid, spread) = moments(&image);
    let scale = pixels_per_unit(depth as f64);
    let halfway = start + 0.5 * motion;
    let expected_centroid = DVec2::new(
        WIDTH as f64 / 2.0 + halfway.x as f64 * scale,
        HEIGHT as f64 / 2.0 - halfway.y as f64 * scale,
    );
    assert!(
        (centroid - expected_centroid).length() < 0.3,
        "the streak is centred at {centroid}, the emitter is halfway at {expected_centroid}"
    );
    let (length, own) = (motion.x as f64 * scale, radius as f64 * scale);
    let along = length * length / 12.0 + own * own / 4.0 + PIXEL;
    let across = own * own / 4.0 + PIXEL;
    assert!(
        (spread.x / along - 1.0).abs() < 0.04,
        "along the motion {} px², the streak gives {along:.2}",
        spread.x
    );
    assert!(
        (spread.y - across).abs() < 0.3,
        "across the motion {} px², the disk gives {across:.2}",
        spread.y
    );

    // Without motion, the emitter at its start and its own size.
    let still = common::render(emitter(start, radius, None), &run(32));
    let (centroid, spread) = moments(&still);
    let at_start =
        DVec2::new(WIDTH as f64 / 2.0 + start.x as f64 * scale, HEIGHT as f64 / 2.0 - start.y as f64 * scale);
    assert!((centroid - at_start).length() < 0.3, "still: {centroid}, the start is {at_start}");
    assert!((spread - DVec2::splat(across)).abs().max_element() < 0.3, "still, yet smeared: {spread}");
}
