//! Fuzzing as a property test: generated and mutated run files and glTF files either load and render
//! (tiny) to an image of finite pixels, or fail with an error naming the file; never a panic or a hang.
//!
//! Deterministic: proptest's default seed is replaced by a fixed one and no failures are persisted,
//! so CI runs the same cases every time. `PROPTEST_CASES=N cargo test --test integration fuzz::` runs more.

use crate::common;

use caustica::film::Image;
use caustica::scene::{RunFile, load, validate};
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

/// Cases per property unless PROPTEST_CASES says otherwise; a few seconds in all in the test profile.
const DEFAULT_CASES: u32 = 2000;
/// Longest a case may take (load + tiny render) before it counts as a hang.
const MAX_SECONDS: f64 = 10.0;

fn runner() -> TestRunner {
    common::fuzz_runner(DEFAULT_CASES)
}

/// The settings a case may not raise: the image is 8×8 at 1 spp with few photons and bounded paths,
/// so a case stays in the milliseconds whatever the file asks for (what is fuzzed is parsing,
/// loading and the renderer's handling of the scene, not its running time).
fn bound_settings(run: &mut RunFile) {
    run.film.width = Some(8);
    run.film.height = Some(8);
    run.render.spp = 1;
    run.render.time_limit = None;
    run.render.rr_depth = run.render.rr_depth.min(8);
    run.render.max_depth = Some(run.render.max_depth.unwrap_or(16).min(16));
    run.photons.photons = run.photons.photons.min(2000);
    run.photons.caustic_photons = run.photons.caustic_photons.min(2000);
    run.photons.k = run.photons.k.min(64);
    run.photons.final_gather = run.photons.final_gather.min(1);
    run.progressive.passes = run.progressive.passes.min(2);
    run.progressive.photons_per_pass = run.progressive.photons_per_pass.min(2000);
}

fn check_image(image: &Image, what: &str) -> Result<(), TestCaseError> {
    prop_assert_eq!(image.pixels.len(), 64, "{}: image size", what);
    for p in &image.pixels {
        prop_assert!(p.is_finite() && p.min_element() >= 0.0, "{}: pixel {}", what, p);
    }
    Ok(())
}

