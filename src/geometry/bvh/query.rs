//! The traversal of one primitive set: closest hit and any hit, through its triangle packs and its
//! spheres (moved back by their displacement when the set moves), with alpha cut-outs.

use super::{Hit, PrimitiveSet, PrimitiveShape};
use crate::geometry::Ray;
use crate::geometry::alpha::{Cutouts, NO_CUTOUT};
use crate::geometry::sphere::intersect_sphere;
use crate::geometry::triangle_pack::{
    PackHits, PackLanes, PackRay, intersect_pack, nearest_in_pack, pack_blocks,
};
use crate::geometry::wide_bvh::{BoxRay, ClosestLeaf, Counts};
use glam::Vec3;

/// A ray prepared once for the box tests and the triangle packs of every set.
pub(super) struct QueryRay {
    boxes: BoxRay,
    packs: PackRay,
}

impl QueryRay {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Self {
        let inverse = BoxRay::inverse(ray.d);
        Self {
            boxes: BoxRay::with_inverse(ray.o, ray.d, inverse),
            packs: PackRay::with_inverse(ray.o, ray.d, inverse),
        }
    }
}

/// The hits of pack `p` of `set`, its lanes seeing the ray moved back by their displacement when
/// the set moves.
#[inline(always)]
fn pack_hits(set: &PrimitiveSet, rays: &QueryRay, ray: &Ray, p: usize, t_max: f32) -> PackHits {
    match set.pack_motion.get(p) {
        None => intersect_pack(&set.packs[p].0, &rays.packs, rays.packs.origin_lanes(), None, t_max),
        Some(m) => {
            let time = PackLanes::splat(ray.time);
            let (o, lanes) = rays.packs.shifted(&[m[0] * time, m[1] * time, m[2] * time]);
            intersect_pack(&set.packs[p].0, &rays.packs, &o, Some(&lanes), t_max)
        }
    }
}

/// Whether pack `p` of `set` blocks the ray before `t_max` (no cut-outs: any lane will do).
#[inline(always)]
fn pack_blocks_ray(set: &PrimitiveSet, rays: &QueryRay, ray: &Ray, p: usize, t_max: f32) -> bool {
    match set.pack_motion.get(p) {
        None => pack_blocks(&set.packs[p].0, &rays.packs, rays.packs.origin_lanes(), None, t_max),
        Some(m) => {
            let time = PackLanes::splat(ray.time);
            let (o, lanes) = rays.packs.shifted(&[m[0] * time, m[1] * time, m[2] * time]);
            pack_blocks(&set.packs[p].0, &rays.packs, &o, Some(&lanes), t_max)
        }
    }
}

/// The ray's origin as sphere `prim` of `set` sees it (moved back by the sphere's displacement).
#[inline(always)]
fn sphere_origin(set: &PrimitiveSet, ray: &Ray, prim: usize) -> Vec3 {
    if set.motion.is_empty() { ray.o } else { ray.o - set.motion[prim] * ray.time }
}

#[inline]
pub(super) fn intersect_set(
    set: &PrimitiveSet,
    cutouts: &Cutouts,
    ray: &Ray,
    rays: &QueryRay,
    id_bits: u32,
    hit: &mut Hit,
    counts: &mut impl Counts,
) {
    let has_cutouts = !set.cutout.is_empty();
    if !has_cutouts && set.pack_motion.is_empty() {
        // Still, opaque triangles: each pack's nearest hit, the distances not stored.
        let t_max = hit.t;
        hit.t = set.triangles.closest(&rays.boxes, t_max, counts, StillPacks { set, rays, id_bits, hit });
    } else {
        intersect_triangles(set, cutouts, ray, rays, id_bits, hit, counts);
    }
    if set.sphere_prims.is_empty() {
        return;
    }
    intersect_spheres(set, ray, rays, id_bits, hit, counts);
}

/// The leaves of a set of still, opaque triangles: each pack's nearest hit, the distances not
/// stored; a type of its own so that the traversal inlines it.
struct StillPacks<'a> {
    set: &'a PrimitiveSet,
    rays: &'a QueryRay,
    id_bits: u32,
    hit: &'a mut Hit,
}

