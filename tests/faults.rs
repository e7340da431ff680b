//! Faults lose nothing: outputs are checked before rendering and never overwrite an input; a signal
//! stops a render at its next step and writes the image so far; writes go through a unique temporary
//! file and a rename, so a failed or killed writer leaves the previous file and nothing else; one
//! failing output never stops the others; identical runs write identical bytes.

use crate::common;

use caustica::film::output::read_exr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

fn caustica(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_caustica")).args(args).output().expect("caustica runs")
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("caustica starts")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-faults-{}-{name}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn box_scene() -> String {
    common::data("cornell-box.gltf").to_str().unwrap().to_owned()
}

fn signal(child: &Child, name: &str) {
    let status = Command::new("kill").args([&format!("-{name}"), &child.id().to_string()]).status().unwrap();
    assert!(status.success(), "kill -{name}");
}

/// Files in `dir` whose name says they are a temporary write.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial") || n.starts_with(".caustica-check-"))
        .collect()
}

#[test]
fn an_output_that_cannot_be_written_is_refused_before_rendering() {
    let dir = scratch("unwritable");
    let good = dir.join("a.exr");
    for bad in ["/proc/caustica.exr", dir.to_str().unwrap()] {
        let out =
            caustica(&["render", &box_scene(), "-q", "--spp", "1", "-o", good.to_str().unwrap(), "-o", bad]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(bad), "{bad}: {stderr}");
        assert!(String::from_utf8_lossy(&out.stdout).is_empty(), "{bad}: it rendered");
        assert!(!good.exists(), "{bad}: the other output was written before the check");
    }
}

#[test]
fn an_input_is_never_overwritten_by_an_output() {
    let dir = scratch("inputs");
    let reference = dir.join("ref.exr");
    std::fs::copy(common::data("cornell-box.ref.exr"), &reference).unwrap();
    let before = std::fs::read(&reference).unwrap();
    let r = reference.to_str().unwrap();
    let out = caustica(&["render", &box_scene(), "-q", "--spp", "1", "--reference", r, "-o", r]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("also an input"));
    let sky = dir.join("sky.exr");
    std::fs::copy(common::data("cornell-box.ref.exr"), &sky).unwrap();
    let s = sky.to_str().unwrap();
    let out = caustica(&["render", &box_scene(), "-q", "--spp", "1", "--environment", s, "-o", s]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("also an input"));
    assert_eq!(std::fs::read(&reference).unwrap(), before, "the reference was changed");
    assert_eq!(std::fs::read(&sky).unwrap(), before, "the map was changed");
}

/// A reference whose size is not the image's is refused before rendering, naming it and both sizes
/// (it was once found only after the render, naming neither).
#[test]
fn a_reference_of_the_wrong_size_is_refused_before_rendering() {
    let reference = common::data("cornell-box.ref.exr");
    let r = reference.to_str().unwrap();
    let o = scratch("wrong-size").join("x.exr");
    let args = ["render", &box_scene(), "-q", "--width", "8", "--height", "6", "--reference", r, "-o"];
    let out = caustica(&[&args[..], &[o.to_str().unwrap()]].concat());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("cornell-box.ref.exr") && stderr.contains("256x256") && stderr.contains("8x6"),
        "{stderr}"
    );
    assert!(!o.exists(), "it rendered");
}

/// SIGINT or SIGTERM: the render stops at its next step, writes a valid image of the samples or
/// passes so far, says so, and exits 130; nothing temporary is left.
#[test]
fn a_signal_stops_the_render_and_writes_the_image_so_far() {
    for (integrator, unit, sig) in [("pt", "--spp", "INT"), ("sppm", "--passes", "TERM")] {
        let dir = scratch(&format!("signal-{integrator}"));
        let target = dir.join("out.exr");
        let child = spawn(&[
            "render",
            &box_scene(),
            "-q",
            "--integrator",
            integrator,
            unit,
            "1000000",
            "--width",
            "48",
            "--height",
            "48",
            "--photons-per-pass",
            "5000",
            "-o",
            target.to_str().unwrap(),
        ]);
        std::thread::sleep(Duration::from_millis(1500));
        signal(&child, sig);
        let out = child.wait_with_output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(130), "{integrator}: {stdout}");
        assert!(stdout.contains("stopped     by a signal"), "{integrator}: {stdout}");
        let image = read_exr(&target).unwrap_or_else(|e| panic!("{integrator}: {e}"));
        assert!(image.pixels.iter().all(|p| p.is_finite()) && image.mean().max_element() > 0.0);
        assert!(leftovers(&dir).is_empty(), "{integrator}: {:?}", leftovers(&dir));
    }
}

