//! The flags of `caustica bench` and `caustica density`.

use super::EnvironmentArgs;
use super::values::choice;
use caustica::density::Kernel;
use caustica::scene::{IntegratorKind, LightSelection};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `caustica bench`.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Run file or glTF to render.
    pub scene: PathBuf,
    /// Reference EXR; without one, a reference is rendered first (see --reference-integrator).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Integrators to compare, comma-separated.
    #[arg(long, value_parser = choice::<IntegratorKind>(), value_delimiter = ',', default_value = "pt,pm,ppm,sppm")]
    pub integrators: Vec<IntegratorKind>,
    /// Light selections to compare for each integrator, comma-separated (default: the run file's).
    #[arg(long, value_parser = choice::<LightSelection>(), value_delimiter = ',')]
    pub light_selections: Vec<LightSelection>,
    /// Wall-clock budget per integrator, seconds.
    #[arg(long, default_value_t = 60.0)]
    pub time: f64,
    /// Where errors.csv, the plots and the images go.
    #[arg(long, default_value = "out/bench")]
    pub out_dir: PathBuf,
    /// Plot error against samples per pixel (or passes) instead of time.
    #[arg(long)]
    pub spp_sweep: bool,
    /// Integrator of the reference rendered when none is given.
    #[arg(long, value_parser = choice::<IntegratorKind>(), default_value = "sppm")]
    pub reference_integrator: IntegratorKind,
    /// Budget of that reference, seconds (default: 4 × --time).
    #[arg(long)]
    pub reference_time: Option<f64>,
    /// Image width when no reference fixes it; overrides the run file.
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height when no reference fixes it; overrides the run file.
    #[arg(long)]
    pub height: Option<u32>,
    /// Sampler seed; overrides the run file (the rendered reference uses seed + 1).
    #[arg(long)]
    pub seed: Option<u64>,
    /// The environment light.
    #[command(flatten)]
    pub environment: EnvironmentArgs,
}

/// Density estimators of `caustica density`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DensityMethod {
    /// Bins of width h from an origin.
    Histogram,
    /// Fixed-bandwidth kernel estimate.
    Kernel,
    /// k-nearest-neighbour estimate.
    Knn,
    /// Variable kernel: bandwidth h · (distance of each point to its k-th neighbour).
    Variable,
}

/// Arguments of `caustica density`.
#[derive(Args, Debug, Clone)]
pub struct DensityArgs {
    /// Whitespace-separated numbers.
    pub data: PathBuf,
    /// Estimator.
    #[arg(long, value_enum, default_value = "kernel")]
    pub method: DensityMethod,
    /// Kernel (kernel and variable methods).
    #[arg(long, value_parser = choice::<Kernel>(), default_value = "epanechnikov")]
    pub kernel: Kernel,
    /// Bandwidth or bin width: a number, `silverman` (the default) or `cv` (least-squares cross-validation).
    #[arg(long)]
    pub h: Option<String>,
    /// Neighbours for the knn and variable methods.
    #[arg(long, default_value_t = 10)]
    pub k: usize,
    /// Histogram origin (default: 0).
    #[arg(long, default_value_t = 0.0)]
    pub origin: f64,
    /// Output PNG.
    #[arg(short, long, default_value = "density.png")]
    pub output: PathBuf,
}