impl ClosestLeaf for StillPacks<'_> {
    #[inline(always)]
    fn nearest(&mut self, first: u32, count: u32, mut t_max: f32) -> f32 {
        for p in first as usize..(first + count) as usize {
            let (pack, prims) = &self.set.packs[p];
            if let Some((i, t, b1, b2)) = nearest_in_pack(pack, &self.rays.packs, t_max) {
                t_max = t;
                *self.hit = Hit { t, prim: prims[i] | self.id_bits, b1, b2 };
            }
        }
        t_max
    }
}

/// The triangles of a set that moves or has cut-outs: every hit lane, nearest first, until one is
/// not cut out.
fn intersect_triangles(
    set: &PrimitiveSet,
    cutouts: &Cutouts,
    ray: &Ray,
    rays: &QueryRay,
    id_bits: u32,
    hit: &mut Hit,
    counts: &mut impl Counts,
) {
    let has_cutouts = !set.cutout.is_empty();
    hit.t = set.triangles.closest(&rays.boxes, hit.t, counts, |first, count, mut t_max| {
        for p in first as usize..(first + count) as usize {
            let mut hits = pack_hits(set, rays, ray, p, t_max);
            // Nearest first; a lane whose triangle is cut out there lets the next one count.
            while let Some(i) = hits.nearest() {
                let prim = set.packs[p].1[i];
                let (b1, b2) = (hits.b1[i], hits.b2[i]);
                if has_cutouts && cut_out(set, cutouts, prim as usize, b1, b2, ray, id_bits) {
                    hits.mask &= !(1 << i);
                    continue;
                }
                t_max = hits.t[i];
                *hit = Hit { t: t_max, prim: prim | id_bits, b1, b2 };
                break;
            }
        }
        t_max
    });
}

/// The spheres of a set.
fn intersect_spheres(
    set: &PrimitiveSet,
    ray: &Ray,
    rays: &QueryRay,
    id_bits: u32,
    hit: &mut Hit,
    counts: &mut impl Counts,
) {
    hit.t = set.spheres.closest(&rays.boxes, hit.t, counts, |first, count, mut t_max| {
        for &prim in &set.sphere_prims[first as usize..(first + count) as usize] {
            let PrimitiveShape::Sphere(c, r) = set.shapes[prim as usize] else { continue };
            if let Some(t) = intersect_sphere(sphere_origin(set, ray, prim as usize), ray.d, t_max, c, r)
                && t < t_max
            {
                t_max = t;
                *hit = Hit { t, prim: prim | id_bits, b1: 0.0, b2: 0.0 };
            }
        }
        t_max
    });
}

#[inline]
pub(super) fn occluded_set(
    set: &PrimitiveSet,
    cutouts: &Cutouts,
    ray: &Ray,
    rays: &QueryRay,
    id_bits: u32,
    counts: &mut impl Counts,
) -> bool {
    let has_cutouts = !set.cutout.is_empty();
    let t_max = ray.t_max;
    let blocked = set.triangles.any(&rays.boxes, t_max, counts, |first, count| {
        (first as usize..(first + count) as usize).any(|p| {
            if !has_cutouts {
                return pack_blocks_ray(set, rays, ray, p, t_max);
            }
            let hits = pack_hits(set, rays, ray, p, t_max);
            let mut mask = hits.mask;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let prim = set.packs[p].1[i] as usize;
                if !cut_out(set, cutouts, prim, hits.b1[i], hits.b2[i], ray, id_bits) {
                    return true;
                }
            }
            false
        })
    });
    blocked
        || (!set.sphere_prims.is_empty()
            && set.spheres.any(&rays.boxes, t_max, counts, |first, count| {
                set.sphere_prims[first as usize..(first + count) as usize].iter().any(|&prim| {
                    let PrimitiveShape::Sphere(c, r) = set.shapes[prim as usize] else { return false };
                    intersect_sphere(sphere_origin(set, ray, prim as usize), ray.d, t_max, c, r)
                        .is_some_and(|t| t < t_max)
                })
            }))
}

/// Whether primitive `i` of `set` is cut out (alpha) where the ray meets it.
#[inline]
fn cut_out(
    set: &PrimitiveSet,
    cutouts: &Cutouts,
    i: usize,
    b1: f32,
    b2: f32,
    ray: &Ray,
    id_bits: u32,
) -> bool {
    match set.cutout.get(i) {
        Some(&id) if id != NO_CUTOUT => cutouts.lets_through(id, b1, b2, ray, i as u32 | id_bits),
        _ => false,
    }
}
