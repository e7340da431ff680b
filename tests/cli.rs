//! The command line: bad input fails with a message naming the file, leaves no output behind.

use crate::common;

use std::path::PathBuf;
use std::process::{Command, Output};

fn caustica(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).output().expect("caustica runs")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn assert_fails_naming(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure, stderr: {stderr}");
    assert!(stderr.contains(needle), "stderr does not name {needle:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
}

#[test]
fn missing_scene_file_is_an_error_naming_it_and_writes_nothing() {
    let dir = scratch("missing");
    let out_file = dir.join("x.exr");
    let out = caustica(&["render", "no/such/scene.gltf", "-q", "-o", out_file.to_str().unwrap()]);
    assert_fails_naming(&out, "no/such/scene.gltf");
    assert!(!out_file.exists());
}

#[test]
fn a_file_that_is_not_gltf_is_an_error_naming_it() {
    let dir = scratch("notgltf");
    let bogus = dir.join("bogus.gltf");
    std::fs::write(&bogus, "this is not json").unwrap();
    let out = caustica(&["render", bogus.to_str().unwrap(), "-q", "-o", dir.join("x.png").to_str().unwrap()]);
    assert_fails_naming(&out, "bogus.gltf");
    assert!(!dir.join("x.png").exists());
}

#[test]
fn zero_samples_and_unknown_integrator_are_rejected() {
    let scene = common::data("cornell-box.gltf");
    let out = caustica(&["render", scene.to_str().unwrap(), "--spp", "0", "-q"]);
    assert_fails_naming(&out, "spp");
    let out = caustica(&["render", scene.to_str().unwrap(), "--integrator", "magic", "-q"]);
    assert_fails_naming(&out, "magic");
    let out = caustica(&["render", scene.to_str().unwrap(), "--spp", "-3", "-q"]);
    assert_fails_naming(&out, "-3");
}

#[test]
fn unknown_output_format_fails_before_rendering() {
    let dir = scratch("format");
    let scene = common::data("cornell-box.gltf");
    let target = dir.join("image.bmp");
    let out = caustica(&["render", scene.to_str().unwrap(), "-q", "-o", target.to_str().unwrap()]);
    assert_fails_naming(&out, "image.bmp");
    assert!(!target.exists());
}

/// Two constant images, 1 and 1.5 in every channel but one pixel at 3: RMSE, relMSE
/// = mean((a − b)² / (b² + 0.01)) and MAE computed by hand, and FLIP 0 (LDR-FLIP compares the tone
/// mapped images, and both saturate to white); black against that white is FLIP's largest difference.
#[test]
fn compare_prints_the_four_metrics_of_two_images() {
    use caustica::film::{Image, output::write_image};
    let dir = scratch("compare");
    let mut a = Image { width: 4, height: 2, pixels: vec![glam::Vec3::splat(1.5); 8] };
    a.pixels[5] = glam::Vec3::splat(3.0);
    let b = Image { width: 4, height: 2, pixels: vec![glam::Vec3::ONE; 8] };
    let (pa, pb) = (dir.join("a.exr"), dir.join("b.exr"));
    write_image(&a, &pa, 0.0).unwrap();
    write_image(&b, &pb, 0.0).unwrap();
    let out = caustica(&["compare", pa.to_str().unwrap(), pb.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let squared: f64 = (7.0 * 0.25 + 4.0) / 8.0;
    let expected = [
        format!("RMSE {:.6}", squared.sqrt()),
        format!("relMSE {:.6}", squared / 1.01),
        format!("MAE {:.6}", (7.0 * 0.5 + 2.0) / 8.0),
        "FLIP 0.000000".to_string(),
    ];
    for metric in expected {
        assert!(stdout.contains(&metric), "missing {metric}: {stdout}");
    }
    let same = caustica(&["compare", pb.to_str().unwrap(), pb.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&same.stdout).contains("RMSE 0.000000"));
    let black = dir.join("black.exr");
    write_image(&Image { width: 4, height: 2, pixels: vec![glam::Vec3::ZERO; 8] }, &black, 0.0).unwrap();
    let out = caustica(&["compare", black.to_str().unwrap(), pb.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let flip: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("FLIP "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no FLIP line: {stdout}"));
    assert!(flip > 0.9, "black against white: FLIP {flip}");
}

/// Every setting is checked the same way whether it comes from the run file or the command line, before
/// anything renders: each of these once rendered something silently wrong (a black image, an image
/// with no photons, a budget overflowed to 0) or hung.
#[test]
fn out_of_range_settings_are_refused_before_rendering_naming_the_key() {
    let dir = scratch("settings");
    let scene = common::data("cornell-box.gltf");
    let scene = scene.to_str().unwrap();
    let target = dir.join("x.exr");
    let o = target.to_str().unwrap();
    for (flags, key) in [
        (&["--integrator", "pm", "--k", "0"][..], "photons.k"),
        (&["--integrator", "pm", "--k", "1"], "photons.k"),
        (&["--integrator", "pm", "--max-radius", "0"], "photons.max_radius"),
        (&["--integrator", "pm", "--max-radius", "NaN"], "photons.max_radius"),
        (&["--integrator", "pm", "--max-radius=-1"], "photons.max_radius"),
        (&["--time-limit", "0"], "render.time_limit"),
        (&["--time-limit=-1"], "render.time_limit"),
        (&["--time-limit", "NaN"], "render.time_limit"),
        (&["--exposure", "NaN"], "film.exposure"),
        (&["--threads", "0"], "--threads"),
        (&["--threads", "5000"], "--threads"),
        (&["--integrator", "sppm", "--memory-budget-mib", "17592186044416"], "memory_budget_mib"),
        (&["--write-every", "0"], "write_every"),
    ] {
        let mut args = vec!["render", scene, "-q", "--spp", "1", "-o", o];
        args.extend_from_slice(flags);
        let out = caustica(&args);
        assert_fails_naming(&out, key);
        assert!(!target.exists(), "{flags:?} wrote an image");
    }
    let run = dir.join("bad-photons.toml");
    let gltf = common::data("cornell-box.gltf");
    std::fs::write(&run, format!("gltf = {:?}\n[photons]\nmax_radius = -1.0\n", gltf.to_str().unwrap()))
        .unwrap();
    assert_fails_naming(&caustica(&["render", run.to_str().unwrap(), "-q", "-o", o]), "max_radius");
    std::fs::write(&run, format!("gltf = {:?}\n[photons]\nk = 0\n", gltf.to_str().unwrap())).unwrap();
    assert_fails_naming(&caustica(&["render", run.to_str().unwrap(), "-q", "-o", o]), "photons.k");
}

#[test]
fn a_compare_window_outside_the_image_and_a_nan_bench_budget_are_refused() {
    let reference = common::data("cornell-box.ref.exr");
    let r = reference.to_str().unwrap();
    let out = caustica(&["compare", r, r, "--window", "0,0,9999,10"]);
    assert_fails_naming(&out, "--window");
    let out = caustica(&["compare", r, r, "--window", "10,10,10,20"]);
    assert_fails_naming(&out, "not a non-empty rectangle");
    let dir = scratch("bench-nan");
    let out = caustica(&[
        "bench",
        common::data("cornell-box.gltf").to_str().unwrap(),
        "--time",
        "1",
        "--reference-time",
        "NaN",
        "--out-dir",
        dir.to_str().unwrap(),
    ]);
    assert_fails_naming(&out, "--reference-time");
}

/// The command line a user meets: `caustica SCENE` renders, `--outfile` is `-o`, `--set` reaches any
/// run-file key (and names a wrong one), a time limit alone renders until it and says so, warnings
/// read as sentences, a directory given as the scene gets its own message.
#[test]
fn the_command_line_a_user_meets() {
    let dir = scratch("user");
    let scene = common::data("cornell-box.gltf");
    let scene = scene.to_str().unwrap();
    let target = dir.join("x.exr");
    let o = target.to_str().unwrap();
    let small = ["--width", "16", "--height", "16", "-q"];

    let mut args = vec![scene, "--spp", "1", "--outfile", o];
    args.extend(small);
    let out = caustica(&args);
    assert!(out.status.success() && target.exists(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("integrator  pt, 1 spp"));

    let mut args =
        vec!["render", scene, "--set", "render.spp=3", "--set", "render.integrator=pt-naive", "-o", o];
    args.extend(small);
    let stdout = String::from_utf8_lossy(&caustica(&args).stdout).into_owned();
    assert!(stdout.contains("integrator  pt-naive, 3 spp"), "{stdout}");
    let mut args = vec!["render", scene, "--set", "render.spps=3", "-o", o];
    args.extend(small);
    assert_fails_naming(&caustica(&args), "spps");

    let mut args = vec!["render", scene, "--time-limit", "0.5", "-o", o];
    args.extend(small);
    let stdout = String::from_utf8_lossy(&caustica(&args).stdout).into_owned();
    assert!(stdout.contains("stopped     by the time limit"), "{stdout}");
    let spp: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("integrator  pt, "))
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("the summary gives the spp");
    assert!(spp > 64.0, "a time limit alone is not bounded by the default 64 spp: {spp}");

    // A glTF without a camera: its warning is a sentence, with no timestamp or module path.
    let no_camera = common::data("gltf-samples/BoxTextured.gltf");
    let mut args = vec!["render", no_camera.to_str().unwrap(), "--spp", "1", "-o", o];
    args.extend(small);
    let stderr = String::from_utf8_lossy(&caustica(&args).stderr).into_owned();
    assert!(stderr.contains("no camera in the file"), "{stderr}");
    assert!(
        !stderr.contains("caustica::") && !stderr.contains("2026-") && !stderr.contains("T0"),
        "{stderr}"
    );

    let out = caustica(&["render", dir.to_str().unwrap(), "-o", o]);
    assert_fails_naming(&out, "is a directory");
}

/// Standard output closed before the command prints (`caustica compare a b | head -c 1`): the
/// command finishes without a panic (println! panicked on the broken pipe, exit 101).
#[test]
fn a_closed_stdout_pipe_is_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("a.exr");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
        .arg("render")
        .arg(common::data("cornell-box.gltf"))
        .args(["--spp", "1", "--width", "8", "--height", "8", "--quiet", "-o"])
        .arg(&image)
        .status()
        .unwrap();
    assert!(status.success());
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
        .arg("compare")
        .args([&image, &image])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success() && !stderr.contains("panicked"), "{:?}: {stderr}", output.status);
}

/// A checkpoint or an output that names a file the run reads, by another spelling of its path, is
/// refused before anything is written, and the file is untouched.
#[test]
fn a_checkpoint_or_output_never_overwrites_what_the_run_reads() {
    let dir = tempfile::tempdir().unwrap();
    let caustica = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
            .current_dir(dir.path())
            .arg("render")
            .arg(common::data("cornell-box.gltf"))
            .args(["--spp", "2", "--width", "8", "--height", "8", "--quiet"])
            .args(args)
            .output()
            .unwrap()
    };
    assert!(caustica(&["-o", "ref.exr"]).status.success());
    assert!(caustica(&["--checkpoint", "ck.exr", "-o", "first.exr"]).status.success());
    let (reference, checkpoint) = (
        std::fs::read(dir.path().join("ref.exr")).unwrap(),
        std::fs::read(dir.path().join("ck.exr")).unwrap(),
    );
    for args in [
        &["--reference", "ref.exr", "--checkpoint", "./ref.exr", "-o", "a.exr"][..],
        &["--checkpoint", "./c.exr", "-o", "c.exr"],
        &["--resume", "ck.exr", "-o", "./ck.exr"],
    ] {
        let output = caustica(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success() && stderr.contains("refusing to overwrite"), "{args:?}: {stderr}");
    }
    assert_eq!(std::fs::read(dir.path().join("ref.exr")).unwrap(), reference);
    assert_eq!(std::fs::read(dir.path().join("ck.exr")).unwrap(), checkpoint);
    assert!(!dir.path().join("c.exr").exists());
    // Resuming goes on writing the checkpoint it resumed from.
    assert!(caustica(&["--resume", "ck.exr", "--checkpoint", "./ck.exr", "-o", "b.exr"]).status.success());
}

/// Odd inputs that rendered or plotted without a word: a checkpoint named .png (written as an EXR
/// under that name), `pm` without photons, a density bandwidth of 0 from data without spread, a NaN
/// histogram origin.
#[test]
fn odd_inputs_are_refused_or_said() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
            .current_dir(dir.path())
            .args(args)
            .output()
            .unwrap()
    };
    let scene = common::data("cornell-box.gltf");
    let scene = scene.to_str().unwrap();
    let small = ["--width", "8", "--height", "8", "--spp", "1", "-o", "o.exr"];
    let output = run(&[&["render", scene, "--checkpoint", "c.png"][..], &small].concat());
    assert!(!output.status.success() && String::from_utf8_lossy(&output.stderr).contains("FILE.exr"));
    assert!(!dir.path().join("c.png").exists() && !dir.path().join("o.exr").exists());
    let output = run(&[&["render", scene, "--integrator", "pm", "--photons", "0"][..], &small].concat());
    let said = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success() && said.contains("photons = 0"), "{said}");
    std::fs::write(dir.path().join("same.txt"), "2 2 2 2\n").unwrap();
    let output = run(&["density", "same.txt", "-o", "d.png"]);
    assert!(!output.status.success() && String::from_utf8_lossy(&output.stderr).contains("give --h"));
    std::fs::write(dir.path().join("d.txt"), "1 2 3 4\n").unwrap();
    let output = run(&["density", "d.txt", "--method", "histogram", "--origin", "NaN", "-o", "d.png"]);
    assert!(!output.status.success() && String::from_utf8_lossy(&output.stderr).contains("origin"));
    assert!(!dir.path().join("d.png").exists());
}

