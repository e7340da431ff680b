//! `caustica bench`: every integrator under the same wall-clock budget, its error against a reference
//! recorded at geometric checkpoints (1, 2, 4, … samples per pixel or passes), written as
//! `errors.csv`, a log-log plot of relMSE against time (PNG and SVG), and a false-colour error image
//! and the final render per integrator.

mod false_colour;
mod plot;

use crate::args::BenchArgs;
use caustica::Renderer;
use caustica::film::Image;
use caustica::film::compare::compare;
use caustica::film::flip::flip;
use caustica::film::output::{read_exr, write_image};
use caustica::scene::{IntegratorKind, LightSelection, RunFile, Scene, load_with};
use caustica::{Choice, Error, Result};
use std::io::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// One measurement.
#[derive(Clone, Copy, Debug)]
pub struct Checkpoint {
    /// Which integrator.
    pub integrator: IntegratorKind,
    /// With which light selection.
    pub light_selection: LightSelection,
    /// Wall time spent rendering so far (measuring the error is not counted).
    pub seconds: f64,
    /// Samples per pixel (path tracing, photon mapping) or passes (progressive photon mapping).
    pub samples_or_passes: f64,
    /// Root-mean-square error.
    pub rmse: f64,
    /// Relative MSE, mean((a − b)² / (b² + 0.01)).
    pub relmse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// Mean LDR-FLIP (`caustica::film::flip`).
    pub flip: f64,
}

/// What a bench run produced.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// Every checkpoint, integrator by integrator, in time order.
    pub checkpoints: Vec<Checkpoint>,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Whether the reference was rendered here (no `--reference`).
    pub rendered_reference: Option<PathBuf>,
}

/// Run the benchmark that `args` describes.
pub fn run(args: &BenchArgs) -> Result<BenchReport> {
    for (name, value) in [("--time", Some(args.time)), ("--reference-time", args.reference_time)] {
        if let Some(v) = value
            && !(v.is_finite() && v > 0.0)
        {
            return Err(Error::Setting { name: name.into(), problem: format!("{v} must be finite and > 0") });
        }
    }
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|source| Error::Io { path: args.out_dir.clone(), source })?;
    let (scene, mut run) = load_with(&args.scene, |run| args.environment.apply(&mut run.environment))?;
    run.render.seed = args.seed.unwrap_or(run.render.seed);
    run.film.width = args.width.or(run.film.width);
    run.film.height = args.height.or(run.film.height);
    run.render.time_limit = None;
    let mut files = Vec::new();
    let mut rendered_reference = None;
    let reference = match &args.reference {
        Some(path) => read_exr(path)?,
        None => {
            let budget = args.reference_time.unwrap_or(4.0 * args.time);
            say(&format!(
                "bench: no --reference: rendering one with {} for {budget:.0} s",
                args.reference_integrator.name()
            ));
            let mut reference_run = run.clone();
            reference_run.render.seed = run.render.seed.wrapping_add(1);
            let image = render_for(&scene, &reference_run, args.reference_integrator, budget, |_, _, _| {})?;
            let path = args.out_dir.join("reference.exr");
            write_image(&image, &path, 0.0)?;
            rendered_reference = Some(path);
            image
        }
    };
    run.film.width = Some(reference.width);
    run.film.height = Some(reference.height);

    let selections = if args.light_selections.is_empty() {
        vec![run.render.light_selection]
    } else {
        args.light_selections.clone()
    };
    let mut checkpoints = Vec::new();
    let mut series = Vec::new();
    let total = args.integrators.len() * selections.len();
    for &integrator in &args.integrators {
        for &light_selection in &selections {
            let name = series_name(integrator, light_selection, selections.len() > 1);
            say(&format!("bench: {name} ({} of {total}) for {:.0} s", series.len() + 1, args.time));
            let mut measure = |seconds: f64, samples_or_passes: f64, image: &Image| {
                if let Some(e) = compare(image, &reference) {
                    checkpoints.push(Checkpoint {
                        integrator,
                        light_selection,
                        seconds,
                        samples_or_passes,
                        rmse: e.rmse,
                        relmse: e.relmse,
                        mae: e.mae,
                        flip: flip(image, &reference).map_or(f64::NAN, |f| f.mean),
                    });
                }
            };
            let mut run = run.clone();
            run.render.light_selection = light_selection;
            let image = render_for(&scene, &run, integrator, args.time, &mut measure)?;
            if let Some(last) = checkpoints.last().filter(|c| c.integrator == integrator) {
                say(&format!(
                    "bench: {name}: {:.1} spp|passes in {:.2} s, relMSE {:.6}",
                    last.samples_or_passes, last.seconds, last.relmse
                ));
            }
            let exr = args.out_dir.join(format!("{name}.exr"));
            write_image(&image, &exr, run.film.exposure)?;
            let error_png = args.out_dir.join(format!("{name}-error.png"));
            false_colour::write_error_image(&image, &reference, &error_png)?;
            let flip_png = args.out_dir.join(format!("{name}-flip.png"));
            write_flip_map(&image, &reference, &flip_png)?;
            files.extend([exr, error_png, flip_png]);
            series.push((integrator, light_selection, name));
        }
    }

    let csv = args.out_dir.join("errors.csv");
    write_csv(&csv, &checkpoints)?;
    files.push(csv);
    let stem = if args.spp_sweep { "relmse-vs-samples" } else { "relmse-vs-time" };
    for ext in ["png", "svg"] {
        let path = args.out_dir.join(format!("{stem}.{ext}"));
        plot::write_plot(&path, &checkpoints, &series, args.spp_sweep)?;
        files.push(path);
    }
    Ok(BenchReport { checkpoints, files, rendered_reference })
}

