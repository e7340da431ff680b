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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::tests::params;

    fn query_point() -> (SurfaceHit, Frame, Bsdf) {
        let si = SurfaceHit {
            p: Vec3::ZERO,
            p_error: Vec3::ZERO,
            ng: Vec3::Z,
            ns: Vec3::Z,
            uv: [Vec2::ZERO; 2],
            color: Vec3::ONE,
            tangent: Vec3::X.extend(1.0),
            material: 0,
            light: u32::MAX,
        };
        // White Lambertian: f = 1/π whatever the directions.
        (si, Frame::from_z(Vec3::Z), Bsdf::new(&params(Vec3::ONE, 0.0, 1.0, 0.0, 1.5, 0.0)))
    }

    /// Photons on the floor around the query, and the same number just behind it (the other side of
    /// a thin wall, normal −z, arrived from below) and on a wall meeting it at a corner (normal +x),
    /// all within the radius.
    fn photons() -> (Vec<Photon>, Vec<Photon>) {
        let power = Vec3::splat(0.01);
        let at = |i: usize| Vec3::new(0.01 * (i % 5) as f32 - 0.02, 0.01 * (i / 5) as f32 - 0.02, 0.0);
        let floor = (0..25).map(|i| Photon::new(at(i), Vec3::new(0.3, 0.1, 1.0).normalize(), Vec3::Z, power));
        let behind = (0..25)
            .map(|i| Photon::new(at(i) - 0.001 * Vec3::Z, -Vec3::Z, -Vec3::Z, power))
            .collect::<Vec<_>>();
        // Arrived from above and to the right: towards the wall, and from the floor's side of it, so
        // that the floor's BSDF would take them if they were counted.
        let corner = (0..25).map(|i| {
            let p = Vec3::new(0.001, at(i).y, at(i).x.abs());
            Photon::new(p, Vec3::new(0.6, 0.0, 0.8), Vec3::X, power)
        });
        (floor.collect(), behind.into_iter().chain(corner).collect())
    }

    /// The estimate at a surface is that surface's photons' alone: photons of another orientation
    /// within the radius, behind a thin wall or on a wall at a corner, change it by nothing (k covers
    /// every photon, so the radius is the maximum radius either way).
    #[test]
    fn photons_on_surfaces_of_another_orientation_are_left_out() {
        let (si, frame, bsdf) = query_point();
        let (floor, others) = photons();
        let estimate = |photons: Vec<Photon>| {
            let map = PhotonMap::build(photons);
            let mut neighbors = Neighbors::with_capacity(200);
            radiance_estimate(
                &map,
                &si,
                &frame,
                &bsdf,
                Vec3::Z,
                200,
                0.05 * 0.05,
                Kernel::Uniform,
                &mut neighbors,
            )
        };
        let alone = estimate(floor.clone());
        assert!(alone.x > 0.0);
        let with_others = estimate(floor.into_iter().chain(others).collect());
        assert_eq!(with_others, alone, "photons of other surfaces were gathered");
    }

    /// A progressive hit point takes photons from behind only when its material transmits, and never
    /// from a surface at a corner.
    #[test]
    fn a_hit_point_gathers_only_its_own_surfaces_photons() {
        let (si, frame, bsdf) = query_point();
        let (floor, others) = photons();
        let point = |transmits| GatherPoint { p: si.p, beta: Vec3::ONE, bsdf, frame, wo: Vec3::Z, transmits };
        for transmits in [false, true] {
            assert!(floor.iter().all(|photon| point(transmits).contribution(photon).is_some()));
            let (behind, corner) = others.split_at(25);
            assert!(corner.iter().all(|photon| point(transmits).contribution(photon).is_none()));
            assert!(behind.iter().all(|photon| point(transmits).contribution(photon).is_some() == transmits));
        }
    }
}
