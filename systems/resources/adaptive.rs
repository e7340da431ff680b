//! Adaptive sampling's state (`render.noise_threshold`): the samples' squares and the pixels the
//! next pass takes.

use super::PixelOrder;
use bevy_ecs::resource::Resource;

/// Adaptive sampling's state, present only when the run asks for it (`render.noise_threshold`).
#[derive(Resource, Debug)]
pub struct AdaptiveSampling {
    /// A pixel whose estimated relative error is under this stops taking samples.
    pub threshold: f64,
    /// Samples every pixel takes first.
    pub min_spp: u32,
    /// The samples' squares, beside the film's sums (shared with the shards that add to them).
    pub squares: std::sync::Arc<caustica_core::film::adaptive::SampleSquares>,
    /// The pixels the next pass samples; `None`: every pixel (the first pass).
    pub next: Option<std::sync::Arc<PixelOrder>>,
}

impl AdaptiveSampling {
    /// Fresh state for an image of `pixels` pixels.
    pub fn new(threshold: f64, min_spp: u32, pixels: usize) -> Self {
        let squares = std::sync::Arc::new(caustica_core::film::adaptive::SampleSquares::new(pixels));
        Self { threshold, min_spp, squares, next: None }
    }

    /// Whether every pixel has stopped.
    pub fn converged(&self) -> bool {
        self.next.as_ref().is_some_and(|order| order.is_empty())
    }

    /// Where the pass that starts at sample `done` ends, towards `target`: the minimum first, then
    /// steps of half the samples so far (at least 4), so a pixel takes at most half again what it
    /// needed while a render of n samples makes about 2.5·ln(n / min) passes, each with a tail
    /// (measured: quarter steps gave 2% fewer samples in 10 s on the Cornell box).
    pub fn pass_end(min_spp: u32, done: u32, target: u32) -> u32 {
        let end = if done == 0 { min_spp } else { done.saturating_add((done / 2).max(4)) };
        end.min(target)
    }
}

/// The samples' squares as a shard holds them (lent from [`AdaptiveSampling`] for a round).
#[derive(Resource, Clone, Debug)]
pub struct AdaptiveSquares(pub std::sync::Arc<caustica_core::film::adaptive::SampleSquares>);
