//! The end-of-run report, printed the same way for every integrator: what is there is shown.

use caustica::Choice;
use caustica::Report;
use caustica::plan::Unit;
use std::path::Path;

/// Where a command's time went, in seconds from its start, for the summary's `time` lines.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timing {
    /// The whole command: loading, preparing, rendering, writing.
    pub total: f64,
    /// Rendering: the driver's passes; of an animation, every frame's render summed.
    pub rendering: f64,
    /// Loading and preparing, before the first render began.
    pub setup: f64,
    /// When the (last) render stopped.
    pub rendered_at: f64,
    /// `--time-limit`, seconds.
    pub limit: Option<f64>,
    /// An animation's frames rendered: each frame had the limit to itself.
    pub frames: Option<u32>,
}

impl Timing {
    /// The summary's `time` line, and a `time limit` line saying what the limit covered.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = vec![match self.frames {
            None => format!("time        {:.3} s total, {:.3} s rendering", self.total, self.rendering),
            Some(frames) => format!(
                "time        {:.3} s total, {:.3} s rendering over {frames} frame{} (mean {:.3} s a frame)",
                self.total,
                self.rendering,
                if frames == 1 { "" } else { "s" },
                self.rendering / frames.max(1) as f64
            ),
        }];
        let Some(limit) = self.limit else { return lines };
        lines.push(match self.frames {
            // An animation's frames each get the whole limit, as they each get the whole --spp.
            Some(_) => format!(
                "time limit  {limit} s for each frame's rendering (loading, posing and writing are not in it)"
            ),
            None if self.setup >= limit => format!(
                "time limit  {limit} s from the command's start, all of it spent loading and preparing \
                 ({:.3} s): the render had none left and stopped at its first check of it; writing took \
                 {:.3} s after it",
                self.setup,
                self.total - self.rendered_at
            ),
            None => format!(
                "time limit  {limit} s from the command's start: loading and preparing took {:.3} s, the \
                 render had the {:.3} s left and ended at {:.3} s; writing took {:.3} s after it",
                self.setup,
                limit - self.setup,
                self.rendered_at,
                self.total - self.rendered_at
            ),
        });
        lines
    }
}

