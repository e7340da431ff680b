//! Scatter: what each active row does where its ray landed — the kernel's camera vertex (emission
//! weighted by MIS, a light sample, the BSDF continuation with Russian roulette) — and which queue
//! it goes to next. Vertices on plain Lambertian triangles are queued together and shaded in lanes
//! (`kernel::lanes`, the scalar kernel's bits); the others one by one.

use super::guide::{Guide, PathGuide};
use super::{PathQueues, PathSampler, PathShadow, PathThroughput, ShadowLearning};
use crate::components::{PathAov, PathHit, PathRay};
use crate::resources::{RenderConfig, SceneResource};
use bevy_ecs::prelude::*;
use caustica_core::geometry::Ray;
use caustica_core::geometry::bvh::{NO_LIGHT, PlainTriangle};
use caustica_core::kernel::guided::{GuidedStep, guided_path_vertex};
use caustica_core::kernel::lanes::{DiffuseOutcome, DiffuseVertex, diffuse_vertices, plain_lambert};
use caustica_core::kernel::path_vertex::path_vertex;
use caustica_core::kernel::{CameraPath, ShadowSample, VertexSampler};
use glam::Vec3;

/// What scatter reads and writes.
type ScatterColumns = (
    &'static PathHit,
    &'static PathSampler,
    &'static mut PathRay,
    &'static mut PathThroughput,
    &'static mut PathShadow,
    Option<&'static mut ShadowLearning>,
    Option<&'static mut PathAov>,
    Option<&'static mut PathGuide>,
);

/// The lanes' queue and their inputs and outputs, kept from step to step (no allocation per step).
#[derive(Default)]
pub struct LaneScratch {
    /// Each material's albedo when it is plain Lambertian.
    albedo: Vec<Option<Vec3>>,
    rows: Vec<u32>,
    vertices: Vec<DiffuseVertex>,
    paths: Vec<CameraPath>,
    rays: Vec<Ray>,
    outcomes: Vec<DiffuseOutcome>,
}

/// What the lanes' scratch holds a row at most: its inputs, path, ray, outcome and queue entry.
pub const LANE_SCRATCH_BYTES_PER_ROW: usize = size_of::<DiffuseVertex>()
    + size_of::<CameraPath>()
    + size_of::<Ray>()
    + size_of::<DiffuseOutcome>()
    + size_of::<u32>();

