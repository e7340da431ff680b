//! Command-line arguments (clap derive: the doc comments are the help text): the commands here,
//! each command's flags in its own file, and the parsers of their values.

mod environment;
mod render;
mod tools;
mod values;

pub use environment::EnvironmentArgs;
pub use render::RenderArgs;
pub use tools::{BenchArgs, DensityArgs, DensityMethod};

use clap::{Parser, Subcommand};
use std::path::PathBuf;
/// Caustica: a physically based renderer on a data-oriented ECS.
///
/// `caustica SCENE [flags]` renders, as `caustica render SCENE [flags]` does; with nothing at all it
/// renders scenes/default.toml.
#[derive(Parser, Debug)]
#[command(version, about, args_conflicts_with_subcommands = true)]
pub struct Cli {
    /// What to do; with none, renders.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// The render flags, when no command is named.
    #[command(flatten)]
    pub render: Box<RenderArgs>,
    /// Log more: loading summaries, and the source of each warning.
    #[arg(short, long, global = true)]
    pub verbose: bool,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a run file (.toml) or a glTF file (.gltf / .glb).
    Render(Box<RenderArgs>),
    /// Print RMSE, relMSE and MAE of IMAGE against REFERENCE (linear EXR files).
    Compare {
        /// The image to judge.
        image: PathBuf,
        /// The reference.
        reference: PathBuf,
        /// Compare only the window X0,Y0,X1,Y1 (pixels, end exclusive), e.g. around a caustic.
        #[arg(long, value_delimiter = ',')]
        window: Option<Vec<u32>>,
    },
    /// Estimate a 1-D density from numbers in a text file and plot it over the data.
    Density(DensityArgs),
    /// Run integrators under the same time budget and record their error against a reference over time.
    Bench(BenchArgs),
    /// Merge the accumulators of a render split with --part into its image; refuses parts that do
    /// not belong together, and names any that are missing.
    Merge {
        /// The accumulator files, in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output image(s), .exr (linear) or .png (sRGB); repeatable.
        #[arg(short, long, required = true)]
        output: Vec<PathBuf>,
        /// PNG exposure in stops.
        #[arg(long, default_value_t = 0.0)]
        exposure: f32,
    },
}
