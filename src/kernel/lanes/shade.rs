//! A lane class's vertices, a group at a time: each row's material resolved (its textures looked
//! up, its normal mapped), rows the class cannot take handed back to the scalar kernel, then for the
//! group in lanes the surface and frame, the light sample with its MIS weight, the BSDF sample,
//! Russian roulette and the next ray — `path_vertex` for `pt` (`NEE`) and `pt-naive`.

use super::bsdf::{Lambert, LaneBsdf, MetalRough, MetalRoughLane, PLACEHOLDER_PARAMS};
use super::coat::{CoatLane, Coated};
use super::columns::CameraColumns;
use super::light::{LightQuery, sample_lights};
use super::surface::{GroupHits, Surface};
use super::v3::{MaskBits, V3, max_element};
use super::{Group, LaneClass, Lanes, WIDTH, gather_group};
use crate::geometry::bvh::PlainTriangle;
use crate::geometry::{Ray, SurfaceHit};
use crate::kernel::continuation::MAX_SURVIVAL;
use crate::kernel::{PathLimits, Quantity};
use crate::render_scene::RenderScene;
use glam::Vec3;

/// What a class reads of a row's material: resolved by the scalar code per row (a texture lookup
/// is a gather), then made into the group's BSDF.
pub trait LaneMaterial {
    /// One row's material, as its textures leave it.
    type Lane: Copy;
    /// The group's BSDF.
    type Bsdf: LaneBsdf;
    /// A placeholder for an unused lane.
    const EMPTY: Self::Lane;
    /// The material of the row whose ray `ray` found `hit` on a triangle of `material` (textured
    /// or not), and the shading normal a normal map gives it; `None` where the scalar kernel must
    /// shade it.
    fn resolve(
        scene: &RenderScene,
        material: u32,
        params: &crate::materials::ShadingParams,
    ) -> Option<Self::Lane>;
    /// [`LaneMaterial::resolve`] for the base below a clear coat ([`CoatedClass`]).
    #[inline(always)]
    fn resolve_under_coat(
        scene: &RenderScene,
        material: u32,
        params: &crate::materials::ShadingParams,
    ) -> Option<Self::Lane> {
        Self::resolve(scene, material, params)
    }
    /// The group's BSDF from its lanes.
    fn bsdf(lanes: &[Self::Lane; WIDTH]) -> Self::Bsdf;
}

/// [`LaneClass::Lambert`].
pub struct LambertClass;

impl LaneMaterial for LambertClass {
    type Lane = Vec3;
    type Bsdf = Lambert;
    const EMPTY: Vec3 = Vec3::ZERO;

    #[inline(always)]
    fn resolve(_: &RenderScene, _: u32, params: &crate::materials::ShadingParams) -> Option<Vec3> {
        Some(params.base_color.max(Vec3::ZERO).min(Vec3::ONE))
    }

    #[inline(always)]
    fn bsdf(lanes: &[Vec3; WIDTH]) -> Lambert {
        Lambert { albedo: V3::gather(|i| lanes[i]) }
    }
}

/// [`LaneClass::MetalRough`].
pub struct MetalRoughClass;

impl LaneMaterial for MetalRoughClass {
    type Lane = MetalRoughLane;
    type Bsdf = MetalRough;
    const EMPTY: MetalRoughLane = MetalRoughLane::EMPTY;

    #[inline(always)]
    fn resolve(_: &RenderScene, _: u32, params: &crate::materials::ShadingParams) -> Option<MetalRoughLane> {
        MetalRough::lane(params)
    }

    #[inline(always)]
    fn resolve_under_coat(
        _: &RenderScene,
        _: u32,
        params: &crate::materials::ShadingParams,
    ) -> Option<MetalRoughLane> {
        MetalRough::lane_under_coat(params)
    }

    #[inline(always)]
    fn bsdf(lanes: &[MetalRoughLane; WIDTH]) -> MetalRough {
        MetalRough::new(lanes)
    }
}

/// [`LaneClass::LambertCoated`] and [`LaneClass::MetalRoughCoated`]: class `M` under a clear coat.
pub struct CoatedClass<M>(std::marker::PhantomData<M>);

impl<M: LaneMaterial> LaneMaterial for CoatedClass<M> {
    type Lane = (M::Lane, CoatLane, crate::materials::ShadingParams);
    type Bsdf = Coated<M::Bsdf>;
    const EMPTY: Self::Lane = (M::EMPTY, CoatLane::EMPTY, PLACEHOLDER_PARAMS);

    #[inline(always)]
    fn resolve(
        scene: &RenderScene,
        material: u32,
        params: &crate::materials::ShadingParams,
    ) -> Option<Self::Lane> {
        let coat = CoatLane::new(params)?;
        Some((M::resolve_under_coat(scene, material, params)?, coat, *params))
    }

