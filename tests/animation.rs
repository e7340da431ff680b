//! glTF animations: a frame at time t is, bit for bit, the file whose animated nodes hold the values
//! sampled at t (Khronos' BoxAnimated: a LINEAR translation of a parent and a LINEAR rotation of its
//! grandchild; AnimatedTriangle: a LINEAR rotation through five keyframes), in the scene and in the
//! image; `pm` keeps its photon maps across an animation that moves only the camera. STEP and
//! CUBICSPLINE, which no sample uses, are checked against the spec's formulas in
//! src/scene/animation.rs.

use crate::common;

use caustica::driver::{FrameRun, init_thread_pools};
use caustica::film::Image;
use caustica::scene::pose::FrameScene;
use caustica::scene::{IntegratorKind, RunFile, Scene, load};
use std::path::Path;

fn setup(path: &Path) -> (Scene, RunFile) {
    let (scene, mut run) = load(path).unwrap();
    run.render.spp = 2;
    run.render.seed = 9;
    (run.film.width, run.film.height) = (Some(24), Some(24));
    // The same camera for both: one that frames the bounds would follow the moved geometry.
    run.camera.eye = Some([0.4, 1.2, 3.5]);
    run.camera.target = Some([0.0, 0.0, 0.0]);
    run.camera.up = Some([0.0, 1.0, 0.0]);
    run.camera.yfov_degrees = Some(40.0);
    (scene, run)
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// `file` with its animations gone and each animated node holding its values at time `t`, written
/// beside `dir`.
fn posed_file(file: &Path, scene: &Scene, t: f32, dir: &Path) -> std::path::PathBuf {
    let animation = scene.animation.as_ref().expect("the file is animated");
    let mut gltf: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    gltf.as_object_mut().unwrap().remove("animations");
    for (index, node) in gltf["nodes"].as_array_mut().unwrap().iter_mut().enumerate() {
        if !animation.drives(index) {
            continue;
        }
        let (translation, rotation, scale) = animation.node_trs(index, t);
        node["translation"] = serde_json::json!(translation.to_array());
        node["rotation"] = serde_json::json!(rotation.to_array());
        node["scale"] = serde_json::json!(scale.to_array());
    }
    let path = dir.join(format!("posed-{t}.gltf"));
    std::fs::write(&path, gltf.to_string()).unwrap();
    path
}

fn same_meshes(a: &Scene, b: &Scene, what: &str) {
    assert_eq!(a.meshes.len(), b.meshes.len(), "{what}");
    for (x, y) in a.meshes.iter().zip(&b.meshes) {
        let p = |m: &caustica::scene::Mesh| {
            m.positions.iter().map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>()
        };
        assert_eq!(p(x), p(y), "{what}: {} placed differently", x.name);
        let n = |m: &caustica::scene::Mesh| {
            m.normals.as_ref().map(|n| n.iter().map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>())
        };
        assert_eq!(n(x), n(y), "{what}: {} normals differ", x.name);
        assert_eq!(x.indices, y.indices, "{what}: {}", x.name);
    }
}

fn frame_equals_the_posed_file(name: &str, times: &[f32]) {
    init_thread_pools(None);
    let file = common::data(&format!("gltf-samples/{name}"));
    let (scene, run) = setup(&file);
    let dir = tempfile::tempdir().unwrap();
    let mut frame_run = FrameRun::new(scene.clone(), &run).unwrap();
    let mut frames = FrameScene::new(scene.clone());
    let mut images = Vec::new();
    for &t in times {
        frames.set_time(t).unwrap();
        let static_file = posed_file(&file, &scene, t, dir.path());
        let (posed, _) = setup(&static_file);
        assert!(posed.animation.is_none());
        same_meshes(frames.scene(), &posed, &format!("{name} at {t} s"));

        frame_run.set_time(t).unwrap();
        let renderer = frame_run.renderer_mut();
        assert_eq!(renderer.units_done(), 0, "a new frame starts the image over");
        renderer.run(None, |_| {});
        let frame = bits(&renderer.image());
        assert_eq!(
            frame,
            bits(&common::render(posed, &run)),
            "{name}: the frame at {t} s is not the posed file"
        );
        images.push(frame);
    }
    // The frames differ: the animation moved something the camera sees.
    assert!(images.windows(2).any(|w| w[0] != w[1]), "{name}: every frame is the same");
}

#[test]
fn box_animated_frames_are_the_file_posed_at_their_time() {
    // Its rotation turns over 1.25–2.5 s, its translation runs over 0–3.7 s: before, between and on
    // keyframes, and past the end. (The moving inner box is traced in the dynamic set, the still
    // outer one in the static set; where a face of one lies exactly on a face of the other, a tie,
    // the set traced first wins, so a frame can differ there from the file, whose one set ties the
    // other way: at 3.5 s one pixel of 576 does. These times have no such tie.)
    frame_equals_the_posed_file("BoxAnimated.gltf", &[0.0, 0.9, 1.25, 2.1, 3.0, 5.0]);
}

#[test]
fn animated_triangle_frames_are_the_file_posed_at_their_time() {
    frame_equals_the_posed_file("AnimatedTriangle.gltf", &[0.1, 0.5, 0.77, 1.0]);
}

/// A file whose animation moves only its camera (Cornell box, camera dollying in): `pm` traces its
/// photon maps for the first frame only, and each later frame is the one a renderer made for that
/// camera alone would give (the maps are view-independent, so keeping them changes no bit).
#[test]
fn pm_keeps_its_photon_maps_when_only_the_camera_moves() {
    init_thread_pools(None);
    let dir = tempfile::tempdir().unwrap();
    // The box lit by its ceiling alone, and with a still point light too (a punctual light that
    // does not move keeps the maps as well).
    for file in [camera_dolly(dir.path(), false), camera_dolly(dir.path(), true)] {
        let (scene, mut run) = load(&file).unwrap();
        run.render.integrator = IntegratorKind::Pm;
        run.render.spp = 2;
        (run.film.width, run.film.height) = (Some(24), Some(24));
        (run.photons.photons, run.photons.caustic_photons) = (4000, 0);
        let mut frame_run = FrameRun::new(scene.clone(), &run).unwrap();
        frame_run.renderer_mut().run(None, |_| {});
        for t in [0.5, 1.0] {
            let update = frame_run.set_time(t).unwrap();
            assert!(update.photons_kept, "{}: at {t} s the photon maps were traced again", file.display());
            let report = frame_run.renderer_mut().run(None, |_| {});
            let photon_phase = report.phases.iter().find(|p| p.name == "photons").map_or(0, |p| p.runs);
            assert_eq!(photon_phase, 0, "at {t} s a photon pass ran");
            // A renderer of the same file posed at t, from scratch, traces the same maps.
            let mut fresh = FrameRun::new(scene.clone(), &run).unwrap();
            fresh.set_time(t).unwrap();
            fresh.renderer_mut().run(None, |_| {});
            let (kept, fresh) = (frame_run.renderer().image(), fresh.renderer().image());
            assert_eq!(bits(&kept), bits(&fresh), "{}: at {t} s", file.display());
        }
    }
}

/// tests/data/cornell-box.gltf with its camera dollying 0.5 m towards the box over one second, and
/// with a still point light above the blocks when `bulb`.
fn camera_dolly(dir: &Path, bulb: bool) -> std::path::PathBuf {
    let gltf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(common::data("cornell-box.gltf")).unwrap()).unwrap();
    let camera = gltf["nodes"].as_array().unwrap().iter().find(|n| n.get("camera").is_some()).unwrap();
    let start: [f32; 3] = serde_json::from_value(camera["translation"].clone()).unwrap();
    let name = camera["name"].as_str().unwrap().to_owned();
    let end = [start[0], start[1], start[2] - 0.5];
    let add_bulb = |gltf: &mut serde_json::Value| {
        if !bulb {
            return;
        }
        gltf["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
        gltf["extensions"] =
            serde_json::json!({"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 0.5}]}});
        let nodes = gltf["nodes"].as_array_mut().unwrap();
        nodes.push(serde_json::json!({"name": "bulb", "translation": [0.0, 0.4, 0.0],
            "extensions": {"KHR_lights_punctual": {"light": 0}}}));
        let bulb_node = nodes.len() - 1;
        gltf["scenes"][0]["nodes"].as_array_mut().unwrap().push(bulb_node.into());
    };
    let file = if bulb { "dolly-bulb.gltf" } else { "dolly.gltf" };
    common::keyframed_cornell(dir, file, (&name, "translation"), [start, end], "LINEAR", add_bulb)
}

/// Motion blur by the animation: a frame rendered over the shutter holds, exactly, the sum of its
/// samples each rendered alone with the scene posed at its own time in the shutter (the film's sums
/// are exact, so the order does not matter); and it is not any one of those poses.
#[test]
fn a_blurred_frame_is_the_sum_of_its_samples_each_posed_at_its_own_time() {
    init_thread_pools(None);
    let (scene, mut run) = setup(&common::data("gltf-samples/AnimatedTriangle.gltf"));
    run.render.spp = 4;
    let (open, close) = (0.1f32, 0.35f32);
    let mut blurred = FrameRun::new(scene.clone(), &run).unwrap();
    blurred.run_over_shutter((open, close), None, |_| {}).unwrap();
    let blurred = blurred.renderer();
    let pixels = (24 * 24) as u32;
    let mut sums = vec![([0i128; 3], 0u32); pixels as usize];
    for k in 0..4u32 {
        let time = open + (k as f32 + 0.5) / 4.0 * (close - open);
        let mut posed = FrameRun::new(scene.clone(), &run).unwrap();
        posed.set_time(time).unwrap();
        let one = posed.renderer_mut();
        one.set_samples(k..k + 1).unwrap();
        one.run(None, |_| {});
        for (pixel, sum) in sums.iter_mut().enumerate() {
            let (s, n) = one.film().sums(pixel as u32);
            for (total, part) in sum.0.iter_mut().zip(s) {
                *total += part;
            }
            sum.1 += n;
        }
    }
    for (pixel, sum) in sums.iter().enumerate() {
        assert_eq!(blurred.film().sums(pixel as u32), *sum, "pixel {pixel}");
    }
    let mut sharp = FrameRun::new(scene.clone(), &run).unwrap();
    sharp.set_time(0.5 * (open + close)).unwrap();
    sharp.renderer_mut().run(None, |_| {});
    assert_ne!(bits(&blurred.image()), bits(&sharp.renderer().image()), "the blur is the middle pose");
}

/// Adaptive sampling under a shutter: once every pixel has converged the blurred frame ends (a run
/// that converged stops without a sample, and the shutter went on posing its next time forever).
#[test]
fn a_blurred_frame_with_adaptive_sampling_ends_when_its_pixels_converge() {
    init_thread_pools(None);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let (scene, mut run) = setup(&common::data("gltf-samples/AnimatedTriangle.gltf"));
        (run.render.spp, run.render.noise_threshold, run.render.min_spp) = (1024, 0.5, 4);
        let mut frame_run = FrameRun::new(scene, &run).unwrap();
        frame_run.run_over_shutter((0.1, 0.35), None, |_| {}).unwrap();
        tx.send(frame_run.renderer().units_done()).unwrap();
    });
    let done = rx.recv_timeout(std::time::Duration::from_secs(120)).expect("the blurred frame never ended");
    assert!((4..1024).contains(&done), "{done} samples per pixel: the pixels should converge early");
}

/// Integrators that trace something once a render would see one pose of the shutter: refused.
#[test]
fn the_shutter_is_refused_where_a_render_traces_its_light_once() {
    init_thread_pools(None);
    let (scene, mut run) = setup(&common::data("gltf-samples/AnimatedTriangle.gltf"));
    for kind in [IntegratorKind::Pm, IntegratorKind::Ppm] {
        run.render.integrator = kind;
        let mut frame_run = FrameRun::new(scene.clone(), &run).unwrap();
        let message = frame_run.run_over_shutter((0.0, 0.1), None, |_| {}).unwrap_err().to_string();
        let name = frame_run.renderer().integrator().name();
        assert!(message.contains(name) && message.contains("once"), "{message}");
    }
}

fn caustica(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).output().expect("caustica runs")
}

