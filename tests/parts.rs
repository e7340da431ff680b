//! Partial renders: K shares of the samples, written as accumulators and merged, give the bits of one
//! run; a merge refuses parts that do not make one render, by name.

use crate::common;

use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::film::Film;
use caustica::film::accumulator::{PartInfo, merge_parts, read_part, write_part};
use caustica::scene::fingerprint::fingerprint;
use caustica::scene::{IntegratorKind, RunFile, Scene, load};
use std::path::{Path, PathBuf};

const SPP: u32 = 8;

fn setup(kind: IntegratorKind, seed: u64) -> (Scene, RunFile) {
    let (scene, mut run) = load(&common::data("cornell-spheres.gltf")).expect("test scene loads");
    run.render.integrator = kind;
    run.render.spp = SPP;
    run.render.seed = seed;
    run.photons.photons = 20_000;
    run.photons.caustic_photons = 20_000;
    run.progressive.passes = SPP;
    run.progressive.photons_per_pass = 4096;
    (run.film.width, run.film.height) = (Some(40), Some(30));
    (scene, run)
}

fn whole(kind: IntegratorKind) -> Film {
    init_thread_pools(None);
    let (scene, run) = setup(kind, 7);
    let mut renderer = Renderer::new(scene, &run).expect("prepares");
    renderer.run(None, |_| {});
    renderer.film().clone()
}

/// Render share `i` of `k` and write its accumulator into `dir`.
fn part(kind: IntegratorKind, seed: u64, i: u32, k: u32, dir: &Path) -> PathBuf {
    part_with_chunk(kind, seed, i, k, dir, None)
}

/// [`part`] with shards of `chunk` paths (the run file's default without).
fn part_with_chunk(
    kind: IntegratorKind,
    seed: u64,
    i: u32,
    k: u32,
    dir: &Path,
    chunk: Option<u32>,
) -> PathBuf {
    init_thread_pools(None);
    let (scene, mut run) = setup(kind, seed);
    if let Some(chunk) = chunk {
        run.render.chunk = chunk;
    }
    let info = PartInfo {
        fingerprint: fingerprint(&scene, &run),
        integrator: format!("{kind:?}"),
        part: i,
        parts: k,
        samples: PartInfo::share(i, k, SPP),
        spp: SPP,
        per_unit: 1,
    };
    let mut renderer = Renderer::new(scene, &run).expect("prepares");
    renderer.set_samples(info.samples.clone()).expect("a sample integrator splits");
    renderer.run(None, |_| {});
    let path = dir.join(format!("part-{i}-of-{k}-seed-{seed}.exr"));
    write_part(renderer.film(), &info, &path).expect("writes");
    path
}

fn assert_same_bits(a: &Film, b: &Film, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for i in 0..a.width * a.height {
        assert_eq!(a.sums(i), b.sums(i), "{what}: pixel {i}");
    }
    assert_eq!(a.image(), b.image(), "{what}: images");
}

fn four_parts_merge_into_one_run(kind: IntegratorKind) {
    let dir = tempfile::tempdir().unwrap();
    let parts: Vec<PathBuf> = (1..=4).map(|i| part(kind, 7, i, 4, dir.path())).collect();
    let one_run = whole(kind);
    let (merged, info) = merge_parts(&parts).expect("the four parts merge");
    assert_eq!((info.samples, info.spp), (0..SPP, SPP));
    assert_same_bits(&merged, &one_run, &format!("{kind:?}, parts 1..4"));
    let shuffled = [&parts[2], &parts[0], &parts[3], &parts[1]];
    assert_same_bits(&merge_parts(&shuffled).unwrap().0, &one_run, &format!("{kind:?}, parts 3, 1, 4, 2"));
}

