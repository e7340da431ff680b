//! Radiance estimates from photons: Jensen's k-nearest estimate for photon mapping, and which photons
//! a progressive hit point gathers and what each adds.

use super::{Neighbors, Photon, PhotonMap};
use crate::density::kernels::Kernel;
use crate::geometry::SurfaceHit;
use crate::materials::{Bsdf, TransportMode};
use crate::sampling::warp::Frame;
use glam::{Vec2, Vec3};

/// Photons whose surface normal is further than this cosine from the query's are from another surface
/// (the other side of a thin wall, a nearby face at a corner) and are left out of the estimate.
pub const NORMAL_COSINE: f32 = 0.9;

/// Radiance reflected towards `wo` by the photons near `si`: Σ f · ΔΦ · K(d²/r²) / r², with r the
/// distance to the k-th nearest photon (or the maximum radius when fewer are that close).
#[allow(clippy::too_many_arguments)]
pub fn radiance_estimate(
    map: &PhotonMap,
    si: &SurfaceHit,
    frame: &Frame,
    bsdf: &Bsdf,
    wo: Vec3,
    k: usize,
    max_radius2: f32,
    kernel: Kernel,
    neighbors: &mut Neighbors,
) -> Vec3 {
    map.knn(si.p, k, max_radius2, neighbors);
    if neighbors.is_empty() {
        return Vec3::ZERO;
    }
    let r2 = if neighbors.len() < k { max_radius2 } else { neighbors.max_dist2() };
    if r2 <= 0.0 {
        return Vec3::ZERO;
    }
    let n_query = if frame.to_world(wo).dot(si.ng) >= 0.0 { si.ng } else { -si.ng };
    let mut sum = Vec3::ZERO;
    for (photon, d2) in neighbors.iter(map) {
        if photon.normal().dot(n_query) < NORMAL_COSINE {
            continue;
        }
        let wi = frame.to_local(photon.direction());
        sum += bsdf.eval(wo, wi, TransportMode::Radiance) * photon.power() * kernel.k2(d2 / r2);
    }
    sum / r2
}

/// A progressive hit point as its gather sees it: where it is, its BSDF, and how it is seen.
#[derive(Clone, Copy, Debug)]
pub struct GatherPoint {
    /// The visible point.
    pub p: Vec3,
    /// Camera-path throughput up to it.
    pub beta: Vec3,
    /// Its BSDF.
    pub bsdf: Bsdf,
    /// Its shading frame.
    pub frame: Frame,
    /// Towards the camera, in the shading frame.
    pub wo: Vec3,
    /// Whether its material transmits (photons from behind then count too).
    pub transmits: bool,
}

impl GatherPoint {
    /// What a photon within the radius adds, as (tangent-plane offset, β · f · ΔΦ), or None when it
    /// does not count: arrived from behind a surface that does not transmit (a photon's normal faces
    /// where it came from), or lies on a surface of another orientation.
    #[inline]
    pub fn contribution(&self, photon: &Photon) -> Option<(Vec2, Vec3)> {
        let side = if self.wo.z >= 0.0 { self.frame.z } else { -self.frame.z };
        let cos = photon.normal().dot(side);
        if cos < NORMAL_COSINE && !(self.transmits && -cos >= NORMAL_COSINE) {
            return None;
        }
        let local = self.frame.to_local(photon.position() - self.p);
        let f = self.bsdf.eval(self.wo, self.frame.to_local(photon.direction()), TransportMode::Radiance);
        Some((local.truncate(), self.beta * f * photon.power()))
    }
}
