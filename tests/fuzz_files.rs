//! Fuzzing the files a render reads back: checkpoints (`--resume`) and parts (`caustica merge`),
//! mutated field by field — every header entry removed or given a hostile value, every layer renamed,
//! every channel removed or retyped — and byte by byte (a flipped bit, a byte overwritten, the file
//! cut short). The real binary either refuses the file with a message naming it (exit 1), or gives
//! exactly the image of the render the file came from; never a panic, an abort or a wrong image.
//!
//! Each case runs the binary (a debug build under `cargo test`). The sweep covers one integrator of
//! each kind of state (`pt`: the film alone; `sppm`: hit points; `ppm`: hit points with their hits),
//! and `lt`, `bdpt` and `vcm` (splats from the lights) in tests of their own;
//! `CAUSTICA_FUZZ_FILES=all` sweeps every other integrator too, `CAUSTICA_FUZZ_BYTES=N` sets the
//! byte-level cases a file. A refused checkpoint must be left as it was, with no output written.

use caustica::film::output::read_exr;
use exr::prelude::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Hostile values for a header entry: empty, zero, negative, past u32, not numbers, ranges and
/// shares the wrong way round or beyond the render, a long text.
const VALUES: &[&str] =
    &["", "0", "-1", "4294967296", "NaN", "0/0", "2/1", "3..1", "0..4294967295", "0..1", "x"];

/// Byte-level cases a file unless `CAUSTICA_FUZZ_BYTES` says otherwise.
const DEFAULT_BYTE_CASES: usize = 24;

fn binary() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_caustica"));
    command.current_dir(env!("CARGO_MANIFEST_DIR"));
    command
}

/// A render of the test scene at 12×12: `integrator` with its unit flag set to `units`, and `more`.
fn render(dir: &Path, integrator: &str, units: u32, more: &[&str]) -> Output {
    let unit = caustica::integrators::ALL
        .iter()
        .find(|i| i.name() == integrator)
        .expect("an integrator")
        .units_key();
    let unit = format!("--{unit}");
    binary()
        .args([
            "render",
            concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-spheres.gltf"),
            "--width",
            "12",
            "--height",
            "12",
            "-q",
        ])
        .args(["--integrator", integrator, &unit, &units.to_string()])
        .args(["--photons", "3000", "--caustic-photons", "500", "--photons-per-pass", "2000"])
        .args(["--hit-points-per-pixel", "2"])
        .args(more)
        .current_dir(dir)
        .output()
        .expect("caustica runs")
}

