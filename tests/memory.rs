//! The memory budget bounds the process's peak resident memory. Every integrator, with and without
//! checkpoints, peaks within a tenth above what it counted before rendering (its summary's `memory`
//! line: the kernel's high-water mark of the rendering process), and a budget just under that count
//! is refused before anything is allocated: so a render the budget lets through stays within 10% of it.

use std::process::{Command, Output};

const INTEGRATORS: [&str; 11] =
    ["pt", "pt-naive", "pm", "ppm", "sppm", "appm", "cppm", "pppm", "lt", "bdpt", "vcm"];

fn render(integrator: &str, size: u32, checkpoint: bool, budget_mib: Option<u64>) -> Output {
    let dir = std::env::temp_dir()
        .join(format!("caustica-memory-{}-{integrator}-{checkpoint}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Memory does not grow with samples or passes after the first: at 1200² one of each is enough.
    let (spp, passes) = if size > 320 { ("1", "1") } else { ("2", "2") };
    let size = size.to_string();
    let units: Vec<&str> = match integrator {
        "pt" | "pt-naive" | "lt" | "bdpt" | "vcm" => vec!["--spp", spp],
        "pm" => vec!["--spp", "1"],
        // ppm's default keeps many hit points a pixel; two keep this test light.
        "ppm" => vec!["--passes", passes, "--hit-points-per-pixel", "2"],
        _ => vec!["--passes", passes],
    };
    let mut command = Command::new(env!("CARGO_BIN_EXE_caustica"));
    command
        .args(["render", "scenes/cornell-spheres.gltf", "--integrator", integrator])
        .args(["--width", &size, "--height", &size])
        .args(&units)
        .arg("-o")
        .arg(dir.join("out.exr"));
    if checkpoint {
        command.arg("--checkpoint").arg(dir.join("ck.exr"));
    }
    if let Some(mib) = budget_mib {
        command.args(["--memory-budget-mib", &mib.to_string()]);
    }
    command.output().expect("caustica runs")
}

/// The summary's peak resident memory and the count made before rendering, MiB.
fn peak_and_count(out: &Output) -> (u64, u64) {
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout
        .lines()
        .find(|l| l.starts_with("memory"))
        .unwrap_or_else(|| panic!("no memory line: {stdout}"));
    let numbers: Vec<u64> = line.split_whitespace().filter_map(|w| w.parse().ok()).collect();
    (numbers[0], numbers[1])
}

/// (At 1200², where the film, the hit points and the light vertices dominate, the count is held to
/// the allocator's own peak in tests/memory_count.rs, without the resident memory's slack.)
fn check_every_integrator(size: u32, checkpoints: &[bool]) {
    for integrator in INTEGRATORS {
        for &checkpoint in checkpoints {
            let (peak, counted) = peak_and_count(&render(integrator, size, checkpoint, None));
            assert!(
                peak as f64 <= 1.1 * counted as f64,
                "{integrator} at {size}² (checkpoint {checkpoint}): peak {peak} MiB, counted {counted} MiB"
            );
            // Two MiB under the count: resident memory differs by less than that run to run.
            let refused = render(integrator, size, checkpoint, Some(counted - 2));
            let stderr = String::from_utf8_lossy(&refused.stderr);
            assert!(
                !refused.status.success() && stderr.contains("memory_budget_mib"),
                "{integrator} at {size}² (checkpoint {checkpoint}) ran under a budget of {} MiB: {stderr}",
                counted - 2
            );
        }
    }
}

#[test]
#[cfg(target_os = "linux")]
fn every_integrator_stays_within_a_tenth_of_its_count_and_a_budget_under_it_is_refused() {
    check_every_integrator(320, &[false, true]);
}

/// `caustica render ARGS` under `ulimit -v` of `kib`: what the machine lets the process have.
#[cfg(target_os = "linux")]
fn render_limited(kib: u64, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kib}; exec \"$0\" render \"$@\""))
        .arg(env!("CARGO_BIN_EXE_caustica"))
        .args(args)
        .output()
        .expect("sh runs")
}

/// A budget raised by hand past what the process may have is refused by name (what, its size, the
/// budget) before anything of it is allocated: an error, never an abort. The cases the hostile
/// search found aborting with "memory allocation of 42949672960 bytes failed".
#[test]
#[cfg(target_os = "linux")]
fn memory_the_budget_lets_through_but_the_process_has_not_got_is_an_error_not_an_abort() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    let out = out.to_str().unwrap();
    for (integrator, size) in [("pt", "32768"), ("vcm", "8192"), ("sppm", "16384")] {
        let result = render_limited(
            2_000_000,
            &[
                "scenes/cornell-spheres.gltf",
                "--integrator",
                integrator,
                "--width",
                size,
                "--height",
                size,
                "--spp",
                "1",
                "--passes",
                "1",
                "--memory-budget-mib",
                "1099511627776",
                "-o",
                out,
            ],
        );
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(1), "{integrator} at {size}²: {:?} {stderr}", result.status);
        assert!(
            stderr.contains("cannot allocate ")
                && stderr.contains("within the memory budget of")
                && stderr.contains("ulimit -v"),
            "{integrator}: {stderr}"
        );
        assert!(!std::path::Path::new(out).exists(), "{integrator}: an image was written");
    }
}

/// A glTF whose one accessor declares 2^28 vertices of zeros (a sparse accessor at the loader's
/// cap): its meshes are counted before any accessor is read and refused over the budget, naming
/// the count; with the budget raised past the process's limit, the accessor's read is refused by
/// name. Never an abort, never 3 GiB read for an image of one triangle.
#[test]
#[cfg(target_os = "linux")]
fn a_gltf_of_2_28_zero_vertices_is_counted_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    // One sparse value (the vertex 1 at x = 1) over 2^28 zeros: 16 bytes of buffer.
    let buffer = [1u32.to_le_bytes(), 1f32.to_le_bytes(), 0f32.to_le_bytes(), 0f32.to_le_bytes()].concat();
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":16,"uri":"data:application/octet-stream;base64,{}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":4}},{{"buffer":0,"byteOffset":4,"byteLength":12}}],
        "accessors":[{{"componentType":5126,"count":{},"type":"VEC3","min":[0,0,0],"max":[1,0,0],
            "sparse":{{"count":1,"indices":{{"bufferView":0,"componentType":5125}},"values":{{"bufferView":1}}}}}}]}}"#,
        crate::loader::base64(&buffer),
        1u64 << 28
    );
    let file = dir.path().join("zeros.gltf");
    std::fs::write(&file, text).unwrap();
    let out = dir.path().join("out.exr");
    let args = |budget: &'static str| {
        vec![
            file.to_str().unwrap().to_string(),
            "--width".into(),
            "16".into(),
            "--height".into(),
            "16".into(),
            "--memory-budget-mib".into(),
            budget.into(),
            "-o".into(),
            out.to_str().unwrap().to_string(),
        ]
    };
    let refused =
        Command::new(env!("CARGO_BIN_EXE_caustica")).arg("render").args(args("2000")).output().unwrap();
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("268435456 vertices") && stderr.contains("over the memory budget of 2000 MiB"),
        "{stderr}"
    );
    let raised = args("100000");
    let limited = render_limited(1_000_000, &raised.iter().map(String::as_str).collect::<Vec<_>>());
    let stderr = String::from_utf8_lossy(&limited.stderr);
    assert_eq!(limited.status.code(), Some(1), "{:?} {stderr}", limited.status);
    assert!(stderr.contains("POSITION (accessor #0): cannot allocate its 268435456 elements"), "{stderr}");
    assert!(!out.exists());
}