    #[inline(always)]
    fn bsdf(lanes: &[Self::Lane; WIDTH]) -> Self::Bsdf {
        Coated::new(M::bsdf(&lanes.map(|l| l.0)), &lanes.map(|l| l.1), lanes.map(|l| l.2))
    }
}

/// Shade the vertices of `rows`, every one of class `class`, as the scalar kernel would: `NEE`
/// adds light sampling with MIS (`pt`); without it BSDF sampling alone continues (`pt-naive`).
pub fn shade_class<const NEE: bool, C: CameraColumns>(
    scene: &RenderScene,
    limits: PathLimits,
    class: LaneClass,
    rows: &[u32],
    columns: &mut C,
) {
    match class {
        LaneClass::Lambert => shade_rows::<NEE, LambertClass, C>(scene, limits, rows, columns),
        LaneClass::MetalRough => shade_rows::<NEE, MetalRoughClass, C>(scene, limits, rows, columns),
        LaneClass::LambertCoated => {
            shade_rows::<NEE, CoatedClass<LambertClass>, C>(scene, limits, rows, columns)
        }
        LaneClass::MetalRoughCoated => {
            shade_rows::<NEE, CoatedClass<MetalRoughClass>, C>(scene, limits, rows, columns)
        }
        LaneClass::Scalar => {}
    }
}

/// The rows of one class, [`WIDTH`] at a time: each resolved, the ones the class takes shaded
/// together.
fn shade_rows<const NEE: bool, M: LaneMaterial, C: CameraColumns>(
    scene: &RenderScene,
    limits: PathLimits,
    rows: &[u32],
    columns: &mut C,
) {
    let mut group = [0u32; WIDTH];
    let mut materials = [M::EMPTY; WIDTH];
    let mut normals = [None; WIDTH];
    let mut triangles = [PlainTriangle::EMPTY; WIDTH];
    let mut surfaces = [None; WIDTH];
    for batch in rows.chunks(WIDTH) {
        // Each row's triangle, and textured rows' surfaces with their texels asked for, so that
        // the lookups' waits on memory overlap instead of following one another.
        for &row in batch {
            scene.geometry.prefetch_primitive(columns.hit(row).prim);
        }
        for (i, &row) in batch.iter().enumerate() {
            let hit = *columns.hit(row);
            triangles[i] = scene.geometry.plain_triangle(hit.prim).expect("a lane class's triangle");
            surfaces[i] = scene
                .lanes
                .textured(triangles[i].material)
                .then(|| scene.geometry.surface_hit(columns.ray(row), &hit));
            if let Some(si) = &surfaces[i] {
                scene.prefetch_textures(si);
            }
        }
        let mut count = 0;
        for (i, &row) in batch.iter().enumerate() {
            let material = triangles[i].material;
            let Some((lane, normal)) = resolve::<M>(scene, material, surfaces[i].as_ref(), row, columns)
            else {
                columns.scalar_vertex(row);
                continue;
            };
            (group[count], materials[count], normals[count]) = (row, lane, normal);
            if count != i {
                triangles[count] = triangles[i];
            }
            count += 1;
        }
        if count == 0 {
            continue;
        }
        for i in count..WIDTH {
            (materials[i], normals[i], triangles[i]) = (materials[0], normals[0], triangles[0]);
        }
        let lanes = GroupLanes { materials: &materials, normals: &normals, triangles: &triangles };
        shade_group::<NEE, M, C>(scene, limits, &group[..count], &lanes, columns);
    }
}

/// What a group's rows resolved to, a lane each.
struct GroupLanes<'a, L> {
    materials: &'a [L; WIDTH],
    normals: &'a [Option<Vec3>; WIDTH],
    triangles: &'a [PlainTriangle; WIDTH],
}

/// A row's material (`material`, looked up at its textured surface `si`:
/// `RenderScene::shading_params`) and the normal its normal map gives
/// (`RenderScene::shading_normal`); `None` where the class hands the row back.
#[inline(always)]
fn resolve<M: LaneMaterial>(
    scene: &RenderScene,
    material: u32,
    si: Option<&SurfaceHit>,
    row: u32,
    columns: &mut impl CameraColumns,
) -> Option<(M::Lane, Option<Vec3>)> {
    let Some(si) = si else {
        return Some((M::resolve(scene, material, &scene.materials[material as usize].shading)?, None));
    };
    let lane = M::resolve(scene, material, &scene.shading_params(si))?;
    let mapped = scene.materials[material as usize].normal_texture.is_some();
    Some((lane, mapped.then(|| scene.shading_normal(si, -columns.ray(row).d))))
}

