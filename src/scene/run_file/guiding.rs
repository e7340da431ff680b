//! `[guiding]`: path guiding for `pt` and `pt-naive` (`crate::guiding`, `kernel::guided`).

use serde::Deserialize;

/// How `pt` learns where light comes from and samples by it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GuidingSettings {
    /// Guide the path tracer (`--guiding`).
    pub enabled: bool,
    /// Samples per pixel spent training, at most: passes of 1, 2, 4, … samples per pixel, each
    /// sampling by what the passes before it learnt, as many as fit (none given: a quarter of
    /// `render.spp`). Their samples count in the image: each is an unbiased estimate.
    pub training_spp: Option<u32>,
    /// The BSDF's share of the continuations at a guided vertex (the guide takes the rest), the same
    /// everywhere. None given: each region of space learns its own from what its samples brought
    /// (`guiding::selection`), 1 where guiding does not pay. It must be above 0: the BSDF keeps every
    /// direction it can reach possible, so a guide that never learnt of some light cannot bias the
    /// image.
    pub bsdf_fraction: Option<f32>,
    /// c: a region of space is split once it recorded more than c·√(2^k) path vertices in training
    /// pass k (Müller et al. 2017: 12 000).
    pub spatial_threshold: f64,
    /// ρ: a directional cell holding more than this share of its region's light is split, below it
    /// merged (Müller et al. 2017: 0.01).
    pub directional_threshold: f64,
}

impl Default for GuidingSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            training_spp: None,
            bsdf_fraction: None,
            spatial_threshold: 12_000.0,
            directional_threshold: 0.01,
        }
    }
}

impl GuidingSettings {
    /// Which setting is out of range, if any (named as in the run file, without the table).
    pub fn check(&self) -> Result<(), String> {
        if let Some(fraction) = self.bsdf_fraction
            && !(fraction > 0.0 && fraction <= 1.0)
        {
            return Err(format!(
                "bsdf_fraction is {fraction}, must be in (0, 1]: with no BSDF share, light the guide never \
                 saw would be lost"
            ));
        }
        if !(self.spatial_threshold >= 1.0 && self.spatial_threshold.is_finite()) {
            return Err(format!("spatial_threshold is {}, must be finite and >= 1", self.spatial_threshold));
        }
        if !(self.directional_threshold > 0.0 && self.directional_threshold <= 1.0) {
            return Err(format!(
                "directional_threshold is {}, must be in (0, 1]",
                self.directional_threshold
            ));
        }
        Ok(())
    }

    /// The training passes of a render of `spp` samples per pixel: pass k has 2^k samples per pixel,
    /// and they fit in the training budget (and leave at least one sample per pixel to render by the
    /// last one's guide).
    pub fn training_passes(&self, spp: u32) -> u32 {
        let budget = self.training_spp.unwrap_or(spp / 4).min(spp.saturating_sub(1));
        // 2^k − 1 samples per pixel fill the first k passes.
        (u64::from(budget) + 1).ilog2()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn training_passes_fill_the_budget_with_doubling_passes() {
        let settings = |training_spp| GuidingSettings { training_spp, ..Default::default() };
        assert_eq!(settings(None).training_passes(64), 4, "16 spp: 1 + 2 + 4 + 8");
        assert_eq!(settings(Some(15)).training_passes(64), 4);
        assert_eq!(settings(Some(14)).training_passes(64), 3);
        assert_eq!(settings(Some(100)).training_passes(8), 3, "at most spp − 1: 1 + 2 + 4 of 8");
        assert_eq!(settings(None).training_passes(1), 0);
        assert_eq!(settings(Some(u32::MAX)).training_passes(u32::MAX), 31);
    }

    #[test]
    fn a_guide_that_could_lose_light_is_refused() {
        let fraction = |f| GuidingSettings { bsdf_fraction: Some(f), ..Default::default() }.check();
        assert!(fraction(0.0).is_err() && fraction(f32::NAN).is_err() && fraction(1.5).is_err());
        assert!(fraction(0.5).is_ok() && fraction(1.0).is_ok());
        assert!(GuidingSettings::default().check().is_ok(), "learnt");
    }
}
