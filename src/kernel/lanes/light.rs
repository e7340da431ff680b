//! Next-event estimation in lanes (`direct::sample_light` with MIS): a light for each lane (`tree.rs`),
//! a point on it (in lanes for triangles, still or moving, `triangle_light.rs`, spheres,
//! `sphere_light.rs`, points, spots and suns, `punctual.rs`, and the environment,
//! `environment_light.rs`; one by one only for a constant sky seen from a zero normal), then the BSDF
//! towards it, the power heuristic against the class's own pdf, the contribution and the shadow
//! segment.

use super::environment_light::{sample_environment, takes};
use super::punctual::{is_punctual, sample_punctual};
use super::sphere_light::{is_sphere, sample_spheres};
use super::surface::Surface;
use super::tree::select_lights;
use super::triangle_light::TriangleLanes;
use super::v3::{Mask, MaskBits, V3, max_element, select};
use super::{Group, Lanes, WIDTH, power_heuristic};
use crate::geometry::Ray;
use crate::geometry::offset::SHADOW_EPSILON;
use crate::kernel::ShadowSample;
use crate::lights::{Light, LightSample, LightShape};
use crate::render_scene::RenderScene;
use glam::Vec3;

/// The vertices a group samples lights from.
pub struct LightQuery<'a> {
    /// Their surfaces.
    pub surface: &'a Surface,
    /// Their paths and random numbers.
    pub group: &'a Group,
    /// The group's lanes in use.
    pub count: usize,
}

/// Each lane's point on its light, as the lights' kinds sampled it.
struct Drawn {
    p: V3,
    le: V3,
    /// Solid-angle density, the choice's probability in it.
    pdf: Lanes,
    delta: Mask,
    valid: Mask,
}

impl Drawn {
    /// No lane drawn yet (ones where nothing is, so that no lane divides by zero).
    #[inline(always)]
    fn none() -> Self {
        Drawn { p: V3::splat(1.0), le: V3::splat(1.0), pdf: Lanes::ONE, delta: Mask::ZERO, valid: Mask::ZERO }
    }

    /// The lanes in `bits` take these samples.
    #[inline(always)]
    fn take(&mut self, bits: u32, p: V3, le: V3, pdf: Lanes, valid: Mask) {
        let mask = Mask::from_fn(|i| bits >> i & 1 == 1);
        self.p = V3::select(mask, p, self.p);
        self.le = V3::select(mask, le, self.le);
        self.pdf = select(mask, pdf, self.pdf);
        self.valid = select(mask, valid, self.valid);
    }
}

