//! Checkpoint and resume: a render stopped by a signal and continued from its checkpoint gives the
//! bits of one that never stopped; a checkpoint of another render, or a damaged one, is refused and
//! nothing is overwritten.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn caustica(args: &[&str], paths: &[&Path]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_caustica"));
    command.arg("render").arg(common::data("cornell-spheres.gltf"));
    command.args(["--width", "48", "--height", "36", "--quiet"]).args(args);
    for path in paths {
        command.arg(path);
    }
    command
}

fn wait_for(path: &Path, child: &mut Child) {
    let start = Instant::now();
    while !path.exists() {
        assert!(child.try_wait().unwrap().is_none(), "the render ended before its first checkpoint");
        assert!(start.elapsed() < Duration::from_secs(120), "no checkpoint after 120 s");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Render `flags` to the end in one go, and again stopped by SIGINT after its first checkpoint and
/// resumed from it: the two EXRs are the same bytes.
fn interrupted_and_resumed_equals_uninterrupted(flags: &[&str]) {
    stopped_by_and_resumed_equals_uninterrupted("INT", flags);
}

/// As [`interrupted_and_resumed_equals_uninterrupted`], stopped by `signal` (`INT` or `TERM`).
fn stopped_by_and_resumed_equals_uninterrupted(signal: &str, flags: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.exr");
    assert!(caustica(flags, &[]).arg("-o").arg(&whole).status().unwrap().success());

    let (checkpoint, stopped, resumed) =
        (dir.path().join("run.ckpt.exr"), dir.path().join("stopped.exr"), dir.path().join("resumed.exr"));
    let ck = checkpoint.to_str().unwrap();
    let mut child = caustica(
        &[flags, &["--checkpoint", ck, "--checkpoint-every", "0.01", "--threads", "1"]].concat(),
        &[],
    )
    .arg("-o")
    .arg(&stopped)
    .stdout(Stdio::null())
    .spawn()
    .unwrap();
    wait_for(&checkpoint, &mut child);
    let status =
        Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
    assert!(status.success());
    let code = child.wait().unwrap().code();
    // 130: stopped by the signal, the checkpoint and the image so far written; 0 if the render
    // reached its end first (then the resume below has nothing left to do, which must work too).
    assert!(matches!(code, Some(130) | Some(0)), "exit {code:?}");
    assert!(stopped.exists(), "the image so far is written");

    let status = caustica(&[flags, &["--resume", ck, "--threads", "2"]].concat(), &[])
        .arg("-o")
        .arg(&resumed)
        .status()
        .unwrap();
    assert!(status.success(), "resume");
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&whole).unwrap(),
        "{flags:?}: resumed != whole"
    );
}

#[test]
fn pt_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&["--integrator", "pt", "--spp", "512"]);
}

#[test]
fn pppm_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&[
        "--integrator",
        "pppm",
        "--passes",
        "48",
        "--photons-per-pass",
        "20000",
    ]);
}

/// `--resume` alone goes on checkpointing to the file it resumed (the README's recipe lost work when a
/// second stop found the old checkpoint), and `--checkpoint OTHER` moves it there.
#[test]
fn a_resumed_render_goes_on_checkpointing_to_its_file() {
    use caustica::film::accumulator::read_info;
    let dir = tempfile::tempdir().unwrap();
    let (ck, other, out) =
        (dir.path().join("ck.exr"), dir.path().join("other.exr"), dir.path().join("o.exr"));
    let run = |args: &[&str], paths: &[&Path]| caustica(args, paths).status().unwrap().success();
    assert!(run(&["--spp", "2", "--checkpoint"], &[&ck, Path::new("-o"), &out]));
    assert!(run(&["--spp", "4", "--resume"], &[&ck, Path::new("-o"), &out]));
    assert_eq!(read_info(&ck).unwrap().0.samples, 0..4, "the resumed render's last checkpoint");
    assert!(run(
        &["--spp", "6", "--resume"],
        &[&ck, Path::new("--checkpoint"), &other, Path::new("-o"), &out]
    ));
    assert_eq!((read_info(&ck).unwrap().0.samples, read_info(&other).unwrap().0.samples), (0..4, 0..6));
}

#[test]
fn lt_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&["--integrator", "lt", "--spp", "256"]);
}

#[test]
fn bdpt_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&["--integrator", "bdpt", "--spp", "64"]);
}

#[test]
fn vcm_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&["--integrator", "vcm", "--spp", "64"]);
}

