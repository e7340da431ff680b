//! How often a spatial leaf's vertices sample the BSDF rather than the guide, learnt per leaf.
//!
//! A fixed share (the paper's ½) doubles the weight of every BSDF sample into a direction the guide
//! calls dark, and wastes the guide's half wherever the guide is poor: where a leaf holds surfaces
//! facing different ways (half its guide then points into the surface), or where the light is
//! spread evenly. So each leaf chooses its share from a few candidates by which makes the least
//! second moment of the vertex's estimate. Every training sample drawn with mixture density `p`
//! and carrying contribution `x` gives, for a candidate share `a`, the unbiased estimate
//! `x²·p / p_a` of the second moment `∫ (x·p)² / p_a` that sampling by `p_a = a·p_bsdf + (1 − a)·p_guide`
//! would make (importance reweighting): one pass estimates every candidate at once, with nothing to
//! tune (Müller's follow-up learns it by stochastic gradient descent instead, whose result depends
//! on the order of the samples). The estimates are fixed-point atomic sums like the energies, so the
//! choice is the same for any thread count.
//!
//! The estimate is of the guide sampled during the pass, which the refinement then replaces; the
//! share chosen is one pass behind, as the guide itself is.

use super::fixed_point::{AtomicSums, from_fixed, to_fixed};
use std::sync::atomic::{AtomicU64, Ordering};