/// A line on stderr, so that a long bench shows where it is while stdout keeps its table.
fn say(line: &str) {
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// A series' name: the integrator, and the light selection when several are compared (`pt-tree`).
pub fn series_name(integrator: IntegratorKind, selection: LightSelection, with_selection: bool) -> String {
    if with_selection {
        format!("{}-{}", integrator.name(), selection.name())
    } else {
        integrator.name().to_owned()
    }
}

/// Render `scene` with `integrator` for `budget` seconds (at least its first sample per pixel or
/// pass), calling `measure(seconds, samples or passes, image)` after 1, 2, 4, … samples per pixel
/// or passes and at the end.
fn render_for(
    scene: &Scene,
    run: &RunFile,
    integrator: IntegratorKind,
    budget: f64,
    mut measure: impl FnMut(f64, f64, &Image),
) -> Result<Image> {
    let mut run = run.clone();
    run.render.integrator = integrator;
    (run.render.spp, run.progressive.passes) = (1, 1);
    let start = Instant::now();
    let mut renderer = Renderer::new(scene.clone(), &run)?;
    let mut rendering = start.elapsed().as_secs_f64();
    let mut target = 1;
    loop {
        let step = Instant::now();
        renderer.set_target(target);
        // The first sample or pass runs whole whatever the budget: a measurement of nothing (a
        // photon pass the limit dropped) is a black image at 0 spp, which a log axis cannot place
        // and which says nothing of the integrator.
        let limit = (target > 1).then(|| (budget - rendering).max(0.0));
        renderer.run(limit, |_| {});
        rendering += step.elapsed().as_secs_f64();
        let image = renderer.image();
        measure(rendering, renderer.progress().done, &image);
        if rendering >= budget {
            return Ok(image);
        }
        target *= 2;
    }
}

/// Print what a bench run measured and wrote.
pub fn print(args: &BenchArgs, report: &BenchReport) {
    if let Some(reference) = &report.rendered_reference {
        outln!(
            "reference   none given: rendered one with {} for {:.0} s (seed + 1) -> {}",
            args.reference_integrator.name(),
            args.reference_time.unwrap_or(4.0 * args.time),
            reference.display()
        );
    }
    for c in &report.checkpoints {
        outln!(
            "{:<6} {:>9.3} s {:>10.1} spp|passes  relMSE {:.6}  RMSE {:.6}  FLIP {:.4}",
            c.integrator.name(),
            c.seconds,
            c.samples_or_passes,
            c.relmse,
            c.rmse,
            c.flip
        );
    }
    for path in &report.files {
        outln!("wrote       {}", path.display());
    }
}

/// FLIP's per-pixel error map of `image` against `reference`, through its magma colour map.
fn write_flip_map(image: &Image, reference: &Image, path: &std::path::Path) -> Result<()> {
    let Some(map) = flip(image, reference) else { return Ok(()) };
    let io = |message: String| Error::Output { path: path.to_path_buf(), message };
    image::save_buffer(path, &map.magma(), map.width, map.height, image::ExtendedColorType::Rgb8)
        .map_err(|e| io(e.to_string()))
}

fn write_csv(path: &std::path::Path, checkpoints: &[Checkpoint]) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut file = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(file, "integrator,seconds,samples_or_passes,rmse,relmse,mae,flip,light_selection")
        .map_err(io)?;
    for c in checkpoints {
        writeln!(
            file,
            "{},{:.6},{:.4},{:.8},{:.8},{:.8},{:.8},{}",
            c.integrator.name(),
            c.seconds,
            c.samples_or_passes,
            c.rmse,
            c.relmse,
            c.mae,
            c.flip,
            c.light_selection.name()
        )
        .map_err(io)?;
    }
    file.flush().map_err(io)
}