/// SIGTERM (a supervisor's, a batch system's) is handled as Ctrl-C is: the checkpoint written, and
/// the render resumed from it is the uninterrupted one.
#[test]
fn lt_bdpt_and_vcm_stopped_by_sigterm_and_resumed_are_the_uninterrupted_render() {
    stopped_by_and_resumed_equals_uninterrupted("TERM", &["--integrator", "lt", "--spp", "256"]);
    stopped_by_and_resumed_equals_uninterrupted("TERM", &["--integrator", "bdpt", "--spp", "64"]);
    stopped_by_and_resumed_equals_uninterrupted("TERM", &["--integrator", "vcm", "--spp", "64"]);
}

fn progressive(kind: &'static str) -> [&'static str; 6] {
    ["--integrator", kind, "--passes", "40", "--photons-per-pass", "20000"]
}

#[test]
fn sppm_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&progressive("sppm"));
}

#[test]
fn appm_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&progressive("appm"));
}

#[test]
fn ppm_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&progressive("ppm"));
}

#[test]
fn cppm_stopped_by_a_signal_and_resumed_is_the_uninterrupted_render() {
    interrupted_and_resumed_equals_uninterrupted(&progressive("cppm"));
}

/// A checkpoint's target can be raised: 8 spp resumed to 16 is a 16-spp render.
#[test]
fn a_resumed_render_can_go_past_its_first_target() {
    let dir = tempfile::tempdir().unwrap();
    let (ck, eight, sixteen, whole) = (
        dir.path().join("ck.exr"),
        dir.path().join("8.exr"),
        dir.path().join("16.exr"),
        dir.path().join("whole.exr"),
    );
    let ck_arg = ck.to_str().unwrap();
    assert!(
        caustica(&["--spp", "8", "--checkpoint", ck_arg], &[])
            .arg("-o")
            .arg(&eight)
            .status()
            .unwrap()
            .success()
    );
    assert!(
        caustica(&["--spp", "16", "--resume", ck_arg], &[])
            .arg("-o")
            .arg(&sixteen)
            .status()
            .unwrap()
            .success()
    );
    assert!(caustica(&["--spp", "16"], &[]).arg("-o").arg(&whole).status().unwrap().success());
    assert_eq!(std::fs::read(&sixteen).unwrap(), std::fs::read(&whole).unwrap());
}

/// Refused, naming the file, with the outputs left as they were: a checkpoint of another seed, a
/// truncated one, one that already holds more than asked, and a checkpoint of visibility-aware light
/// selection, which learns from its first samples what the film does not hold.
#[test]
fn a_foreign_or_damaged_checkpoint_is_refused_and_nothing_is_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let ck: PathBuf = dir.path().join("ck.exr");
    let ck_arg = ck.to_str().unwrap();
    let out = dir.path().join("out.exr");
    assert!(
        caustica(&["--spp", "4", "--checkpoint", ck_arg], &[])
            .arg("-o")
            .arg(&out)
            .status()
            .unwrap()
            .success()
    );
    let before = std::fs::read(&out).unwrap();

    let refused = |args: &[&str]| {
        let output = caustica(args, &[]).arg("-o").arg(&out).output().unwrap();
        assert!(!output.status.success(), "{args:?} should be refused");
        assert_eq!(std::fs::read(&out).unwrap(), before, "{args:?}: the output was overwritten");
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let e = refused(&["--spp", "8", "--seed", "99", "--resume", ck_arg]);
    assert!(e.contains("ck.exr") && e.contains("another scene or settings"), "{e}");

    let cut = dir.path().join("cut.exr");
    let bytes = std::fs::read(&ck).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 3]).unwrap();
    let e = refused(&["--spp", "8", "--resume", cut.to_str().unwrap()]);
    assert!(e.contains("cut.exr"), "{e}");

    let e = refused(&["--spp", "2", "--resume", ck_arg]);
    assert!(e.contains("already holds 4"), "{e}");

    let e = refused(&[
        "--spp",
        "4",
        "--light-selection",
        "visibility",
        "--checkpoint",
        dir.path().join("v.exr").to_str().unwrap(),
    ]);
    assert!(e.contains("--checkpoint") && e.contains("visibility"), "{e}");
}

