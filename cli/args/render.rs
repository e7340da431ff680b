//! The flags of `caustica render`, and how they override the run file.

use super::EnvironmentArgs;
use super::values::{Triple, choice, parse_frames, parse_part, parse_pixel};
use caustica::density::Kernel;
use caustica::film::aov::Aov;
use caustica::sampling::SamplerKind;
use caustica::scene::{FilterKind, IntegratorKind, LightSelection, RunFile};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `caustica render`. Negative numbers are values (`--spp -1` is refused as a count,
/// not met with clap's tip to write `-- -1`).
#[derive(Args, Debug, Default, Clone)]
#[command(allow_negative_numbers = true)]
pub struct RenderArgs {
    /// Run file or glTF to render (default: scenes/default.toml).
    pub scene: Option<PathBuf>,
    /// Samples per pixel; overrides the run file.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Integrator; overrides the run file.
    #[arg(long, value_parser = choice::<IntegratorKind>())]
    pub integrator: Option<IntegratorKind>,
    /// How next-event estimation picks a light; overrides the run file.
    #[arg(long, value_parser = choice::<LightSelection>())]
    pub light_selection: Option<LightSelection>,
    /// Sampler seed; overrides the run file.
    #[arg(long)]
    pub seed: Option<u64>,
    /// How sample numbers are drawn (default sobol); overrides the run file.
    #[arg(long, value_parser = choice::<SamplerKind>())]
    pub sampler: Option<SamplerKind>,
    /// Worker threads, 1 to 1024 (default: all cores). The image does not depend on it.
    // The cap: thousands of threads cost seconds of startup and can fail to spawn, for no speed.
    #[arg(long, visible_alias = "nthreads", value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub threads: Option<u16>,
    /// Image width; overrides the run file and the glTF's extras.
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height; overrides the run file and the glTF's extras.
    #[arg(long)]
    pub height: Option<u32>,
    /// Maximum bounces (default unbounded, Russian roulette ends paths); overrides the run file.
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// First bounce at which Russian roulette may end a path; overrides the run file.
    #[arg(long)]
    pub rr_depth: Option<u32>,
    /// Pixel reconstruction filter; overrides the run file.
    #[arg(long, value_parser = choice::<FilterKind>())]
    pub filter: Option<FilterKind>,
    /// PNG exposure in stops; overrides the run file.
    #[arg(long)]
    pub exposure: Option<f32>,
    /// Feature images to write as layers of the EXR output (comma-separated); overrides the run file.
    #[arg(long = "aov", value_delimiter = ',', value_parser = choice::<Aov>())]
    pub aovs: Vec<Aov>,
    /// glTF camera to use, by name; overrides the run file.
    #[arg(long)]
    pub camera: Option<String>,
    /// Camera position X,Y,Z; overrides the file's camera (or the automatic framing).
    #[arg(long, value_name = "X,Y,Z")]
    pub eye: Option<Triple>,
    /// Point the camera looks at, X,Y,Z.
    #[arg(long, value_name = "X,Y,Z")]
    pub target: Option<Triple>,
    /// Camera up vector X,Y,Z (default +Y when a target is given).
    #[arg(long, value_name = "X,Y,Z")]
    pub up: Option<Triple>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEGREES")]
    pub yfov: Option<f32>,
    /// The environment light.
    #[command(flatten)]
    pub environment: EnvironmentArgs,
    /// Output image(s), .exr (linear) or .png (sRGB); repeatable; overrides the run file. With
    /// --frames, a run of # in the name is the frame number, zero-padded to as many digits
    /// (`out/frame-####.exr`); without one, `-NNNN` is added before the extension.
    #[arg(short, long, visible_alias = "outfile")]
    pub output: Vec<PathBuf>,
    /// Render frames START to END (END not included) of the file's animations, one image each, frame
    /// f at time f / fps: `--frames 0:48`; overrides the run file's `[frames]`.
    #[arg(long, value_name = "START:END", value_parser = parse_frames)]
    pub frames: Option<(u32, u32)>,
    /// Frames per second of --frames (default 24).
    #[arg(long)]
    pub fps: Option<f32>,
    /// With --frames: blur each frame by the animation over a shutter open this many frames,
    /// centred on the frame's time (0.5: a 180° shutter), each sample per pixel (or pass) at its
    /// own time in it; pt, sppm and the others that trace every pass anew (not pm or ppm).
    #[arg(long, value_name = "FRAMES")]
    pub shutter: Option<f32>,
    /// Set any run-file key, KEY=VALUE, as `render.spp=256` or `camera.eye=[0, 1, 3]` (a value that is
    /// not TOML is taken as a string: `render.integrator=sppm`); the common keys without their table
    /// (`spp=256`, `passes=64`, `width=800`: those Python's keyword overrides take); `-D` as in
    /// Mitsuba; repeatable; other flags win over it.
    #[arg(long = "set", short = 'D', value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Photon mapping: photons for the global map.
    #[arg(long)]
    pub photons: Option<u32>,
    /// Photon mapping: photons for the caustic map.
    #[arg(long)]
    pub caustic_photons: Option<u32>,
    /// Photon mapping: photons per radiance estimate.
    #[arg(long)]
    pub k: Option<u32>,
    /// Photon mapping: largest gather radius (scene units).
    #[arg(long)]
    pub max_radius: Option<f32>,
    /// Photon mapping: density kernel over the gather disc.
    #[arg(long, value_parser = choice::<Kernel>())]
    pub kernel: Option<Kernel>,
    /// Photon mapping: final-gather rays per pixel sample (0 = read the global map directly).
    #[arg(long)]
    pub final_gather: Option<u32>,
    /// Progressive photon mapping: photon passes; overrides the run file.
    #[arg(long)]
    pub passes: Option<u32>,
    /// Progressive photon mapping: photons emitted per pass; overrides the run file.
    #[arg(long)]
    pub photons_per_pass: Option<u32>,
    /// Progressive photon mapping: fraction α of each pass's photons kept (0 < α ≤ 1); overrides the run file.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// Progressive photon mapping: first gather radius in scene units; overrides the run file.
    #[arg(long)]
    pub initial_radius: Option<f32>,
    /// The process's peak resident memory, MiB (default: half the RAM): the scene as built, plus the
    /// film, paths, photons, hit points, the written image and checkpoints, counted before any is
    /// allocated; overrides the run file.
    #[arg(long)]
    pub memory_budget_mib: Option<u64>,
    /// Progressive photon mapping: hit points per pixel, a power of two, stratified over the pixel
    /// filter (default 32 for ppm, 1 for the others); overrides the run file.
    #[arg(long)]
    pub hit_points_per_pixel: Option<u32>,
    /// Stop this many seconds after the command started, loading and preparing included (with
    /// --frames: of each frame's rendering); overrides the run file. One rule for a limit given on
    /// the command line, here or as --set render.time_limit: without samples given there too
    /// (--spp, --passes, --set render.spp or progressive.passes) it renders until the limit,
    /// however many samples or passes that is; with them, whichever comes first. A run file's own
    /// time_limit stops its spp or passes early.
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Path guiding (pt, pt-naive): training passes of 1, 2, 4, … samples per pixel learn where light
    /// comes from, and the rest sample by it too (run file: `[guiding] enabled = true`).
    #[arg(long)]
    pub guiding: bool,
    /// With --guiding: write what the guide learnt at the surface pixel X,Y sees, as an image of the
    /// sphere (φ across, cos θ down), beside the first output as NAME-guide.exr.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel)]
    pub guiding_debug: Option<(u32, u32)>,
    /// Adaptive sampling (pt, pt-naive): a pixel stops taking samples once its estimated relative
    /// error is under this (0.01 = 1%), and --spp is the most a pixel takes; 0 turns it off;
    /// overrides the run file. With --time-limit: until the limit or every pixel under it.
    #[arg(long, value_name = "ERROR")]
    pub noise_threshold: Option<f64>,
    /// Adaptive sampling: samples every pixel takes before it may stop (default 16); overrides the
    /// run file.
    #[arg(long)]
    pub min_spp: Option<u32>,
    /// Also write the outputs every K samples per pixel or passes (the integrator's unit), so a long
    /// render can be looked at; overrides the run file.
    #[arg(long)]
    pub write_every: Option<u32>,
    /// Print a per-system profile (calls, total, %, mean, min, max) at exit.
    #[arg(long)]
    pub profile: bool,
    /// Write a Chrome trace (open in ui.perfetto.dev or chrome://tracing) with one event per system run.
    #[arg(long, value_name = "FILE.json")]
    pub trace_chrome: Option<PathBuf>,
    /// Show the image as it converges in the tev viewer listening at HOST:PORT (tev's default is
    /// 127.0.0.1:14158).
    #[arg(long, value_name = "HOST:PORT")]
    pub display_server: Option<String>,
    /// Reference EXR: print the error of the result against it.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Render only share I of K of the samples (pt, pt-naive, pm, lt) or passes (pppm) and write an
    /// accumulator EXR (its exact sums) to the one `-o FILE.exr`; `caustica merge` makes the image
    /// of all K.
    #[arg(long, value_name = "I/K", value_parser = parse_part)]
    pub part: Option<(u32, u32)>,
    /// Write a checkpoint (an accumulator EXR of the whole passes so far) to FILE every
    /// --checkpoint-every seconds, on SIGINT or SIGTERM, and at the end (every integrator).
    #[arg(long, value_name = "FILE.exr")]
    pub checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub checkpoint_every: f64,
    /// Continue the render a checkpoint holds (the same scene and settings; --spp or --passes may
    /// raise the target): once it reaches the target, the same bits as a render never stopped. It
    /// goes on checkpointing to that file (or to --checkpoint FILE).
    #[arg(long, value_name = "FILE.exr")]
    pub resume: Option<PathBuf>,
    /// Also write each output denoised by Intel Open Image Denoise, guided by albedo and normal, as
    /// NAME-denoised.EXT beside it (a build with feature `denoise`; README, "Denoising").
    #[arg(long)]
    pub denoise: bool,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// A budget on the command line replaces the run file's, wherever the run file put it.
fn apply_memory_budget(run: &mut RunFile, mib: Option<u64>) {
    if let Some(mib) = mib {
        run.render.memory_budget_mib = Some(mib);
        run.progressive.memory_budget_mib = None;
    }
}

impl RenderArgs {
    /// Apply the command-line overrides to a run file.
    pub fn apply(&self, run: &mut RunFile) {
        let r = &mut run.render;
        r.spp = self.spp.unwrap_or(r.spp);
        r.integrator = self.integrator.unwrap_or(r.integrator);
        r.light_selection = self.light_selection.unwrap_or(r.light_selection);
        r.seed = self.seed.unwrap_or(r.seed);
        r.sampler = self.sampler.unwrap_or(r.sampler);
        r.max_depth = self.max_depth.or(r.max_depth);
        r.rr_depth = self.rr_depth.unwrap_or(r.rr_depth);
        r.time_limit = self.time_limit.or(r.time_limit);
        r.noise_threshold = self.noise_threshold.unwrap_or(r.noise_threshold);
        r.min_spp = self.min_spp.unwrap_or(r.min_spp);
        run.guiding.enabled |= self.guiding;
        // A time limit on the command line without samples there is the budget: render until it,
        // whatever the run file's spp or passes. The same rule for --time-limit and --set.
        use caustica::scene::run_file::assigns;
        let limit_here = self.time_limit.is_some() || assigns(&self.set, "render.time_limit");
        let samples_here = self.spp.is_some()
            || self.passes.is_some()
            || assigns(&self.set, "render.spp")
            || assigns(&self.set, "progressive.passes");
        let until_the_limit = limit_here && !samples_here;
        if until_the_limit {
            r.spp = u32::MAX;
        }
        let g = &mut run.progressive;
        g.passes = self.passes.unwrap_or(if until_the_limit { u32::MAX } else { g.passes });
        g.photons_per_pass = self.photons_per_pass.unwrap_or(g.photons_per_pass);
        g.alpha = self.alpha.unwrap_or(g.alpha);
        g.initial_radius = self.initial_radius.or(g.initial_radius);
        g.hit_points_per_pixel = self.hit_points_per_pixel.or(g.hit_points_per_pixel);
        run.output.write_every = self.write_every.or(run.output.write_every);
        if let Some((start, end)) = self.frames {
            (run.frames.start, run.frames.end) = (start, Some(end));
        }
        run.frames.fps = self.fps.unwrap_or(run.frames.fps);
        run.frames.shutter = self.shutter.unwrap_or(run.frames.shutter);
        let p = &mut run.photons;
        p.photons = self.photons.unwrap_or(p.photons);
        p.caustic_photons = self.caustic_photons.unwrap_or(p.caustic_photons);
        p.k = self.k.unwrap_or(p.k);
        p.max_radius = self.max_radius.or(p.max_radius);
        p.kernel = self.kernel.unwrap_or(p.kernel);
        p.final_gather = self.final_gather.unwrap_or(p.final_gather);
        let f = &mut run.film;
        f.width = self.width.or(f.width);
        f.height = self.height.or(f.height);
        f.filter = self.filter.unwrap_or(f.filter);
        f.exposure = self.exposure.unwrap_or(f.exposure);
        if !self.aovs.is_empty() {
            f.aovs = self.aovs.clone();
        }
        let c = &mut run.camera;
        if self.camera.is_some() {
            c.name = self.camera.clone();
        }
        c.eye = self.eye.map(|t| t.0).or(c.eye);
        c.target = self.target.map(|t| t.0).or(c.target);
        c.up = self.up.map(|t| t.0).or(c.up);
        c.yfov_degrees = self.yfov.or(c.yfov_degrees);
        self.environment.apply(&mut run.environment);
        apply_memory_budget(run, self.memory_budget_mib);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::{Cli, Command};
    use caustica::scene::environment::EnvironmentRadiance;
    use clap::Parser;
    use glam::Vec3;

    fn render_args(args: &[&str]) -> RenderArgs {
        let cli = Cli::try_parse_from(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        let Some(Command::Render(args)) = cli.command else { panic!("a render command") };
        *args
    }

    /// A run file with a constant environment and a map beside it, in a fresh directory.
    fn outdoor(test: &str) -> (std::path::PathBuf, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("caustica-args-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let sky = dir.join("sky.exr");
        let image = caustica::film::Image { width: 4, height: 2, pixels: vec![Vec3::ONE; 8] };
        caustica::film::output::write_image(&image, &sky, 0.0).unwrap();
        let run = dir.join("outdoor.toml");
        let spheres = "[[sphere]]\nname = \"ball\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n\
                       material = { base_color = [0.5, 0.5, 0.5] }\n";
        std::fs::write(&run, format!("[environment]\ncolor = [0.1, 0.2, 0.3]\n\n{spheres}")).unwrap();
        (run, sky)
    }

    #[test]
    fn environment_flags_choose_over_the_run_file() {
        let (path, sky) = outdoor("flags");
        let args = render_args(&[
            "caustica",
            "render",
            "x.toml",
            "--environment",
            sky.to_str().unwrap(),
            "--environment-strength",
            "3",
        ]);
        let (scene, run) = caustica::scene::load_with(&path, |run| args.apply(run)).expect("loads");
        assert_eq!(run.environment.color, None, "a map on the command line replaces the run file's colour");
        let env = scene.environment.expect("environment");
        assert!(matches!(env.radiance, EnvironmentRadiance::Map(_)));
        assert_eq!(env.strength, 3.0);

        let args = render_args(&["caustica", "render", "x.toml", "--environment-color", "1,0.5,0.25"]);
        let (scene, _) = caustica::scene::load_with(&path, |run| args.apply(run)).expect("loads");
        let env = scene.environment.expect("environment");
        assert_eq!(env.radiance, EnvironmentRadiance::Constant(Vec3::new(1.0, 0.5, 0.25)));
    }

    #[test]
    fn malformed_colours_and_conflicting_flags_are_refused_by_the_parser() {
        for args in [
            vec!["caustica", "render", "--environment-color", "1,2"],
            vec!["caustica", "render", "--environment-color", "1,x,2"],
            vec!["caustica", "render", "--eye", "1,2,inf"],
            vec!["caustica", "render", "--environment", "a.exr", "--environment-color", "1,1,1"],
            vec!["caustica", "render", "--integrator", "ptt"],
        ] {
            assert!(Cli::try_parse_from(&args).is_err(), "{args:?} parsed");
        }
        let (path, _) = outdoor("negative-strength");
        let args = render_args(&["caustica", "render", "--environment-strength=-1"]);
        let error = caustica::scene::load_with(&path, |run| args.apply(run)).expect_err("negative strength");
        assert!(error.to_string().contains("environment.strength"), "{error}");
    }

    /// One rule for a time limit given on the command line, by flag or by --set: without samples
    /// given there too it renders until the limit, whatever the run file's spp and passes; with
    /// them, the samples stand. (--set render.time_limit kept the run file's spp, --time-limit
    /// dropped it.)
    #[test]
    fn a_command_line_time_limit_renders_until_it_however_it_is_given() {
        let (path, _) = outdoor("time-limit");
        let spp_of = |args: &[&str]| {
            let args = render_args(&[&["caustica", "render"], args].concat());
            let (_, run) = caustica::scene::load_with_sets(&path, &args.set, |run| args.apply(run)).unwrap();
            (run.render.spp, run.progressive.passes)
        };
        let until = (u32::MAX, u32::MAX);
        assert_eq!(spp_of(&["--time-limit", "5"]), until);
        assert_eq!(spp_of(&["--set", "render.time_limit=5"]), until);
        assert_eq!(spp_of(&["--set", "time_limit=5"]), until);
        assert_eq!(spp_of(&["--time-limit", "5", "--spp", "8"]).0, 8);
        assert_eq!(spp_of(&["--set", "time_limit=5", "--spp", "8"]).0, 8);
        assert_eq!(spp_of(&["--time-limit", "5", "--set", "spp=8"]).0, 8);
        assert_eq!(spp_of(&["--set", "render.time_limit=5", "--set", "render.spp=8"]).0, 8);
        assert_eq!(spp_of(&["--time-limit", "5", "--passes", "3"]).1, 3);
        assert_eq!(spp_of(&[]).0, RunFile::default().render.spp, "no limit, no change");
    }

    #[test]
    fn flags_reach_the_run_file_by_their_run_file_names() {
        let args = render_args(&[
            "caustica",
            "render",
            "--camera",
            "tele",
            "--integrator",
            "pt-naive",
            "--light-selection",
            "tree",
            "--filter",
            "gaussian",
            "--kernel",
            "biweight",
            "--hit-points-per-pixel",
            "4",
        ]);
        let mut run = RunFile::default();
        args.apply(&mut run);
        assert_eq!(run.camera.name.as_deref(), Some("tele"));
        assert_eq!(run.render.integrator, IntegratorKind::PtNaive);
        assert_eq!(run.render.light_selection, LightSelection::Tree);
        assert_eq!(run.film.filter, FilterKind::Gaussian);
        assert_eq!(run.photons.kernel, Kernel::Biweight);
        assert_eq!(run.progressive.hit_points_per_pixel, Some(4));
    }
}
