//! The environment light end to end: run files and flags that choose it, the default white one, bad
//! maps, and unbiased next-event estimation and MIS with every light selection.

use crate::common;

use caustica::film::Image;
use caustica::film::output::write_image;
use caustica::scene::environment::EnvironmentRadiance;
use caustica::scene::{self, IntegratorKind, LightSelection, RunFile};
use glam::Vec3;
use std::path::{Path, PathBuf};

fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-environment-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

/// A 64 × 32 sky: a blue gradient brighter at the zenith, a warm patch (the "sun", 40× the sky) of
/// 3 × 2 texels, and a dark ground.
fn sky_map() -> Image {
    let (width, height) = (64u32, 32u32);
    let pixels = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            if (20..23).contains(&x) && (8..10).contains(&y) {
                Vec3::new(40.0, 32.0, 24.0)
            } else if y < height / 2 {
                Vec3::new(0.3, 0.5, 1.0) * (1.5 - y as f32 / height as f32)
            } else {
                Vec3::splat(0.05)
            }
        })
        .collect();
    Image { width, height, pixels }
}

fn write_sky(dir: &Path) -> PathBuf {
    let path = dir.join("sky.exr");
    write_image(&sky_map(), &path, 0.0).expect("write sky");
    path
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write temp file");
    path
}

/// A grey hill (a big sphere, kept small enough that photons from the environment's disc land near the
/// camera), a plastic ball and a small lamp above, under `environment` (run-file syntax).
fn outdoor_run_file(dir: &Path, environment: &str) -> PathBuf {
    write(
        dir,
        "outdoor.toml",
        &format!(
            r#"
[camera]
eye = [0.0, 1.2, 4.0]
target = [0.0, 0.4, 0.0]
yfov_degrees = 45.0

[film]
width = 32
height = 24

[environment]
{environment}

[[sphere]]
name = "ball"
center = [0.0, 0.5, 0.0]
radius = 0.5
material = {{ base_color = [0.8, 0.3, 0.2], roughness = 0.3 }}

[[sphere]]
name = "floor"
center = [0.0, -3.0, 0.0]
radius = 3.0
material = {{ base_color = [0.5, 0.5, 0.5], roughness = 1.0 }}

[[sphere]]
name = "lamp"
center = [1.2, 1.8, 0.5]
radius = 0.15
material = {{ emission = [6.0, 6.0, 5.0] }}
"#
        ),
    )
}

#[test]
fn run_file_environment_map_is_read_relative_to_the_run_file() {
    let dir = temp_dir("run-file-map");
    write_sky(&dir);
    let path =
        outdoor_run_file(&dir, "file = \"sky.exr\"\nstrength = 2.0\nrotation_degrees = [0.0, 90.0, 0.0]");
    let (scene, _) = scene::load(&path).expect("run file with a map loads");
    let env = scene.environment.expect("environment");
    assert_eq!(env.strength, 2.0);
    assert!((env.rotation * Vec3::Z - Vec3::X).length() < 1e-6);
    match env.radiance {
        EnvironmentRadiance::Map(image) => assert_eq!(image, sky_map()),
        other => panic!("expected a map, got {other:?}"),
    }
}