/// Print `report` of a render of `scene`, with where its time went.
pub fn print_report(scene: &Path, report: &Report, timing: &Timing) {
    let seconds = report.seconds.max(1e-9);
    outln!("scene       {}", scene.display());
    outln!(
        "integrator  {}, {} {}{}, {}x{}",
        report.integrator.name(),
        format_progress(report.done),
        report.unit.name(),
        match report.target {
            u32::MAX => String::new(),
            target if report.done < target as f64 => format!(" of {target}"),
            _ => String::new(),
        },
        report.width,
        report.height
    );
    for line in timing.lines() {
        outln!("{line}");
    }
    match report.stopped_by {
        Some(caustica::driver::StopReason::TimeLimit) => outln!("stopped     by the time limit"),
        Some(caustica::driver::StopReason::Interrupted) => {
            outln!("stopped     by a signal (Ctrl-C or SIGTERM): the image so far")
        }
        None => {}
    }
    if let Some(a) = &report.adaptive {
        let e = &a.estimate;
        outln!(
            "adaptive    threshold {}: {} samples, {} of {} pixels converged ({:.1}%), {}-{} spp per pixel",
            a.threshold,
            report.paths.samples,
            e.converged,
            e.pixels,
            100.0 * e.converged as f64 / e.pixels.max(1) as f64,
            a.fewest,
            a.most
        );
        outln!(
            "estimated   relMSE {:.3e} (mean squared relative error of the pixels, from their samples), largest pixel error {:.3}",
            e.relmse,
            e.max_error
        );
    }
    outln!("phases      {}", phases(report));
    let paths = &report.paths;
    outln!("samples/s   {:.3} M", report.samples_per_second() / 1e6);
    outln!(
        "rays/s      {:.3} M ({} rays, {} shadow rays)",
        report.rays_per_second() / 1e6,
        paths.rays,
        paths.shadow_rays
    );
    if report.unit == Unit::Samples {
        // Sharded paths count the rows each step ran over; one wavefront, its size every step.
        let slot_steps = if paths.slot_steps > 0 {
            paths.slot_steps as f64
        } else {
            paths.steps as f64 * report.wavefront as f64
        };
        outln!(
            "wavefront   {} paths, {} steps, {:.0}% busy",
            report.wavefront,
            paths.steps,
            100.0 * paths.rays as f64 / slot_steps.max(1.0)
        );
    }
    if paths.lookups > 0 {
        outln!(
            "lookups     {} k-nearest queries, {:.3} M/s",
            paths.lookups,
            paths.lookups as f64 / seconds / 1e6
        );
    }
    if let Some(photons) = &report.photons {
        let photon_seconds = report.phase_seconds("photons").max(1e-9);
        outln!(
            "photons     {} emitted, {} stored, {} traced, {} ended by roulette; {:.2} M photons/s",
            photons.emitted,
            photons.stored,
            photons.traced,
            photons.roulette_kills,
            photons.emitted as f64 / photon_seconds / 1e6
        );
        for map in &photons.maps {
            outln!(
                "photon map  {}: {} emitted, {} stored ({:.1} MB)",
                Report::map_name(map.kind),
                map.emitted,
                map.stored,
                map.bytes as f64 / 1e6
            );
        }
    }
    for (label, text) in &report.notes {
        outln!("{label:<11} {text}");
    }
    if let Some(hp) = &report.hit_points {
        outln!(
            "hit points  {} ({} per pixel, {} bytes each with their camera path), mean radius {:.4e} (initial {:.4e})",
            hp.count,
            hp.per_pixel,
            hp.bytes_each,
            hp.mean_radius,
            hp.initial_radius
        );
    }
    match &report.photons {
        Some(photons) => outln!(
            "NaN/Inf     {} samples, {} photon contributions dropped",
            paths.nan_samples,
            photons.dropped
        ),
        None => outln!("NaN/Inf     {} samples dropped", paths.nan_samples),
    }
    if let Some(bad) = &paths.first_bad {
        let (x, y) = (bad.pixel % report.width, bad.pixel / report.width);
        let cause = bad.cause.map_or("its radiance".to_owned(), |(what, depth)| {
            format!("{} at depth {depth}", what.describe())
        });
        outln!(
            "            the first: pixel ({x}, {y}), sample {}, {cause} went NaN or infinite; seed {}, pixel and \
             sample give every random number of it again",
            bad.sample,
            report.seed
        );
    }
    if let Some(pass) = report.photons.as_ref().and_then(|p| p.first_dropped_pass) {
        outln!("            the first photon contribution dropped in pass {pass}");
    }
}

/// Whole numbers without decimals, fractions (a time limit cut the pass) with two.
fn format_progress(done: f64) -> String {
    if done.fract() == 0.0 { format!("{done:.0}") } else { format!("{done:.2}") }
}

/// The phases' times, phases of the same name summed, in the order they first ran.
fn phases(report: &Report) -> String {
    let mut merged: Vec<(&str, f64)> = Vec::new();
    for phase in report.phases.iter().filter(|p| p.runs > 0) {
        match merged.iter_mut().find(|(name, _)| *name == phase.name) {
            Some((_, seconds)) => *seconds += phase.seconds,
            None => merged.push((phase.name, phase.seconds)),
        }
    }
    merged.iter().map(|(name, seconds)| format!("{name} {seconds:.3} s")).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::Timing;

    #[test]
    fn the_time_lines_say_what_the_limit_covered() {
        let render =
            Timing { total: 21.0, rendering: 17.5, setup: 2.5, rendered_at: 20.2, ..Default::default() };
        assert_eq!(render.lines(), ["time        21.000 s total, 17.500 s rendering"]);
        let limited = Timing { limit: Some(20.0), ..render };
        assert_eq!(
            limited.lines()[1],
            "time limit  20 s from the command's start: loading and preparing took 2.500 s, the render had \
             the 17.500 s left and ended at 20.200 s; writing took 0.800 s after it"
        );
        let spent = Timing { limit: Some(2.0), ..render };
        assert!(
            spent.lines()[1].contains("all of it spent loading and preparing (2.500 s)"),
            "{:?}",
            spent.lines()
        );
        let frames = Timing { frames: Some(4), rendering: 73.6, limit: Some(20.0), ..render };
        assert_eq!(
            frames.lines()[0],
            "time        21.000 s total, 73.600 s rendering over 4 frames (mean 18.400 s a frame)"
        );
        assert!(frames.lines()[1].contains("20 s for each frame's rendering"));
    }
}
