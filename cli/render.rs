//! `caustica render`: load, check the outputs, run the driver with a progress bar, write, report.

use crate::args::RenderArgs;
use crate::display::DisplayServer;
use crate::outputs::{
    check_frame_outputs, check_outputs, check_part_output, denoised_path, inputs, is_exr, output_paths,
};
use crate::profile::SystemProfile;
use crate::report::{Timing, print_report};
use anyhow::{Context, Result};
use caustica::Renderer;
use caustica::driver::StopReason;
use caustica::driver::init_thread_pools;
use caustica::files::{overwritten_input, same_file};
use caustica::film::accumulator;
use caustica::film::aov::Aov;
use caustica::film::output;
use caustica::scene::{self, RunFile};
use caustica::trace::TraceStatistics;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

const DEFAULT_SCENE: &str = "scenes/default.toml";

fn default_scene() -> PathBuf {
    let here = PathBuf::from(DEFAULT_SCENE);
    if here.exists() { here } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_SCENE) }
}

/// Render the scene `args` name (or the default one) and write its outputs; a time limit counts from
/// `start`, the command's. Returns whether the render ran to its end (false: a signal stopped it, and
/// the image so far was written).
pub fn render(args: &RenderArgs, profile: Option<&SystemProfile>, start: Instant) -> Result<bool> {
    init_thread_pools(args.threads.map(usize::from));
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    if scene_path.is_dir() {
        anyhow::bail!(
            "{} is a directory: name a run file (.toml) or a glTF file (.gltf, .glb)",
            scene_path.display()
        );
    }
    let (scene, mut run) = scene::load_with_sets(&scene_path, &args.set, |run| args.apply(run))?;
    spp_as_passes(args, &mut run)?;
    let outputs = output_paths(args, &run, &scene_path);
    let denoised = if args.denoise { outputs.iter().map(|o| denoised_path(o)).collect() } else { Vec::new() };
    // Every file the command writes goes through the same checks: not an input, not another output.
    let guide_image = args.guiding_debug.map(|_| guide_path(&outputs[0]));
    let all_outputs: Vec<PathBuf> = outputs.iter().chain(&denoised).chain(&guide_image).cloned().collect();
    if guide_image.is_some() && run.frames.range().is_some() {
        anyhow::bail!(
            "--guiding-debug writes one image of what the guide learnt; with --frames there is a guide a \
             frame: render the frame you want to look at without --frames"
        );
    }
    check_outputs(&all_outputs, &inputs(args, &run, &scene_path))?;
    // The summary says which outputs replaced a file (a second run with other settings overwrites
    // the first's image).
    let existed: Vec<PathBuf> = all_outputs.iter().filter(|p| p.exists()).cloned().collect();
    let written_aovs = run.film.aovs.clone();
    if !written_aovs.is_empty() && args.part.is_none() && !outputs.iter().any(|o| is_exr(o)) {
        anyhow::bail!(
            "feature images (--aov) are written as layers of an EXR: name an output FILE.exr (-o), not only {}",
            outputs.iter().map(|o| o.display().to_string()).collect::<Vec<_>>().join(", ")
        );
    }
    if args.denoise {
        crate::denoiser::check()?;
        if args.part.is_some() {
            anyhow::bail!("--denoise needs the whole image: denoise the merged parts instead");
        }
        // The denoiser's guides.
        for aov in [Aov::Albedo, Aov::Normal] {
            if !run.film.aovs.contains(&aov) {
                run.film.aovs.push(aov);
            }
        }
    }
    if run.frames.shutter > 0.0 && run.frames.range().is_none() {
        anyhow::bail!("--shutter blurs an animation's frames by its motion: give --frames START:END too");
    }
    if let Some(range) = run.frames.range() {
        check_frame_outputs(&all_outputs, range, &inputs(args, &run, &scene_path))?;
        return crate::frames::render_frames(
            args,
            &scene_path,
            scene,
            &run,
            (&outputs, &written_aovs),
            &denoised,
            start,
        );
    }
    if args.part.is_some() {
        check_part_output(&outputs)?;
    }
    if args.part.is_some() && (args.checkpoint.is_some() || args.resume.is_some()) {
        anyhow::bail!("--part renders a share of its own; it does not combine with --checkpoint or --resume");
    }
    let resumed =
        args.resume.as_deref().map(|path| crate::checkpoint::read_resume(path, &scene, &run)).transpose()?;
    // A resumed render goes on checkpointing to the file it resumed, unless told another: else a
    // second stop would leave only the old checkpoint.
    let mut checkpoints = match args.checkpoint.as_ref().or(args.resume.as_ref()) {
        Some(path) => {
            // Every file the run reads but the checkpoint it resumes from, which it goes on writing.
            let read = inputs(args, &run, &scene_path);
            let read = read.iter().filter(|p| !args.resume.as_deref().is_some_and(|r| same_file(r, p)));
            if let Some(other) = overwritten_input(path, all_outputs.iter().chain(read).map(PathBuf::as_path))
            {
                anyhow::bail!(
                    "{}: the checkpoint is also {}, which this run reads or writes: refusing to overwrite it",
                    path.display(),
                    other.display()
                );
            }
            if !is_exr(path) {
                anyhow::bail!("{}: a checkpoint is an EXR accumulator: name it FILE.exr", path.display());
            }
            output::check_output_path(path)?;
            Some(crate::checkpoint::Checkpoints::new(path, args.checkpoint_every, &scene, &run)?)
        }
        None => None,
    };
    let reference = args.reference.as_deref().map(output::read_exr).transpose()?;
    let preparing = || format!("preparing {}", scene_path.display());
    let (mut renderer, part) = match args.part {
        Some((i, k)) => {
            let (renderer, info) = Renderer::for_share(scene, &run, i, k).with_context(preparing)?;
            (renderer, Some(info))
        }
        None => (Renderer::new(scene, &run).with_context(preparing)?, None),
    };
    // Loading and building the scene (decoding, the BVH's build) can peak above what the render is
    // counted to hold: that peak has happened, so it is measured rather than counted.
    let loaded_peak = caustica::memory::peak_resident_bytes().unwrap_or(0);
    if let Some(reference) = &reference {
        let film = renderer.report();
        if (reference.width, reference.height) != (film.width, film.height) {
            anyhow::bail!(
                "the reference {} is {}x{} but the image will be {}x{}",
                args.reference.as_deref().unwrap_or(Path::new("")).display(),
                reference.width,
                reference.height,
                film.width,
                film.height
            );
        }
    }
    if profile.is_some() {
        renderer.world.insert_resource(TraceStatistics::default());
    }
    crate::signals::watch_for_signals(&renderer);
    let mut display = args.display_server.as_deref().and_then(|address| {
        let report = renderer.report();
        let name = scene_path.file_name().map_or("caustica".into(), |n| n.to_string_lossy().into_owned());
        DisplayServer::connect(address, &name, report.width, report.height)
            .map_err(|e| tracing::warn!("no live preview: cannot reach tev at {address}: {e}"))
            .ok()
    });
    renderer.set_max_pass(run.output.write_every);
    if let Some(resumed) = resumed {
        resumed.apply(&mut renderer)?;
        if !args.quiet {
            let progress = renderer.progress();
            eprintln!(
                "resumed     {} at {:.0} of {} {}",
                args.resume.as_deref().unwrap_or(Path::new("")).display(),
                progress.done,
                progress.target,
                progress.unit.name()
            );
        }
    }
    // Rates and ETAs count what this run renders, not what a checkpoint brought.
    let started_at = renderer.progress().done;
    if let Some(checkpoints) = &mut checkpoints {
        checkpoints.configure(&mut renderer)?;
    }

    let bar = progress_bar(&renderer, args.quiet);
    let mut log = crate::progress_log::ProgressLog::new(args.quiet, started_at);
    let render_start = Instant::now();
    let setup = start.elapsed().as_secs_f64();
    // What loading and preparing left of the limit. With none left the render still starts and
    // stops at its first check of the limit, so the image is written as a stopped render's is.
    let left = run.render.time_limit.map(|limit| (limit - setup).max(0.0));
    let mut written_marks = 0;
    let mut report = renderer.run(left, |renderer| {
        if let Some(checkpoints) = &mut checkpoints
            && let Err(e) = checkpoints.write_if_due(renderer)
        {
            bar.suspend(|| tracing::warn!("{e:#}; rendering goes on"));
        }
        let progress = renderer.progress();
        let seconds = render_start.elapsed().as_secs_f64();
        show_progress(&bar, &progress, seconds, started_at);
        log.update(&progress, seconds);
        if let Some(server) = &mut display
            && server.due()
            && let Err(e) = server.update(&renderer.image())
        {
            bar.suspend(|| tracing::warn!("the live preview stopped: {e}"));
            display = None;
        }
        // The image so far every K samples per pixel or passes, so that a long render can be looked at
        // while it runs. A write that fails is reported and the render goes on: the final write
        // tries again.
        let Some(k) = run.output.write_every else { return };
        let marks = progress.done as u32 / k;
        if marks > written_marks && progress.done < progress.target as f64 {
            written_marks = marks;
            for e in write_outputs(renderer, &renderer.image(), &outputs, &written_aovs, &run) {
                bar.suspend(|| tracing::warn!("{e}; rendering goes on"));
            }
        }
    });
    let rendered_at = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    // The last checkpoint: at the end, or where a signal stopped the render (between passes).
    let checkpoint_failed = checkpoints.as_mut().and_then(|c| c.write(&renderer).err());
    let image = renderer.image();
    if let Some(server) = &mut display
        && let Err(e) = server.update(&image)
    {
        tracing::warn!("the live preview did not get the final image: {e}");
    }
    let failed: Vec<String> = match &part {
        Some(info) => accumulator::write_part(renderer.film(), info, &outputs[0])
            .err()
            .into_iter()
            .map(|e| e.to_string())
            .collect(),
        None => write_outputs(&renderer, &image, &outputs, &written_aovs, &run),
    };
    if let (Some((x, y)), Some(path)) = (args.guiding_debug, &guide_image) {
        write_guide_image(&renderer, x, y, path);
    }
    let denoise_failed = if args.denoise && part.is_none() {
        write_denoised(&renderer, &image, &denoised, &run).err()
    } else {
        None
    };
    // A share reports what it rendered itself, not where it ends in the whole render's units.
    if let Some(info) = &part {
        report.done -= info.samples.start as f64;
        report.target = info.samples.len() as u32;
    }
    let timing = Timing {
        total: start.elapsed().as_secs_f64(),
        rendering: report.seconds,
        setup,
        rendered_at,
        limit: run.render.time_limit,
        frames: None,
    };
    print_report(&scene_path, &report, &timing);
    if let Some(info) = &part {
        outln!(
            "part        {}/{}: units {}..{} of {} {}",
            info.part,
            info.parts,
            info.samples.start,
            info.samples.end,
            info.spp,
            report.unit.name()
        );
    }
    if let Some(profile) = profile {
        outln!("\nper-system profile (tracing spans)\n{}", profile.table());
        if let Some(mut statistics) = renderer.world.get_resource_mut::<TraceStatistics>() {
            outln!("trace counters (BVH8: nodes = inner nodes, leaves = packs of 8 triangles or a sphere)");
            outln!("{}", profile.trace_table(&statistics.totals()));
            if let Some(line) = lanes_line(&statistics.vertex_totals()) {
                outln!("{line}");
            }
        }
    }
    if let Some(reference) = &reference {
        let e = caustica::film::compare::compare(&image, reference).expect("sizes checked before rendering");
        outln!("error       RMSE {:.5}  relMSE {:.5}  MAE {:.5}", e.rmse, e.relmse, e.mae);
    }
    for path in outputs.iter().chain(denoised.iter().filter(|_| denoise_failed.is_none())) {
        let replaced = if existed.contains(path) { " (replaced the file that was there)" } else { "" };
        outln!("wrote       {}{replaced}", path.display());
    }
    if let Some(checkpoints) = &checkpoints {
        outln!("checkpoints {}", checkpoints.summary());
    }
    if let Some(peak) = caustica::memory::peak_resident_bytes() {
        let counted =
            checkpoints.as_ref().map_or(renderer.memory_counted(), |c| c.memory_counted).max(loaded_peak);
        let mib = |b: u64| b.div_ceil(1 << 20);
        outln!(
            "memory      peak {} MiB resident; counted {} MiB before rendering, budget {} MiB",
            mib(peak),
            mib(counted),
            mib(renderer.memory_budget())
        );
    }
    if let Some(e) = checkpoint_failed {
        anyhow::bail!("the checkpoint was not written: {e:#}");
    }
    if !failed.is_empty() {
        anyhow::bail!("{}", failed.join("; "));
    }
    if let Some(e) = denoise_failed {
        return Err(e);
    }
    Ok(report.stopped_by != Some(StopReason::Interrupted))
}

