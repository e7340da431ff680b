//! The run file's choices by name: integrator, light selection, pixel filter.

use crate::choice::Choice;
use serde::Deserialize;

/// Which integrator renders the image. This enum and its [`Choice::CHOICES`] below are the name
/// table (what run files, the command line and their help call each); everything else an
/// integrator is (its descriptor and plan) is registered once, in the `caustica` crate's
/// `integrators::ALL`, which every "for each integrator" reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    /// Path tracing with next-event estimation and MIS (power heuristic).
    #[default]
    Pt,
    /// Path tracing with BSDF sampling only; light is found only by hitting it.
    PtNaive,
    /// Photon mapping (Jensen): NEE for direct light, a caustic map, and a global map read directly or
    /// by final gathering.
    Pm,
    /// Progressive photon mapping (Hachisuka, Ogaki & Jensen 2008): hit points traced once, photon
    /// passes shrink their radii; all light but directly seen emission comes from photons.
    Ppm,
    /// Stochastic progressive photon mapping (Hachisuka & Jensen 2009): hit points re-traced every pass
    /// (depth of field, motion blur, antialiasing, glossy surfaces), direct light by NEE.
    Sppm,
    /// Adaptive PPM (Kaplanyan & Dachsbacher 2013): per-pixel radius from estimated variance and bias.
    Appm,
    /// Chi-squared PPM (Lin et al. 2020): keep the radius while photons look uniform in the disc.
    Cppm,
    /// Probabilistic PPM (Knaus & Zwicker 2011): every pass an independent estimate at a global
    /// radius sequence, averaged; no pass depends on another, so passes split across machines.
    Pppm,
    /// Light tracing (Veach's t = 1): light subpaths whose vertices connect to the camera and add
    /// to the film where they land; camera rays add only the emission they see directly.
    Lt,
    /// Bidirectional path tracing: every (s, t) strategy of Veach's, weighted by the power
    /// heuristic with Georgiev's recursive sums.
    Bdpt,
    /// Vertex connection and merging: bdpt's strategies and the light vertices merged at every
    /// camera vertex, all under one MIS (Georgiev et al. 2012).
    Vcm,
}

/// How next-event estimation picks a light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightSelection {
    /// Every light equally likely.
    Uniform,
    /// In proportion to emitted power.
    Power,
    /// By a light tree: power, distance and orientation towards the shading point (Conty Estevez &
    /// Kulla 2018). The default, as pbrt-v4's and Cycles': it costs what power selection does where a
    /// scene has a lamp or two, and far less error per second where it has many (veach-mis: 0.46×
    /// Mitsuba's time to error, power selection 0.94×).
    #[default]
    Tree,
    /// The light tree plus a grid that learns from the first samples' shadow rays which light
    /// clusters actually reach each region after occlusion (mixed with the tree, so unbiased).
    Visibility,
}

/// Pixel reconstruction filter, sampled by importance (each sample lands in one pixel with weight 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterKind {
    /// Box of radius 0.5 pixel (the references' filter).
    #[default]
    Box,
    /// Tent (triangle) of radius 1 pixel.
    Tent,
    /// Gaussian with sigma 0.5 pixel, truncated at radius 1.5.
    Gaussian,
}

impl Choice for IntegratorKind {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Pt, "pt", "path tracing with next-event estimation and MIS"),
        (Self::PtNaive, "pt-naive", "path tracing with BSDF sampling only"),
        (Self::Pm, "pm", "photon mapping (Jensen): NEE, caustic map, global map or final gathering"),
        (Self::Ppm, "ppm", "progressive photon mapping: hit points traced once, radii shrink"),
        (Self::Sppm, "sppm", "stochastic progressive photon mapping: hit points re-traced every pass"),
        (Self::Appm, "appm", "adaptive PPM: per-pixel radius from estimated variance and bias"),
        (Self::Cppm, "cppm", "chi-squared PPM: the radius shrinks when photons are not uniform in the disc"),
        (
            Self::Pppm,
            "pppm",
            "probabilistic PPM: independent passes at a global radius, averaged (splits by pass)",
        ),
        (Self::Lt, "lt", "light tracing: light subpaths connected to the camera (point-light caustics)"),
        (
            Self::Bdpt,
            "bdpt",
            "bidirectional path tracing: camera and light subpaths connected, every strategy weighted",
        ),
        (
            Self::Vcm,
            "vcm",
            "vertex connection and merging: bdpt's connections and photon-style merges under one MIS",
        ),
    ];
}

impl Choice for LightSelection {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Uniform, "uniform", "every light equally likely"),
        (Self::Power, "power", "in proportion to emitted power"),
        (Self::Tree, "tree", "a light tree: power, distance and orientation"),
        (Self::Visibility, "visibility", "the light tree plus visibility learned from early shadow rays"),
    ];
}

impl Choice for FilterKind {
    const CHOICES: &'static [(Self, &'static str, &'static str)] = &[
        (Self::Box, "box", "box of radius 0.5 pixel"),
        (Self::Tent, "tent", "tent of radius 1 pixel"),
        (Self::Gaussian, "gaussian", "Gaussian, sigma 0.5 pixel, truncated at 1.5"),
    ];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_line_names_are_the_run_file_names() {
        crate::choice::assert_names_match_serde::<IntegratorKind>();
        crate::choice::assert_names_match_serde::<LightSelection>();
        crate::choice::assert_names_match_serde::<FilterKind>();
    }
}