#[test]
fn bad_environment_maps_are_errors_naming_the_file() {
    let dir = temp_dir("bad-maps");
    let missing = outdoor_run_file(&dir, "file = \"nowhere.exr\"");
    let error = scene::load(&missing).expect_err("missing map").to_string();
    assert!(error.contains("nowhere.exr") && error.contains("environment"), "{error}");

    write(&dir, "garbage.exr", "not an exr");
    let path = outdoor_run_file(&dir, "file = \"garbage.exr\"");
    let error = scene::load(&path).expect_err("garbage map").to_string();
    assert!(error.contains("garbage.exr") && error.contains("EXR"), "{error}");

    let mut sky = sky_map();
    sky.pixels[5 * 64 + 7] = Vec3::new(1.0, f32::NAN, 1.0);
    write_image(&sky, &dir.join("nan.exr"), 0.0).expect("write");
    let path = outdoor_run_file(&dir, "file = \"nan.exr\"");
    let error = scene::load(&path).expect_err("NaN texel").to_string();
    assert!(error.contains("nan.exr") && error.contains("(7, 5)"), "{error}");

    // A texel of 3e38 is finite, but the map's sums overflow f32 and once gave a black image.
    let mut sky = sky_map();
    sky.pixels[3 * 64 + 9] = Vec3::splat(3e38);
    write_image(&sky, &dir.join("hot.exr"), 0.0).expect("write");
    let path = outdoor_run_file(&dir, "file = \"hot.exr\"");
    let error = scene::load(&path).expect_err("3e38 texel").to_string();
    assert!(error.contains("environment") && error.contains("1e20"), "{error}");

    write(&dir, "sky.png", "png");
    let path = outdoor_run_file(&dir, "file = \"sky.png\"");
    let error = scene::load(&path).expect_err("PNG map").to_string();
    assert!(error.contains("sky.png") && error.contains(".hdr"), "{error}");

    let path = outdoor_run_file(&dir, "file = \"sky.exr\"\ncolor = [1.0, 1.0, 1.0]");
    let error = scene::load(&path).expect_err("both").to_string();
    assert!(error.contains("outdoor.toml") && error.contains("choose one"), "{error}");
}

#[test]
fn radiance_hdr_maps_load_like_exr() {
    let dir = temp_dir("hdr");
    let sky = sky_map();
    let rgb: Vec<image::Rgb<f32>> = sky.pixels.iter().map(|p| image::Rgb(p.to_array())).collect();
    let file = std::fs::File::create(dir.join("sky.hdr")).expect("create");
    image::codecs::hdr::HdrEncoder::new(file).encode(&rgb, 64, 32).expect("encode hdr");
    let path = outdoor_run_file(&dir, "file = \"sky.hdr\"");
    let (scene, _) = scene::load(&path).expect("hdr loads");
    let EnvironmentRadiance::Map(image) = scene.environment.expect("environment").radiance else {
        panic!("a map")
    };
    // RGBE keeps 8 bits of mantissa per channel.
    for (a, b) in image.pixels.iter().zip(&sky.pixels) {
        assert!((*a - *b).abs().max_element() <= 0.01 * b.max_element() + 1e-6, "{a} vs {b}");
    }
}

/// A scene with neither emitters nor an environment is lit by a white one, with a warning naming the
/// file; a lit scene gets no environment unless it asks for one.
#[test]
fn a_scene_without_lights_gets_a_white_environment_with_a_warning() {
    let mut dark = caustica::test_scenes::environment_furnace(0.5, 1.0);
    dark.environment = None;
    let logs = common::capture_logs(|| caustica::RenderScene::build(&dark, LightSelection::Power));
    let (geometry, logs) = logs;
    assert!(geometry.lights.environment.is_some());
    assert!(logs.contains("environment furnace (procedural)") && logs.contains("uniform white"), "{logs}");
    let mut run = RunFile::default();
    run.render.spp = 4;
    let image = common::render(dark, &run);
    let mean = image.mean();
    assert!(mean.min_element() > 0.3, "a dark scene renders lit: mean {mean}");

    let mut lit = caustica::test_scenes::furnace(0.5, 0.5);
    lit.environment = None;
    let (geometry, logs) = common::capture_logs(|| caustica::RenderScene::build(&lit, LightSelection::Power));
    assert!(geometry.lights.environment.is_none());
    assert!(!logs.contains("uniform white"), "{logs}");
}

/// The outdoor scene under the sky map (rotated 40°, with its sun) and a lamp, in a temporary folder
/// named after `name`, and pt-naive's image of it at 256 spp: the reference light sampling must meet.
fn naive_under_the_sky_and_a_lamp(name: &str) -> (caustica::scene::Scene, RunFile, caustica::film::Image) {
    let dir = temp_dir(name);
    write_sky(&dir);
    let path = outdoor_run_file(&dir, "file = \"sky.exr\"\nrotation_degrees = [0.0, 40.0, 0.0]");
    let (scene, mut run) = scene::load(&path).expect("loads");
    run.render.integrator = IntegratorKind::PtNaive;
    run.render.spp = 256;
    run.render.seed = 1;
    let naive = common::render(scene.clone(), &run);
    assert!(naive.mean().min_element() > 0.05, "lit: {}", naive.mean());
    (scene, run, naive)
}

