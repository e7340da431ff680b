//! `caustica render` for the progressive photon mappers: passes with a progress bar, partial images,
//! and the end-of-run report.

use anyhow::{Context, Result};
use caustica::film::output;
use caustica::scene::{RunFile, Scene};
use caustica::progressive::{BYTES_PER_PIXEL, prepare_progressive};
use caustica::resources::PhotonStats;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Render `scene` with `run`'s progressive integrator and write `outputs`.
pub fn render(
    scene_path: &Path,
    scene: Scene,
    run: &RunFile,
    outputs: &[PathBuf],
    reference: Option<&caustica::film::Image>,
    quiet: bool,
    start: Instant,
) -> Result<()> {
    let mut renderer =
        prepare_progressive(scene, run).with_context(|| format!("preparing {}", scene_path.display()))?;
    let settings = run.progressive;
    let bar = if quiet { ProgressBar::hidden() } else { ProgressBar::new(settings.passes as u64) };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} passes  {msg}  ETA {eta}")
            .expect("valid template"),
    );
    let (mut photon_seconds, mut gather_seconds, mut camera_seconds, mut stored) = (0.0, 0.0, 0.0, 0u64);
    let mut write_error = None;
    let seconds = renderer.run(run.render.time_limit, |renderer, pass| {
        photon_seconds += pass.photon_seconds;
        gather_seconds += pass.gather_seconds;
        camera_seconds += pass.camera_seconds;
        stored += pass.stored as u64;
        let rate = settings.photons_per_pass as f64 / pass.photon_seconds.max(1e-9) / 1e6;
        bar.set_position(pass.passes as u64);
        bar.set_message(format!("{rate:.2} M photons/s  mean radius {:.3e}", renderer.mean_radius()));
        if let Some(k) = run.output.write_every
            && k > 0
            && pass.passes % k == 0
            && write_error.is_none()
        {
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
    for path in outputs {
        output::write_image(&image, path, run.film.exposure)?;
    }

    let photons = renderer.world.resource::<PhotonStats>();
    let passes = renderer.passes;
    let emitted = renderer.photons_emitted();
    println!("scene       {}", scene_path.display());
    println!(
        "integrator  {:?}, {passes} passes × {} photons, α = {}, {}x{}",
        run.render.integrator, settings.photons_per_pass, settings.alpha, image.width, image.height
    );
    println!("time        {:.3} s total, {seconds:.3} s rendering", start.elapsed().as_secs_f64());
    println!(
        "stages      camera {camera_seconds:.3} s, photons {photon_seconds:.3} s, gather + update {gather_seconds:.3} s"
    );
    println!(
        "photons     {emitted} emitted, {stored} stored, {} traced, {} ended by roulette; {:.2} M photons/s",
        photons.traced,
        photons.roulette_kills,
        emitted as f64 / photon_seconds.max(1e-9) / 1e6
    );
    println!(
        "hit points  {} ({BYTES_PER_PIXEL} bytes each with their camera path), mean radius {:.4e}",
        image.pixels.len(),
        renderer.mean_radius()
    );
    println!(
        "NaN/Inf     {} samples, {} photon contributions dropped",
        renderer.world.resource::<caustica::resources::RenderStats>().nan_samples,
        renderer.dropped_photons()
    );
    super::report_error_and_outputs(&image, reference, outputs)
}