/// The BSDF shares a leaf may choose: never 0, so the BSDF keeps every direction it can reach
/// possible and a guide that missed some light cannot bias the image.
pub const CANDIDATE_SHARES: [f32; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

/// The share where a leaf knows too little to choose (the paper's fixed one).
pub const PRIOR_SHARE: f32 = 0.5;

/// Samples with a contribution a leaf needs before it chooses its own share: fewer are mostly one
/// firefly's say.
pub const MIN_SAMPLES_TO_CHOOSE: u64 = 64;

/// Guiding must make the second moment at most this share of the BSDF alone's, or the leaf samples
/// the BSDF alone: a guided vertex costs about twice an unguided one (the scalar kernel against the
/// lanes, and the tree's walks), and the least of five noisy estimates is optimistic. At 0.9 the
/// Cornell box guided 16 of its 92 regions and lost 1.4x at equal time; at 0.5, none.
pub const WORTH_GUIDING: f64 = 0.5;

/// What a leaf records towards its next share.
#[derive(Debug, Default)]
pub(crate) struct SelectionRecording {
    second_moments: AtomicSums<{ CANDIDATE_SHARES.len() }>,
    /// Samples that carried a contribution.
    contributing: AtomicU64,
}

impl SelectionRecording {
    /// Record a sample drawn with density `pdf` (the mixture's) whose contribution (the pixel's
    /// radiance gathered after the vertex, luminance) was `contribution`; `bsdf_pdf` and `guide_pdf`
    /// are the two densities of its direction. Broken or zero values are dropped.
    #[inline]
    pub(crate) fn record(&self, contribution: f32, pdf: f32, bsdf_pdf: f32, guide_pdf: f32) {
        if !(contribution > 0.0 && contribution.is_finite() && pdf > 0.0 && pdf.is_finite()) {
            return;
        }
        if !(bsdf_pdf >= 0.0 && guide_pdf >= 0.0 && bsdf_pdf.is_finite() && guide_pdf.is_finite()) {
            return;
        }
        self.contributing.fetch_add(1, Ordering::Relaxed);
        let weighted = contribution as f64 * contribution as f64 * pdf as f64;
        for (i, &a) in CANDIDATE_SHARES.iter().enumerate() {
            let candidate = a as f64 * bsdf_pdf as f64 + (1.0 - a as f64) * guide_pdf as f64;
            // A candidate that could not have drawn this direction would have missed its light: the
            // greatest estimate there is.
            let estimate = if candidate > 0.0 { (weighted / candidate) as f32 } else { f32::MAX };
            if let Some(fixed) = to_fixed(estimate) {
                self.second_moments.add(i, fixed);
            }
        }
    }

    /// The share to sample by next: the candidate of least estimated second moment, unless guiding
    /// gains too little over the BSDF alone ([`WORTH_GUIDING`]) or too few samples carried light
    /// ([`PRIOR_SHARE`]). `guide_was_uniform`: the pass's guide had learnt nothing, so the estimates
    /// say nothing of the guide that comes next.
    pub(crate) fn choose(&self, guide_was_uniform: bool) -> f32 {
        if guide_was_uniform || self.contributing.load(Ordering::Relaxed) < MIN_SAMPLES_TO_CHOOSE {
            return PRIOR_SHARE;
        }
        let moments: Vec<f64> =
            (0..CANDIDATE_SHARES.len()).map(|i| from_fixed(self.second_moments.get(i))).collect();
        let bsdf_alone = moments[CANDIDATE_SHARES.len() - 1];
        // The first of the least, in index order: ties go to the smaller share, deterministically.
        let (best, least) = moments
            .iter()
            .enumerate()
            .fold((0, f64::INFINITY), |(b, m), (i, &v)| if v < m { (i, v) } else { (b, m) });
        if least < WORTH_GUIDING * bsdf_alone { CANDIDATE_SHARES[best] } else { 1.0 }
    }

    /// The recorded integers, for the tree's fingerprint.
    pub(crate) fn hash_into(&self, hasher: &mut xxhash_rust::xxh3::Xxh3) {
        hasher.update(&self.contributing.load(Ordering::Relaxed).to_le_bytes());
        (0..CANDIDATE_SHARES.len()).for_each(|i| hasher.update(&self.second_moments.get(i).to_le_bytes()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Light from a direction the guide has learnt (guide pdf 20 against the BSDF's 0.3): the
    /// estimates favour the guide, and the chosen share is the smallest candidate.
    #[test]
    fn a_guide_that_knows_the_light_takes_most_samples() {
        let recording = SelectionRecording::default();
        for _ in 0..200 {
            let pdf = 0.5 * 0.3 + 0.5 * 20.0;
            recording.record(1.0, pdf, 0.3, 20.0);
        }
        assert_eq!(recording.choose(false), CANDIDATE_SHARES[0]);
    }

    /// Light where the guide is dark (a leaf whose guide points into the surface): the BSDF alone.
    #[test]
    fn a_guide_blind_to_the_light_gives_the_bsdf_everything() {
        let recording = SelectionRecording::default();
        for _ in 0..200 {
            let pdf = 0.5 * 0.3 + 0.5 * 0.001;
            recording.record(1.0, pdf, 0.3, 0.001);
        }
        assert_eq!(recording.choose(false), 1.0);
    }

    /// A guide no better than the BSDF gains nothing worth its cost.
    #[test]
    fn a_guide_like_the_bsdf_is_not_worth_sampling() {
        let recording = SelectionRecording::default();
        for _ in 0..200 {
            recording.record(1.0, 0.3, 0.3, 0.3);
        }
        assert_eq!(recording.choose(false), 1.0);
    }

    /// A guide that would cut the second moment by about a quarter does not pay for its cost.
    #[test]
    fn a_guide_that_helps_a_little_is_not_worth_sampling() {
        let recording = SelectionRecording::default();
        for _ in 0..200 {
            recording.record(1.0, 0.5 * 0.3 + 0.5 * 0.43, 0.3, 0.43);
        }
        assert_eq!(recording.choose(false), 1.0);
    }

    #[test]
    fn too_little_light_or_an_untrained_guide_keeps_the_prior() {
        let recording = SelectionRecording::default();
        for _ in 0..MIN_SAMPLES_TO_CHOOSE - 1 {
            recording.record(1.0, 10.0, 0.3, 20.0);
        }
        recording.record(0.0, 10.0, 0.3, 20.0);
        recording.record(f32::NAN, 10.0, 0.3, 20.0);
        assert_eq!(recording.choose(false), PRIOR_SHARE);
        recording.record(1.0, 10.0, 0.3, 20.0);
        assert_eq!(recording.choose(false), CANDIDATE_SHARES[0]);
        assert_eq!(recording.choose(true), PRIOR_SHARE);
    }
}