/// `--write-every` writes the image so far for every integrator (for `pt` every K samples per pixel):
/// a render killed outright (SIGKILL, nothing can run) leaves the last complete image.
#[test]
fn write_every_leaves_a_complete_image_when_the_process_is_killed() {
    let dir = scratch("killed");
    let target = dir.join("out.exr");
    let child = spawn(&[
        "render",
        &box_scene(),
        "-q",
        "--spp",
        "1000000",
        "--write-every",
        "1",
        "--width",
        "48",
        "--height",
        "48",
        "-o",
        target.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    signal(&child, "KILL");
    child.wait_with_output().unwrap();
    let image = read_exr(&target).expect("a periodic write left a complete image");
    assert!(image.mean().max_element() > 0.0);
}

/// An output whose folder turns into a file while the render runs: its periodic and final writes
/// fail and are reported, the render goes on to its end, and the other output gets the final image.
#[test]
fn one_failing_output_does_not_stop_the_render_or_the_others() {
    let dir = scratch("one-fails");
    let (lost, kept) = (dir.join("lost"), dir.join("kept"));
    std::fs::create_dir_all(&lost).unwrap();
    let (a, b) = (lost.join("a.exr"), kept.join("b.exr"));
    let child = spawn(&[
        "render",
        &box_scene(),
        "-q",
        "--integrator",
        "sppm",
        "--passes",
        "60",
        "--photons-per-pass",
        "20000",
        "--width",
        "48",
        "--height",
        "48",
        "--write-every",
        "1",
        "-o",
        a.to_str().unwrap(),
        "-o",
        b.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_millis(800));
    // Renamed away in one step: removing it could race the render's own temporary files in it.
    std::fs::rename(&lost, dir.join("gone")).unwrap();
    std::fs::write(&lost, "now a file").unwrap();
    let out = child.wait_with_output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!out.status.success(), "a lost output is a failure");
    assert!(stderr.contains("a.exr"), "{stderr}");
    assert!(stdout.contains("sppm, 60 passes"), "the render ran to its end: {stdout}");
    assert!(read_exr(&b).is_ok(), "the other output has the final image");
}

/// Two runs writing the same output at once both succeed and leave one complete image, and a file of
/// the name the old fixed temporary name used is not touched.
#[test]
fn concurrent_writers_of_one_output_do_not_collide() {
    let dir = scratch("concurrent");
    let target = dir.join("same.exr");
    let bystander = dir.join("same.partial.exr");
    std::fs::write(&bystander, "mine").unwrap();
    let args = [
        "render",
        &box_scene(),
        "-q",
        "--spp",
        "8",
        "--width",
        "64",
        "--height",
        "64",
        "-o",
        target.to_str().unwrap(),
    ];
    let (first, second) = (spawn(&args), spawn(&args));
    assert!(first.wait_with_output().unwrap().status.success());
    assert!(second.wait_with_output().unwrap().status.success());
    assert!(read_exr(&target).is_ok());
    assert_eq!(std::fs::read_to_string(&bystander).unwrap(), "mine");
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
}

/// The same render twice writes the same bytes (the EXR's compressed blocks were written in thread
/// order, so two runs at 600×600 differed though their pixels did not).
#[test]
fn identical_runs_write_identical_bytes() {
    let dir = scratch("bytes");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    for path in [&a, &b] {
        let out = caustica(&[
            "render",
            &box_scene(),
            "-q",
            "--spp",
            "1",
            "--width",
            "600",
            "--height",
            "600",
            "-o",
            path.to_str().unwrap(),
        ]);
        assert!(out.status.success());
    }
    assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(), "the two files differ");
}

fn assert_fails_naming(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected a failure naming {needle:?}: {stderr}");
    assert!(stderr.contains(needle), "stderr does not name {needle:?}: {stderr}");
    assert!(!stderr.contains("panicked") && !stderr.contains("backtrace"), "{stderr}");
}

/// What used to abort, hang or panic now fails with a message, before allocating.
#[test]
fn oversized_requests_and_hostile_files_fail_with_a_message() {
    let dir = scratch("hostile");
    let o = dir.join("x.exr");
    let o = o.to_str().unwrap();
    let scene = box_scene();
    // A 32768² film is 28 GiB; photon maps of 2^32 photons far more: both over a 1 GiB budget.
    let out = caustica(&[
        "render",
        &scene,
        "-q",
        "--width",
        "32768",
        "--height",
        "32768",
        "--memory-budget-mib",
        "1024",
        "-o",
        o,
    ]);
    assert_fails_naming(&out, "memory_budget_mib");
    let out = caustica(&["render", &scene, "-q", "--integrator", "pm", "--photons", "4294967295", "-o", o]);
    assert_fails_naming(&out, "photons");
    // A POSITION accessor with no bufferView (all zeros) declaring 2^40 vertices.
    let gltf = dir.join("huge.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "accessors":[{"componentType":5126,"count":1099511627776,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}]}"#,
    )
    .unwrap();
    let out = caustica(&["render", gltf.to_str().unwrap(), "-q", "-o", o]);
    assert_fails_naming(&out, "huge.gltf");
    // A buffer naming a device, which never ends.
    let device = dir.join("device.gltf");
    std::fs::write(
        &device,
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"../../../../../../dev/zero","byteLength":64}]}"#,
    )
    .unwrap();
    let out = caustica(&["render", device.to_str().unwrap(), "-q", "-o", o]);
    assert_fails_naming(&out, "not a regular file");
    // Data whose spread overflows; a trace that cannot be written.
    let traced = dir.join("traced.exr");
    let data = dir.join("wide.txt");
    std::fs::write(&data, "1e308 -1e308 0").unwrap();
    let out = caustica(&["density", data.to_str().unwrap(), "-o", dir.join("d.png").to_str().unwrap()]);
    assert_fails_naming(&out, "wide.txt");
    let out = caustica(&[
        "render",
        &scene,
        "-q",
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "--trace-chrome",
        "/dev/full",
        "-o",
        traced.to_str().unwrap(),
    ]);
    assert_fails_naming(&out, "/dev/full");
    assert!(read_exr(&traced).is_ok(), "the image is written all the same");
    // A PNG renamed .hdr is not a map.
    let png = dir.join("sky.png");
    caustica::film::output::write_image(
        &caustica::film::Image { width: 4, height: 2, pixels: vec![glam::Vec3::ONE; 8] },
        &png,
        0.0,
    )
    .unwrap();
    let fake = dir.join("sky.hdr");
    std::fs::rename(&png, &fake).unwrap();
    let out =
        caustica(&["render", &scene, "-q", "--spp", "1", "--environment", fake.to_str().unwrap(), "-o", o]);
    assert_fails_naming(&out, "not a Radiance HDR");
    assert!(!Path::new(o).exists());
}

