//! `caustica bench` on a tiny scene: the CSV is well formed, the plots and error images decode.

use std::process::Command;

fn bench(dir: &std::path::Path, extra: &[&str]) -> String {
    bench_with_stderr(dir, extra).0
}

/// What `caustica bench` printed on stdout (its table) and on stderr (where it is, as it goes).
fn bench_with_stderr(dir: &std::path::Path, extra: &[&str]) -> (String, String) {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell-box.gltf");
    let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["bench", scene, "--integrators", "pt,sppm", "--time", "1.0", "--reference-time", "1.0"])
        .args(["--width", "24", "--height", "24", "--out-dir"])
        .arg(dir)
        .args(extra)
        .output()
        .expect("caustica runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    (String::from_utf8(out.stdout).unwrap(), String::from_utf8(out.stderr).unwrap())
}

#[test]
fn bench_writes_a_monotone_csv_with_finite_errors_and_decodable_plots() {
    let dir = std::env::temp_dir().join(format!("caustica-bench-{}", std::process::id()));
    let (stdout, stderr) = bench_with_stderr(&dir, &[]);
    // A long bench says where it is as it goes, not only at its end.
    for step in ["rendering one with sppm", "bench: pt (1 of 2)", "bench: pt: ", "bench: sppm (2 of 2)"] {
        assert!(stderr.contains(step), "no '{step}' on stderr:\n{stderr}");
    }
    assert!(
        stdout.contains("none given: rendered one with sppm"),
        "says the reference was rendered:\n{stdout}"
    );
    let csv = std::fs::read_to_string(dir.join("errors.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("integrator,seconds,samples_or_passes,rmse,relmse,mae,flip,light_selection")
    );
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(str::to_owned).collect()).collect();
    for integrator in ["pt", "sppm"] {
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == integrator).collect();
        assert!(mine.len() >= 2, "{integrator}: {} checkpoints", mine.len());
        let number = |r: &Vec<String>, i: usize| r[i].parse::<f64>().unwrap();
        for pair in mine.windows(2) {
            assert!(number(pair[1], 1) > number(pair[0], 1), "{integrator}: time not increasing");
            assert!(number(pair[1], 2) >= number(pair[0], 2), "{integrator}: samples not increasing");
        }
        for r in &mine {
            assert!((3..6).all(|i| number(r, i).is_finite() && number(r, i) >= 0.0), "{integrator}: {r:?}");
            assert!((0.0..=1.0).contains(&number(r, 6)), "{integrator}: FLIP out of [0, 1]: {r:?}");
        }
        // More samples look more like the reference: the last checkpoint's FLIP is below the first's.
        assert!(number(mine[mine.len() - 1], 6) < number(mine[0], 6), "{integrator}: FLIP did not fall");
        let map = image::open(dir.join(format!("{integrator}-flip.png"))).expect("the FLIP map decodes");
        assert_eq!((map.width(), map.height()), (24, 24));
        let error = image::open(dir.join(format!("{integrator}-error.png"))).expect("error image decodes");
        assert_eq!((error.width(), error.height()), (24, 24));
    }
    let plot = image::open(dir.join("relmse-vs-time.png")).expect("the PNG plot decodes");
    assert!(plot.width() > 100 && plot.height() > 100);
    let svg = std::fs::read_to_string(dir.join("relmse-vs-time.svg")).unwrap();
    assert!(
        svg.trim_start().starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
        "SVG is not a document"
    );
    assert!(svg.contains("polyline") || svg.contains("<path"), "SVG has no lines");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn spp_sweep_plots_against_samples() {
    let dir = std::env::temp_dir().join(format!("caustica-bench-sweep-{}", std::process::id()));
    bench(
        &dir,
        &[
            "--spp-sweep",
            "--reference",
            concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell-box.ref.exr"),
        ],
    );
    assert!(image::open(dir.join("relmse-vs-samples.png")).is_ok());
    // The reference fixes the size: 256×256, whatever --width says.
    let error = image::open(dir.join("pt-error.png")).unwrap();
    assert_eq!((error.width(), error.height()), (256, 256));
    std::fs::remove_dir_all(&dir).ok();
}

/// A budget shorter than an integrator's first pass (pm's photon pass) still measures that pass
/// whole: one checkpoint at one sample, in the CSV and on the chart (a stop inside it measured a
/// black image at 0 spp, which the log axis of `--spp-sweep` dropped with its series).
#[test]
fn an_integrator_slower_than_the_budget_is_measured_once_at_its_first_pass() {
    let dir = std::env::temp_dir().join(format!("caustica-bench-short-{}", std::process::id()));
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell-box.gltf");
    let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["bench", scene, "--integrators", "pm", "--time", "0.001", "--spp-sweep"])
        .args(["--reference", concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell-box.ref.exr")])
        .arg("--out-dir")
        .arg(&dir)
        .output()
        .expect("caustica runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("errors.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 1, "{csv}");
    assert_eq!(rows[0][0], "pm");
    assert!(rows[0][2].parse::<f64>().unwrap() >= 1.0, "measured before its first sample: {csv}");
    let svg = std::fs::read_to_string(dir.join("relmse-vs-samples.svg")).unwrap();
    assert!(svg.contains("pm") && svg.contains("<circle"), "pm is not on the chart");
    std::fs::remove_dir_all(&dir).ok();
}