/// The command renders an animation's frames to a numbered pattern and says where each frame's
/// time went; what cannot be played is refused before anything is written.
#[test]
fn the_command_renders_frames_and_refuses_what_it_cannot_play() {
    let dir = tempfile::tempdir().unwrap();
    let animated = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-animated.gltf");
    let pattern = dir.path().join("f-##.png");
    let args = ["render", animated.to_str().unwrap(), "--frames", "2:5", "--fps", "4", "--spp", "1"];
    let out = caustica(
        &[&args[..], &["--width", "16", "--height", "16", "-o", pattern.to_str().unwrap()]].concat(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for frame in 2..5 {
        assert!(dir.path().join(format!("f-0{frame}.png")).exists(), "frame {frame}: {stdout}");
        assert!(stdout.contains(&format!("frame     {frame}  t {:.3} s", frame as f32 / 4.0)), "{stdout}");
    }
    assert!(!dir.path().join("f-05.png").exists() && !dir.path().join("f-01.png").exists());
    assert!(stdout.contains("frames      3 of 3") && stdout.contains("BVH"), "{stdout}");

    let still = common::data("cornell-box.gltf");
    let refusals: [(&[&str], &str); 4] = [
        (&["render", still.to_str().unwrap(), "--frames", "0:2"], "no animation"),
        (&["render", animated.to_str().unwrap(), "--frames", "5:2"], "END must be after START"),
        (&["render", animated.to_str().unwrap(), "--shutter", "0.5"], "--frames"),
        (
            &[
                "render",
                animated.to_str().unwrap(),
                "--frames",
                "0:2",
                "--shutter",
                "0.5",
                "--integrator",
                "pm",
            ],
            "once",
        ),
    ];
    // Hostile values of the frame flags: refused by name, nothing written.
    let a = animated.to_str().unwrap();
    let mut hostile: Vec<(Vec<String>, &str)> = Vec::new();
    for fps in ["0", "-1", "NaN", "inf", "1e39"] {
        hostile.push((vec!["--frames=0:2".into(), format!("--fps={fps}")], "frames.fps"));
    }
    for shutter in ["-1", "NaN", "inf", "1e39"] {
        hostile.push((vec!["--frames=0:2".into(), format!("--shutter={shutter}")], "frames.shutter"));
    }
    for range in ["1:1", "-1:2", "0", ":", "a:b", "0:4294967296", "0:4294967295"] {
        hostile.push((vec![format!("--frames={range}")], "--frames"));
    }
    // Two patterns naming one file from some frame on: g-#.png and g-##.png both write g-10.png.
    let (short, long) = (dir.path().join("g-#.png"), dir.path().join("g-##.png"));
    hostile.push((
        ["--frames=0:12", "-o", short.to_str().unwrap(), "-o", long.to_str().unwrap()]
            .map(String::from)
            .to_vec(),
        "g-10.png (frame 10): named twice",
    ));
    let hostile: Vec<(Vec<&str>, &str)> = hostile
        .iter()
        .map(|(flags, needle)| {
            let mut args = vec!["render", a];
            args.extend(flags.iter().map(String::as_str));
            (args, *needle)
        })
        .collect();
    for (args, needle) in refusals.iter().map(|(a, n)| (a.to_vec(), *n)).chain(hostile) {
        let args = &args[..];
        let out_file = dir.path().join("refused-#.png");
        let out = caustica(
            &[args, &["-q", "--spp", "1", "--width", "8", "--height", "8", "-o", out_file.to_str().unwrap()]]
                .concat(),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(needle), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!dir.path().join("refused-0.png").exists(), "{args:?} wrote a frame");
    }
}

/// A malformed channel is refused with an error naming the file and the channel (the gltf crate's
/// validation does not check a channel's target, and it unwraps it).
#[test]
fn malformed_channels_are_refused_naming_the_file_and_the_channel() {
    let file = common::data("gltf-samples/BoxAnimated.gltf");
    let original: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, serde_json::Value, &str); 5] = [
        ("/animations/0/channels/0/target/node", 99.into(), "animation #0 channel 0 targets node #99"),
        (
            "/animations/0/channels/0/target/path",
            "skew".into(),
            "animation #0 channel 0 targets a path other",
        ),
        (
            "/animations/1/samplers/0/interpolation",
            "CUBICSPLINE".into(),
            "of CubicSpline interpolation (it needs",
        ),
        ("/animations/1/samplers/0/output", 8.into(), "animation #1 channel 0"),
        ("/animations/0/samplers/0/output", 9.into(), "animation #0 channel 0"),
    ];
    for (pointer, value, expected) in cases {
        let mut gltf = original.clone();
        *gltf.pointer_mut(pointer).unwrap() = value;
        let path = dir.path().join("broken.gltf");
        std::fs::write(&path, gltf.to_string()).unwrap();
        let error = load(&path).map(|_| ()).expect_err(pointer).to_string();
        assert!(error.contains(expected), "{pointer}: {error}");
        assert!(error.contains("broken.gltf"), "{pointer}: {error}");
    }
}

