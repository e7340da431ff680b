//! Fuzzing the command line: `caustica render` with adversarial values for its flags (zero, one,
//! negative, NaN, infinite, u32::MAX, names that are no choice) either writes an image of the size
//! asked for with finite, non-negative pixels and exits 0, or exits 1 or 2 with an error; never a
//! panic, an abort, a signal or a hang.
//!
//! Every case runs the real binary (a debug build under `cargo test`), so the case count is small;
//! `PROPTEST_CASES=N cargo test --test integration fuzz_cli::` runs more. The seed is fixed, as in `fuzz.rs`.

use crate::common;

use caustica::film::output::read_exr;
use proptest::prelude::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::LazyLock;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// Random combinations unless PROPTEST_CASES says otherwise: each spawns the binary (~40 ms).
const DEFAULT_CASES: u32 = 200;
/// A case still running after this long is a hang (the base flags keep renders to milliseconds,
/// and every large request is either refused by the memory budget or stopped by the time limit).
const MAX_SECONDS: u64 = 60;

/// The flags every case starts from: a tiny render whatever the integrator, with a time limit that
/// stops any target a fuzzed flag raises. A fuzzed flag replaces its base value (clap refuses a
/// flag given twice).
const BASE: &[(&str, &str)] = &[
    ("--width", "8"),
    ("--height", "8"),
    ("--spp", "1"),
    ("--passes", "1"),
    ("--photons", "1000"),
    ("--photons-per-pass", "1000"),
    ("--memory-budget-mib", "64"),
    ("--time-limit", "5"),
];

const COUNT: &[&str] = &["0", "1", "2", "4294967295", "4294967296", "-1", "NaN", "1e3", ""];
const REAL: &[&str] = &["0", "-1", "NaN", "inf", "-inf", "1e-30", "0.05", "1e39", "0.5", "2", "x"];
const TRIPLE: &[&str] = &["0,0,0", "0,1,3", "NaN,0,0", "1e39,0,0", "inf,1,1", "0,1", "-1,-1,-1", "a,b,c"];

/// Each fuzzed flag with the values a case picks from: `--integrator` first, with every registered
/// integrator's name and two that are none, then [`OTHER_FLAGS`].
static FLAGS: LazyLock<Vec<(&str, &[&str])>> = LazyLock::new(|| {
    let integrators = caustica::integrators::names().chain(["", "PT"]).collect();
    let mut flags = vec![("--integrator", &*Vec::leak(integrators))];
    flags.extend_from_slice(OTHER_FLAGS);
    flags
});

const OTHER_FLAGS: &[(&str, &[&str])] = &[
    ("--spp", COUNT),
    ("--passes", COUNT),
    ("--width", &["0", "1", "3", "8", "-1", "NaN", "32769", "65536", "4294967295"]),
    ("--height", &["0", "1", "3", "8", "-1", "NaN", "32769", "65536", "4294967295"]),
    ("--photons", COUNT),
    ("--photons-per-pass", COUNT),
    ("--caustic-photons", COUNT),
    ("--k", &["0", "1", "2", "50", "4294967295", "-1"]),
    ("--max-radius", REAL),
    ("--initial-radius", REAL),
    ("--alpha", REAL),
    ("--exposure", REAL),
    ("--threads", &["0", "1", "2", "-1", "1024", "1025", "65536"]),
    ("--write-every", &["0", "1", "4294967295", "-1"]),
    ("--hit-points-per-pixel", &["0", "1", "3", "4", "256", "512", "4294967295"]),
    ("--max-depth", COUNT),
    ("--rr-depth", COUNT),
    ("--yfov", &["0", "180", "179.9", "-1", "NaN", "1e-30", "45"]),
    ("--eye", TRIPLE),
    ("--target", TRIPLE),
    ("--up", TRIPLE),
    ("--seed", &["0", "18446744073709551615", "-1", "x"]),
    ("--memory-budget-mib", &["0", "1", "64", "17592186044416", "18446744073709551615", "-1"]),
    ("--time-limit", &["0", "-1", "NaN", "0.5", "1e-300", "x"]),
    ("--final-gather", &["0", "1", "4294967295"]),
    ("--environment-strength", REAL),
    ("--environment-color", TRIPLE),
    ("--environment-rotation", TRIPLE),
    ("--environment", &["", "/dev/null", "/nonexistent.exr", "tests/data/cornell-box.gltf"]),
    ("--camera", &["", "Camera", "no such camera"]),
    ("--light-selection", &["uniform", "power", "tree", "visibility", "bogus"]),
    ("--sampler", &["independent", "sobol", "bogus"]),
    ("--filter", &["box", "gaussian", "tent", "bogus"]),
    ("--kernel", &["uniform", "cone", "epanechnikov", "biweight", "gaussian", "bogus"]),
    ("--set", &["render.spp=3", "render.spp=-1", "film.width=\"x\"", "nonsense.key=1", "=", "photons.k=[1]"]),
];

static CASE: AtomicU32 = AtomicU32::new(0);