/// pt with each light selection against pt-naive on a scene lit by a map (with a sun) and a lamp:
/// next-event estimation picks the environment by its distribution and the selector's pmf, and a
/// BSDF ray that escapes is weighted by the pdf light sampling would have had. A pmf or pdf that does
/// not match what is sampled biases the difference by far more than the 4 standard errors allowed.
#[test]
fn light_sampling_of_the_environment_is_unbiased_for_every_selection() {
    let (scene, run, naive) = naive_under_the_sky_and_a_lamp("unbiased");
    for selection in
        [LightSelection::Uniform, LightSelection::Power, LightSelection::Tree, LightSelection::Visibility]
    {
        let mut run = run.clone();
        run.render.integrator = IntegratorKind::Pt;
        run.render.light_selection = selection;
        run.render.spp = 64;
        run.render.seed = 2;
        let image = common::render(scene.clone(), &run);
        let (mean, se) = common::paired_difference(&image, &naive);
        assert!(mean.abs() < 4.0 * se, "{selection:?}: pt − pt-naive = {mean} ± {se}");
        for (block, z) in common::block_z_scores(&image, &naive, 4).iter().enumerate() {
            // 16 blocks × 4 selections: 4.5σ keeps the family-wise false-alarm rate near 5e-4.
            assert!(z.abs() < 4.5, "{selection:?}: block {block} z = {z}");
        }
    }
}

/// bdpt against pt-naive under the sky map (with its sun) and a lamp: light subpaths leave the sky
/// from its disc and the lamp by power, the camera's escaped rays and light samples are weighted by
/// the map's density, and the rough ball is glossy. A density of the sky that the weights get wrong
/// biases every block.
#[test]
fn bdpt_under_the_sky_and_a_lamp_is_unbiased() {
    let (scene, mut run, naive) = naive_under_the_sky_and_a_lamp("bdpt");
    run.render.integrator = IntegratorKind::Bdpt;
    run.render.spp = 64;
    run.render.seed = 3;
    let image = common::render(scene, &run);
    let (mean, se) = common::paired_difference(&image, &naive);
    assert!(mean.abs() < 4.4 * se, "bdpt − pt-naive = {mean} ± {se}");
    for (block, z) in common::block_z_scores(&image, &naive, 4).iter().enumerate() {
        assert!(z.abs() < 4.4, "block {block} z = {z}");
    }
}

/// A Lambertian ball alone under the sky map, with a distant lamp so that photon emission must split
/// its photons between the environment and another light by power.
fn ball_under_the_sky(dir: &Path) -> PathBuf {
    write(
        dir,
        "ball.toml",
        r#"
[camera]
eye = [0.0, 0.3, 2.2]
target = [0.0, 0.0, 0.0]
yfov_degrees = 24.0

[film]
width = 32
height = 24

[environment]
file = "sky.exr"

[[sphere]]
name = "ball"
center = [0.0, 0.0, 0.0]
radius = 0.5
material = { base_color = [0.8, 0.3, 0.2], roughness = 1.0, specular = 0.0 }

[[sphere]]
name = "lamp"
center = [2.5, 2.5, 1.0]
radius = 0.3
material = { emission = [60.0, 60.0, 50.0] }
"#,
    )
}

/// Radius of the ball in `ball_under_the_sky` (centred at the origin).
const BALL_RADIUS: f64 = 0.5;

