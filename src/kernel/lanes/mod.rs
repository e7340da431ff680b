//! Camera vertices in lanes: `pt`'s and `pt-naive`'s work at a vertex on a plain Lambertian
//! triangle — the surface, its frame, the light sample's contribution with its MIS weight, the
//! cosine-weighted continuation, Russian roulette and the next rays — for 8 paths at once (16 on
//! AVX-512), one lane each.
//!
//! Every lane runs the floating-point operations of the scalar kernel ([`super::arrival`],
//! [`super::direct`], [`super::continuation`], the Lambertian BSDF, the frame, the offset ray
//! origin) in the same order, so a lane reports the scalar kernel's bits and an image does not
//! change with the paths its lanes hold (the test holds every field to it). What branches per path
//! stays scalar inside: the choice of a light and the point on it (`Lights::sample`, per lane).
//!
//! A vertex takes the lanes when [`plain_lambert`] says its material is a Lambertian without
//! textures, maps, coats or volume, its triangle is [`crate::geometry::bvh::Geometry::plain_triangle`] (no motion, no
//! vertex colours) and not an emitter, its path is in air, and it is not the path's last depth;
//! everything else goes through the scalar kernel.

mod v3;

use super::continuation::MAX_SURVIVAL;
use super::dimensions::VertexSampler;
use super::direct::ShadowSample;
use super::{CameraPath, PathLimits, Quantity};
use crate::geometry::Ray;
use crate::geometry::bvh::{Hit, PlainTriangle};
use crate::geometry::offset::{SHADOW_EPSILON, gamma};
use crate::materials::Bsdf;
use crate::render_scene::RenderScene;
use crate::scene::MaterialDesc;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};
use v3::{Mask, MaskBits, V3, max_element, select};

/// Sixteen lanes, one AVX-512 register, where the machine has them.
#[cfg(target_feature = "avx512f")]
pub type Lanes = wide::f32x16;
/// Eight lanes, one AVX register (without AVX, `wide` runs it as two SSE halves).
#[cfg(not(target_feature = "avx512f"))]
pub type Lanes = wide::f32x8;
/// The lanes' bits.
#[cfg(target_feature = "avx512f")]
type Bits = wide::u32x16;
#[cfg(not(target_feature = "avx512f"))]
type Bits = wide::u32x8;

/// Paths a group of lanes holds.
pub const WIDTH: usize = size_of::<Lanes>() / size_of::<f32>();

/// The albedo of a material whose every hit is a plain Lambertian (lanes can shade it): no
/// texture, normal map, coat or volume, and a BSDF that is Lambert's alone.
pub fn plain_lambert(m: &MaterialDesc) -> Option<Vec3> {
    let textured = m.base_color_texture.is_some()
        || m.metallic_roughness_texture.is_some()
        || m.normal_texture.is_some()
        || m.clearcoat_texture.is_some()
        || m.clearcoat_roughness_texture.is_some()
        || m.clearcoat_normal_texture.is_some();
    if textured || (m.shading.thickness > 0.0 && m.shading.transmission > 0.0) {
        return None;
    }
    Bsdf::new(&m.shading).lambert_albedo()
}

/// One camera vertex on a plain Lambertian triangle that does not emit: what the lanes read
/// besides the path itself.
#[derive(Clone, Copy, Debug)]
pub struct DiffuseVertex {
    /// The ray that found it.
    pub ray: Ray,
    /// Where on the triangle.
    pub hit: Hit,
    /// The triangle.
    pub triangle: PlainTriangle,
    /// Its material's albedo ([`plain_lambert`]).
    pub albedo: Vec3,
    /// The vertex's random numbers.
    pub u: VertexSampler,
}

/// What became of a vertex: whether its path goes on (its next ray written over the one that found
/// the vertex), and the light sample to test, if it took one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiffuseOutcome {
    /// The path goes on.
    pub continues: bool,
    /// Next-event estimation's sample.
    pub light_sample: Option<ShadowSample>,
}

