//! The same scene, seed and sample count give the same bits whatever the thread count.

mod common;

use caustica::film::output::read_exr;
use std::process::Command;

fn render_with_threads(threads: u32, out: &std::path::Path, scene: &str, integrator: &str) {
    // "pt-tree", "pt-visibility": path tracing with the light tree, and with learned visibility.
    let (integrator, selection) = match integrator {
        "pt-tree" => ("pt", "tree"),
        "pt-visibility" => ("pt", "visibility"),
        other => (other, "power"),
    };
    let status = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(["render", scene, "--spp", "4", "--width", "48", "--height", "48", "--quiet", "--seed", "7"])
        .args(["--light-selection", selection])
        .args(["--integrator", integrator, "--photons", "20000", "--caustic-photons", "20000"])
        .args(["--passes", "3", "--photons-per-pass", "20000"])
        .args(["--threads", &threads.to_string(), "-o"])
        .arg(out)
        .status()
        .expect("caustica runs");
    assert!(status.success(), "render with {threads} threads failed");
}

#[test]
fn one_and_two_threads_give_bit_identical_images() {
    let dir = std::env::temp_dir().join(format!("caustica-determinism-{}", std::process::id()));
    // pm: photon passes, kd-tree builds and lookups must be thread-independent too; sppm and cppm:
    // photon deposits into hit points, the radius updates and the χ² cells as well.
    for (scene, integrator) in [
        ("cornell-spheres.gltf", "pt"),
        ("cornell-box.gltf", "pt"),
        ("cornell-spheres.gltf", "pm"),
        ("cornell-spheres.gltf", "sppm"),
        ("cornell-box.gltf", "cppm"),
        ("cornell-spheres.gltf", "pt-tree"),
        ("cornell-box.gltf", "pt-visibility"),
        // The environment: a map sampled for NEE and emitting photons, and the default white one.
        ("scenes/environment.toml", "pt-tree"),
        ("scenes/environment.toml", "sppm"),
        ("gltf-samples/BoxTextured.gltf", "pm"),
    ] {
        let path = match scene.strip_prefix("scenes/") {
            Some(name) => std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name),
            None => common::data(scene),
        };
        let scene = path.to_str().unwrap();
        let (a, b) = (dir.join("t1.exr"), dir.join("t2.exr"));
        render_with_threads(1, &a, scene, integrator);
        render_with_threads(2, &b, scene, integrator);
        let (a, b) = (read_exr(&a).unwrap(), read_exr(&b).unwrap());
        assert!(a.mean().max_element() > 0.0, "{scene}: black image");
        let same = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits));
        assert!(same, "{scene}, {integrator}: images differ between 1 and 2 threads");
    }
    std::fs::remove_dir_all(dir).ok();
}
