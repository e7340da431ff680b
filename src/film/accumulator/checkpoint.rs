//! What a checkpoint adds to an accumulator: a progressive mapper's hit points, written uncompressed
//! (a checkpoint is written often, during the render, and read at most once).

use super::{PartInfo, Snapshot};
use crate::error::Result;
use crate::film::Film;
use std::path::Path;

/// A progressive photon mapper's hit points in a checkpoint: each of `points_per_pixel` hit points
/// per pixel is `channels.len()` 32-bit words, channel `k` holding word `k` of every hit point in
/// entity order (pixel-major): the uint channels `w.000`, `w.001`, … of a second EXR part,
/// `hit_points`, of width × points per pixel, as they are; and the initial radius, in its header
/// (entry `r0`, the f32's bits).
#[derive(Clone, Debug, PartialEq)]
pub struct HitPointState {
    /// Hit points per pixel.
    pub points_per_pixel: u32,
    /// The initial radius the render chose.
    pub r0: f32,
    /// One channel per word of a hit point, each as long as there are hit points.
    pub channels: Vec<Vec<u32>>,
}

impl HitPointState {
    /// Hit points held.
    pub fn points(&self) -> usize {
        self.channels.first().map_or(0, Vec::len)
    }
}

/// Write `film` with `info`, and a progressive mapper's hit points when given, to `path`,
/// uncompressed: a checkpoint is written often, during the render, and read at most once.
pub fn write_checkpoint(
    film: &Film,
    info: &PartInfo,
    hit_points: Option<HitPointState>,
    path: &Path,
) -> Result<()> {
    Snapshot::of(film, hit_points).write_checkpoint(info, path)
}

impl Snapshot {
    /// Write it as a checkpoint: uncompressed, as [`write_checkpoint`] does.
    pub fn write_checkpoint(self, info: &PartInfo, path: &Path) -> Result<()> {
        self.write(info, path, exr::prelude::Encoding::UNCOMPRESSED)
    }
}
