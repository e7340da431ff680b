//! The same scene, seed and sample count give the same bits whatever the thread count.

use crate::common;

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

/// Every integrator on the glass-and-mirror box at 1, 2 and 3 threads (an odd count splits the
/// wavefront unevenly), and the light selections and the environment at 1 and 2.
#[test]
fn one_two_and_three_threads_give_bit_identical_images() {
    let dir = std::env::temp_dir().join(format!("caustica-determinism-{}", std::process::id()));
    // pm: photon passes, kd-tree builds and lookups must be thread-independent too; the progressive
    // ones: photon deposits into hit points, the radius updates, the χ² cells and the Laplacians.
    let every_integrator = caustica::integrators::ALL.map(|i| ("cornell-spheres.gltf", i.name(), 3));
    for (scene, integrator, max_threads) in every_integrator.into_iter().chain([
        ("cornell-box.gltf", "pt", 2),
        ("cornell-spheres.gltf", "pt-tree", 2),
        ("cornell-box.gltf", "pt-visibility", 2),
        // The environment: a map sampled for NEE and emitting photons, and the default white one.
        ("scenes/environment.toml", "pt-tree", 2),
        ("scenes/environment.toml", "sppm", 2),
        ("gltf-samples/BoxTextured.gltf", "pm", 2),
    ]) {
        let path = match scene.strip_prefix("scenes/") {
            Some(name) => std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name),
            None => common::data(scene),
        };
        let scene = path.to_str().unwrap();
        let first = dir.join("t1.exr");
        render_with_threads(1, &first, scene, integrator);
        let a = read_exr(&first).unwrap();
        assert!(a.mean().max_element() > 0.0, "{scene}: black image");
        for threads in 2..=max_threads {
            let other = dir.join(format!("t{threads}.exr"));
            render_with_threads(threads, &other, scene, integrator);
            let b = read_exr(&other).unwrap();
            let same = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits));
            assert!(same, "{scene}, {integrator}: images differ between 1 and {threads} threads");
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

/// `pt` and `pt-naive` run on shards of `render.chunk` camera paths each, one shard per thread:
/// the image is the same bits for any chunk size and thread count, with feature images, adaptive
/// sampling and visibility-aware light selection too (each adds a column or a shared resource).
/// So does `lt`, whose light subpaths run on shards of their own (their indices handed out from one
/// counter): with its camera rays and feature images, and under point lights alone, without.
#[test]
fn chunk_sizes_and_thread_counts_give_bit_identical_path_traced_images() {
    let dir = std::env::temp_dir().join(format!("caustica-chunks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = common::data("cornell-spheres.gltf");
    let punctual = common::data("punctual-lights.gltf");
    let render = |threads: u32, chunk: u32, extra: &[&str], name: &str| {
        let out = dir.join(format!("{name}-{threads}-{chunk}.exr"));
        let scene = if name == "lt-punctual" { &punctual } else { &scene };
        let status = Command::new(env!("CARGO_BIN_EXE_caustica"))
            .arg("render")
            .arg(scene)
            .args(["--spp", "6", "--width", "40", "--height", "30", "--quiet", "--seed", "3"])
            .args(["--threads", &threads.to_string(), "--set", &format!("render.chunk={chunk}"), "-o"])
            .arg(&out)
            .args(extra)
            .status()
            .expect("caustica runs");
        assert!(status.success(), "{name}: {threads} threads, chunk {chunk} failed");
        let image = read_exr(&out).unwrap();
        image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>()
    };
    for (name, extra) in [
        ("pt", &[][..]),
        ("pt-naive", &["--integrator", "pt-naive"][..]),
        ("pt-visibility", &["--light-selection", "visibility"][..]),
        (
            "pt-adaptive-aov",
            &["--noise-threshold", "0.2", "--min-spp", "2", "--aov", "albedo,normal,depth"][..],
        ),
        ("lt-aov", &["--integrator", "lt", "--aov", "albedo,normal,depth"][..]),
        ("lt-punctual", &["--integrator", "lt"][..]),
    ] {
        let first = render(1, 4096, extra, name);
        for (threads, chunk) in [(1, 1), (1, 7), (2, 64), (3, 13), (2, 4096)] {
            assert!(
                render(threads, chunk, extra, name) == first,
                "{name}: {threads} threads with chunks of {chunk} paths differ from one thread with 4096"
            );
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

/// Many workers on a small film: each keeps at most its share of the film in flight, and no more
/// workers than the film can keep busy make a shard (with 1024 threads on a 32² film every worker
/// spawned a World and a full chunk, 4 million paths and gigabytes), and the bits are those of two
/// workers.
#[test]
fn many_workers_on_a_small_film_keep_their_share_and_the_bits() {
    use caustica::Renderer;
    use caustica::scene::load;
    caustica::driver::init_thread_pools(None);
    let (scene, mut run) = load(&common::data("cornell-box.gltf")).unwrap();
    (run.film.width, run.film.height, run.render.spp, run.render.seed) = (Some(32), Some(32), 2, 3);
    let bits = |image: caustica::film::Image| -> Vec<[u32; 3]> {
        image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    };
    let two = bits(common::render(scene.clone(), &run));
    let workers = 64;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(workers).build().unwrap();
    let (image, report) = pool.install(|| {
        let mut renderer = Renderer::new(scene, &run).unwrap();
        let report = renderer.run(None, |_| {});
        (renderer.image(), report)
    });
    // A share of 1024 / 64 = 16 pixels, raised to the smallest chunk that is cut (64 rows), in at
    // most 1024 / 64 = 16 shards: no more paths in flight than the film has pixels.
    assert!(report.wavefront <= 1024, "{} paths in flight for a 1024-pixel film", report.wavefront);
    assert_eq!(bits(image), two);
}