/// Pixels whose four corners' rays all meet the ball: what they show is the ball's reflection alone,
/// where the background pixels (the sky seen directly, exact in every method) would dilute an error.
fn ball_pixels(camera: &caustica::scene::CameraDesc, width: u32, height: u32) -> Vec<bool> {
    let eye = camera.camera_to_world.w_axis.truncate();
    let tan = (0.5 * camera.yfov).tan();
    let aspect = width as f32 / height as f32;
    let meets_ball = |x: f32, y: f32| {
        let d = (-camera.camera_to_world.z_axis.truncate()
            + camera.camera_to_world.x_axis.truncate() * (2.0 * x / width as f32 - 1.0) * tan * aspect
            - camera.camera_to_world.y_axis.truncate() * (2.0 * y / height as f32 - 1.0) * tan)
            .normalize();
        let b = eye.dot(d);
        b * b - (eye.length_squared() - (BALL_RADIUS * BALL_RADIUS) as f32) > 0.0
    };
    (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f32, (i / width) as f32);
            [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)].iter().all(|(dx, dy)| meets_ball(x + dx, y + dy))
        })
        .collect()
}
/// Independent photon renders per integrator.
const REPLICAS: u64 = 16;
/// Student's t, 15 degrees of freedom, one-sided 1e-4 (two cases, two sides: 4e-4 family-wise).
const T_QUANTILE: f64 = 4.88;

