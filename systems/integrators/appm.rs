//! Adaptive progressive photon mapping, `appm` (Kaplanyan & Dachsbacher 2013).
//!
//! Parameters: the `[progressive]` table (see `integrators::progressive`). The camera and photon passes are `sppm`'s. What
//! differs is the radius: each hit point estimates the per-pass variance of its estimate (times r²,
//! which makes it radius-free) and the Laplacian of its radiance (biweight-kernel Laplacian over the
//! pass's photons), and takes the radius that minimises the asymptotic MSE of the average of the
//! passes' estimates, r⁶ = 2C / (μ₂² ΔL² i), kept within [¼, 2] × the global PPM radius of that pass
//! and below the initial radius.
//!
//! Where this departs from the paper: the paper works in the pixel's measurement with its own
//! kernel and a separate Laplacian bandwidth; we estimate both with the current gather radius and
//! the uniform disc kernel (μ₂ = 1/4), so the Laplacian estimate is itself biased by the disc's
//! size, and the band keeps that in check. Per-pass estimates are averaged (each with its own radius)
//! instead of Hachisuka's flux correction, which assumes a radius that only shrinks.

use super::descriptor::Integrator;
use super::progressive::{self, Variant};
use crate::gather::{build_pass_photon_map, gather_photons_with_laplacian};
use crate::plan::Plan;
use crate::resources::SceneFeatures;
use crate::stages::PassSystems;
use crate::update::update_radii_adaptive;
use bevy_ecs::prelude::*;
use caustica_core::error::Result;
use caustica_core::photon::progressive::RadiusRule;
use caustica_core::scene::{IntegratorKind, RunFile};

/// `appm`: `sppm` with an MSE-optimal radius per hit point.
pub static APPM: Integrator = progressive::descriptor(IntegratorKind::Appm, plan);

/// The plan of `appm`: `sppm`'s passes with the Laplacian-estimating gather and the MSE-optimal radius.
fn plan(this: &Integrator, world: &mut World, run: &RunFile, features: SceneFeatures) -> Result<Plan> {
    let variant = Variant {
        rule: RadiusRule::Adaptive,
        statistics: |schedule| {
            schedule.add_systems(
                (build_pass_photon_map, gather_photons_with_laplacian).chain().in_set(PassSystems::Gather),
            );
            schedule.add_systems(update_radii_adaptive.in_set(PassSystems::Update));
        },
    };
    progressive::plan(this, world, run, features, variant)
}