/// The profile's line on camera vertices: the share each lane class shaded, and the scalar kernel's.
fn lanes_line(totals: &caustica::trace::VertexTotals) -> Option<String> {
    use caustica::kernel::lanes::LaneClass;
    let all: u64 = totals.iter().sum();
    if all == 0 {
        return None;
    }
    let share = |n: u64| 100.0 * n as f64 / all as f64;
    let lanes = all - totals[LaneClass::Scalar.index()];
    let classes: Vec<String> =
        LaneClass::ALL.iter().map(|c| format!("{} {:.1}%", c.name(), share(totals[c.index()]))).collect();
    Some(format!("camera vertices {all}: {:.1}% in lanes ({})", share(lanes), classes.join(", ")))
}

/// Where `--guiding-debug` writes its image: `NAME-guide.exr` beside the first output `NAME.EXT`.
fn guide_path(output: &Path) -> PathBuf {
    output.with_file_name(format!(
        "{}-guide.exr",
        output.file_stem().map_or("render".into(), |s| s.to_string_lossy())
    ))
}

/// `--guiding-debug X,Y`: what the guide learnt where pixel X,Y looks, to `path` (checked with the
/// outputs before the render).
fn write_guide_image(renderer: &Renderer, x: u32, y: u32, path: &Path) {
    match caustica::camera_paths::guide::learnt_at_pixel(&renderer.world, x, y) {
        Some((p, share, image)) => match output::write_image(&image, path, 0.0) {
            Ok(()) => outln!("guide       at {p} (pixel {x},{y}), BSDF share {share}: {}", path.display()),
            Err(e) => tracing::warn!("--guiding-debug: {e}"),
        },
        None => tracing::warn!(
            "--guiding-debug {x},{y}: no guide there (no --guiding, off the film, or no surface)"
        ),
    }
}