/// The summary's time line of an animation is every frame's rendering summed, with the mean a
/// frame: it was the last frame's alone ("70.3 s total, 18.4 s rendering" for four frames).
#[test]
fn the_frames_summary_sums_every_frames_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let animated = common::data("gltf-samples/AnimatedTriangle.gltf");
    let pattern = dir.path().join("f-##.png");
    let out = caustica(&[
        "render",
        animated.to_str().unwrap(),
        "--frames",
        "0:3",
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "1",
        "-q",
        "-o",
        pattern.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // "time        0.007 s total, 0.003 s rendering over 3 frames (mean 0.001 s a frame)"
    let line = stdout.lines().find(|l| l.starts_with("time ")).expect("a time line");
    let rest = line.split(" s rendering over 3 frames (mean ").nth(1).unwrap_or_else(|| panic!("{line}"));
    let number = |s: &str| s.split_whitespace().last().unwrap().parse::<f64>().unwrap();
    let rendering = number(line.split(" s rendering").next().unwrap().split(',').nth(1).unwrap());
    let mean: f64 = rest.split_whitespace().next().unwrap().parse().unwrap();
    // The frame lines give each frame's render in ms, to 0.1 ms; the summary's seconds to 1 ms.
    let frames: Vec<f64> = stdout
        .lines()
        .filter(|l| l.starts_with("frame "))
        .map(|l| number(l.split(" ms, denoise").next().unwrap()) / 1e3)
        .collect();
    assert_eq!(frames.len(), 3, "{stdout}");
    for frame in &frames {
        assert!(
            rendering + 0.0005 + 1e-9 >= frame - 0.00005,
            "{rendering} s in all < a frame's {frame} s:\n{stdout}"
        );
    }
    let sum: f64 = frames.iter().sum();
    assert!(
        (rendering - sum).abs() <= 0.0005 + 3.0 * 0.00005 + 1e-9,
        "{rendering} s against the frames' {sum} s:\n{stdout}"
    );
    assert!((mean - rendering / 3.0).abs() <= 0.001, "mean {mean} of {rendering} s:\n{stdout}");
    assert!(stdout.contains("frame 2's alone"), "says whose the other lines are:\n{stdout}");
}

/// SIGINT or SIGTERM (once, or twice: stop at once) while `--frames` renders: the frames written
/// are whole images, numbered from the first without a gap, nothing temporary is left beside them,
/// and the command says it stopped and exits 130.
#[test]
fn a_signal_during_frames_leaves_whole_frames_and_no_partial_file() {
    let animated = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-animated.gltf");
    for (integrator, sig, times) in [("pt", "TERM", 1), ("vcm", "INT", 1), ("pt", "INT", 2)] {
        let what = format!("{integrator}, SIG{sig} x{times}");
        let dir = tempfile::tempdir().unwrap();
        let pattern = dir.path().join("f-######.exr");
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
            .args(["render", animated.to_str().unwrap(), "--frames", "0:100000", "--fps", "24", "-q"])
            .args([
                "--integrator",
                integrator,
                "--spp",
                "2",
                "--seed",
                "45",
                "--width",
                "16",
                "--height",
                "16",
            ])
            .arg("-o")
            .arg(&pattern)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let first = dir.path().join("f-000000.exr");
        while !first.exists() {
            assert!(child.try_wait().unwrap().is_none(), "{what}: ended before its first frame");
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        for _ in 0..times {
            let kill = std::process::Command::new("kill")
                .arg(format!("-{sig}"))
                .arg(child.id().to_string())
                .status();
            assert!(kill.unwrap().success());
        }
        let out = child.wait_with_output().unwrap();
        let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert_eq!(out.status.code(), Some(130), "{what}: {stdout}{stderr}");
        assert!(!stderr.contains("panicked"), "{what}: {stderr}");
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        let written = names.len();
        assert!(0 < written && written < 100000, "{what}: {names:?}");
        for (frame, name) in names.iter().enumerate() {
            assert_eq!(*name, format!("f-{frame:06}.exr"), "{what}: a gap or a leftover in {names:?}");
            let image = caustica::film::output::read_exr(&dir.path().join(name))
                .unwrap_or_else(|e| panic!("{what}: {name}: {e}"));
            assert_eq!((image.width, image.height), (16, 16), "{what}: {name}");
            assert!(image.pixels.iter().all(|p| p.is_finite()), "{what}: {name}");
        }
        if times == 1 {
            assert!(stdout.contains("stopped     by a signal"), "{what}: {stdout}");
            assert!(stdout.contains(&format!("frames      {written} of 100000")), "{what}: {stdout}");
        } else {
            assert!(
                stderr.contains("stopped at once") || stdout.contains("stopped     by a signal"),
                "{what}: {stderr}"
            );
        }
    }
}

/// A move that takes geometry beyond the ±1e6 m the loader allows (where the BVH's boxes stop
/// nesting: `lt` panicked on a light moved to 1e37 m) is refused naming the node, and leaves the
/// scene, its moves and which meshes are dynamic as they were.
#[test]
fn a_move_beyond_reach_is_refused_and_changes_nothing() {
    let (scene, _) = setup(&common::data("cornell-box.gltf"));
    let mut frames = FrameScene::new(scene);
    let lifted = glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.1, 0.0));
    frames.move_node("tall_block", lifted).unwrap();
    let (before, dynamic) = (frames.scene().meshes.clone(), frames.dynamic.clone());
    for (node, m) in [
        ("short_block", glam::Mat4::from_translation(glam::Vec3::new(1e30, 0.0, 0.0))),
        ("tall_block", glam::Mat4::from_scale(glam::Vec3::new(3e-25, 1e38, 3e-25))),
        ("light", glam::Mat4::from_scale(glam::Vec3::splat(1e7))),
    ] {
        let e = frames.move_node(node, m).unwrap_err().to_string();
        assert!(e.contains(node) && e.contains("beyond"), "{node}: {e}");
        assert_eq!(frames.dynamic, dynamic, "{node}: a refused move made a mesh dynamic");
        let same = frames.scene().meshes.iter().zip(&before).all(|(a, b)| a.positions == b.positions);
        assert!(same, "{node}: a refused move moved the scene");
    }
    // A projective last row is not dropped in silence.
    let projective = glam::Mat4::from_cols_array_2d(&[
        [1.0, 0.0, 0.0, 0.5],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]);
    let e = frames.move_node("short_block", projective).unwrap_err().to_string();
    assert!(e.contains("affine"), "{e}");
    // The earlier move still holds, and the identity still puts it back.
    frames.move_node("tall_block", glam::Mat4::IDENTITY).unwrap();
    assert!(frames.scene().meshes.iter().zip(&before).any(|(a, b)| a.positions != b.positions));
}
