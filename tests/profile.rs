//! `--profile` and `--trace-chrome`: every system of the schedule shows up, once per run.

use std::process::Command;

fn render(dir: &std::path::Path, extra: &[&str]) -> String {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell-box.gltf");
    let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene, "--spp", "1", "--width", "16", "--height", "16", "-q", "--profile"])
        .arg("--trace-chrome")
        .arg(dir.join("trace.json"))
        .arg("-o")
        .arg(dir.join("x.exr"))
        .args(extra)
        .output()
        .expect("caustica runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// "B" events (span entered) per label in the Chrome trace.
fn begin_events(path: &std::path::Path, label: &str) -> usize {
    let events: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).expect("the trace is valid JSON");
    events.iter().filter(|e| e["ph"] == "B" && e["name"] == label).count()
}

#[test]
fn path_tracing_profile_lists_every_system_and_the_trace_has_one_event_per_run() {
    let dir = std::env::temp_dir().join(format!("caustica-profile-pt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let stdout = render(&dir, &[]);
    let steps: usize = stdout
        .lines()
        .find_map(|l| l.strip_prefix("wavefront").and_then(|r| r.split(',').nth(1)))
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .expect("the summary reports the steps");
    let systems = [
        "emit_paths<false, false>",
        "trace_paths",
        "scatter_paths<true>",
        "trace_shadow_rays",
        "splat_paths",
    ];
    for system in systems {
        let row =
            stdout.lines().find(|l| l.starts_with(system)).unwrap_or_else(|| panic!("no row for {system}"));
        let calls: usize = row[system.len()..].split_whitespace().next().unwrap().parse().unwrap();
        assert_eq!(calls, steps, "{system}: {calls} calls in {steps} steps");
        let label = format!("system: {system}");
        assert_eq!(begin_events(&dir.join("trace.json"), &label), steps, "{label} events");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn progressive_profile_lists_the_camera_photon_and_statistics_systems() {
    let dir = std::env::temp_dir().join(format!("caustica-profile-sppm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let stdout = render(&dir, &["--integrator", "sppm", "--passes", "3", "--photons-per-pass", "2000"]);
    for system in [
        "scatter_to_visible_points<true>",
        "begin_photon_subpaths",
        "emit_photon_subpaths",
        "trace_subpaths",
        "scatter_photon_subpaths",
        "order_photon_deposits",
        "build_pass_photon_map",
        "gather_photons_into_hit_points",
        "update_hit_point_radii",
    ] {
        assert!(stdout.lines().any(|l| l.starts_with(system)), "no row for {system} in\n{stdout}");
    }
    // The statistics schedule runs once per pass.
    assert_eq!(begin_events(&dir.join("trace.json"), "system: update_hit_point_radii"), 3);
    std::fs::remove_dir_all(dir).ok();
}

/// The number in the row of `stage` in the trace counters' table, column `column` (0: rays).
fn counter(stdout: &str, stage: &str, column: usize) -> f64 {
    let table = stdout.split("trace counters").nth(1).expect("a trace counters table");
    let row =
        table.lines().find(|l| l.starts_with(stage)).unwrap_or_else(|| panic!("no counters for {stage}"));
    row[stage.len()..].split_whitespace().nth(column).unwrap().parse().unwrap()
}

#[test]
fn trace_counters_count_every_ray_the_report_counts_and_the_tree_work_it_took() {
    let dir = std::env::temp_dir().join(format!("caustica-profile-counters-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let stdout = render(&dir, &[]);
    // "rays/s      6.899 M (3975700 rays, 2353296 shadow rays)"
    let summary = stdout.lines().find(|l| l.starts_with("rays/s")).expect("the summary reports rays");
    let numbers: Vec<f64> = summary.split(['(', ',', ' ']).filter_map(|w| w.parse().ok()).collect();
    let (rays, shadow_rays) = (numbers[1], numbers[2]);
    assert!(rays > 0.0 && shadow_rays > 0.0, "{summary}");
    assert_eq!(counter(&stdout, "trace_paths", 0), rays);
    assert_eq!(counter(&stdout, "trace_shadow_rays", 0), shadow_rays);
    // Every ray of the closed box starts inside the root's box: at least the root is visited, and a
    // closest hit inside a closed box needs at least one leaf.
    for stage in ["trace_paths", "trace_shadow_rays"] {
        assert!(counter(&stdout, stage, 2) >= 1.0, "{stage} nodes/ray");
    }
    assert!(counter(&stdout, "trace_paths", 3) >= 1.0, "trace_paths leaves/ray");
    std::fs::remove_dir_all(dir).ok();
}

/// Every row of every integrator's profile names its system: a system made from a closure showed up
/// as `{{closure}}` (`pm`'s photon map build, 6% of its time, was one), and a row that names no system
/// says nothing about where the time went.
#[test]
fn every_integrators_profile_names_every_system() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cornell-box.gltf");
    for kind in caustica::integrators::kinds() {
        let integrator = caustica::integrators::of(kind).name();
        let out = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .args(["render", scene, "--integrator", integrator, "--width", "16", "--height", "16"])
            .args(["--spp", "1", "--passes", "1", "--photons", "2000", "--caustic-photons", "2000"])
            .args(["--photons-per-pass", "2000"])
            .args(["-q", "--profile", "-o"])
            .arg(dir.path().join(format!("{integrator}.exr")))
            .output()
            .expect("caustica runs");
        assert!(out.status.success(), "{integrator}: {}", String::from_utf8_lossy(&out.stderr));
        let stdout = String::from_utf8(out.stdout).unwrap();
        let table = stdout.split("per-system profile").nth(1).expect("a profile table");
        let rows: Vec<&str> = table
            .lines()
            .skip_while(|l| !l.starts_with("system"))
            .skip(1)
            .take_while(|l| !l.starts_with("all systems"))
            .collect();
        assert!(rows.len() >= 5, "{integrator}: only {} rows in\n{table}", rows.len());
        for row in rows {
            let name = row.split_whitespace().next().unwrap_or("");
            assert!(
                !row.contains("closure")
                    && !row.contains("{{")
                    && name.starts_with(|c: char| c.is_ascii_lowercase()),
                "{integrator}: a row that does not name its system: {row:?}"
            );
        }
    }
}