/// The photon mappers see the same environment as `pt`: a photon from the environment with the wrong
/// disc area, pdf or selection pmf would be off by a factor (the disc is the scene's whole
/// cross-section). On a convex ball alone a photon that bounces leaves the scene, so photons carry
/// direct light only: the methods whose photons carry it, `ppm` and `sppm` without light sampling,
/// are the ones held here (`pm`'s and `sppm`'s photons come from the same emission; their indirect
/// light is held to the Mitsuba reference in photon_references.rs). Compared: the mean over the
/// pixels wholly on the ball. The bound is derived, not measured:
/// - noise: `pt`'s image mean has the standard error of its independent pixels (from two seeds); a
///   photon mapper's, that of `REPLICAS` seeds (pixels share photons), with Student's t;
/// - bias: on a ball alone there is no edge for a gather disc to run off, and curvature costs nothing
///   (the cap within chord distance d has area πd² exactly, Archimedes, and the gather measures chord
///   distances). What is left is the blur of the irradiance, which under any environment and distant
///   lamp is a clamped-cosine convolution: all but about 1% of it in spherical harmonics of order
///   l ≤ 2 (Ramamoorthi & Hanrahan 2001). A disc of radius r blurs band l by (r²/8)·l(l+1)/R²,
///   0.75·r²/R² for l = 2; doubling that covers the rest and the terminator: 1.5·r²/R² of the mean,
///   with r the largest radius the method uses (the progressive mappers' first radius).
#[test]
fn photon_mappers_see_the_same_environment_as_the_path_tracer() {
    use caustica::scene::schedule::ScheduleSettings;
    let dir = temp_dir("photons");
    write_sky(&dir);
    let path = ball_under_the_sky(&dir);
    let (scene, mut run) = scene::load(&path).expect("loads");
    let (width, height) = (run.film.width.expect("width"), run.film.height.expect("height"));
    let camera = caustica::scene::CameraDesc {
        name: "run file".into(),
        camera_to_world: caustica::camera::look_at(
            Vec3::from_array(run.camera.eye.expect("eye")),
            Vec3::from_array(run.camera.target.expect("target")),
            Vec3::Y,
        ),
        yfov: run.camera.yfov_degrees.expect("yfov").to_radians(),
        aspect_ratio: None,
    };
    let on_ball = ball_pixels(&camera, width, height);
    let grey = |p: Vec3| p.element_sum() as f64 / 3.0;
    let ball_mean = |image: &Image| {
        let values: Vec<f64> =
            image.pixels.iter().zip(&on_ball).filter(|(_, on)| **on).map(|(&p, _)| grey(p)).collect();
        values.iter().sum::<f64>() / values.len() as f64
    };
    // Two seeds of pt: their pixel differences are noise alone (a pixel's spread across the image is
    // the image, not noise), and pt's pixels are independent.
    run.render.spp = 256;
    let pt: Vec<Image> = (1..=2)
        .map(|seed| {
            let mut run = run.clone();
            run.render.seed = seed;
            common::render(scene.clone(), &run)
        })
        .collect();
    let n = on_ball.iter().filter(|on| **on).count() as f64;
    let pt_mean = 0.5 * (ball_mean(&pt[0]) + ball_mean(&pt[1]));
    let pt_variance: f64 = pt[0]
        .pixels
        .iter()
        .zip(&pt[1].pixels)
        .zip(&on_ball)
        .filter(|(_, on)| **on)
        .map(|((&a, &b), _)| (grey(a) - grey(b)).powi(2) / 4.0)
        .sum();
    let pt_se = pt_variance.sqrt() / n;
    let without_nee = ScheduleSettings { nee: Some(false), ..Default::default() };
    let cases = [(IntegratorKind::Ppm, ScheduleSettings::default()), (IntegratorKind::Sppm, without_nee)];
    for (kind, schedule) in cases {
        let (mut means, mut radius) = (Vec::new(), 0.0f32);
        for seed in 0..REPLICAS {
            let mut run = run.clone();
            run.render.integrator = kind;
            run.render.seed = 10 + seed;
            run.render.spp = 4;
            run.progressive.passes = 16;
            run.progressive.photons_per_pass = 80_000;
            run.schedule = schedule.clone();
            caustica::driver::init_thread_pools(None);
            let mut renderer = caustica::Renderer::new(scene.clone(), &run).expect("prepares");
            let report = renderer.run(None, |_| {});
            radius = report.hit_points.expect("progressive mappers have hit points").initial_radius;
            means.push(ball_mean(&renderer.image()));
        }
        let k = REPLICAS as f64;
        let mean = means.iter().sum::<f64>() / k;
        let se = (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
        let bias = 1.5 * (radius as f64 / BALL_RADIUS).powi(2) * mean;
        let bound = T_QUANTILE * (se * se + pt_se * pt_se).sqrt() + bias;
        eprintln!(
            "{kind:?} (nee {:?}): mean {mean:.5} ± {se:.5}, pt {pt_mean:.5} ± {pt_se:.5}, bias bound {bias:.5} (r {radius:.4})",
            schedule.nee
        );
        assert!(
            (mean - pt_mean).abs() <= bound,
            "{kind:?} ({:?}): image mean {mean} vs pt {pt_mean}: off by more than {bound}",
            schedule.nee
        );
    }
}

#[test]
fn a_camera_less_file_is_framed_and_the_flags_override_the_framing() {
    let mut scene = caustica::test_scenes::environment_furnace(0.5, 1.0);
    scene.camera = None;
    let mut run = RunFile::default();
    run.film.width = Some(40);
    run.film.height = Some(20);
    let (result, logs) = common::capture_logs(|| caustica::driver::scene_world(scene.clone(), &run));
    let (world, _) = result.expect("world");
    assert!(logs.contains("no camera in the file") && logs.contains("three-quarter view"), "{logs}");
    let camera = world.resource::<caustica::resources::CameraResource>();
    // A three-quarter view: 45° round from +Z towards +X, 30° up.
    let from = caustica::camera::Camera::framing_direction();
    assert!((from.x - from.z).abs() < 1e-6 && (from.y - 0.5).abs() < 1e-6 && from.x > 0.0, "{from}");
    // The unit ball's bounding box has radius √3; at 45° it is framed from √3 / sin 22.5°.
    let eye = camera.generate_ray(20, 10, glam::Vec2::splat(0.5), glam::Vec2::ZERO, 0.0).o;
    assert!((eye - from * 3f32.sqrt() / 22.5f32.to_radians().sin()).length() < 1e-3, "{eye}");

    // Tall images fit the horizontal field instead.
    run.film.width = Some(20);
    run.film.height = Some(40);
    let (world, _) = caustica::driver::scene_world(scene.clone(), &run).unwrap();
    let camera = world.resource::<caustica::resources::CameraResource>();
    let eye = camera.generate_ray(10, 20, glam::Vec2::splat(0.5), glam::Vec2::ZERO, 0.0).o;
    let half_x = (0.5 * (22.5f32.to_radians().tan())).atan();
    assert!((eye.length() - 3f32.sqrt() / half_x.sin()).abs() < 1e-3, "{eye}");

    // A narrower field of view chosen by the user frames from further away instead of cropping.
    run.film.width = Some(40);
    run.film.height = Some(20);
    run.camera.yfov_degrees = Some(20.0);
    let (world, _) = caustica::driver::scene_world(scene.clone(), &run).unwrap();
    let eye = world
        .resource::<caustica::resources::CameraResource>()
        .generate_ray(20, 10, glam::Vec2::splat(0.5), glam::Vec2::ZERO, 0.0)
        .o;
    assert!((eye.length() - 3f32.sqrt() / 10f32.to_radians().sin()).abs() < 1e-3, "{eye}");

    run.camera.eye = Some([4.0, 0.0, 0.0]);
    run.camera.target = Some([0.0, 0.0, 0.0]);
    run.camera.yfov_degrees = Some(30.0);
    let (result, logs) = common::capture_logs(|| caustica::driver::scene_world(scene.clone(), &run));
    let (world, _) = result.expect("world");
    assert!(!logs.contains("no camera"), "eye and target given: no warning: {logs}");
    let ray = world.resource::<caustica::resources::CameraResource>().generate_ray(
        20,
        10,
        glam::Vec2::splat(0.5),
        glam::Vec2::ZERO,
        0.0,
    );
    assert!((ray.o - Vec3::new(4.0, 0.0, 0.0)).length() < 1e-5 && ray.d.x < -0.99, "{ray:?}");
}

/// KHR_materials_unlit surfaces emit their base colour to show it and reflect nothing; they are not
/// the scene's light, so a scene lit by them alone gets the white environment (and its warning), and
/// an unlit ball under it shows exactly its colour, as the extension asks, against the white sky.
#[test]
fn unlit_surfaces_show_their_colour_and_do_not_count_as_the_scenes_light() {
    let colour = Vec3::new(0.2, 0.5, 0.8);
    let mut scene = caustica::test_scenes::environment_furnace(0.5, 1.0);
    scene.environment = None;
    scene.materials[0] = caustica::scene::MaterialDesc {
        name: "label".into(),
        shading: caustica::materials::ShadingParams {
            base_color: Vec3::ZERO,
            metallic: 0.0,
            specular: 0.0,
            ..Default::default()
        },
        emission: colour,
        unlit: true,
        ..Default::default()
    };
    let (built, logs) = common::capture_logs(|| caustica::RenderScene::build(&scene, LightSelection::Power));
    assert!(built.lights.environment.is_some(), "an unlit-only scene got no environment");
    assert!(logs.contains("only unlit surfaces") && logs.contains("uniform white"), "{logs}");
    let mut run = RunFile::default();
    run.render.spp = 4;
    let image = common::render(scene, &run);
    let (w, h) = (image.width, image.height);
    let centre = image.pixels[(h / 2 * w + w / 2) as usize];
    assert!((centre - colour).abs().max_element() < 1e-4, "the unlit ball shows {centre}, not {colour}");
    let corner = image.pixels[0];
    assert!((corner - Vec3::ONE).abs().max_element() < 1e-4, "the sky behind it is {corner}");
}

/// Emitters far too weak for the scene's size (a file's emissive marks, made for a viewer that lights
/// it) are the scene's light all the same, and the warning says so and names the flag; a lamp of
/// ordinary power gets no such warning.
#[test]
fn emission_far_too_weak_for_the_scene_is_named_in_a_warning() {
    let weak = caustica::test_scenes::furnace(0.5, 1e-4);
    let (built, logs) = common::capture_logs(|| caustica::RenderScene::build(&weak, LightSelection::Power));
    assert!(built.lights.environment.is_none(), "the rule changed: emitters are the scene's light");
    assert!(
        logs.contains("only light is its emissive surfaces") && logs.contains("--environment-color"),
        "{logs}"
    );
    let lamp = caustica::test_scenes::furnace(0.5, 1.0);
    let (_, logs) = common::capture_logs(|| caustica::RenderScene::build(&lamp, LightSelection::Power));
    assert!(!logs.contains("emissive surfaces"), "{logs}");
}