/// The chunk size never changes the bits, so parts made with different ones merge into the bits of
/// one run (it is left out of the fingerprint that refuses foreign parts).
#[test]
fn parts_made_with_other_chunk_sizes_merge() {
    let dir = tempfile::tempdir().unwrap();
    let parts: Vec<PathBuf> = [(1, 1024), (2, 4096), (3, 333), (4, 64)]
        .map(|(i, c)| part_with_chunk(IntegratorKind::Pt, 7, i, 4, dir.path(), Some(c)))
        .to_vec();
    let (merged, _) = merge_parts(&parts).expect("parts of other chunk sizes merge");
    assert_same_bits(&merged, &whole(IntegratorKind::Pt), "pt, parts with chunks 1024, 4096, 333, 64");
}

#[test]
fn pt_parts_merge_into_the_bits_of_one_run_in_any_order() {
    four_parts_merge_into_one_run(IntegratorKind::Pt);
}

#[test]
fn pm_parts_merge_into_the_bits_of_one_run_in_any_order() {
    four_parts_merge_into_one_run(IntegratorKind::Pm);
}

#[test]
fn pppm_parts_merge_into_the_bits_of_one_run_in_any_order() {
    four_parts_merge_into_one_run(IntegratorKind::Pppm);
}

#[test]
fn lt_parts_merge_into_the_bits_of_one_run_in_any_order() {
    four_parts_merge_into_one_run(IntegratorKind::Lt);
}

#[test]
fn bdpt_parts_merge_into_the_bits_of_one_run_in_any_order() {
    four_parts_merge_into_one_run(IntegratorKind::Bdpt);
}

#[test]
fn vcm_parts_merge_into_the_bits_of_one_run_in_any_order() {
    four_parts_merge_into_one_run(IntegratorKind::Vcm);
}

#[test]
fn pt_naive_parts_merge_into_the_bits_of_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let parts: Vec<PathBuf> = (1..=3).map(|i| part(IntegratorKind::PtNaive, 7, i, 3, dir.path())).collect();
    assert_same_bits(&merge_parts(&parts).unwrap().0, &whole(IntegratorKind::PtNaive), "pt-naive, 3 parts");
}

#[test]
fn a_missing_a_duplicate_or_a_foreign_part_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let parts: Vec<PathBuf> = (1..=4).map(|i| part(IntegratorKind::Pt, 7, i, 4, dir.path())).collect();
    let message = |paths: &[&PathBuf]| merge_parts(paths).expect_err("refused").to_string();

    let missing = message(&[&parts[0], &parts[3]]);
    assert!(missing.contains("missing parts 2/4, 3/4"), "{missing}");

    let twice = message(&[&parts[0], &parts[1], &parts[1], &parts[2], &parts[3]]);
    assert!(twice.contains("part 2/4 is given twice") && twice.contains("part-2-of-4"), "{twice}");

    let foreign = part(IntegratorKind::Pt, 8, 3, 4, dir.path());
    let mixed = message(&[&parts[0], &parts[1], &foreign, &parts[3]]);
    assert!(mixed.contains("part-3-of-4-seed-8.exr") && mixed.contains("fingerprint"), "{mixed}");

    let other_split = part(IntegratorKind::Pt, 7, 2, 3, dir.path());
    let split = message(&[&parts[0], &other_split]);
    assert!(split.contains("part-2-of-3") && split.contains("split"), "{split}");
}

#[test]
fn an_ordinary_image_or_a_truncated_accumulator_is_not_read_as_a_part() {
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("image.exr");
    caustica::film::output::write_image(&whole(IntegratorKind::Pt).image(), &image, 0.0).unwrap();
    let e = read_part(&image).expect_err("an image is not an accumulator").to_string();
    assert!(e.contains("image.exr") && e.contains("not a caustica accumulator"), "{e}");

    let good = part(IntegratorKind::Pt, 7, 1, 2, dir.path());
    let bytes = std::fs::read(&good).unwrap();
    let cut = dir.path().join("cut.exr");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = read_part(&cut).expect_err("truncated").to_string();
    assert!(e.contains("cut.exr"), "{e}");
}

