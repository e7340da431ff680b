//! `caustica render --frames START:END`: a file's animation rendered frame by frame on one renderer,
//! each frame posed (only the moving meshes' BVH rebuilt), rendered from a black film, written, and
//! its time accounted (pose, BVH, lights, render, denoise, write).

use crate::args::RenderArgs;
use crate::report::{Timing, print_report};
use anyhow::{Context, Result};
use caustica::Renderer;
use caustica::driver::{FrameRun, StopReason};
use caustica::film::aov::Aov;
use caustica::film::output;
use caustica::scene::{RunFile, Scene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The outputs of frame `frame`: each name's run of `#` replaced by the frame number, zero-padded to
/// the run's length; a name without one gets `-NNNN` before its extension.
pub fn frame_path(path: &Path, frame: u32) -> PathBuf {
    let name = path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
    let named = match name.find('#') {
        Some(start) => {
            let run = name[start..].chars().take_while(|&c| c == '#').count();
            format!("{}{frame:0run$}{}", &name[..start], &name[start + run..])
        }
        None => {
            let path = Path::new(&name);
            let stem = path.file_stem().map_or(String::new(), |s| s.to_string_lossy().into_owned());
            match path.extension() {
                Some(ext) => format!("{stem}-{frame:04}.{}", ext.to_string_lossy()),
                None => format!("{stem}-{frame:04}"),
            }
        }
    };
    path.with_file_name(named)
}

/// Where one frame's time went, in seconds.
#[derive(Clone, Copy, Debug, Default)]
struct FrameTimes {
    pose: f64,
    bvh: f64,
    lights: f64,
    render: f64,
    denoise: f64,
    write: f64,
}

impl FrameTimes {
    fn add(&mut self, other: &Self) {
        self.pose += other.pose;
        self.bvh += other.bvh;
        self.lights += other.lights;
        self.render += other.render;
        self.denoise += other.denoise;
        self.write += other.write;
    }

    fn line(&self, scale: f64) -> String {
        let ms = |s: f64| s * scale * 1e3;
        format!(
            "pose {:.2} ms, BVH {:.2} ms, lights {:.2} ms, render {:.1} ms, denoise {:.1} ms, write {:.1} ms",
            ms(self.pose),
            ms(self.bvh),
            ms(self.lights),
            ms(self.render),
            ms(self.denoise),
            ms(self.write)
        )
    }
}

/// Render frames `range` of `scene`'s animation to `outputs` (patterns, [`frame_path`]), denoised
/// copies too when `denoised` names them. Returns whether every frame was rendered (false: a
/// signal stopped it after writing the frame in flight).
pub fn render_frames(
    args: &RenderArgs,
    scene_path: &Path,
    scene: Scene,
    run: &RunFile,
    (outputs, aovs): (&[PathBuf], &[Aov]),
    denoised: &[PathBuf],
    start: Instant,
) -> Result<bool> {
    let range = run.frames.range().expect("called for an animation");
    if args.part.is_some() || args.checkpoint.is_some() || args.resume.is_some() || args.reference.is_some() {
        anyhow::bail!(
            "--frames renders whole frames: it does not combine with --part, --checkpoint, --resume or --reference"
        );
    }
    let Some(animation) = scene.animation.clone() else {
        anyhow::bail!(
            "{}: the file has no animation (no glTF `animations` moving nodes): --frames has nothing to play",
            scene_path.display()
        );
    };
    let fps = run.frames.fps;
    let last_time = (range.end - 1) as f32 / fps;
    if last_time > animation.duration {
        tracing::warn!(
            "{}: the animation ends at {:.3} s; frames after frame {} hold its last pose",
            scene_path.display(),
            animation.duration,
            (animation.duration * fps).floor()
        );
    }
    let mut frame_run = FrameRun::new(scene, run).context(format!("preparing {}", scene_path.display()))?;
    let setup = start.elapsed().as_secs_f64();
    crate::signals::watch_for_signals(frame_run.renderer());
    let frames = range.len() as u64;
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(frames) };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} frame {pos}/{len} {msg}  ETA {eta}").expect("valid"),
    );
    let mut total = FrameTimes::default();
    let mut kept_photons = 0;
    let mut rendered = 0u32;
    let mut last_report = None;
    for frame in range.clone() {
        let time = frame as f32 / fps;
        let mut times = FrameTimes::default();
        if frame != range.start || time != 0.0 {
            let update = frame_run.set_time(time).with_context(|| format!("frame {frame} at {time} s"))?;
            times.pose = update.pose_seconds + update.camera_seconds;
            times.bvh = update.scene.geometry_seconds;
            times.lights = update.scene.lights_seconds;
            kept_photons += update.photons_kept as u32;
        }
        // Posing a frame lowers the renderer's interrupt flag: a signal that came since the last
        // frame was written ends the animation here, before a frame it would cut short.
        if crate::signals::signalled() && last_report.is_some() {
            break;
        }
        let render_start = Instant::now();
        let show = |r: &Renderer| {
            let p = r.progress();
            bar.set_message(format!("{:.1}/{} {}", p.done, p.target, p.unit.name()));
        };
        let report = match run.frames.shutter_of(frame) {
            Some(shutter) => frame_run.run_over_shutter(shutter, run.render.time_limit, show)?,
            None => frame_run.renderer_mut().run(run.render.time_limit, show),
        };
        times.render = render_start.elapsed().as_secs_f64();
        let renderer = frame_run.renderer();
        let image = renderer.image();
        let write_start = Instant::now();
        let features = renderer.aov_images();
        for pattern in outputs {
            let path = frame_path(pattern, frame);
            output::write_image_with_aovs(
                &image,
                features.as_ref().map(|f| (f, aovs)),
                &path,
                run.film.exposure,
            )?;
        }
        times.write = write_start.elapsed().as_secs_f64();
        if !denoised.is_empty() {
            let denoise_start = Instant::now();
            let features = features.context("the render made no albedo and normal to denoise with")?;
            let clean = crate::denoiser::denoise(&image, &features)?;
            times.denoise = denoise_start.elapsed().as_secs_f64();
            let write_start = Instant::now();
            for pattern in denoised {
                output::write_image(&clean, &frame_path(pattern, frame), run.film.exposure)?;
            }
            times.write += write_start.elapsed().as_secs_f64();
        }
        bar.suspend(|| outln!("frame {frame:>5}  t {time:.3} s  {}", times.line(1.0)));
        bar.inc(1);
        total.add(&times);
        rendered += 1;
        let interrupted = report.stopped_by == Some(StopReason::Interrupted);
        last_report = Some(report);
        if interrupted {
            break;
        }
    }
    bar.finish_and_clear();
    let mut report = last_report.expect("at least one frame");
    // A signal between two frames stopped no render: the summary says why the frames end anyway.
    if rendered as usize != range.len() && crate::signals::signalled() {
        report.stopped_by = Some(StopReason::Interrupted);
    }
    // The time line sums the frames' renders (each frame's line shows its own): the last frame's
    // alone, as the summary's other lines are, read as the whole animation's rendering time.
    let timing = Timing {
        total: start.elapsed().as_secs_f64(),
        rendering: total.render,
        setup,
        rendered_at: start.elapsed().as_secs_f64(),
        limit: run.render.time_limit,
        frames: Some(rendered),
    };
    print_report(scene_path, &report, &timing);
    outln!(
        "frames      {rendered} of {} ({}:{} at {fps} fps), {:.3} s; mean per frame: {}",
        range.len(),
        range.start,
        range.end,
        start.elapsed().as_secs_f64(),
        total.line(1.0 / rendered.max(1) as f64)
    );
    outln!(
        "            the lines from `integrator` to `NaN/Inf` above are frame {}'s alone, the last rendered",
        range.start + rendered - 1
    );
    if kept_photons > 0 {
        outln!(
            "photons     traced for the first frame and kept for the {kept_photons} after it: the animation moves only the camera"
        );
    }
    for pattern in outputs.iter().chain(denoised) {
        outln!(
            "wrote       {} .. {}",
            frame_path(pattern, range.start).display(),
            frame_path(pattern, range.start + rendered - 1).display()
        );
    }
    Ok(rendered as usize == range.len())
}

#[cfg(test)]
mod tests {
    use super::frame_path;
    use std::path::{Path, PathBuf};

    #[test]
    fn frame_numbers_fill_the_hashes_or_follow_the_stem() {
        assert_eq!(frame_path(Path::new("out/frame-####.exr"), 7), PathBuf::from("out/frame-0007.exr"));
        assert_eq!(frame_path(Path::new("out/f##.png"), 123), PathBuf::from("out/f123.png"));
        assert_eq!(frame_path(Path::new("out/a#b.png"), 5), PathBuf::from("out/a5b.png"));
        assert_eq!(frame_path(Path::new("out/render.exr"), 12), PathBuf::from("out/render-0012.exr"));
        // A directory named with # is left alone: only the file name is a pattern.
        assert_eq!(frame_path(Path::new("o#/x.png"), 1), PathBuf::from("o#/x-0001.png"));
    }
}
