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