/// One group of at most [`WIDTH`] rows, their materials resolved; unused lanes repeat the first.
#[inline(always)]
fn shade_group<const NEE: bool, M: LaneMaterial, C: CameraColumns>(
    scene: &RenderScene,
    limits: PathLimits,
    rows: &[u32],
    lanes: &GroupLanes<M::Lane>,
    columns: &mut C,
) {
    let count = rows.len();
    let g = gather_group(rows, lanes.triangles, columns);
    let bsdf = M::bsdf(lanes.materials);
    let hits = GroupHits { triangles: &lanes.triangles[..count], b1: g.b1, b2: g.b2, d: g.d };
    let s = Surface::of(&hits, lanes.normals);
    if columns.records_features() {
        let (normal, beta) = (s.n_side.lanes(), g.beta.lanes());
        for (i, &row) in rows.iter().enumerate() {
            columns.reached(row, g.t[i], bsdf.albedo_hint(i), normal[i], beta[i]);
        }
    }
    let light_samples = if NEE {
        let f = |wi: V3| bsdf.eval(s.wo, wi).scale(wi.z.abs());
        let pdf = |wi: V3| bsdf.pdf(s.wo, wi);
        sample_lights(scene, &LightQuery { surface: &s, group: &g, count }, f, pdf)
    } else {
        [None; WIDTH]
    };
    let next = continuation(&g, &s, &bsdf);
    for (i, &row) in rows.iter().enumerate() {
        let continues = next.updated >> i & 1 == 1 && {
            let path = columns.path(row);
            path.beta = next.beta[i];
            path.prev_pdf = next.pdf[i];
            path.specular_bounce = false;
            path.prev_p = next.p[i];
            path.prev_n = next.n_side[i];
            path.depth += 1;
            let survives = path.depth < limits.rr_depth || next.killed >> i & 1 == 0;
            if survives && path.depth >= limits.rr_depth {
                path.beta = next.survived_beta[i];
            }
            if survives && !path.beta.is_finite() {
                path.l = Vec3::NAN;
                path.mark_bad(Quantity::Throughput);
            }
            survives && path.beta.is_finite() && path.beta.max_element() > 0.0
        };
        // The scalar kernel leaves the ray of a path that ends as it was.
        if continues {
            *columns.ray(row) =
                Ray { o: next.origin[i], d: next.wi[i], t_max: f32::INFINITY, time: next.time[i] };
        }
        columns.vertex_done(row, continues, light_samples[i]);
    }
}

/// What `continuation::continue_path` leaves of each lane, to be written into its path.
struct Next {
    /// Lanes whose BSDF drew a direction that is followed.
    updated: u32,
    /// Lanes Russian roulette ends (where it plays).
    killed: u32,
    beta: [Vec3; WIDTH],
    survived_beta: [Vec3; WIDTH],
    pdf: [f32; WIDTH],
    p: [Vec3; WIDTH],
    n_side: [Vec3; WIDTH],
    origin: [Vec3; WIDTH],
    wi: [Vec3; WIDTH],
    time: [f32; WIDTH],
}

/// The BSDF's sample and the continuation past it (`continuation::continue_along`).
#[inline(never)]
fn continuation(g: &Group, s: &Surface, bsdf: &impl LaneBsdf) -> Next {
    let u = [
        Lanes::new(std::array::from_fn(|i| g.u[i].bsdf_direction().x)),
        Lanes::new(std::array::from_fn(|i| g.u[i].bsdf_direction().y)),
    ];
    let u_lobe = Lanes::new(std::array::from_fn(|i| g.u[i].bsdf_lobe()));
    let bs = bsdf.sample(s.wo, u_lobe, u);
    let zero = Lanes::ZERO;
    let usable = bs.drawn & !bs.pdf.simd_le(zero) & !max_element(bs.f).simd_le(zero);
    let wi_world = s.frame.to_world(bs.wi);
    let updated = usable & !s.crosses_inconsistently(wi_world, bs.wi);
    let beta = g.beta * bs.f.scale(bs.wi.z.abs() / bs.pdf);
    let origin = s.ray_origin(wi_world);
    let survive = max_element(beta.scale(g.eta_scale)).fast_min(Lanes::splat(MAX_SURVIVAL));
    let u_roulette = Lanes::new(std::array::from_fn(|i| g.u[i].roulette()));
    Next {
        updated: updated.bits(),
        killed: u_roulette.simd_ge(survive).to_bitmask(),
        beta: beta.lanes(),
        survived_beta: beta.scale_div(survive).lanes(),
        pdf: bs.pdf.to_array(),
        p: s.p.lanes(),
        n_side: s.n_side.lanes(),
        origin: origin.lanes(),
        wi: wi_world.lanes(),
        time: g.time.to_array(),
    }
}