/// Denoise `image` with the render's albedo and normal and write it to every path of `denoised`.
fn write_denoised(
    renderer: &Renderer,
    image: &caustica::film::Image,
    denoised: &[PathBuf],
    run: &RunFile,
) -> Result<()> {
    let features = renderer.aov_images().context("the render made no albedo and normal to denoise with")?;
    let start = Instant::now();
    let clean = crate::denoiser::denoise(image, &features)?;
    tracing::info!("denoised in {:.3} s", start.elapsed().as_secs_f64());
    for path in denoised {
        output::write_image(&clean, path, run.film.exposure)?;
    }
    Ok(())
}

/// Write `image` to every output, with the feature images `aovs` as layers of the EXRs; the
/// errors of the writes that failed.
fn write_outputs(
    renderer: &Renderer,
    image: &caustica::film::Image,
    outputs: &[PathBuf],
    aovs: &[Aov],
    run: &RunFile,
) -> Vec<String> {
    let features = renderer.aov_images();
    let aovs = features.as_ref().map(|f| (f, aovs));
    outputs
        .iter()
        .filter_map(|path| output::write_image_with_aovs(image, aovs, path, run.film.exposure).err())
        .map(|e| e.to_string())
        .collect()
}

/// `--spp` for an integrator that counts passes: sppm, appm, cppm and pppm trace one camera sample a
/// pixel each pass, so N samples are N passes (said, not silently ignored as it was), unless
/// `--passes` says how many; ppm traces its camera samples once, as its hit points, so there N
/// samples are N hit points a pixel.
fn spp_as_passes(args: &RenderArgs, run: &mut RunFile) -> Result<()> {
    let integrator = caustica::integrators::of(run.render.integrator);
    let Some(spp) = args.spp.filter(|_| integrator.unit == caustica::plan::Unit::Passes) else {
        return Ok(());
    };
    let name = integrator.name();
    if integrator.hit_points_traced_once {
        // ppm's camera samples are its hit points, traced once: N samples a pixel are N hit points.
        match args.hit_points_per_pixel {
            Some(hit_points) if hit_points != spp => tracing::warn!(
                "ppm traces its camera samples once, as hit points: --hit-points-per-pixel {hit_points} is \
                 used, not --spp {spp}"
            ),
            Some(_) => {}
            None => {
                // A pixel's hit points are a (0, m, 2)-net: a power of two, at most 256.
                let hit_points = spp.max(1).checked_next_power_of_two().unwrap_or(256).min(256);
                run.progressive.hit_points_per_pixel = Some(hit_points);
                tracing::warn!(
                    "ppm traces its camera samples once, as hit points (a power of two a pixel, at most 256): \
                     --spp {spp} traces {hit_points} a pixel"
                );
            }
        }
        return Ok(());
    }
    match args.passes {
        Some(passes) if passes != spp => {
            tracing::warn!(
                "{name} counts passes of one camera sample a pixel: --passes {passes} is used, not --spp {spp}"
            )
        }
        Some(_) => {}
        None => {
            run.progressive.passes = spp;
            tracing::warn!(
                "{name} counts passes of one camera sample a pixel: --spp {spp} renders {spp} passes"
            );
        }
    }
    Ok(())
}