/// Shade every active row: it stays active with its next ray, or is finished; a light sample
/// queues it for the shadow stage too. `NEE` selects `pt` (light sampling + MIS) over `pt-naive`.
pub fn scatter_paths<const NEE: bool>(
    scene: Res<SceneResource>,
    config: Res<RenderConfig>,
    mut queues: ResMut<PathQueues>,
    guide: Option<Res<Guide>>,
    mut lanes: Local<LaneScratch>,
    mut paths: Query<ScatterColumns>,
) {
    if queues.active.is_empty() {
        return;
    }
    // A guide that trains no more and guides nowhere leaves the render as it would be without one.
    let guide = guide.filter(|guide| guide.training() || guide.sampling);
    let Ok(mut tables) = paths.contiguous_iter_mut() else { return };
    let Some((hits, samplers, mut rays, mut states, mut shadows, mut learning, mut aovs, mut remembered)) =
        tables.next()
    else {
        return;
    };
    let (rays, states, shadows) =
        (rays.bypass_change_detection(), states.bypass_change_detection(), shadows.bypass_change_detection());
    let mut learning = learning.as_mut().map(|l| l.bypass_change_detection());
    let mut aovs = aovs.as_mut().map(|a| a.bypass_change_detection());
    let mut remembered = remembered.as_mut().map(|r| r.bypass_change_detection());
    let queues = &mut *queues;
    let lanes = &mut *lanes;
    lanes.albedo.clear();
    lanes.albedo.extend(scene.materials.iter().map(plain_lambert));
    lanes.rows.clear();
    lanes.vertices.clear();
    lanes.paths.clear();
    lanes.rays.clear();
    let mut next = std::mem::take(&mut queues.next);
    let mut active = std::mem::take(&mut queues.active);
    let mut queue_shadow = |row: u32, sample: ShadowSample, queues: &mut PathQueues| {
        let i = row as usize;
        shadows[i] = PathShadow { ray: sample.ray, contribution: sample.contribution };
        if let Some(learning) = learning.as_deref_mut() {
            learning[i] = ShadowLearning { light: sample.light, normal: sample.normal };
        }
        queues.shadow.push(row);
    };
    for &row in &active {
        let i = row as usize;
        // Feature images record the first surface from the scalar vertex: a render that asks for
        // them shades every vertex there. A guided render does too where its guide takes part (the
        // lanes know no guide; while training, they report the steps they took).
        if aovs.is_none()
            && guide.as_ref().is_none_or(|guide| !guide.takes_part(&rays[i].0, &hits[i].0))
            && let Some((triangle, albedo)) =
                takes_lanes(&scene, &lanes.albedo, &config, &hits[i].0, &states[i].0)
        {
            let (ray, hit, path) = (rays[i].0, hits[i].0, states[i].0);
            let u = VertexSampler::new(samplers[i].0, path.depth);
            lanes.vertices.push(DiffuseVertex { ray, hit, triangle, albedo, u });
            lanes.paths.push(path);
            lanes.rays.push(ray);
            lanes.rows.push(row);
            continue;
        }
        let aov = aovs.as_deref_mut().map(|a| &mut a[i].0);
        let (continues, light_sample) = match &guide {
            None => path_vertex::<NEE>(
                &scene,
                config.limits,
                &hits[i].0,
                &mut rays[i].0,
                &mut states[i].0,
                samplers[i].0,
                aov,
            ),
            Some(guide) => {
                let mut training = remembered.as_deref_mut().filter(|_| guide.training()).map(|r| &mut r[i]);
                let path = &mut states[i].0;
                if let Some(remembered) = training.as_deref_mut().filter(|_| !NEE) {
                    remembered.arrive(path.l);
                }
                let (continues, light_sample, step) = guided_path_vertex::<NEE>(
                    &scene,
                    config.limits,
                    &hits[i].0,
                    &mut rays[i].0,
                    path,
                    samplers[i].0,
                    aov,
                    &guide.tree,
                );
                if let Some(remembered) = training {
                    if NEE {
                        // The light emitted here is now in `l`; light sampled here is not yet.
                        remembered.arrive(path.l);
                    }
                    if let (Some(step), true) = (step, continues) {
                        remembered.remember(step, path.beta);
                    }
                }
                (continues, light_sample)
            }
        };
        if let Some(sample) = light_sample {
            queue_shadow(row, sample, queues);
        }
        if continues { next.push(row) } else { queues.finished.push(row) }
    }
    if !lanes.rows.is_empty() {
        lanes.outcomes.clear();
        lanes.outcomes.resize(lanes.rows.len(), DiffuseOutcome::default());
        diffuse_vertices::<NEE>(
            &scene,
            config.limits,
            &lanes.vertices,
            &mut lanes.paths,
            &mut lanes.rays,
            &mut lanes.outcomes,
        );
        let training = guide.as_ref().is_some_and(|guide| guide.training());
        for (k, &row) in lanes.rows.iter().enumerate() {
            let i = row as usize;
            states[i].0 = lanes.paths[k];
            rays[i].0 = lanes.rays[k];
            let outcome = lanes.outcomes[k];
            if let (true, Some(remembered)) = (training, remembered.as_deref_mut()) {
                // A lane's vertex emits nothing and its light sample is not yet counted, so the
                // radiance gathered now is what its previous vertex waits for.
                let (remembered, path) = (&mut remembered[i], &states[i].0);
                remembered.arrive(path.l);
                if outcome.continues {
                    remembered.remember(lane_step(&lanes.vertices[k], rays[i].0.d), path.beta);
                }
            }
            if let Some(sample) = outcome.light_sample {
                queue_shadow(row, sample, queues);
            }
            if outcome.continues { next.push(row) } else { queues.finished.push(row) }
        }
    }
    active.clear();
    queues.active = next;
    queues.next = active;
}

/// The step a lane's Lambertian vertex took along `wi`, for training: the lanes sample the cosine
/// lobe about the shading normal, so its pdf is the BSDF's.
fn lane_step(v: &DiffuseVertex, wi: Vec3) -> GuidedStep {
    let p = v.ray.o + v.ray.d * v.hit.t;
    let [a, b, c] = v.triangle.p;
    let n = match v.triangle.normals {
        Some([na, nb, nc]) => na * (1.0 - v.hit.b1 - v.hit.b2) + nb * v.hit.b1 + nc * v.hit.b2,
        None => (b - a).cross(c - a),
    }
    .normalize_or_zero();
    let pdf = n.dot(wi).abs() * std::f32::consts::FRAC_1_PI;
    GuidedStep { p, wi, pdf, bsdf_pdf: pdf }
}

/// The triangle and albedo of the vertex where `hit` lands, if it takes the lanes: a plain triangle
/// of a plain Lambertian material that does not emit, a path in air, not at its last depth.
#[inline]
fn takes_lanes(
    scene: &caustica_core::RenderScene,
    albedo: &[Option<Vec3>],
    config: &RenderConfig,
    hit: &caustica_core::geometry::bvh::Hit,
    path: &CameraPath,
) -> Option<(PlainTriangle, Vec3)> {
    if !hit.is_hit() || path.depth >= config.limits.max_depth || path.media.current().is_some() {
        return None;
    }
    let triangle = scene.geometry.plain_triangle(hit.prim).filter(|t| t.light == NO_LIGHT)?;
    Some((triangle, albedo.get(triangle.material as usize).copied().flatten()?))
}
