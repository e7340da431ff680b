//! The environment flags that `render` and `bench` share.

use super::values::Triple;
use clap::Args;
use std::path::PathBuf;

/// The environment flags of `render` and `bench`.
#[derive(Args, Debug, Default, Clone)]
pub struct EnvironmentArgs {
    /// Environment light: an equirectangular map (.exr or .hdr); overrides the run file.
    #[arg(long, value_name = "FILE")]
    pub environment: Option<PathBuf>,
    /// Environment light of constant radiance R,G,B (linear); overrides the run file.
    #[arg(long, value_name = "R,G,B", conflicts_with = "environment")]
    pub environment_color: Option<Triple>,
    /// Multiplies the environment's radiance.
    #[arg(long)]
    pub environment_strength: Option<f32>,
    /// Rotation of the environment map about world X, then Y, then Z, in degrees.
    #[arg(long, value_name = "X,Y,Z")]
    pub environment_rotation: Option<Triple>,
}

impl EnvironmentArgs {
    /// Apply the flags over a run file's `[environment]`.
    pub fn apply(&self, e: &mut caustica::scene::environment::EnvironmentSettings) {
        if let Some(file) = &self.environment {
            // Relative to where the command runs, not to the run file's directory.
            e.file = Some(std::path::absolute(file).unwrap_or_else(|_| file.clone()));
            e.color = None;
        }
        if let Some(color) = self.environment_color {
            e.color = Some(color.0);
            e.file = None;
        }
        e.strength = self.environment_strength.or(e.strength);
        e.rotation_degrees = self.environment_rotation.map(|t| t.0).or(e.rotation_degrees);
    }
}