/// Shade `vertices` (their paths in `paths`, their rays in `rays`, both updated), a group of
/// [`WIDTH`] at a time, as the scalar kernel would: `NEE` adds light sampling with MIS (`pt`),
/// without it BSDF sampling alone continues (`pt-naive`). The three slices have one entry per
/// vertex; `outcomes` receives theirs.
pub fn diffuse_vertices<const NEE: bool>(
    scene: &RenderScene,
    limits: PathLimits,
    vertices: &[DiffuseVertex],
    paths: &mut [CameraPath],
    rays: &mut [Ray],
    outcomes: &mut [DiffuseOutcome],
) {
    let n = vertices.len();
    assert!(paths.len() == n && rays.len() == n && outcomes.len() == n, "one path, ray and outcome a vertex");
    for start in (0..n).step_by(WIDTH) {
        let end = (start + WIDTH).min(n);
        group::<NEE>(
            scene,
            limits,
            &vertices[start..end],
            &mut paths[start..end],
            &mut rays[start..end],
            &mut outcomes[start..end],
        );
    }
}

/// Lane `i` of a group of `count` vertices: unused lanes repeat the first.
#[inline(always)]
fn lane_of(i: usize, count: usize) -> usize {
    if i < count { i } else { 0 }
}

/// `f` of each vertex of the group, a lane each.
#[inline(always)]
fn gather(vertices: &[DiffuseVertex], f: impl Fn(&DiffuseVertex) -> f32) -> Lanes {
    let count = vertices.len();
    Lanes::new(std::array::from_fn(|i| f(&vertices[lane_of(i, count)])))
}

/// `f` of each vertex of the group, a lane each.
#[inline(always)]
fn gather3(vertices: &[DiffuseVertex], f: impl Fn(&DiffuseVertex) -> Vec3) -> V3 {
    let count = vertices.len();
    V3::gather(|i| f(&vertices[lane_of(i, count)]))
}

/// One group of at most [`WIDTH`] vertices; unused lanes repeat the first vertex and are dropped.
fn group<const NEE: bool>(
    scene: &RenderScene,
    limits: PathLimits,
    vertices: &[DiffuseVertex],
    paths: &mut [CameraPath],
    rays: &mut [Ray],
    outcomes: &mut [DiffuseOutcome],
) {
    let count = vertices.len();

    // The surface (Geometry::surface_hit): the triangle is still, so its vertices move by zero,
    // which the scalar kernel adds too (it turns a -0 coordinate into +0).
    let zero = V3::splat(0.0);
    let corner = |k: usize| gather3(vertices, |v| v.triangle.p[k]) + zero;
    let (p0, p1, p2) = (corner(0), corner(1), corner(2));
    let b1 = gather(vertices, |v| v.hit.b1);
    let b2 = gather(vertices, |v| v.hit.b2);
    let b0 = Lanes::ONE - b1 - b2;
    let p = p0.scale(b0) + p1.scale(b1) + p2.scale(b2);
    let p_error =
        (p0.scale(b0).abs() + p1.scale(b1).abs() + p2.scale(b2).abs()).scale(Lanes::splat(gamma(7)));
    let ng = (p1 - p0).cross(p2 - p0).normalize();
    let has_normals = Mask::from_fn(|i| vertices[lane_of(i, count)].triangle.normals.is_some());
    let ns = if has_normals.bits() == 0 {
        ng
    } else {
        let normal = |k: usize| gather3(vertices, |v| v.triangle.normals.map_or(Vec3::ZERO, |n| n[k]));
        let interpolated =
            (normal(0).scale(b0) + normal(1).scale(b1) + normal(2).scale(b2)).normalize_or_zero();
        let flipped = interpolated.dot(ng).simd_lt(Lanes::ZERO);
        let ns = V3::select(interpolated.is_zero(), ng, V3::select(flipped, -interpolated, interpolated));
        V3::select(has_normals, ns, ng)
    };

    // The vertex (Vertex::new): the frame about the shading normal, the direction back.
    let frame = Frame::from_z(ns);
    let d = gather3(vertices, |v| v.ray.d);
    let wo = frame.to_local(-d);
    let n_side = V3::select(wo.z.simd_ge(Lanes::ZERO), ns, -ns);
    let albedo = gather3(vertices, |v| v.albedo);
    let beta = V3::gather(|i| paths[lane_of(i, count)].beta);
    let eta_scale = Lanes::new(std::array::from_fn(|i| paths[lane_of(i, count)].eta_scale));
    let time = gather(vertices, |v| v.ray.time);
    let surface = Surface { p, p_error, ng, frame, wo, n_side, albedo };

    let light_samples =
        if NEE { light_samples(scene, &surface, beta, time, vertices) } else { [None; WIDTH] };
    let next = continuation(&surface, paths, beta, eta_scale, time, limits, vertices);
    for i in 0..count {
        let continues = next.continues >> i & 1 == 1;
        // The scalar kernel leaves the ray of a path that ends as it was.
        if continues {
            rays[i] = next.rays[i];
        }
        outcomes[i] = DiffuseOutcome { continues, light_sample: light_samples[i] };
    }
}