/// `--display-server`: a fake tev on a local port receives tev's protocol — a CreateImage of the
/// render's size with channels R, G, B, then UpdateImage (v3) bands of interleaved RGB — and the last
/// updates carry exactly the image written to the file.
#[test]
fn the_live_preview_speaks_tevs_protocol_and_ends_with_the_final_image() {
    use std::io::Read;
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let dir = scratch("tev");
    let target = dir.join("out.exr");
    let child = spawn(&[
        "render",
        &box_scene(),
        "-q",
        "--spp",
        "64",
        "--width",
        "40",
        "--height",
        "100",
        "--display-server",
        &address,
        "-o",
        target.to_str().unwrap(),
    ]);
    let (mut stream, _) = listener.accept().unwrap();
    let mut bytes = Vec::new();
    stream.read_to_end(&mut bytes).unwrap();
    assert!(child.wait_with_output().unwrap().status.success());

    let (mut at, mut packets) = (0usize, Vec::new());
    while at < bytes.len() {
        let size = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        packets.push(&bytes[at + 4..at + size]);
        at += size;
    }
    assert_eq!(at, bytes.len(), "packets end where the stream does");
    struct Reader<'a>(&'a [u8]);
    impl Reader<'_> {
        fn byte(&mut self) -> u8 {
            let b = self.0[0];
            self.0 = &self.0[1..];
            b
        }
        fn string(&mut self) -> String {
            let end = self.0.iter().position(|&b| b == 0).unwrap();
            let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
            self.0 = &self.0[end + 1..];
            s
        }
        fn i32(&mut self) -> i32 {
            let v = i32::from_le_bytes(self.0[..4].try_into().unwrap());
            self.0 = &self.0[4..];
            v
        }
        fn i64(&mut self) -> i64 {
            let v = i64::from_le_bytes(self.0[..8].try_into().unwrap());
            self.0 = &self.0[8..];
            v
        }
    }
    let mut create = Reader(packets[0]);
    assert_eq!(create.byte(), 4, "CreateImage first");
    create.byte();
    let name = create.string();
    assert_eq!((create.i32(), create.i32(), create.i32()), (40, 100, 3));
    assert_eq!([create.string(), create.string(), create.string()], ["R", "G", "B"]);
    let mut shown = vec![f32::NAN; 40 * 100 * 3];
    assert!(packets.len() > 1, "updates follow");
    for packet in &packets[1..] {
        let mut r = Reader(packet);
        assert_eq!(r.byte(), 6, "UpdateImage v3");
        r.byte();
        assert_eq!(r.string(), name);
        assert_eq!(r.i32(), 3);
        assert_eq!([r.string(), r.string(), r.string()], ["R", "G", "B"]);
        let (x, y, w, h) = (r.i32(), r.i32(), r.i32(), r.i32());
        assert!(x == 0 && w == 40 && y >= 0 && h > 0 && y + h <= 100, "band {x} {y} {w} {h}");
        assert_eq!([r.i64(), r.i64(), r.i64(), r.i64(), r.i64(), r.i64()], [0, 1, 2, 3, 3, 3]);
        assert_eq!(r.0.len(), (w * h * 3 * 4) as usize, "interleaved RGB floats");
        for (i, chunk) in r.0.chunks(4).enumerate() {
            shown[(y * w * 3) as usize + i] = f32::from_le_bytes(chunk.try_into().unwrap());
        }
    }
    let written = read_exr(&target).unwrap();
    let expected: Vec<f32> = written.pixels.iter().flat_map(|p| p.to_array()).collect();
    assert!(shown == expected, "the last updates are the final image");
}