/// A checkpoint damaged on disk or written wrong is refused, naming the file and the damage, never
/// resumed into a wrong image or a panic: a flipped bit in the sums (the checksum), a `ppm` hit point
/// whose material is not the scene's (it panicked indexing the materials), an `sppm` radius of NaN
/// (it resumed into black pixels with exit 0).
#[test]
fn damaged_checkpoints_are_refused_not_resumed() {
    use caustica::film::accumulator::{read_checkpoint, write_checkpoint};
    let dir = tempfile::tempdir().unwrap();
    let write = |flags: &[&str], name: &str| {
        let ck = dir.path().join(name);
        let args = [flags, &["--checkpoint", ck.to_str().unwrap()]].concat();
        assert!(caustica(&args, &[]).arg("-o").arg(dir.path().join("o.exr")).status().unwrap().success());
        ck
    };
    let refusal = |flags: &[&str], ck: &Path| {
        let args = [flags, &["--resume", ck.to_str().unwrap()]].concat();
        let output = caustica(&args, &[]).arg("-o").arg(dir.path().join("r.exr")).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert_eq!(output.status.code(), Some(1), "{flags:?}: {stderr}");
        stderr
    };

    let pt = write(&["--spp", "2"], "pt.exr");
    let mut bytes = std::fs::read(&pt).unwrap();
    // The last bytes of an uncompressed checkpoint are the last line's high sum words.
    let at = bytes.len() - 6;
    bytes[at] ^= 0x10;
    std::fs::write(&pt, bytes).unwrap();
    let e = refusal(&["--spp", "4"], &pt);
    assert!(e.contains("pt.exr") && e.contains("damaged"), "{e}");

    // Words of a hit point: τ (6), N (2), R² (1), then ppm's visible point: p (3), β (3), wo, ns, and
    // three words of packed shading, the material in the last one's high half.
    let damage = |ck: &Path, word: usize, value: u32| {
        let (film, info, state) = read_checkpoint(ck).unwrap();
        let mut state = state.expect("hit points");
        state.channels[word][0] = value;
        write_checkpoint(&film, &info, Some(state), ck).unwrap();
    };
    let ppm = ["--integrator", "ppm", "--photons-per-pass", "2000", "--hit-points-per-pixel", "1"];
    let ck = write(&[&ppm[..], &["--passes", "3"]].concat(), "ppm.exr");
    damage(&ck, 19, 0xffff_0000);
    let e = refusal(&[&ppm[..], &["--passes", "4"]].concat(), &ck);
    assert!(e.contains("material 65535") && e.contains("damaged"), "{e}");

    let sppm = ["--integrator", "sppm", "--photons-per-pass", "2000"];
    let ck = write(&[&sppm[..], &["--passes", "2"]].concat(), "sppm.exr");
    damage(&ck, 8, f32::NAN.to_bits());
    let e = refusal(&[&sppm[..], &["--passes", "4"]].concat(), &ck);
    assert!(e.contains("radius") && e.contains("damaged"), "{e}");
}