/// A vertex's surface, in lanes.
struct Surface {
    p: V3,
    p_error: V3,
    ng: V3,
    frame: Frame,
    wo: V3,
    n_side: V3,
    albedo: V3,
}

/// The shading frame in lanes (`warp::Frame::from_z`, Duff et al. 2017).
struct Frame {
    x: V3,
    y: V3,
    z: V3,
}

impl Frame {
    fn from_z(n: V3) -> Self {
        let sign = Lanes::ONE.copysign(n.z);
        let a = Lanes::splat(-1.0) / (sign + n.z);
        let b = n.x * n.y * a;
        let x = V3 { x: Lanes::ONE + sign * n.x * n.x * a, y: sign * b, z: -sign * n.x };
        let y = V3 { x: b, y: sign + n.y * n.y * a, z: -n.y };
        Self { x, y, z: n }
    }

    fn to_local(&self, v: V3) -> V3 {
        V3 { x: v.dot(self.x), y: v.dot(self.y), z: v.dot(self.z) }
    }

    fn to_world(&self, v: V3) -> V3 {
        self.x.scale(v.x) + self.y.scale(v.y) + self.z.scale(v.z)
    }
}

/// Next-event estimation (`direct::sample_light` with MIS) for each lane: the light and its point
/// chosen per lane by the scene's selection, the rest in lanes.
fn light_samples(
    scene: &RenderScene,
    s: &Surface,
    beta: V3,
    time: Lanes,
    vertices: &[DiffuseVertex],
) -> [Option<ShadowSample>; WIDTH] {
    let (p, n_side, times) = (s.p.lanes(), s.n_side.lanes(), time.to_array());
    let chosen: [Option<(u32, crate::lights::LightSample)>; WIDTH] = std::array::from_fn(|i| {
        let (u, own_light) = vertices.get(i).map(|v| (v.u, v.triangle.light))?;
        let (light, mut ls) =
            scene.lights.sample(p[i], n_side[i], times[i], u.light_select(), u.light_point())?;
        ls.le *= scene.emissive_texel(light, ls.p, times[i]);
        (light != own_light).then_some((light, ls))
    });
    let valid = Mask::from_fn(|i| chosen[i].is_some());
    let sample = |f: &dyn Fn(&crate::lights::LightSample) -> Vec3| {
        V3::gather(|i| chosen[i].as_ref().map_or(Vec3::ONE, |(_, ls)| f(ls)))
    };
    let light_p = sample(&|ls| ls.p);
    let le = sample(&|ls| ls.le);
    let pdf = Lanes::new(std::array::from_fn(|i| chosen[i].as_ref().map_or(1.0, |(_, ls)| ls.pdf)));
    let delta = Mask::from_fn(|i| chosen[i].as_ref().is_some_and(|(_, ls)| ls.delta));

    let wi_world = (light_p - s.p).normalize();
    let wi = s.frame.to_local(wi_world);
    let crosses = crosses_inconsistently(s, wi_world, wi);
    let same_side = (s.wo.z * wi.z).simd_gt(Lanes::ZERO);
    let f = V3::select(same_side, s.albedo.scale(Lanes::splat(FRAC_1_PI)), V3::splat(0.0)).scale(wi.z.abs());
    let lit = max_element(f).simd_gt(Lanes::ZERO) & pdf.simd_gt(Lanes::ZERO);
    let bsdf_pdf = select(same_side, wi.z.abs() * Lanes::splat(FRAC_1_PI), Lanes::ZERO);
    let weight = power_heuristic(pdf, bsdf_pdf);
    let weighted = (beta * f * le).scale(weight / pdf);
    let unweighted = (beta * f * le).scale_div(pdf);
    let contribution = V3::select(delta, unweighted, weighted);
    let origin = offset_ray_origin(s.p, s.p_error, s.ng, wi_world);
    let to_light = light_p - origin;
    let keep = (valid & !crosses & lit).bits();
    let (origin, to_light, contribution) = (origin.lanes(), to_light.lanes(), contribution.lanes());
    std::array::from_fn(|i| {
        let (light, _) = chosen[i]?;
        (keep >> i & 1 == 1).then(|| ShadowSample {
            ray: Ray { o: origin[i], d: to_light[i], t_max: 1.0 - SHADOW_EPSILON, time: times[i] },
            contribution: contribution[i],
            light,
            normal: n_side[i],
        })
    })
}