/// The bidirectional integrators and `lt` under SIGINT and SIGTERM: the render stops at its next
/// pass, writes a complete image of the passes so far (no temporary left beside it), says so and
/// exits 130. Signalled once its first periodic image is on disk, so that the handler is installed
/// and a pass is under way.
#[test]
fn a_signal_stops_lt_bdpt_and_vcm_and_writes_the_image_so_far() {
    for (integrator, sig) in
        [("lt", "INT"), ("lt", "TERM"), ("bdpt", "INT"), ("bdpt", "TERM"), ("vcm", "INT"), ("vcm", "TERM")]
    {
        let what = format!("{integrator} SIG{sig}");
        let dir = scratch(&format!("signal-{integrator}-{sig}"));
        let target = dir.join("out.exr");
        let mut child = spawn(&[
            "render",
            &box_scene(),
            "-q",
            "--integrator",
            integrator,
            "--spp",
            "1000000",
            "--seed",
            "45",
            "--width",
            "32",
            "--height",
            "32",
            "--write-every",
            "1",
            "-o",
            target.to_str().unwrap(),
        ]);
        while !target.exists() {
            assert!(child.try_wait().unwrap().is_none(), "{what}: ended before its first image");
            std::thread::sleep(Duration::from_millis(20));
        }
        signal(&child, sig);
        let out = child.wait_with_output().unwrap();
        let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert_eq!(out.status.code(), Some(130), "{what}: {stdout}{stderr}");
        assert!(stdout.contains("stopped     by a signal"), "{what}: {stdout}");
        assert!(stderr.contains("stopping") && !stderr.contains("panicked"), "{what}: {stderr}");
        let image = read_exr(&target).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!((image.width, image.height), (32, 32), "{what}");
        assert!(image.pixels.iter().all(|p| p.is_finite()) && image.mean().max_element() > 0.0, "{what}");
        assert!(leftovers(&dir).is_empty(), "{what}: {:?}", leftovers(&dir));
        std::fs::remove_dir_all(&dir).ok();
    }
}

