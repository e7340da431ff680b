//! The `caustica` command: load a scene, render it, write the images, report.

use anyhow::{Context, Result};
use args::{Cli, Command, RenderArgs};
use caustica::film::{compare::compare, output};
use profile::SystemProfile;
use caustica::scene;
use caustica::render::{init_thread_pools, prepare};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;
use tracing_subscriber::EnvFilter;

mod args;
mod bench;
mod density_plot;
mod profile;
mod progressive;

const DEFAULT_SCENE: &str = "scenes/default.toml";

fn main() -> Result<()> {
    let cli = Cli::parse();
    let render_args = match &cli.command {
        Some(Command::Render(args)) => (**args).clone(),
        _ => RenderArgs::default(),
    };
    let profile = render_args.profile.then(SystemProfile::default);
    let _chrome_guard = install_subscriber(profile.as_ref(), render_args.trace_chrome.as_deref())?;
    match cli.command {
        None | Some(Command::Render(_)) => {
            render(&render_args)?;
            if let Some(profile) = profile {
                println!("\nper-system profile (tracing spans)\n{}", profile.table());
            }
            Ok(())
        }
        Some(Command::Compare { image, reference, window }) => {
            compare_files(&image, &reference, window.as_deref())
        }
        Some(Command::Bench(args)) => {
            init_thread_pools(None);
            let report = bench::run(&args)?;
            if let Some(reference) = &report.rendered_reference {
                println!(
                    "reference   none given: rendered one with {} for {:.0} s (seed + 1) -> {}",
                    bench::integrator_name(args.reference_integrator),
                    args.reference_time.unwrap_or(4.0 * args.time),
                    reference.display()
                );
            }
            for c in &report.checkpoints {
                println!(
                    "{:<6} {:>9.3} s {:>10.1} spp|passes  relMSE {:.6}  RMSE {:.6}",
                    bench::integrator_name(c.integrator),
                    c.seconds,
                    c.samples_or_passes,
                    c.relmse,
                    c.rmse
                );
            }
            for path in &report.files {
                println!("wrote       {}", path.display());
            }
            Ok(())
        }
        Some(Command::Density(args)) => {
            let summary = density_plot::run(&args)?;
            println!(
                "{} points, h = {:.4} ({}); wrote {}",
                summary.n,
                summary.h,
                summary.h_rule,
                args.output.display()
            );
            Ok(())
        }
    }
}

/// Log to stderr (RUST_LOG, default warn), plus the profile and Chrome-trace layers when asked for.
/// The log filter applies to the log layer only, so the others see every system span.
fn install_subscriber(
    profile: Option<&SystemProfile>,
    chrome: Option<&Path>,
) -> Result<Option<tracing_chrome::FlushGuard>> {
    use tracing_subscriber::prelude::*;
    let log_filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("warn"));
    if profile.is_none() && chrome.is_none() {
        // A global filter disables the per-system spans at their call sites: no cost at all.
        tracing_subscriber::fmt().with_env_filter(log_filter).with_writer(std::io::stderr).init();
        return Ok(None);
    }
    let log = tracing_subscriber::fmt::layer().with_writer(std::io::stderr).with_filter(log_filter);
    let (chrome_layer, guard) = match chrome {
        Some(path) => {
            let file = std::fs::File::create(path)
                .with_context(|| format!("{}: cannot create the Chrome trace", path.display()))?;
            let (layer, guard) = tracing_chrome::ChromeLayerBuilder::new()
                .writer(std::io::BufWriter::new(file))
                .name_fn(Box::new(|event_or_span| match event_or_span {
                    tracing_chrome::EventOrSpan::Span(span) => profile::span_label(span),
                    tracing_chrome::EventOrSpan::Event(event) => event.metadata().name().to_owned(),
                }))
                .build();
            (Some(layer), Some(guard))
        }
        None => (None, None),
    };
    // The profile layer records span names that the Chrome layer's labels read, so it goes first.
    let names = profile.cloned().unwrap_or_default().layer();
    tracing_subscriber::registry().with(names).with(chrome_layer).with(log).init();
    Ok(guard)
}

fn default_scene() -> PathBuf {
    let here = PathBuf::from(DEFAULT_SCENE);
    if here.exists() { here } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_SCENE) }
}