#[test]
fn progressive_integrators_and_learned_light_selection_refuse_to_split() {
    init_thread_pools(None);
    let (scene, mut run) = setup(IntegratorKind::Sppm, 7);
    run.progressive.passes = 4;
    let mut renderer = Renderer::new(scene, &run).unwrap();
    let e = renderer.set_samples(0..2).expect_err("sppm's passes chain").to_string();
    assert!(e.contains("part") && e.contains("progressive"), "{e}");

    let (scene, mut run) = setup(IntegratorKind::Pt, 7);
    run.render.light_selection = caustica::scene::LightSelection::Visibility;
    let mut renderer = Renderer::new(scene, &run).unwrap();
    let e = renderer.set_samples(0..2).expect_err("visibility learns from the first samples").to_string();
    assert!(e.contains("visibility"), "{e}");
}

/// The command line end to end: `render --part` twice, `merge`, and the merged EXR is byte for byte
/// the one a whole `render` writes, on a different thread count.
#[test]
fn the_command_line_splits_and_merges_to_the_same_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::data("cornell-box.gltf");
    let render = |extra: &[&str], out: &Path| {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
            .arg("render")
            .arg(&scene)
            .args(["--spp", "6", "--width", "24", "--height", "24", "--quiet", "-o"])
            .arg(out)
            .args(extra)
            .status()
            .unwrap();
        assert!(status.success(), "caustica render {extra:?}");
    };
    let (a, b, whole) = (dir.path().join("a.exr"), dir.path().join("b.exr"), dir.path().join("whole.exr"));
    render(&["--part", "2/2", "--threads", "1"], &b);
    render(&["--part", "1/2", "--threads", "2"], &a);
    render(&["--threads", "3"], &whole);
    // The same share is the same bytes in another process (the header's entries once came out in the
    // order of a HashMap, which differs process to process).
    let again = dir.path().join("a-again.exr");
    render(&["--part", "1/2", "--threads", "1"], &again);
    assert_eq!(
        std::fs::read(&again).unwrap(),
        std::fs::read(&a).unwrap(),
        "a part's bytes differ run to run"
    );
    let merged = dir.path().join("merged.exr");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["merge"])
        .args([&b, &a])
        .arg("-o")
        .arg(&merged)
        .output()
        .unwrap();
    assert!(output.status.success(), "merge: {}", String::from_utf8_lossy(&output.stderr));
    assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&whole).unwrap());

    let output = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["merge"])
        .arg(&a)
        .arg("-o")
        .arg(dir.path().join("never.exr"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && stderr.contains("missing part 2/2"), "{stderr}");
    assert!(!dir.path().join("never.exr").exists());
}

/// Headers that claim more than a merge can hold are refused before anything that size is
/// allocated: four billion shares (a slot per share was 32 GB, the list of missing ones more), and a
/// part whose data window claims 100 000 × 100 000 pixels in a file of a few kilobytes (400 GB).
#[test]
fn claimed_sizes_are_checked_before_anything_that_size_is_allocated() {
    let dir = tempfile::tempdir().unwrap();
    let part = dir.path().join("p.exr");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"))
        .arg("render")
        .arg(common::data("cornell-box.gltf"))
        .args([
            "--spp",
            "4000000000",
            "--part",
            "1/4000000000",
            "--width",
            "8",
            "--height",
            "8",
            "--quiet",
            "-o",
        ])
        .arg(&part)
        .status()
        .unwrap();
    assert!(status.success());
    let message = caustica::film::accumulator::merge_parts(&[&part]).unwrap_err().to_string();
    assert!(message.contains("2/4000000000") && message.contains("3999999989 more"), "{message}");

    // The data window (box2i: x min, y min, x max, y max) made 100 000 pixels square.
    let mut bytes = std::fs::read(&part).unwrap();
    let name = b"dataWindow\0box2i\0";
    let at = bytes.windows(name.len()).position(|w| w == name).unwrap() + name.len() + 4;
    for (i, value) in [0i32, 0, 99_999, 99_999].iter().enumerate() {
        bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&value.to_le_bytes());
    }
    let huge = dir.path().join("huge.exr");
    std::fs::write(&huge, bytes).unwrap();
    let message = caustica::film::accumulator::merge_parts(&[&huge]).unwrap_err().to_string();
    assert!(message.contains("huge.exr") && message.contains("10000000000 pixels"), "{message}");
}
