//! A share of a split render: the samples (or passes) one process or machine renders of every
//! pixel, whose film merges with the other shares' into the bits of one render of them all.

use super::Renderer;
use crate::integrators;
use caustica_core::error::Result;
use caustica_core::film::accumulator::PartInfo;
use caustica_core::scene::{RunFile, Scene};

impl Renderer {
    /// A renderer of share `part` (from 1) of `parts` of the render `run` sets up of `scene` (a
    /// render split across processes or machines), stopping only between passes, and what its
    /// accumulator records (`film::accumulator::write_part`): the one sequence the command and the
    /// hosts use.
    pub fn for_share(scene: Scene, run: &RunFile, part: u32, parts: u32) -> Result<(Self, PartInfo)> {
        let integrator = integrators::of_run(run);
        let fingerprint = caustica_core::scene::fingerprint::fingerprint(&scene, run);
        let mut info = PartInfo::of_share(fingerprint, integrator.name(), integrator.units(run), part, parts)
            .map_err(|problem| caustica_core::error::Error::Setting { name: "part".into(), problem })?;
        let mut renderer = Self::new(scene, run)?;
        renderer.set_whole_passes(true);
        renderer.set_samples(info.samples.clone())?;
        info.per_unit = renderer.camera_samples_per_unit();
        Ok((renderer, info))
    }

    /// Render only samples (or passes) `samples` of every pixel: one share of a render split across
    /// processes or machines (`caustica render --part`). The film then holds their sums, which merge
    /// with the other shares' into the same bits as one run of all of them. Before the first pass, and
    /// only where [`share_refusal`] has no objection.
    pub fn set_samples(&mut self, samples: std::ops::Range<u32>) -> Result<()> {
        let refuse = |problem: &str| {
            Err(caustica_core::error::Error::Setting { name: "part".into(), problem: problem.into() })
        };
        if let Some(problem) = self.integrator.share_refusal(&self.run) {
            return refuse(&problem);
        }
        if self.passes > 0 {
            return refuse("the render has started");
        }
        if samples.is_empty() {
            return refuse("the share holds no samples");
        }
        (self.first, self.done, self.target) = (samples.start, samples.start, samples.end);
        Ok(())
    }
}

/// Why a share of the render `run` sets up cannot be rendered alone and merged, if it cannot: what a
/// host asks before it splits (`Renderer::set_samples` has the last word).
pub fn share_refusal(run: &RunFile) -> Option<String> {
    integrators::of_run(run).share_refusal(run)
}