fn render(args: &RenderArgs) -> Result<()> {
    let start = Instant::now();
    init_thread_pools(args.threads);
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    let (scene, run) = scene::load_with(&scene_path, |run| args.apply(run))?;
    let outputs = output_paths(args, &run, &scene_path);
    for path in &outputs {
        output::check_output_path(path)?;
    }
    let reference = args.reference.as_deref().map(output::read_exr).transpose()?;
    if run.render.integrator.is_progressive() {
        return progressive::render(
            &scene_path,
            scene,
            &run,
            &outputs,
            reference.as_ref(),
            args.quiet,
            start,
        );
    }

    let mut renderer = prepare(scene, &run).with_context(|| format!("preparing {}", scene_path.display()))?;
    let total = renderer.world.resource::<caustica::resources::Workload>().total_samples();
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(total) };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} samples  {per_sec}  ETA {eta}")
            .expect("valid template"),
    );
    let summary = renderer.run_until(run.render.time_limit, |stats| bar.set_position(stats.samples));
    bar.finish_and_clear();
    let image = renderer.image();
    for path in &outputs {
        output::write_image(&image, path, run.film.exposure)?;
    }

    let s = summary.stats;
    let wall = start.elapsed().as_secs_f64();
    println!("scene       {}", scene_path.display());
    println!(
        "integrator  {:?}, {} spp, {}x{}",
        run.render.integrator, run.render.spp, image.width, image.height
    );
    println!("time        {wall:.3} s total, {:.3} s rendering", summary.seconds);
    println!("samples/s   {:.3} M", s.samples as f64 / summary.seconds / 1e6);
    println!(
        "rays/s      {:.3} M ({} rays, {} shadow rays)",
        (s.rays + s.shadow_rays) as f64 / summary.seconds / 1e6,
        s.rays,
        s.shadow_rays
    );
    let wavefront = renderer.world.resource::<caustica::resources::Workload>().wavefront;
    println!(
        "wavefront   {} paths, {} steps, {:.0}% busy",
        wavefront,
        s.steps,
        100.0 * s.rays as f64 / (s.steps as f64 * wavefront as f64)
    );
    println!("NaN/Inf     {} samples dropped", s.nan_samples);
    if s.lookups > 0 {
        println!(
            "lookups     {} k-nearest queries, {:.3} M/s",
            s.lookups,
            s.lookups as f64 / summary.seconds / 1e6
        );
    }
    if let Some(report) =
        renderer.world.get_resource::<caustica::integrators::photon_map::PhotonReport>()
    {
        for pass in &report.passes {
            println!(
                "photons     {:?}: {} emitted, {} stored ({:.1} MB), {} traced, {} ended by roulette; \
                 trace {:.3} s ({:.2} M photon rays/s), kd-tree {:.3} s",
                pass.kind,
                pass.emitted,
                pass.stored,
                pass.bytes as f64 / 1e6,
                pass.traced,
                pass.roulette_kills,
                pass.trace_seconds,
                pass.traced as f64 / pass.trace_seconds / 1e6,
                pass.build_seconds
            );
        }
    }
    report_error_and_outputs(&image, reference.as_ref(), &outputs)
}

/// The error against the reference, if one was given, and the files written.
fn report_error_and_outputs(
    image: &caustica::film::Image,
    reference: Option<&caustica::film::Image>,
    outputs: &[PathBuf],
) -> Result<()> {
    if let Some(reference) = reference {
        let e = compare(image, reference).context("the reference's size differs from the image")?;
        println!("error       RMSE {:.5}  relMSE {:.5}  MAE {:.5}", e.rmse, e.relmse, e.mae);
    }
    for path in outputs {
        println!("wrote       {}", path.display());
    }
    Ok(())
}

/// `-o` flags, else the run file's `[output]`, else `out/<scene>.exr` and `.png`.
fn output_paths(args: &RenderArgs, run: &scene::RunFile, scene_path: &Path) -> Vec<PathBuf> {
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

fn compare_files(image: &Path, reference: &Path, window: Option<&[u32]>) -> Result<()> {
    let mut a = output::read_exr(image)?;
    let mut b = output::read_exr(reference)?;
    match window {
        Some(&[x0, y0, x1, y1]) => (a, b) = (a.crop(x0, y0, x1, y1), b.crop(x0, y0, x1, y1)),
        Some(w) => anyhow::bail!("--window takes X0,Y0,X1,Y1 (four numbers), got {} numbers", w.len()),
        None => {}
    }
    let e = compare(&a, &b).with_context(|| {
        format!(
            "{} is {}x{} but {} is {}x{}",
            image.display(),
            a.width,
            a.height,
            reference.display(),
            b.width,
            b.height
        )
    })?;
    println!("RMSE {:.6}\nrelMSE {:.6}\nMAE {:.6}", e.rmse, e.relmse, e.mae);
    Ok(())
}