/// The arguments of one case: the base flags, each replaced by its fuzzed value when there is one,
/// then the fuzzed flags that have no base.
fn arguments(picks: &[(usize, usize)]) -> Vec<(String, String)> {
    let fuzzed: Vec<(&str, &str)> = picks
        .iter()
        .map(|&(f, v)| {
            (FLAGS[f % FLAGS.len()].0, FLAGS[f % FLAGS.len()].1[v % FLAGS[f % FLAGS.len()].1.len()])
        })
        .collect();
    let chosen = |flag: &str| fuzzed.iter().rev().find(|(f, _)| *f == flag).map(|(_, v)| *v);
    let mut args: Vec<(String, String)> =
        BASE.iter().map(|&(f, v)| (f.to_string(), chosen(f).unwrap_or(v).to_string())).collect();
    for &(flag, _) in &fuzzed {
        if !args.iter().any(|(f, _)| f == flag) {
            args.push((flag.to_string(), chosen(flag).unwrap().to_string()));
        }
    }
    args
}

/// Ok(true) when the case rendered, Ok(false) when it was refused with an error.
fn cli_case(picks: &[(usize, usize)]) -> Result<bool, TestCaseError> {
    let n = CASE.fetch_add(1, Ordering::Relaxed);
    let output = std::env::temp_dir().join(format!("caustica-fuzz-cli-{}-{n}.exr", std::process::id()));
    let flags = arguments(picks);
    let scene = common::data("cornell-box.gltf");
    let mut command = Command::new(env!("CARGO_BIN_EXE_caustica"));
    command.current_dir(env!("CARGO_MANIFEST_DIR")).arg("render").arg(&scene).args(["-q", "-o"]).arg(&output);
    // `--flag=value` so that values starting with '-' are values, not flags.
    command.args(flags.iter().map(|(f, v)| format!("{f}={v}")));
    let described = flags.iter().map(|(f, v)| format!("{f}={v}")).collect::<Vec<_>>().join(" ");
    let mut child = command.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().expect("caustica starts");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if start.elapsed() > Duration::from_secs(MAX_SECONDS) {
            child.kill().ok();
            child.wait().ok();
            std::fs::remove_file(&output).ok();
            return Err(TestCaseError::fail(format!("hung: {described}")));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).ok();
    let result = judge(status.code(), &stderr, &output, &flags, &described);
    std::fs::remove_file(&output).ok();
    result.map(|()| status.success())
}

fn judge(
    code: Option<i32>,
    stderr: &str,
    output: &Path,
    flags: &[(String, String)],
    described: &str,
) -> Result<(), TestCaseError> {
    prop_assert!(!stderr.contains("panicked"), "panic: {}\n{}", described, stderr);
    match code {
        Some(0) => {
            let image = read_exr(output).map_err(|e| TestCaseError::fail(format!("{described}: {e}")))?;
            let size = |flag: &str| flags.iter().find(|(f, _)| f == flag).unwrap().1.parse::<u32>().unwrap();
            prop_assert_eq!(
                (image.width, image.height),
                (size("--width"), size("--height")),
                "{}",
                described
            );
            for p in &image.pixels {
                prop_assert!(p.is_finite() && p.min_element() >= 0.0, "{}: pixel {}", described, p);
            }
        }
        Some(1 | 2) => {
            prop_assert!(
                stderr.contains("error"),
                "exit without an error message: {}\n{}",
                described,
                stderr
            );
            prop_assert!(!output.exists(), "a failed run left an image: {}", described);
        }
        other => prop_assert!(false, "exit {:?} (signal or abort): {}\n{}", other, described, stderr),
    }
    Ok(())
}

#[test]
fn adversarial_flags_render_or_fail_with_an_error() {
    let start = Instant::now();
    let mut runner = common::fuzz_runner(DEFAULT_CASES);
    let strategy = proptest::collection::vec((0..FLAGS.len(), 0usize..16), 1..4);
    let rendered = AtomicU32::new(0);
    let result = runner.run(&strategy, |picks| {
        rendered.fetch_add(cli_case(&picks)? as u32, Ordering::Relaxed);
        Ok(())
    });
    let (cases, rendered) = (runner.config().cases, rendered.into_inner());
    eprintln!("CLI: {cases} cases in {:.1} s, {rendered} rendered", start.elapsed().as_secs_f64());
    if let Err(e) = result {
        panic!("{e}");
    }
    // A fuzzer whose every case is refused would test only the argument parser.
    assert!(rendered * 10 >= cases, "only {rendered} of {cases} cases rendered");
}

/// Every value of every flag once, each with an integrator in turn (the combinations above are a
/// sample; these are all of the single values).
#[test]
fn every_adversarial_value_alone_renders_or_fails_with_an_error() {
    let integrators = FLAGS[0].1.len();
    let mut turn = 0;
    for (f, (flag, values)) in FLAGS.iter().enumerate() {
        for v in 0..values.len() {
            let mut picks = vec![(f, v)];
            if *flag != "--integrator" {
                picks.insert(0, (0, turn % integrators));
                turn += 1;
            }
            if let Err(e) = cli_case(&picks) {
                panic!("{e}");
            }
        }
    }
}

/// Every flag the fuzzer knows is a flag of `caustica render` (so a renamed flag cannot quietly turn
/// every case into a usage error).
#[test]
fn the_fuzzed_flags_exist() {
    let help = Command::new(env!("CARGO_BIN_EXE_caustica")).args(["render", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for (flag, _) in FLAGS.iter() {
        assert!(
            help.contains(&format!("{flag} ")) || help.contains(&format!("{flag}=")),
            "{flag} not in --help"
        );
    }
}
