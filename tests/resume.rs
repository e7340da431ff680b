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
    let status = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
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