fn succeeded(out: &Output) -> &Output {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

/// A file's mutations: (what was done, the mutated file's bytes), or `None` where the EXR writer
/// cannot write the mutation (it checks channel lengths against the layer's size).
fn field_mutations(original: &Path) -> Vec<(String, Option<Vec<u8>>)> {
    let image = read_all_flat_layers_from_file(original).expect("the original reads");
    let mut cases = Vec::new();
    let mut emit = |what: String, image: &FlatImage| {
        let mut bytes = std::io::Cursor::new(Vec::new());
        let written = image.write().non_parallel().to_buffered(&mut bytes).ok().map(|_| bytes.into_inner());
        cases.push((what, written));
    };
    for (l, layer) in image.layer_data.iter().enumerate() {
        let name = layer.attributes.layer_name.as_ref().map_or(String::new(), |n| n.to_string());
        let mut mutated = image.clone();
        mutated.layer_data[l].attributes.layer_name = Some(Text::from("x"));
        emit(format!("layer {name} renamed x"), &mutated);
        let mut mutated = image.clone();
        mutated.layer_data.remove(l);
        if !mutated.layer_data.is_empty() {
            emit(format!("layer {name} removed"), &mutated);
        }
        // The layer's entries: one list attribute of key=value texts.
        for (attribute, value) in &layer.attributes.other {
            let AttributeValue::TextVector(entries) = value else { continue };
            for (i, entry) in entries.iter().enumerate() {
                let entry = entry.to_string();
                let key = entry.split_once('=').map_or(entry.as_str(), |(k, _)| k).to_owned();
                let mut with = |what: String, list: Vec<Text>| {
                    let mut mutated = image.clone();
                    mutated.layer_data[l]
                        .attributes
                        .other
                        .insert(attribute.clone(), AttributeValue::TextVector(list));
                    emit(format!("{name}: {what}"), &mutated);
                };
                let mut removed = entries.clone();
                removed.remove(i);
                with(format!("entry {key} removed"), removed);
                for value in VALUES.iter().copied().chain([&*"9".repeat(2000)]) {
                    let mut changed = entries.clone();
                    changed[i] = Text::from(format!("{key}={value}").as_str());
                    let shown: String = value.chars().take(12).collect();
                    with(format!("{key}={shown}"), changed);
                }
            }
            let mut mutated = image.clone();
            mutated.layer_data[l]
                .attributes
                .other
                .insert(attribute.clone(), AttributeValue::Text(Text::from("x")));
            emit(format!("{name}: entries as one text"), &mutated);
        }
        for (c, channel) in layer.channel_data.list.iter().enumerate() {
            let channel_name = channel.name.to_string();
            let mut mutated = image.clone();
            mutated.layer_data[l].channel_data.list.remove(c);
            emit(format!("{name}: channel {channel_name} removed"), &mutated);
            let mut mutated = image.clone();
            let samples = &mut mutated.layer_data[l].channel_data.list[c].sample_data;
            *samples = match samples {
                FlatSamples::U32(words) => {
                    FlatSamples::F32(words.iter().map(|&w| f32::from_bits(w)).collect())
                }
                FlatSamples::F32(values) => FlatSamples::U32(values.iter().map(|v| v.to_bits()).collect()),
                FlatSamples::F16(values) => {
                    FlatSamples::U32(values.iter().map(|v| v.to_bits() as u32).collect())
                }
            };
            emit(format!("{name}: channel {channel_name} retyped"), &mutated);
        }
    }
    cases
}

/// Byte-level mutations of `bytes`, from a fixed seed: a flipped bit, a byte set, the file cut.
fn byte_mutations(bytes: &[u8], cases: usize, seed: u64) -> Vec<(String, Option<Vec<u8>>)> {
    let mut state = seed | 1;
    let mut next = move || {
        // xorshift64*: a fixed sequence with no dependency.
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        state.wrapping_mul(0x2545_f491_4f6c_dd1d)
    };
    (0..cases)
        .map(|_| {
            let at = next() as usize % bytes.len();
            let mut mutated = bytes.to_vec();
            let what = match next() % 3 {
                0 => {
                    let bit = next() % 8;
                    mutated[at] ^= 1 << bit;
                    format!("bit {bit} of byte {at} flipped")
                }
                1 => {
                    let byte = next() as u8;
                    mutated[at] = byte;
                    format!("byte {at} set to {byte}")
                }
                _ => {
                    mutated.truncate(at);
                    format!("cut at {at} bytes")
                }
            };
            (what, Some(mutated))
        })
        .collect()
}

fn byte_cases() -> usize {
    std::env::var("CAUSTICA_FUZZ_BYTES").ok().and_then(|n| n.parse().ok()).unwrap_or(DEFAULT_BYTE_CASES)
}

/// Check one outcome: a refusal naming `file`, or success with `expected`'s pixels in `output`.
fn check(what: &str, out: &Output, file: &str, output: &Path, expected: &caustica::film::Image) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{what}: panic: {stderr}");
    match out.status.code() {
        Some(0) => {
            let got = read_exr(output).unwrap_or_else(|e| panic!("{what}: exit 0 but the image: {e}"));
            assert!(got == *expected, "{what}: exit 0 with another image than the render it came from");
        }
        Some(1) => assert!(stderr.contains(file), "{what}: the error does not name {file}: {stderr}"),
        code => panic!("{what}: exit {code:?}: {stderr}"),
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-fuzz-files-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A checkpoint of two of three units, mutated, and resumed to three: the whole render's image or a
/// refusal naming the checkpoint.
fn fuzz_checkpoints(integrator: &str) -> (usize, usize) {
    let dir = scratch(integrator);
    succeeded(&render(&dir, integrator, 3, &["-o", "whole.exr"]));
    let whole = read_exr(&dir.join("whole.exr")).unwrap();
    succeeded(&render(&dir, integrator, 2, &["--checkpoint", "ck.exr", "-o", "first.exr"]));
    let original = std::fs::read(dir.join("ck.exr")).unwrap();
    // The unmutated checkpoint resumes to the whole render: the property below is not vacuous.
    let out = render(&dir, integrator, 3, &["--resume", "ck.exr", "-o", "resumed.exr"]);
    check("unmutated", succeeded(&out), "ck.exr", &dir.join("resumed.exr"), &whole);
    let mut cases = field_mutations(&dir.join("ck.exr"));
    cases.extend(byte_mutations(&original, byte_cases(), integrator.len() as u64 * 7919));
    let (mut run, mut unwritable) = (0, 0);
    for (what, bytes) in cases {
        let Some(bytes) = bytes else {
            unwritable += 1;
            continue;
        };
        std::fs::write(dir.join("case.exr"), &bytes).unwrap();
        let _ = std::fs::remove_file(dir.join("out.exr"));
        let out = render(&dir, integrator, 3, &["--resume", "case.exr", "-o", "out.exr"]);
        let what = format!("{integrator} checkpoint, {what}");
        check(&what, &out, "case.exr", &dir.join("out.exr"), &whole);
        // A refused checkpoint is left as it was, and nothing is written in its name.
        if !out.status.success() {
            assert!(!dir.join("out.exr").exists(), "{what}: refused, but an output was written");
            assert!(
                std::fs::read(dir.join("case.exr")).unwrap() == bytes,
                "{what}: the checkpoint was changed"
            );
        }
        run += 1;
    }
    let _ = std::fs::remove_dir_all(&dir);
    (run, unwritable)
}

/// Every integrator from the registry but the light-path ones, which have a test each below.
fn integrators() -> Vec<&'static str> {
    if std::env::var("CAUSTICA_FUZZ_FILES").is_ok_and(|v| v == "all") {
        caustica::integrators::ALL
            .iter()
            .map(|i| i.name())
            .filter(|name| !matches!(*name, "lt" | "bdpt" | "vcm"))
            .collect()
    } else {
        vec!["pt", "sppm", "ppm"]
    }
}

/// The bidirectional integrators' and `lt`'s checkpoints (the film alone, splatted from the lights)
/// field by field and byte by byte, one test each so that each stays within the time limit.
fn fuzz_one(integrator: &str) {
    let (run, unwritable) = fuzz_checkpoints(integrator);
    assert!(run > 100, "{integrator}: only {run} mutations ran ({unwritable} not writable)");
}

#[test]
fn mutated_lt_checkpoints_resume_to_the_same_bits_or_are_refused_naming_the_file() {
    fuzz_one("lt");
}

#[test]
fn mutated_bdpt_checkpoints_resume_to_the_same_bits_or_are_refused_naming_the_file() {
    fuzz_one("bdpt");
}

#[test]
fn mutated_vcm_checkpoints_resume_to_the_same_bits_or_are_refused_naming_the_file() {
    fuzz_one("vcm");
}

#[test]
fn mutated_checkpoints_resume_to_the_same_bits_or_are_refused_naming_the_file() {
    for integrator in integrators() {
        let (run, unwritable) = fuzz_checkpoints(integrator);
        eprintln!(
            "{integrator} checkpoints: {run} mutations resumed or refused ({unwritable} not writable as EXR)"
        );
    }
}

#[test]
fn mutated_parts_merge_to_the_same_bits_or_are_refused_naming_the_file() {
    let dir = scratch("merge");
    for (i, name) in ["p1.exr", "p2.exr"].iter().enumerate() {
        succeeded(&render(&dir, "pt", 4, &["--part", &format!("{}/2", i + 1), "-o", name]));
    }
    let merge = |first: &str, output: &str| {
        binary()
            .args(["merge", first, "p2.exr", "-o", output])
            .current_dir(&dir)
            .output()
            .expect("caustica runs")
    };
    succeeded(&merge("p1.exr", "whole.exr"));
    let whole = read_exr(&dir.join("whole.exr")).unwrap();
    let original = std::fs::read(dir.join("p1.exr")).unwrap();
    let mut cases = field_mutations(&dir.join("p1.exr"));
    cases.extend(byte_mutations(&original, byte_cases(), 104_729));
    let mut run = 0;
    for (what, bytes) in cases {
        let Some(bytes) = bytes else { continue };
        std::fs::write(dir.join("case.exr"), bytes).unwrap();
        let _ = std::fs::remove_file(dir.join("out.exr"));
        check(
            &format!("part, {what}"),
            &merge("case.exr", "out.exr"),
            "case.exr",
            &dir.join("out.exr"),
            &whole,
        );
        run += 1;
    }
    eprintln!("parts: {run} mutations merged or refused");
    let _ = std::fs::remove_dir_all(&dir);
}