/// Each lane's light sample: `f(wi)` is the BSDF times |cos| towards local direction `wi`, `pdf(wi)`
/// the density with which the class's own sampling would have chosen it (MIS).
#[inline(never)]
pub fn sample_lights(
    scene: &RenderScene,
    query: &LightQuery,
    f: impl Fn(V3) -> V3,
    pdf: impl Fn(V3) -> Lanes,
) -> [Option<ShadowSample>; WIDTH] {
    let (s, g) = (query.surface, query.group);
    let (p, n_side, times) = (s.p.lanes(), s.n_side.lanes(), g.time.to_array());
    let lights = &scene.lights;
    let mut chosen_lights: [Option<&Light>; WIDTH] = [None; WIDTH];
    // Lanes whose light is a triangle, a point, spot or sun, a sphere, the environment (all in
    // lanes), or another.
    let (mut in_lanes, mut punctual, mut spheres, mut sky, mut one_by_one) = (0u32, 0u32, 0u32, 0u32, 0u32);
    // The lights chosen, asked for before any is read: a scene of many emitting triangles (a
    // lamp's mesh) reads them from memory, and the lanes' waits then overlap.
    let u_select = std::array::from_fn(|i| g.u[i].light_select());
    // Each lane's light and the probability of its choice, in lanes (`tree.rs`).
    let chosen = select_lights(lights, s.p, s.n_side, u_select, query.count);
    for choice in &chosen[..query.count] {
        if let Some(light) = choice.and_then(|(index, _)| lights.lights.get(index as usize)) {
            crate::geometry::wide_bvh::prefetch_line(&light.shape);
            crate::geometry::wide_bvh::prefetch_line(&light.motion);
        }
    }
    for i in 0..query.count {
        let Some((index, _)) = chosen[i] else { continue };
        match lights.lights.get(index as usize) {
            Some(l) if matches!(l.shape, LightShape::Triangle { .. }) => {
                chosen_lights[i] = Some(l);
                in_lanes |= 1 << i;
            }
            Some(l) if is_punctual(l) => {
                chosen_lights[i] = Some(l);
                punctual |= 1 << i;
            }
            Some(l) if is_sphere(l) => {
                chosen_lights[i] = Some(l);
                spheres |= 1 << i;
            }
            None if lights.environment.as_ref().is_some_and(|e| takes(e, n_side[i])) => sky |= 1 << i,
            _ => one_by_one |= 1 << i,
        }
    }
    // Each kind's lanes sample in lanes, unused lanes repeating the kind's first light, and the
    // lanes of a kind take its samples; `pmf`, the choices' probabilities, scales every pdf.
    let kind_lights = |bits: u32| -> [&Light; WIDTH] {
        let first = chosen_lights[bits.trailing_zeros() as usize].expect("a lane's light");
        std::array::from_fn(|i| chosen_lights[i].filter(|_| bits >> i & 1 == 1).unwrap_or(first))
    };
    let pmf = Lanes::new(std::array::from_fn(|i| chosen[i].map_or(1.0, |(_, pmf)| pmf)));
    let u_point = std::array::from_fn(|i| g.u[i].light_point());
    let u = [Lanes::new(u_point.map(|u| u.x)), Lanes::new(u_point.map(|u| u.y))];
    let mut drawn = Drawn::none();
    if one_by_one != 0 {
        // The other lights (a constant sky seen from a zero normal).
        let scalar: [Option<LightSample>; WIDTH] = std::array::from_fn(|i| {
            let (index, pmf) = chosen[i].filter(|_| one_by_one >> i & 1 == 1)?;
            let (_, mut ls) = lights.sample_chosen(index, pmf, p[i], n_side[i], times[i], u_point[i])?;
            ls.le *= scene.emissive_texel(index, ls.p, times[i]);
            Some(ls)
        });
        let from_scalar =
            |f: &dyn Fn(&LightSample) -> Vec3| V3::gather(|i| scalar[i].as_ref().map_or(Vec3::ONE, f));
        drawn = Drawn {
            p: from_scalar(&|ls| ls.p),
            le: from_scalar(&|ls| ls.le),
            pdf: Lanes::new(std::array::from_fn(|i| scalar[i].as_ref().map_or(1.0, |ls| ls.pdf))),
            delta: Mask::from_fn(|i| scalar[i].as_ref().is_some_and(|ls| ls.delta)),
            valid: Mask::from_fn(|i| scalar[i].is_some()),
        };
    }
    if in_lanes != 0 {
        let triangles = kind_lights(in_lanes);
        let sampled = TriangleLanes::new(&triangles, g.time);
        let one_by_one = |i: usize| {
            let ls = triangles[i].sample(p[i], n_side[i], times[i], u_point[i])?;
            Some((ls.p, ls.pdf))
        };
        let (point, pdf, valid) = sampled.sample(s.p, s.n_side, u, one_by_one);
        // An emissive texture multiplies the radiance where the point landed (a gather a lane).
        let textured = (0..WIDTH).filter(|&i| in_lanes >> i & 1 == 1 && triangles[i].texture.is_some());
        let textured = textured.fold(0u32, |bits, i| bits | 1 << i);
        let radiance = if textured == 0 {
            sampled.le
        } else {
            let (point, le) = (point.lanes(), sampled.le.lanes());
            V3::gather(|i| match chosen[i] {
                Some((index, _)) if textured >> i & 1 == 1 => {
                    le[i] * scene.emissive_texel(index, point[i], times[i])
                }
                _ => le[i],
            })
        };
        drawn.take(in_lanes, point, radiance, pdf * pmf, valid);
    }
    if punctual != 0 {
        let sampled = sample_punctual(&kind_lights(punctual), s.p);
        // A delta light's pdf is one, times its choice's probability.
        drawn.take(punctual, sampled.p, sampled.le, pmf, sampled.drawn);
        drawn.delta |= Mask::from_fn(|i| punctual >> i & 1 == 1);
    }
    if spheres != 0 {
        let sampled = sample_spheres(&kind_lights(spheres), s.p, g.time, u);
        drawn.take(spheres, sampled.p, sampled.le, sampled.pdf * pmf, sampled.drawn);
    }
    if let Some(environment) = lights.environment.as_ref().filter(|_| sky != 0) {
        let sampled = sample_environment(environment, s.p, s.n_side, u_point);
        drawn.take(sky, sampled.p, sampled.le, sampled.pdf * pmf, sampled.drawn);
    }
    let Drawn { p: light_p, le, pdf: light_pdf, delta, valid } = drawn;
    let own = Mask::from_fn(|i| chosen[i].is_some_and(|(index, _)| index == g.own_light[i]));
    let valid = valid & !own;
    let lights_of = |i: usize| chosen[i].map(|(index, _)| index);

    let wi_world = (light_p - s.p).normalize();
    let wi = s.frame.to_local(wi_world);
    let crosses = s.crosses_inconsistently(wi_world, wi);
    let f = f(wi);
    let lit = max_element(f).simd_gt(Lanes::ZERO) & light_pdf.simd_gt(Lanes::ZERO);
    let weight = power_heuristic(light_pdf, pdf(wi));
    let weighted = (g.beta * f * le).scale(weight / light_pdf);
    let unweighted = (g.beta * f * le).scale_div(light_pdf);
    let contribution = V3::select(delta, unweighted, weighted);
    let origin = s.ray_origin(wi_world);
    let to_light = light_p - origin;
    let keep = (valid & !crosses & lit).bits();
    let (origin, to_light, contribution) = (origin.lanes(), to_light.lanes(), contribution.lanes());
    std::array::from_fn(|i| {
        let light = lights_of(i)?;
        (keep >> i & 1 == 1).then(|| ShadowSample {
            ray: Ray { o: origin[i], d: to_light[i], t_max: 1.0 - SHADOW_EPSILON, time: times[i] },
            contribution: contribution[i],
            light,
            normal: n_side[i],
        })
    })
}