/// What a new user met (issue 32): `--spp -1` is refused as a count, not met with clap's `-- -1`
/// tip; comparing a PNG says that images are compared as EXRs; `--part` to a PNG names the file and
/// what it must be; `-D spp=2` sets `render.spp` as Mitsuba's `-D` and Python's `spp=` do; a share's
/// summary gives the samples it rendered, not where it ends.
#[test]
fn what_a_new_user_met_is_said_plainly() {
    let dir = scratch("new-user");
    let scene = common::data("cornell-box.gltf");
    let scene = scene.to_str().unwrap();
    let out = dir.join("o.exr");
    let out = out.to_str().unwrap();
    let negative = caustica(&["render", scene, "--spp", "-1", "-o", out]);
    let stderr = String::from_utf8_lossy(&negative.stderr);
    assert!(!negative.status.success() && stderr.contains("'-1'") && !stderr.contains("-- -1"), "{stderr}");

    let png = dir.join("o.png");
    let rendered = caustica(&[
        "render",
        scene,
        "-D",
        "spp=2",
        "-D",
        "width=8",
        "--height",
        "8",
        "-o",
        png.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&rendered.stdout);
    assert!(rendered.status.success() && stdout.contains("2 spp, 8x8"), "{stdout}");
    let reference = common::data("cornell-box.ref.exr");
    assert_fails_naming(
        &caustica(&["compare", png.to_str().unwrap(), reference.to_str().unwrap()]),
        "not an OpenEXR file",
    );

    let part = caustica(&["render", scene, "--spp", "8", "--part", "1/4", "-o", png.to_str().unwrap()]);
    assert_fails_naming(&part, "o.png: --part writes an accumulator");

    let share = caustica(&[
        "render", scene, "--spp", "64", "--width", "8", "--height", "8", "--part", "2/4", "-o", out,
    ]);
    let stdout = String::from_utf8_lossy(&share.stdout);
    assert!(
        stdout.contains("pt, 16 spp, 8x8") && stdout.contains("part        2/4: units 16..32 of 64 spp"),
        "{stdout}"
    );
}

/// `--spp` with an integrator that counts passes: sppm and its kin take one camera sample a pixel a
/// pass, so the samples become passes and the command says so; ppm traces its camera samples once,
/// as hit points, so there they become hit points a pixel; a `--passes` beside it wins, and the
/// unused `--spp` is named.
#[test]
fn spp_with_a_pass_counting_integrator_is_mapped_or_refused_and_said() {
    let dir = scratch("spp-passes");
    let scene = common::data("cornell-box.gltf");
    let scene = scene.to_str().unwrap();
    let out = dir.join("o.exr");
    let out = out.to_str().unwrap();
    let small = ["--width", "8", "--height", "8", "--photons-per-pass", "1000", "-o", out];
    let sppm = caustica(&[&["render", scene, "--integrator", "sppm", "--spp", "3"][..], &small].concat());
    let (stdout, stderr) = (String::from_utf8_lossy(&sppm.stdout), String::from_utf8_lossy(&sppm.stderr));
    assert!(sppm.status.success(), "{stderr}");
    assert!(stderr.contains("--spp 3 renders 3 passes"), "said: {stderr}");
    assert!(stdout.contains("sppm, 3 passes"), "rendered 3 passes: {stdout}");
    let ppm = caustica(
        &[&["render", scene, "--integrator", "ppm", "--spp", "3", "--passes", "1"][..], &small].concat(),
    );
    let stderr = String::from_utf8_lossy(&ppm.stderr);
    assert!(ppm.status.success() && stderr.contains("--spp 3 traces 4 a pixel"), "{stderr}");
    let both = caustica(
        &[&["render", scene, "--integrator", "pppm", "--spp", "3", "--passes", "2"][..], &small].concat(),
    );
    let (stdout, stderr) = (String::from_utf8_lossy(&both.stdout), String::from_utf8_lossy(&both.stderr));
    assert!(both.status.success() && stdout.contains("pppm, 2 passes"), "{stdout}{stderr}");
    assert!(stderr.contains("--passes 2 is used, not --spp 3"), "said: {stderr}");
}

/// An integrator switched on the command line does not overwrite the run file's image of another:
/// its name goes into the run file's output names (and into the default ones).
#[test]
fn an_integrator_from_the_command_line_writes_beside_the_run_files_outputs() {
    let dir = scratch("integrator-outputs");
    let gltf = common::data("cornell-box.gltf");
    let run = dir.join("box.toml");
    let png = dir.join("box.png");
    std::fs::write(
        &run,
        format!(
            "gltf = {:?}\n[render]\nspp = 1\n[film]\nwidth = 8\nheight = 8\n[output]\npng = {:?}\n",
            gltf, png
        ),
    )
    .unwrap();
    let run = run.to_str().unwrap();
    let pt = caustica(&["render", run, "-q"]);
    assert!(pt.status.success(), "{}", String::from_utf8_lossy(&pt.stderr));
    let before = std::fs::read(&png).expect("the run file's output");
    let lt = caustica(&["render", run, "--integrator", "lt", "-q"]);
    assert!(lt.status.success(), "{}", String::from_utf8_lossy(&lt.stderr));
    assert!(dir.join("box-lt.png").is_file(), "lt's image beside it");
    assert_eq!(std::fs::read(&png).unwrap(), before, "pt's image untouched");
}

/// With stderr not a terminal (here a pipe, as in a batch job's log) the bar does not draw: plain
/// progress lines say where the render is, up to its end; `-q` silences them.
#[test]
fn a_log_that_is_not_a_terminal_gets_progress_lines() {
    let dir = scratch("progress-log");
    let scene = common::data("cornell-box.gltf");
    let out = dir.join("o.png");
    let args = ["render", scene.to_str().unwrap(), "--width", "16", "--height", "16", "--spp", "8"];
    let logged = caustica(&[&args[..], &["-o", out.to_str().unwrap()]].concat());
    let stderr = String::from_utf8_lossy(&logged.stderr);
    assert!(logged.status.success(), "{stderr}");
    assert!(stderr.lines().any(|l| l.starts_with("progress    100%  8.0/8 spp")), "{stderr}");
    let quiet = caustica(&[&args[..], &["-q", "-o", out.to_str().unwrap()]].concat());
    assert!(!String::from_utf8_lossy(&quiet.stderr).contains("progress"), "-q says nothing");
}

/// A time limit counts from the command's start: one smaller than loading and preparing takes (a
/// nanosecond) leaves the render none, and the command still writes a whole image and says where the
/// limit went. Every integrator, since `pm` drops a photon pass that a stop cuts (its image is then
/// black, and still an image).
#[test]
fn a_time_limit_spent_before_rendering_still_writes_an_image_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::data("cornell-box.gltf");
    for integrator in ["pt", "pm", "sppm"] {
        let (exr, png) =
            (dir.path().join(format!("{integrator}.exr")), dir.path().join(format!("{integrator}.png")));
        let out = caustica(&[
            "render",
            scene.to_str().unwrap(),
            "--integrator",
            integrator,
            "--time-limit",
            "1e-9",
            "--width",
            "16",
            "--height",
            "16",
            "-q",
            "-o",
            exr.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{integrator}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(
            stdout.contains(
                "time limit  0.000000001 s from the command's start, all of it spent loading and preparing"
            ),
            "{integrator}: the summary names the limit and what it covered:\n{stdout}"
        );
        assert!(stdout.contains("stopped     by the time limit"), "{integrator}:\n{stdout}");
        let image = caustica::film::output::read_exr(&exr).expect("the EXR reads back");
        assert_eq!((image.width, image.height), (16, 16));
        assert!(image.pixels.iter().all(|p| p.is_finite()), "{integrator}: a pixel is not finite");
        let png = image::open(&png).expect("the PNG decodes");
        assert_eq!((png.width(), png.height()), (16, 16));
    }
}

/// `--guiding-debug` writes `NAME-guide.exr` beside the first output: that file goes through the
/// checks every output does. An input (the environment map), another output and a checkpoint of
/// that name are each refused before anything renders, the file left as it was; with `--frames`
/// the option is refused rather than silently skipped.
#[test]
fn the_guide_image_is_checked_as_every_output_is() {
    let dir = scratch("guide-image");
    let scene = common::data("cornell-box.gltf");
    let output = dir.join("render.exr");
    let guide = dir.join("render-guide.exr");
    let sky = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sky.exr");
    std::fs::copy(&sky, &guide).unwrap();
    let before = std::fs::read(&guide).unwrap();
    let (scene, output_s, guide_s) =
        (scene.to_str().unwrap(), output.to_str().unwrap(), guide.to_str().unwrap());
    let base = [
        "render",
        scene,
        "--spp",
        "16",
        "--width",
        "16",
        "--height",
        "16",
        "--guiding",
        "--guiding-debug",
        "8,8",
        "-q",
    ];
    let run = |extra: &[&str]| caustica(&[&base[..], extra].concat());
    let out = run(&["-o", output_s, "--environment", guide_s]);
    assert_fails_naming(&out, "the output is also an input");
    let out = run(&["-o", output_s, "-o", guide_s]);
    assert_fails_naming(&out, "named twice");
    let checkpoint = dir.join("render-guide.exr");
    let out = run(&["-o", output_s, "--checkpoint", checkpoint.to_str().unwrap()]);
    assert_fails_naming(&out, "refusing to overwrite it");
    let out = run(&["-o", output_s, "--frames", "0:2"]);
    assert_fails_naming(&out, "--guiding-debug");
    assert_eq!(std::fs::read(&guide).unwrap(), before, "the file named like the guide image was changed");
    assert!(!output.exists(), "a refused render wrote its output");
    // Named nowhere else, it is written.
    std::fs::remove_file(&guide).unwrap();
    let out = run(&["-o", output_s]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(guide.exists(), "the guide image was not written: {said}");
}

/// The summary says when an output replaced a file that was there (a second run with other
/// settings writes over the first's image), and not when it made a new one.
#[test]
fn the_summary_says_which_outputs_replaced_a_file() {
    let dir = scratch("summary-overwrite");
    let scene = common::data("cornell-box.gltf");
    let output = dir.join("box.png");
    let _ = std::fs::remove_file(&output);
    let run = || {
        let out = caustica(&[
            "render",
            scene.to_str().unwrap(),
            "--spp",
            "1",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            output.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let first = run();
    assert!(first.contains("wrote") && !first.contains("(replaced"), "{first}");
    let second = run();
    assert!(second.contains("(replaced the file that was there)"), "{second}");
}
