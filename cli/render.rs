//! `caustica render`: load, check the outputs, run the driver with a progress bar, write, report.

use crate::args::RenderArgs;
use crate::report::print_report;
use anyhow::{Context, Result};
use caustica::Renderer;
use caustica::driver::init_thread_pools;
use caustica::film::output;
use caustica::scene::{self, RunFile};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

const DEFAULT_SCENE: &str = "scenes/default.toml";

fn default_scene() -> PathBuf {
    let here = PathBuf::from(DEFAULT_SCENE);
    if here.exists() { here } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_SCENE) }
}

/// Render the scene `args` name (or the default one) and write its outputs.
pub fn render(args: &RenderArgs) -> Result<()> {
    let start = Instant::now();
    init_thread_pools(args.threads.map(usize::from));
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    let (scene, run) = scene::load_with(&scene_path, |run| args.apply(run))?;
    let outputs = output_paths(args, &run, &scene_path);
    for path in &outputs {
        output::check_output_path(path)?;
    }
    let reference = args.reference.as_deref().map(output::read_exr).transpose()?;
    let mut renderer =
        Renderer::new(scene, &run).with_context(|| format!("preparing {}", scene_path.display()))?;

    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(renderer.target() as u64) };
    let template = format!("{{bar:40}} {{pos}}/{{len}} {}  {{msg}}  ETA {{eta}}", renderer.plan.unit.name());
    bar.set_style(ProgressStyle::with_template(&template).expect("valid template"));
    let (mut written_after, mut write_error) = (0, None);
    let report = renderer.run(run.render.time_limit, |renderer| {
        bar.set_position(renderer.progress().done as u64);
        // The image so far every K passes, so that a long render can be looked at while it runs.
        let passes = renderer.passes();
        if let Some(k) = run.output.write_every.filter(|&k| k > 0)
            && passes % k == 0
            && passes > written_after
            && write_error.is_none()
        {
            written_after = passes;
            let image = renderer.image();
            write_error = outputs
                .iter()
                .map(|p| output::write_image(&image, p, run.film.exposure))
                .find_map(|r| r.err());
        }
    });
    bar.finish_and_clear();
    if let Some(e) = write_error {
        return Err(e.into());
    }
    let image = renderer.image();
    for path in &outputs {
        output::write_image(&image, path, run.film.exposure)?;
    }
    print_report(&scene_path, &report, start.elapsed().as_secs_f64());
    if let Some(reference) = &reference {
        let e = caustica::film::compare::compare(&image, reference)
            .context("the reference's size differs from the image")?;
        println!("error       RMSE {:.5}  relMSE {:.5}  MAE {:.5}", e.rmse, e.relmse, e.mae);
    }
    for path in &outputs {
        println!("wrote       {}", path.display());
    }
    Ok(())
}

/// `-o` flags, else the run file's `[output]`, else `out/<scene>.exr` and `.png`.
fn output_paths(args: &RenderArgs, run: &RunFile, scene_path: &Path) -> Vec<PathBuf> {
    if !args.output.is_empty() {
        return args.output.clone();
    }
    let listed: Vec<PathBuf> = [&run.output.exr, &run.output.png].into_iter().flatten().cloned().collect();
    if !listed.is_empty() {
        return listed;
    }
    let stem = scene_path.file_stem().map_or("render".into(), |s| s.to_string_lossy().into_owned());
    vec![PathBuf::from(format!("out/{stem}.exr")), PathBuf::from(format!("out/{stem}.png"))]
}