/// The continuations of a group.
struct Continuations {
    /// Bit `i`: lane `i`'s path goes on.
    continues: u32,
    /// Their next rays (what the scalar kernel leaves in the ray of a path that ends).
    rays: [Ray; WIDTH],
}

/// `continuation::continue_path` after a Lambertian sample, for each lane, writing the paths as the
/// scalar kernel does (including what it writes before it ends a path).
#[allow(clippy::too_many_arguments)]
fn continuation(
    s: &Surface,
    paths: &mut [CameraPath],
    beta: V3,
    eta_scale: Lanes,
    time: Lanes,
    limits: PathLimits,
    vertices: &[DiffuseVertex],
) -> Continuations {
    let count = vertices.len();
    // lambert_sample
    let usable = !s.wo.z.simd_eq(Lanes::ZERO) & s.wo.is_finite() & max_element(s.albedo).simd_gt(Lanes::ZERO);
    let u = [gather(vertices, |v| v.u.bsdf_direction().x), gather(vertices, |v| v.u.bsdf_direction().y)];
    let hemisphere = cosine_hemisphere(u);
    let wi = V3 { z: select(s.wo.z.simd_lt(Lanes::ZERO), -hemisphere.z, hemisphere.z), ..hemisphere };
    let pdf = wi.z.abs() * Lanes::splat(FRAC_1_PI);
    let f = s.albedo.scale(Lanes::splat(FRAC_1_PI));
    let sampled = usable & pdf.simd_gt(Lanes::ZERO) & max_element(f).simd_gt(Lanes::ZERO);
    let wi_world = s.frame.to_world(wi);
    let updated = sampled & !crosses_inconsistently(s, wi_world, wi);
    let beta = beta * f.scale(wi.z.abs() / pdf);
    let origin = offset_ray_origin(s.p, s.p_error, s.ng, wi_world);
    let survive = max_element(beta.scale(eta_scale)).fast_min(Lanes::splat(MAX_SURVIVAL));
    let u_roulette = gather(vertices, |v| v.u.roulette());
    let rr_depth = limits.rr_depth;
    let survived_beta = beta.scale_div(survive);

    let (updated, killed) = (updated.bits(), u_roulette.simd_ge(survive).to_bitmask());
    let (p, n_side, pdf, time) = (s.p.lanes(), s.n_side.lanes(), pdf.to_array(), time.to_array());
    let (beta, survived_beta) = (beta.lanes(), survived_beta.lanes());
    let (origin, wi_world) = (origin.lanes(), wi_world.lanes());
    let mut continues = 0;
    let rays = std::array::from_fn(|i| {
        let ray = Ray { o: origin[i], d: wi_world[i], t_max: f32::INFINITY, time: time[i] };
        if i >= count || updated >> i & 1 == 0 {
            return ray;
        }
        let path = &mut paths[i];
        path.beta = beta[i];
        path.prev_pdf = pdf[i];
        path.specular_bounce = false;
        path.prev_p = p[i];
        path.prev_n = n_side[i];
        path.depth += 1;
        if path.depth >= rr_depth {
            if killed >> i & 1 == 1 {
                return ray;
            }
            path.beta = survived_beta[i];
        }
        if !path.beta.is_finite() {
            path.l = Vec3::NAN;
            path.mark_bad(Quantity::Throughput);
            return ray;
        }
        if path.beta.max_element() > 0.0 {
            continues |= 1 << i;
        }
        ray
    });
    Continuations { continues, rays }
}

