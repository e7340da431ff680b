//! The end-of-run report, printed the same way for every integrator: what is there is shown.

use caustica::Choice;
use caustica::Report;
use caustica::plan::Unit;
use std::path::Path;

/// Print `report` of a render of `scene` that took `total_seconds` with loading.
pub fn print_report(scene: &Path, report: &Report, total_seconds: f64) {
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
    outln!("time        {total_seconds:.3} s total, {:.3} s rendering", report.seconds);
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
