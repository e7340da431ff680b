//! The memory budget bounds the process's peak resident memory. Every integrator, with and without
//! checkpoints, peaks within a tenth above what it counted before rendering (its summary's `memory`
//! line: the kernel's high-water mark of the rendering process), and a budget just under that count
//! is refused before anything is allocated: so a render the budget lets through stays within 10% of it.

use std::process::{Command, Output};

fn render(integrator: &str, size: u32, checkpoint: bool, budget_mib: Option<u64>) -> Output {
    let dir = std::env::temp_dir()
        .join(format!("caustica-memory-{}-{integrator}-{checkpoint}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Memory does not grow with samples or passes after the first: at 1200² one of each is enough.
    let (spp, passes) = if size > 320 { ("1", "1") } else { ("2", "2") };
    let size = size.to_string();
    let unit = caustica::integrators::ALL
        .iter()
        .find(|i| i.name() == integrator)
        .expect("an integrator")
        .units_key();
    let units: Vec<&str> = match integrator {
        "pm" => vec!["--spp", "1"],
        // ppm's default keeps many hit points a pixel; two keep this test light.
        "ppm" => vec!["--passes", passes, "--hit-points-per-pixel", "2"],
        _ if unit == "spp" => vec!["--spp", spp],
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

/// (At 800², where the film, the hit points and the light vertices dominate, the count is held to
/// the allocator's own peak in tests/memory_count.rs, without the resident memory's slack.)
fn check_every_integrator(size: u32, checkpoints: &[bool]) {
    for integrator in caustica::integrators::ALL.map(|i| i.name()) {
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
/// the count; with the budget raised past the process's limit, the meshes' count is refused by
/// the allocator, naming the file. Never an abort, never 3 GiB read for an image of one triangle.
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
    assert!(stderr.contains("cannot allocate the meshes of") && stderr.contains("zeros.gltf"), "{stderr}");
    assert!(!out.exists());
}

/// An external buffer is read within the budget and fallibly: one of 1.5 GB (a sparse file: no disk
/// is used) is refused over a budget of 1000 MiB naming the buffer, and under a `ulimit -v` of 1 GB
/// with the budget raised, refused naming the allocation: never an abort.
#[test]
#[cfg(target_os = "linux")]
fn an_external_buffer_is_read_within_the_budget_and_fallibly() {
    let dir = tempfile::tempdir().unwrap();
    const LENGTH: u64 = 1_500_000_000;
    let bin = std::fs::File::create(dir.path().join("big.bin")).unwrap();
    bin.set_len(LENGTH).unwrap();
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":{LENGTH},"uri":"big.bin"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}}]}}"#
    );
    let file = dir.path().join("big.gltf");
    std::fs::write(&file, text).unwrap();
    let out = dir.path().join("out.exr");
    let (file, out) = (file.to_str().unwrap(), out.to_str().unwrap());
    let args = |budget| [file, "--width", "16", "--height", "16", "--memory-budget-mib", budget, "-o", out];
    let refused =
        Command::new(env!("CARGO_BIN_EXE_caustica")).arg("render").args(args("1000")).output().unwrap();
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("buffer #0") && stderr.contains("over the memory budget of 1000 MiB"),
        "{stderr}"
    );
    let limited = render_limited(1_000_000, &args("100000"));
    let stderr = String::from_utf8_lossy(&limited.stderr);
    assert_eq!(limited.status.code(), Some(1), "{:?} {stderr}", limited.status);
    assert!(stderr.contains("buffer #0") && stderr.contains("cannot allocate its 1431 MiB"), "{stderr}");
    assert!(!std::path::Path::new(out).exists());
}

/// The dense mesh's case: a glTF of a million triangles, whose load and BVH build peak above what
/// the render adds. The summary's count (the load's measured peak, or what is held once it is built
/// plus the render's count) is within a tenth of the resident peak, above a one-triangle file's.
#[test]
#[cfg(target_os = "linux")]
fn a_dense_mesh_peaks_within_a_tenth_of_its_count() {
    let dir = tempfile::tempdir().unwrap();
    let grid = |n: u32, name: &str| {
        // An n × n grid of quads over the unit square facing the default camera.
        let mut bin = Vec::new();
        for y in 0..=n {
            for x in 0..=n {
                for v in [x as f32 / n as f32 - 0.5, y as f32 / n as f32 - 0.5, -2.0f32] {
                    bin.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        let positions = bin.len();
        for y in 0..n {
            for x in 0..n {
                let i = y * (n + 1) + x;
                for v in [i, i + 1, i + n + 2, i, i + n + 2, i + n + 1] {
                    bin.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        std::fs::write(dir.path().join(format!("{name}.bin")), &bin).unwrap();
        let (vertices, indices) = ((n + 1) * (n + 1), 6 * n * n);
        let text = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":{},"uri":"{name}.bin"}}],
            "bufferViews":[{{"buffer":0,"byteLength":{positions}}},{{"buffer":0,"byteOffset":{positions},"byteLength":{}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":{vertices},"type":"VEC3","min":[-0.5,-0.5,-2],"max":[0.5,0.5,-2]}},
                {{"bufferView":1,"componentType":5125,"count":{indices},"type":"SCALAR"}}]}}"#,
            bin.len(),
            bin.len() - positions
        );
        let file = dir.path().join(format!("{name}.gltf"));
        std::fs::write(&file, text).unwrap();
        file
    };
    let peak_and_count_of = |file: &std::path::Path| {
        let out = dir.path().join("out.exr");
        let result = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .arg("render")
            .arg(file)
            .args(["--width", "32", "--height", "32", "--spp", "1", "-o"])
            .arg(&out)
            .output()
            .unwrap();
        peak_and_count(&result)
    };
    let (empty_peak, _) = peak_and_count_of(&grid(1, "one"));
    let (peak, counted) = peak_and_count_of(&grid(708, "dense"));
    let (peak, counted) = (peak - empty_peak, counted - empty_peak);
    assert!(
        counted.abs_diff(peak) as f64 <= 0.1 * peak as f64,
        "a million triangles: peak {peak} MiB, counted {counted} MiB above a one-triangle file's"
    );
}