/// An error must name one of `files` (by file name), or be a setting error naming the key.
fn check_error(message: &str, files: &[&Path]) -> Result<(), TestCaseError> {
    let named = files.iter().any(|f| message.contains(&*f.file_name().unwrap().to_string_lossy()));
    prop_assert!(named || message.starts_with("invalid setting "), "error names no file: {}", message);
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Run files
// ---------------------------------------------------------------------------------------------

/// The real tables and keys of `src/scene/run_file.rs`, with value kinds.
const KEYS: &[(&str, &[(&str, Kind)])] = &[
    (
        "render",
        &[
            ("integrator", Kind::Integrator),
            ("spp", Kind::Number),
            ("seed", Kind::Number),
            ("max_depth", Kind::Number),
            ("rr_depth", Kind::Number),
            ("light_selection", Kind::Word(&["uniform", "power", "tree", "visibility", "best"])),
            ("sampler", Kind::Word(&["sobol", "independent", "halton"])),
            ("time_limit", Kind::Number),
            ("memory_budget_mib", Kind::Number),
        ],
    ),
    (
        "film",
        &[
            ("width", Kind::Number),
            ("height", Kind::Number),
            ("filter", Kind::Word(&["box", "tent", "gaussian", "mitchell"])),
            ("exposure", Kind::Number),
        ],
    ),
    (
        "camera",
        &[
            ("name", Kind::Word(&["Camera", "", "no such camera"])),
            ("eye", Kind::Vec3),
            ("target", Kind::Vec3),
            ("up", Kind::Vec3),
            ("yfov_degrees", Kind::Number),
            ("aperture_radius", Kind::Number),
            ("focus_distance", Kind::Number),
            ("shutter", Kind::Vec2),
        ],
    ),
    (
        "photons",
        &[
            ("photons", Kind::Number),
            ("caustic_photons", Kind::Number),
            ("k", Kind::Number),
            ("max_radius", Kind::Number),
            ("kernel", Kind::Word(&["uniform", "cone", "epanechnikov", "biweight", "gaussian", "box"])),
            ("final_gather", Kind::Number),
        ],
    ),
    (
        "progressive",
        &[
            ("passes", Kind::Number),
            ("photons_per_pass", Kind::Number),
            ("alpha", Kind::Number),
            ("initial_radius", Kind::Number),
            ("memory_budget_mib", Kind::Number),
            ("hit_points_per_pixel", Kind::Number),
        ],
    ),
    (
        "[sphere]",
        &[
            ("name", Kind::Word(&["ball", ""])),
            ("center", Kind::Vec3),
            ("radius", Kind::Number),
            ("material", Kind::Material),
            ("motion", Kind::Vec3),
        ],
    ),
    ("[motion]", &[("node", Kind::Word(&["short_block", "tall_block", "nope"])), ("translate", Kind::Vec3)]),
    (
        "[light]",
        &[
            ("type", Kind::Word(&["point", "spot", "sun", "area"])),
            ("intensity", Kind::Number),
            ("name", Kind::Word(&["lamp", ""])),
            ("position", Kind::Vec3),
            ("direction", Kind::Vec3),
            ("target", Kind::Vec3),
            ("color", Kind::Vec3),
            ("inner_cone_degrees", Kind::Number),
            ("outer_cone_degrees", Kind::Number),
        ],
    ),
    (
        "environment",
        &[
            (
                "file",
                Kind::Word(&[concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/sky.exr"), "missing.exr", ""]),
            ),
            ("color", Kind::Vec3),
            ("strength", Kind::Number),
            ("rotation_degrees", Kind::Vec3),
        ],
    ),
];

#[derive(Clone, Copy)]
enum Kind {
    Number,
    Word(&'static [&'static str]),
    /// A registered integrator's name, or now and then one that is not.
    Integrator,
    Vec2,
    Vec3,
    Material,
}

/// Numbers that break things: NaN, infinities, negatives, zero, huge, tiny, past u32 and u64.
const NUMBERS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1",
    "2",
    "3",
    "0.5",
    "0.0001",
    "1e-30",
    "1e30",
    "-1e30",
    "64",
    "1000",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "-0.0",
    "1e6",
];
/// Ordinary values, so that most generated files get past parsing to loading and rendering.
const SANE_NUMBERS: &[&str] = &["0", "1", "2", "0.5", "0.25", "3", "8", "0.9", "1.5", "100"];
const MATERIAL_KEYS: &[&str] = &[
    "base_color",
    "metallic",
    "roughness",
    "transmission",
    "ior",
    "specular",
    "emission",
    "glow",
    "clearcoat",
    "clearcoat_roughness",
    "attenuation_color",
    "attenuation_distance",
];
const GLTFS: &[&str] =
    &["cornell-box.gltf", "gltf-samples/Box.gltf", "gltf-samples/Cameras.gltf", "missing.gltf"];

/// A value of `kind` from the choice numbers `c`.
fn value(kind: Kind, c: &[u16; 4]) -> String {
    let list = if c[3].is_multiple_of(3) { NUMBERS } else { SANE_NUMBERS };
    let n = |i: usize| list[c[i] as usize % list.len()].to_owned();
    match (c[3] % 16, kind) {
        // Now and then a value of the wrong type.
        (0, _) => ["\"text\"", "true", "[]", "{ a = 1 }"][c[0] as usize % 4].to_owned(),
        (_, Kind::Number) => n(0),
        (_, Kind::Word(words)) => format!("\"{}\"", words[c[0] as usize % words.len()]),
        (_, Kind::Integrator) => {
            let words: Vec<&str> = caustica::integrators::names().chain(["PT", "bdpt2"]).collect();
            format!("\"{}\"", words[c[0] as usize % words.len()])
        }
        (_, Kind::Vec2) => format!("[{}, {}]", n(0), n(1)),
        (_, Kind::Vec3) => format!("[{}, {}, {}]", n(0), n(1), n(2)),
        (_, Kind::Material) => {
            let key = MATERIAL_KEYS[c[0] as usize % MATERIAL_KEYS.len()];
            let v = if key == "base_color" || key == "emission" || key == "attenuation_color" {
                format!("[{}, {}, {}]", n(1), n(2), n(1))
            } else {
                n(1)
            };
            format!("{{ {key} = {v}, emission = [{}, 1.0, 1.0] }}", n(2))
        }
    }
}

/// Run-file text from entries (table, key, value choices), grouped into their tables, with an
/// optional `gltf` line, then mutated byte-wise by `edits` (position, byte).
fn run_file_text(gltf: Option<usize>, entries: &[(u16, u16, [u16; 4])], edits: &[(u16, u8)]) -> String {
    let mut text = String::new();
    if let Some(g) = gltf {
        text += &format!("gltf = \"{}\"\n", GLTFS[g % GLTFS.len()]);
    }
    for (t, (table, keys)) in KEYS.iter().enumerate() {
        let mine: Vec<_> = entries.iter().filter(|(et, _, _)| *et as usize % KEYS.len() == t).collect();
        if mine.is_empty() {
            continue;
        }
        if table.starts_with('[') {
            // Each entry is one array element with its required keys and one more.
            for (_, k, c) in mine {
                text += &format!("[{table}]\n");
                let (key, kind) = keys[*k as usize % keys.len()];
                let required: &[usize] = if *table == "[sphere]" { &[1, 2] } else { &[0, 1] };
                for &r in required {
                    if keys[r].0 != key {
                        text +=
                            &format!("{} = {}\n", keys[r].0, value(keys[r].1, &[c[1], c[2], c[0], c[3] | 1]));
                    }
                }
                text += &format!("{key} = {}\n", value(kind, c));
            }
        } else {
            text += &format!("[{table}]\n");
            let mut seen = Vec::new();
            for (_, k, c) in mine {
                let (key, kind) = keys[*k as usize % keys.len()];
                if !seen.contains(&key) {
                    seen.push(key);
                    text += &format!("{key} = {}\n", value(kind, c));
                }
            }
        }
    }
    let mut bytes = text.into_bytes();
    for &(at, byte) in edits {
        if bytes.is_empty() {
            break;
        }
        let at = at as usize % bytes.len();
        match byte % 3 {
            0 => bytes[at] = byte,
            1 => drop(bytes.remove(at)),
            _ => bytes.insert(at, byte),
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// The run file `parse` makes, as if read from `path`, loaded and rendered (tiny), timed and counted.
fn render_run_file(
    path: &Path,
    parse: impl FnOnce() -> Result<RunFile, String>,
) -> (Result<Image, String>, f64) {
    let start = Instant::now();
    let outcome = (|| -> Result<Image, String> {
        let mut run = parse()?;
        let mut scene = run.load_scene(path).map_err(|e| e.to_string())?;
        validate(&mut scene, path).map_err(|e| e.to_string())?;
        bound_settings(&mut run);
        common::try_render(scene, &run)
    })();
    count(&outcome);
    (outcome, start.elapsed().as_secs_f64())
}

fn run_file_case(text: &str) -> Result<(), TestCaseError> {
    let path = common::data("fuzz-run.toml");
    let (outcome, seconds) =
        render_run_file(&path, || RunFile::parse(text, &path).map_err(|e| e.to_string()));
    prop_assert!(seconds < MAX_SECONDS, "took {} s", seconds);
    match outcome {
        Ok(image) => check_image(&image, "run file"),
        Err(message) => {
            let mut files: Vec<&Path> = GLTFS.iter().map(|g| Path::new(*g)).collect();
            files.push(&path);
            check_error(&message, &files)
        }
    }
}

fn run_file_strategy() -> impl Strategy<Value = String> {
    (
        proptest::option::of(0usize..GLTFS.len()),
        proptest::collection::vec((any::<u16>(), any::<u16>(), any::<[u16; 4]>()), 0..8),
        // Byte edits in a quarter of the cases: most should stay TOML and reach the loader.
        prop_oneof![3 => Just(Vec::new()), 1 => proptest::collection::vec((any::<u16>(), any::<u8>()), 1..3)],
    )
        .prop_map(|(gltf, entries, edits)| run_file_text(gltf, &entries, &edits))
}

#[test]
fn generated_run_files_render_or_fail_with_a_message_naming_the_file() {
    let start = Instant::now();
    let mut runner = runner();
    let result = runner.run(&run_file_strategy(), |text| run_file_case(&text));
    eprintln!(
        "run files: {} cases in {:.1} s (all fuzz tests so far: {})",
        runner.config().cases,
        start.elapsed().as_secs_f64(),
        summary()
    );
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// Arbitrary bytes, mostly not TOML at all.
#[test]
fn random_bytes_as_a_run_file_fail_cleanly() {
    let mut runner = runner();
    let strategy = proptest::collection::vec(any::<u8>(), 0..200);
    let result = runner.run(&strategy, |bytes| run_file_case(&String::from_utf8_lossy(&bytes)));
    if let Err(e) = result {
        panic!("{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// --set (the command's and Python's run-file overrides)
// ---------------------------------------------------------------------------------------------

/// The run file `--set` writes into: a glTF, and the tables it may or may not already have.
const SET_BASE: &str = "gltf = \"cornell-box.gltf\"\n[render]\nspp = 1\n";

/// Key segments: the real tables and keys, and what breaks a dotted key (empty parts, spaces,
/// quotes, brackets, `=`, non-ASCII).
const SEGMENTS: &[&str] = &[
    "render",
    "film",
    "photons",
    "progressive",
    "camera",
    "environment",
    "sphere",
    "light",
    "schedule",
    "spp",
    "width",
    "k",
    "passes",
    "eye",
    "",
    " ",
    "\"",
    "[",
    "]",
    "=",
    "#",
    "ü",
    "a b",
    "0",
    "-1",
];

/// `--set` assignments as a string list, applied to [`SET_BASE`], loaded and rendered (tiny): an
/// image of finite pixels, or an error that names the assignment (`--set …`), the run file or a
/// setting.
fn set_case(sets: &[String]) -> Result<(), TestCaseError> {
    let path = common::data("fuzz-set.toml");
    let (outcome, seconds) = render_run_file(&path, || RunFile::parse_with_sets(SET_BASE, sets));
    prop_assert!(seconds < MAX_SECONDS, "took {} s: {:?}", seconds, sets);
    match outcome {
        Ok(image) => check_image(&image, "--set"),
        Err(message) if message.starts_with("--set ") || message.contains("(after --set") => Ok(()),
        Err(message) => check_error(&message, &[&path, Path::new("cornell-box.gltf")]),
    }
}

/// Every key of every single table, alone, with every number that breaks things and a value of each
/// wrong type.
#[test]
fn every_set_key_with_every_hostile_value_renders_or_names_the_assignment() {
    let start = Instant::now();
    let wrong_types = ["\"text\"", "true", "[]", "{ a = 1 }", "", "[1, [2]]", "\"\u{0}\""];
    let mut cases = 0;
    for (table, keys) in KEYS.iter().filter(|(t, _)| !t.starts_with('[')) {
        for (key, _) in keys.iter() {
            for value in NUMBERS.iter().chain(&wrong_types) {
                set_case(&[format!("{table}.{key}={value}")])
                    .unwrap_or_else(|e| panic!("{table}.{key}={value}: {e}"));
                cases += 1;
            }
        }
    }
    eprintln!("--set sweep: {cases} cases in {:.1} s", start.elapsed().as_secs_f64());
}

/// Random keys of one to seven segments (real names and breaking ones) with values of the keys'
/// kinds and junk, one to four assignments a case.
#[test]
fn random_set_keys_and_values_render_or_name_the_assignment() {
    let start = Instant::now();
    let segment = (0..SEGMENTS.len()).prop_map(|i| SEGMENTS[i].to_owned());
    let key = proptest::collection::vec(segment, 1..8).prop_map(|parts| parts.join("."));
    let value = prop_oneof![
        (0..NUMBERS.len()).prop_map(|i| NUMBERS[i].to_owned()),
        any::<[u16; 4]>().prop_map(|c| value(Kind::Vec3, &c)),
        "[ -~]{0,12}",
    ];
    let set = (key, value, any::<bool>()).prop_map(|(k, v, eq)| if eq { format!("{k}={v}") } else { k + &v });
    let mut runner = runner();
    let result = runner.run(&proptest::collection::vec(set, 1..5), |sets| set_case(&sets));
    eprintln!("--set random: {} cases in {:.1} s", runner.config().cases, start.elapsed().as_secs_f64());
    if let Err(e) = result {
        panic!("{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// glTF
// ---------------------------------------------------------------------------------------------

const SEEDS: &[&str] = &[
    "cornell-box.gltf",
    "gltf-samples/Box.gltf",
    "gltf-samples/Triangle.gltf",
    "gltf-samples/TriangleWithoutIndices.gltf",
    "gltf-samples/SimpleMeshes.gltf",
    "gltf-samples/Cameras.gltf",
    "gltf-samples/BoxTextured.gltf",
    "gltf-samples/BoxVertexColors.gltf",
    "gltf-samples/SimpleSparseAccessor.gltf",
    "gltf-samples/TextureCoordinateTest.gltf",
    "gltf-samples/SimpleSkin.gltf",
];
const GLTF_NUMBERS: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "5",
    "6",
    "7",
    "16",
    "5120",
    "5123",
    "5125",
    "5126",
    "34962",
    "34963",
    "1e39",
    "-1e39",
    "0.5",
    "1e-45",
    "65536",
    "4294967295",
    "4294967296",
    "99999999999",
    "-0",
];
const GLTF_STRINGS: &[&str] = &[
    "",
    "POSITION",
    "NORMAL",
    "TEXCOORD_0",
    "COLOR_0",
    "SCALAR",
    "VEC2",
    "VEC3",
    "VEC4",
    "MAT4",
    "KHR_materials_transmission",
    "KHR_unknown",
    "data:application/octet-stream;base64,AAAA",
    "data:application/octet-stream;base64,",
    "data:image/png;base64,iVBORw0KGgo=",
    "missing.bin",
    "../../../../etc/passwd",
    "x",
];

/// Byte ranges in a text.
type Spans = Vec<(usize, usize)>;

/// Where the numbers and strings (content spans) of JSON text are.
fn tokens(text: &[u8]) -> (Spans, Spans) {
    let (mut numbers, mut strings) = (Vec::new(), Vec::new());
    let mut i = 0;
    while i < text.len() {
        match text[i] {
            b'"' => {
                let start = i + 1;
                i += 1;
                while i < text.len() && text[i] != b'"' {
                    i += if text[i] == b'\\' { 2 } else { 1 };
                }
                strings.push((start, i.min(text.len())));
                i += 1;
            }
            b'-' | b'0'..=b'9' => {
                let start = i;
                while i < text.len() && matches!(text[i], b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9') {
                    i += 1;
                }
                numbers.push((start, i));
            }
            _ => i += 1,
        }
    }
    (numbers, strings)
}

/// Apply mutations (operation, index, choice) to glTF JSON text.
fn mutate_gltf(mut text: Vec<u8>, edits: &[(u8, u32, u16)]) -> Vec<u8> {
    for &(op, at, choice) in edits {
        let (numbers, strings) = tokens(&text);
        let replace = |text: &mut Vec<u8>, (a, b): (usize, usize), with: &str| {
            text.splice(a..b, with.bytes());
        };
        // Mostly value edits (the JSON stays valid and the loader's checks are reached), sometimes structure.
        match op % 10 {
            0..=3 if !numbers.is_empty() => {
                let span = numbers[at as usize % numbers.len()];
                replace(&mut text, span, GLTF_NUMBERS[choice as usize % GLTF_NUMBERS.len()]);
            }
            4..=6 if !strings.is_empty() => {
                let span = strings[at as usize % strings.len()];
                replace(&mut text, span, GLTF_STRINGS[choice as usize % GLTF_STRINGS.len()]);
            }
            7 if !text.is_empty() => text.truncate(at as usize % text.len()),
            8 if !text.is_empty() => {
                let a = at as usize % text.len();
                let b = (a + choice as usize % 64).min(text.len());
                text.drain(a..b);
            }
            9 if !numbers.is_empty() => {
                // Swap two numbers (an index for a count, an offset for a type...).
                let (x, y) = (numbers[at as usize % numbers.len()], numbers[choice as usize % numbers.len()]);
                let (first, second) = if x.0 < y.0 { (x, y) } else { (y, x) };
                if first.1 <= second.0 {
                    let (a, b) = (text[first.0..first.1].to_vec(), text[second.0..second.1].to_vec());
                    text.splice(second.0..second.1, a);
                    text.splice(first.0..first.1, b);
                }
            }
            _ => {}
        }
    }
    text
}

static CASE: AtomicU32 = AtomicU32::new(0);
/// Cases that rendered and cases that failed with an error, for the summary line.
static RENDERED: AtomicU32 = AtomicU32::new(0);
static FAILED: AtomicU32 = AtomicU32::new(0);

fn count<T, E: std::fmt::Display>(outcome: &Result<T, E>) {
    if let (Err(e), Ok(_)) = (outcome, std::env::var("FUZZ_VERBOSE")) {
        eprintln!("fuzz error: {e}");
    }
    let counter = if outcome.is_ok() { &RENDERED } else { &FAILED };
    counter.fetch_add(1, Ordering::Relaxed);
}

fn summary() -> String {
    format!(
        "{} rendered, {} failed cleanly",
        RENDERED.load(Ordering::Relaxed),
        FAILED.load(Ordering::Relaxed)
    )
}

fn temp_gltf(bytes: &[u8]) -> PathBuf {
    let n = CASE.fetch_add(1, Ordering::Relaxed);
    let path = std::env::temp_dir().join(format!("caustica-fuzz-{}-{n}.gltf", std::process::id()));
    std::fs::write(&path, bytes).expect("temp file written");
    path
}

/// The registry: every integrator the fuzzer picks from.
const INTEGRATORS: &[&caustica::integrators::Integrator] = &caustica::integrators::ALL;

fn gltf_case(seed: usize, edits: &[(u8, u32, u16)], integrator: usize) -> Result<(), TestCaseError> {
    let original = std::fs::read(common::data(SEEDS[seed % SEEDS.len()])).expect("seed file");
    let path = temp_gltf(&mutate_gltf(original, edits));
    let start = Instant::now();
    let outcome = load(&path).map_err(|e| e.to_string()).and_then(|(scene, mut run)| {
        run.render.integrator = INTEGRATORS[integrator % INTEGRATORS.len()].kind;
        bound_settings(&mut run);
        common::try_render(scene, &run)
    });
    let seconds = start.elapsed().as_secs_f64();
    let _ = std::fs::remove_file(&path);
    count(&outcome);
    prop_assert!(seconds < MAX_SECONDS, "took {} s", seconds);
    match outcome {
        Ok(image) => check_image(&image, "glTF"),
        Err(message) => check_error(&message, &[&path]),
    }
}

#[test]
fn mutated_gltf_files_render_or_fail_with_a_message_naming_the_file() {
    let start = Instant::now();
    let mut runner = runner();
    let strategy = (
        0..SEEDS.len(),
        proptest::collection::vec((any::<u8>(), any::<u32>(), any::<u16>()), 1..5),
        0..INTEGRATORS.len(),
    );
    let result = runner.run(&strategy, |(seed, edits, integrator)| gltf_case(seed, &edits, integrator));
    eprintln!(
        "glTF: {} cases in {:.1} s (all fuzz tests so far: {})",
        runner.config().cases,
        start.elapsed().as_secs_f64(),
        summary()
    );
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// Found by the glTF fuzzer: gltf-json 1.4 validation indexed the accessors with an out-of-range
/// POSITION index and panicked; the loader must report it instead.
#[test]
fn a_position_accessor_out_of_range_is_an_error_naming_the_file() {
    let text = std::fs::read_to_string(common::data("gltf-samples/Triangle.gltf")).unwrap();
    let broken = text.replacen("\"POSITION\" : 1", "\"POSITION\" : 96", 1);
    assert_ne!(text, broken, "the sample changed: update the replacement");
    let path = temp_gltf(broken.as_bytes());
    let error = load(&path).map(|_| ()).expect_err("out-of-range accessor must be an error").to_string();
    let _ = std::fs::remove_file(&path);
    assert!(
        error.contains(&*path.file_name().unwrap().to_string_lossy()) && error.contains("POSITION"),
        "{error}"
    );
}

/// Found by the run-file fuzzer: a sphere 4e9 m from the origin next to the Cornell box broke the
/// BVH's nesting of quantised boxes (an obvhs assertion); the loader must refuse it, naming it, and
/// a scene that reaches 1e6 m must still render.
#[test]
fn geometry_beyond_the_f32_range_is_an_error_and_up_to_it_renders() {
    let path = common::data("fuzz-run.toml");
    let far = "gltf = \"cornell-box.gltf\"\n[[sphere]]\ncenter = [4294967295, -1, -1]\nradius = 4294967295\n";
    let run = RunFile::parse(far, &path).unwrap();
    let mut scene = run.load_scene(&path).unwrap();
    let error = validate(&mut scene, &path).expect_err("a 4e9 m sphere must be refused").to_string();
    assert!(error.contains("fuzz-run.toml") && error.contains("sphere #0"), "{error}");
    let near = "gltf = \"cornell-box.gltf\"\n[[sphere]]\ncenter = [0, -500000, 0]\nradius = 499999\n";
    let mut run = RunFile::parse(near, &path).unwrap();
    let mut scene = run.load_scene(&path).unwrap();
    validate(&mut scene, &path).unwrap();
    bound_settings(&mut run);
    let image = common::try_render(scene, &run).unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
}

/// Found by the glTF fuzzer: a texture looked up at a huge uv overflowed the texel index; an infinite
/// uv interpolated with a NaN weight and returned NaN (found when this test got its assertion).
#[test]
fn texture_lookups_at_huge_or_infinite_uv_do_not_panic() {
    let texture = caustica::scene::Texture {
        width: 2,
        height: 2,
        texels: vec![glam::Vec4::ONE; 4],
        ..Default::default()
    };
    for uv in [1e30f32, -1e30, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 3.5] {
        // Every texel is one, so any lookup that lands on texels (and interpolates them) is one.
        assert_eq!(texture.sample(glam::Vec2::splat(uv)), glam::Vec4::ONE, "uv {uv}");
    }
}