/// A write past the file size limit (`ulimit -f`) raised SIGXFSZ, which killed the process mid-write
/// and left `.NAME.partial` behind. Now it fails as a full disk does: "File too large", a non-zero
/// exit, nothing left beside the output, and the file that was there as it was.
#[test]
fn a_write_past_the_file_size_limit_fails_and_leaves_nothing_behind() {
    let dir = scratch("file-size-limit");
    let target = dir.join("out.exr");
    std::fs::write(&target, b"the previous image").unwrap();
    // `ulimit -f` counts 512-byte blocks: 4 KiB, far under a 64² EXR.
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -f 8; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", &box_scene(), "-q", "--spp", "1", "--width", "64", "--height", "64", "-o"])
        .arg(&target)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a write past the limit succeeded: {stderr}");
    assert!(out.status.code().is_some(), "killed by a signal ({:?}): {stderr}", out.status);
    assert!(stderr.contains("File too large") && stderr.contains("out.exr"), "{stderr}");
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    assert_eq!(std::fs::read(&target).unwrap(), b"the previous image");
    std::fs::remove_dir_all(&dir).ok();
}

/// An output that is a symbolic link is written where the link points, as `cp` and a shell's
/// redirection write through one: the link stays a link (renaming over it replaced it with a file
/// and left the file it pointed to with the old image). And `-o` into a missing folder makes it.
#[test]
fn an_output_through_a_symbolic_link_is_written_where_it_points_and_missing_folders_are_made() {
    let dir = scratch("symlink");
    let real = dir.join("real.exr");
    let link = dir.join("link.exr");
    std::fs::write(&real, b"old").unwrap();
    std::os::unix::fs::symlink("real.exr", &link).unwrap();
    let nested = dir.join("made").join("here").join("out.png");
    let out = caustica(&[
        "render",
        &box_scene(),
        "-q",
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "-o",
        link.to_str().unwrap(),
        "-o",
        nested.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link was replaced");
    let image = read_exr(&real).expect("the image is where the link points");
    assert_eq!((image.width, image.height), (16, 16));
    assert!(nested.is_file(), "the missing folders were not made");
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    std::fs::remove_dir_all(&dir).ok();
}

/// Two signals a moment apart (as `timeout` sends them, to the process and then its group) are one
/// request: the render stops and writes its image as for one, rather than read the second as
/// "quit now" and write nothing.
#[test]
fn signals_that_come_together_are_one_request() {
    let dir = scratch("signals-together");
    let target = dir.join("out.exr");
    let child = spawn(&[
        "render",
        &box_scene(),
        "--spp",
        "1000000",
        "--width",
        "48",
        "--height",
        "48",
        "-o",
        target.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    signal(&child, "INT");
    std::thread::sleep(Duration::from_millis(30));
    signal(&child, "INT");
    let out = child.wait_with_output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(130), "{stdout}{stderr}");
    assert!(!stderr.contains("stopped at once"), "the second signal quit: {stderr}");
    assert!(stdout.contains("stopped     by a signal"), "{stdout}");
    let image = read_exr(&target).expect("the image so far is written");
    assert!(image.pixels.iter().all(|p| p.is_finite()) && image.mean().max_element() > 0.0);
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    std::fs::remove_dir_all(&dir).ok();
}