/// `continuation::crosses_inconsistently` in lanes: `wi` on one side of the surface by the shading
/// frame and on the other by the geometric normal, relative to where the path arrived.
fn crosses_inconsistently(s: &Surface, wi_world: V3, wi_local: V3) -> Mask {
    let wo_world = s.frame.to_world(s.wo);
    (wi_world.dot(s.ng) * wo_world.dot(s.ng) * wi_local.z * s.wo.z).simd_lt(Lanes::ZERO)
}

/// `mis::power_heuristic` in lanes.
fn power_heuristic(pdf_a: Lanes, pdf_b: Lanes) -> Lanes {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let ratio = select((a + b).simd_eq(Lanes::ZERO), Lanes::ZERO, a / (a + b));
    select(a.is_inf(), Lanes::ONE, ratio)
}

/// `warp::cosine_hemisphere` in lanes (Malley's method over `warp::concentric_disk`).
fn cosine_hemisphere(u: [Lanes; 2]) -> V3 {
    let two = Lanes::splat(2.0);
    let (ox, oy) = (two * u[0] - Lanes::ONE, two * u[1] - Lanes::ONE);
    let quarter = Lanes::splat(FRAC_PI_4);
    let (sin_x, cos_x) = sin_cos_quarter(quarter * (oy / ox));
    let (sin_y, cos_y) = sin_cos_quarter(quarter * (ox / oy));
    let wide_x = ox.abs().simd_gt(oy.abs());
    let centre = ox.simd_eq(Lanes::ZERO) & oy.simd_eq(Lanes::ZERO);
    let dx = select(centre, Lanes::ZERO, select(wide_x, ox * cos_x, oy * sin_y));
    let dy = select(centre, Lanes::ZERO, select(wide_x, ox * sin_x, oy * cos_y));
    let z = (Lanes::ONE - (dx * dx + dy * dy)).fast_max(Lanes::ZERO).sqrt();
    V3 { x: dx, y: dy, z }
}

/// `warp::sin_cos_quarter` in lanes.
fn sin_cos_quarter(x: Lanes) -> (Lanes, Lanes) {
    let s = Lanes::splat;
    let z = x * x;
    let sin = x + x * z * (s(-1.666_665_5e-1) + z * (s(8.332_161e-3) + z * s(-1.951_529_6e-4)));
    let cos = Lanes::ONE - s(0.5) * z
        + z * z * (s(4.166_664_6e-2) + z * (s(-1.388_731_6e-3) + z * s(2.443_315_7e-5)));
    (sin, cos)
}

/// `offset::offset_ray_origin` in lanes.
fn offset_ray_origin(p: V3, p_error: V3, n: V3, w: V3) -> V3 {
    let d = n.abs().dot(p_error);
    let offset = V3::select(w.dot(n).simd_lt(Lanes::ZERO), n.scale(-d), n.scale(d));
    let po = p + offset;
    let away = |po: Lanes, offset: Lanes| {
        select(
            offset.simd_gt(Lanes::ZERO),
            next_up(po),
            select(offset.simd_lt(Lanes::ZERO), next_down(po), po),
        )
    };
    V3 { x: away(po.x, offset.x), y: away(po.y, offset.y), z: away(po.z, offset.z) }
}

/// `f32::next_up` in lanes: the next float towards +∞ (±0 to the smallest subnormal; NaN and +∞
/// stay).
fn next_up(x: Lanes) -> Lanes {
    let bits = x.to_bits();
    let abs = bits & Bits::splat(0x7fff_ffff);
    let one = Bits::splat(1);
    let stepped = bits.simd_eq(abs).select(bits + one, bits - one);
    let next = abs.simd_eq(Bits::splat(0)).select(one, stepped);
    let keep = x.is_nan() | x.simd_eq(Lanes::splat(f32::INFINITY));
    select(keep, x, Lanes::from_bits(next))
}

/// `f32::next_down` in lanes: the next float towards −∞.
fn next_down(x: Lanes) -> Lanes {
    let bits = x.to_bits();
    let abs = bits & Bits::splat(0x7fff_ffff);
    let one = Bits::splat(1);
    let stepped = bits.simd_eq(abs).select(bits - one, bits + one);
    let next = abs.simd_eq(Bits::splat(0)).select(Bits::splat(0x8000_0001), stepped);
    let keep = x.is_nan() | x.simd_eq(Lanes::splat(f32::NEG_INFINITY));
    select(keep, x, Lanes::from_bits(next))
}

#[cfg(test)]
mod tests;