/// A bar over the samples per pixel or passes aimed at, or a spinner when a time limit alone bounds
/// the render; its message is updated by [`show_progress`].
fn progress_bar(renderer: &Renderer, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let target = renderer.target();
    if target == u32::MAX {
        let bar = ProgressBar::new_spinner();
        bar.set_style(ProgressStyle::with_template("{spinner} {msg}  {elapsed}").expect("valid template"));
        bar.enable_steady_tick(std::time::Duration::from_millis(250));
        return bar;
    }
    let bar = ProgressBar::new(target as u64 * 100);
    bar.set_style(ProgressStyle::with_template("{bar:40} {msg}  ETA {eta}").expect("valid template"));
    bar
}

/// "12.3/64 spp, 5.1 spp/s" or "17/64 passes, 2.3 passes/s".
fn show_progress(bar: &ProgressBar, progress: &caustica::Progress, seconds: f64, started_at: f64) {
    let unit = progress.unit.name();
    let target = if progress.target == u32::MAX { String::new() } else { format!("/{}", progress.target) };
    let rate = (progress.done - started_at).max(0.0) / seconds.max(1e-9);
    bar.set_message(format!("{:.1}{target} {unit}, {rate:.2} {unit}/s", progress.done));
    bar.set_position((progress.done * 100.0) as u64);
}