/// A checkpoint of `integrator` at 2 spp, rewritten by the library with one field made to lie and
/// its checksum made to match (what a tool that edits checkpoints, or a bug in the writer, makes):
/// each is refused with exit 1, naming the file and the field, and neither the checkpoint nor the
/// output is touched. The view channels `R`, `G`, `B` (the mean, for image viewers) are not what a
/// resume reads: NaN, infinite and negative there resume into the uninterrupted render, bit for bit.
fn well_formed_lies_are_refused(integrator: &str) {
    use caustica::film::Film;
    use caustica::film::accumulator::{HitPointState, PartInfo, read_checkpoint, write_checkpoint};
    let dir = tempfile::tempdir().unwrap();
    let flags = ["--integrator", integrator, "--seed", "45", "--width", "16", "--height", "12"];
    let render = |more: &[&str], paths: &[&Path]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_caustica"));
        command.arg("render").arg(common::data("cornell-spheres.gltf")).arg("--quiet").args(flags).args(more);
        command.args(paths).output().unwrap()
    };
    let (ck, out, whole) =
        (dir.path().join("ck.exr"), dir.path().join("out.exr"), dir.path().join("whole.exr"));
    assert!(render(&["--spp", "2", "--checkpoint"], &[&ck, Path::new("-o"), &out]).status.success());
    assert!(render(&["--spp", "3", "-o"], &[&whole]).status.success());
    let output_before = std::fs::read(&out).unwrap();
    let (film, info, state) = read_checkpoint(&ck).unwrap();
    assert!(state.is_none(), "{integrator}: the film is the whole state");
    assert_eq!(info.samples, 0..2);
    let (width, height) = (film.width, film.height);
    let counted = film.samples(0);

    // The film, pixel by pixel through `edit`, at `width` × `rows`.
    type Pixel = ([i128; 3], u32);
    let rebuilt = |rows: u32, edit: &dyn Fn(u32, Pixel) -> Pixel| {
        let copy = Film::new(width, rows);
        for pixel in 0..width * rows {
            let (sums, count) = if pixel < width * height { film.sums(pixel) } else { ([0; 3], counted) };
            let (sums, count) = edit(pixel, (sums, count));
            copy.add_sums(pixel, sums, count);
        }
        copy
    };
    let same = |_: u32, pixel| pixel;
    let refused = |name: &str, film: &Film, info: &PartInfo, state: Option<HitPointState>, needle: &str| {
        let path = dir.path().join(format!("{name}.exr"));
        write_checkpoint(film, info, state, &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let output = render(&["--spp", "3", "--resume"], &[&path, Path::new("-o"), &out]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{integrator} {name}: {stderr}");
        assert!(
            stderr.contains(&format!("{name}.exr")) && stderr.contains(needle),
            "{integrator} {name}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{integrator} {name}: {stderr}");
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "{integrator} {name}: the checkpoint was changed");
        assert_eq!(
            std::fs::read(&out).unwrap(),
            output_before,
            "{integrator} {name}: the output was overwritten"
        );
    };
    let with = |change: &dyn Fn(&mut PartInfo)| {
        let mut info = info.clone();
        change(&mut info);
        info
    };

    refused(
        "fingerprint",
        &film,
        &with(&|i| i.fingerprint = "0".repeat(16)),
        None,
        "another scene or settings",
    );
    refused("integrator", &film, &with(&|i| i.integrator = "pt".into()), None, "integrator");
    refused("parts", &film, &with(&|i| (i.part, i.parts) = (1, 2)), None, "split render");
    refused("start", &film, &with(&|i| i.samples = 1..2), None, "split render");
    refused("fewer", &film, &with(&|i| i.samples = 0..1), None, "samples where the checkpoint says");
    refused(
        "more",
        &film,
        &with(&|i| (i.samples, i.spp) = (0..3, 3)),
        None,
        "samples where the checkpoint says",
    );
    refused("spp", &film, &with(&|i| i.spp = 0), None, "spp");
    refused("per_unit", &film, &with(&|i| i.per_unit = 7), None, "per unit");
    refused("rows", &rebuilt(height + 1, &same), &info, None, &format!("{width}x{}", height + 1));
    refused(
        "count",
        &rebuilt(height, &|p, (s, c)| (s, if p == 5 { c + 1 } else { c })),
        &info,
        None,
        "pixel 5",
    );
    let stray =
        HitPointState { points_per_pixel: 1, r0: 0.01, channels: vec![vec![0; (width * height) as usize]] };
    refused("hit_points", &film, &info, Some(stray), "hit points");

    // The view channels, rewritten with the EXR library: not read by a resume.
    use exr::prelude::*;
    let mut image = read_all_flat_layers_from_file(&ck).unwrap();
    for channel in image.layer_data[0].channel_data.list.iter_mut() {
        let value = match channel.name.to_string().as_str() {
            "R" => f32::NAN,
            "G" => f32::INFINITY,
            "B" => -1.0,
            _ => continue,
        };
        let FlatSamples::F32(values) = &mut channel.sample_data else { panic!("R, G and B are f32") };
        values.iter_mut().for_each(|v| *v = value);
    }
    let viewed = dir.path().join("viewed.exr");
    image.write().to_file(&viewed).unwrap();
    let resumed = dir.path().join("resumed.exr");
    let output = render(&["--spp", "3", "--resume"], &[&viewed, Path::new("-o"), &resumed]);
    assert!(output.status.success(), "{integrator}: {}", String::from_utf8_lossy(&output.stderr));
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&whole).unwrap(),
        "{integrator}: resumed != whole"
    );
}

#[test]
fn lt_checkpoints_whose_fields_lie_are_refused() {
    well_formed_lies_are_refused("lt");
}

#[test]
fn bdpt_checkpoints_whose_fields_lie_are_refused() {
    well_formed_lies_are_refused("bdpt");
}

#[test]
fn vcm_checkpoints_whose_fields_lie_are_refused() {
    well_formed_lies_are_refused("vcm");
}

/// A resumed render says so and where it starts (it said nothing, and its first progress line's rate
/// counted the checkpoint's samples as its own).
#[test]
fn a_resumed_render_says_it_resumed_and_from_where() {
    let dir = tempfile::tempdir().unwrap();
    let (ck, out) = (dir.path().join("ck.exr"), dir.path().join("o.exr"));
    assert!(
        caustica(&["--spp", "2", "--checkpoint"], &[&ck, Path::new("-o"), &out]).status().unwrap().success()
    );
    let resumed = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .arg("render")
        .arg(common::data("cornell-spheres.gltf"))
        .args(["--width", "48", "--height", "36", "--spp", "4", "--resume"])
        .arg(&ck)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert!(resumed.status.success(), "{stderr}");
    assert!(stderr.contains("resumed") && stderr.contains("at 2 of 4 spp"), "{stderr}");
}
