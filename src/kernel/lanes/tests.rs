//! The lanes against the scalar kernel, path by path and bit for bit.

use super::*;
use crate::kernel::path_vertex::path_vertex;
use crate::render_scene::RenderScene;
use crate::sampling::warp::uniform_sphere;
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::{LightSelection, Scene};
use crate::test_scenes::{diffuse, quad, uv_sphere};

/// A room (the inside of a sphere with interpolated normals, and a flat floor without) around a
/// ball with normals, lit by two emitting quads: every kind of triangle lanes shade, and the
/// emitters they leave to the scalar kernel.
fn room() -> Scene {
    Scene {
        meshes: vec![
            uv_sphere("room", Vec3::ZERO, 1.0, 10, true, 0),
            quad("floor", -0.6, 0.7, true, 1),
            uv_sphere("ball", Vec3::new(0.2, -0.3, 0.1), 0.25, 8, false, 2),
            quad("lamp", 0.9, 0.2, false, 3),
            quad("dim lamp", -0.55, 0.1, true, 4),
        ],
        materials: vec![
            diffuse("walls", Vec3::new(0.7, 0.6, 0.5), Vec3::ZERO),
            diffuse("floor", Vec3::new(0.2, 0.8, 0.3), Vec3::ZERO),
            diffuse("ball", Vec3::new(0.9, 0.9, 0.1), Vec3::ZERO),
            diffuse("lamp", Vec3::ZERO, Vec3::splat(8.0)),
            diffuse("dim lamp", Vec3::ZERO, Vec3::new(0.5, 1.0, 2.0)),
        ],
        source: "lanes room (procedural)".into(),
        ..Scene::default()
    }
}

/// Vertices of random rays from inside the room, with random path states, that lanes take.
fn vertices(scene: &RenderScene, kind: SamplerKind, n: u32) -> Vec<(DiffuseVertex, CameraPath, Sampler)> {
    let albedo: Vec<Option<Vec3>> = scene.materials.iter().map(plain_lambert).collect();
    let mut out = Vec::new();
    for i in 0..n * 4 {
        let s = Sampler::new(11, i, 0);
        let o = (Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) - 0.5) * 1.2;
        let ray = Ray { o, d: uniform_sphere(s.get2d(3)), t_max: f32::INFINITY, time: 0.0 };
        let hit = scene.geometry.intersect(&ray);
        if !hit.is_hit() {
            continue;
        }
        let Some(triangle) = scene.geometry.plain_triangle(hit.prim) else { continue };
        let Some(albedo) = albedo[triangle.material as usize] else { continue };
        if triangle.light != crate::geometry::bvh::NO_LIGHT {
            continue;
        }
        let depth = (s.get1d(5) * 9.0) as u32;
        let path = CameraPath {
            beta: Vec3::new(s.get1d(6), s.get1d(7), s.get1d(8)) * 2.0,
            l: Vec3::new(s.get1d(9), 0.0, 0.5),
            eta_scale: 0.5 + s.get1d(10) * 2.0,
            prev_pdf: s.get1d(11) * 3.0,
            prev_p: Vec3::new(s.get1d(12), s.get1d(13), 0.0),
            prev_n: Vec3::Y,
            depth,
            specular_bounce: s.get1d(14) < 0.2,
            ..CameraPath::START
        };
        let sampler = Sampler::of(kind, 3, i % 97, i / 97);
        let u = VertexSampler::new(sampler, depth);
        out.push((DiffuseVertex { ray, hit, triangle, albedo, u }, path, sampler));
        if out.len() == n as usize {
            break;
        }
    }
    out
}

fn path_bits(p: &CameraPath) -> Vec<u32> {
    let v = |v: Vec3| v.to_array().map(f32::to_bits);
    [v(p.beta), v(p.l), v(p.prev_p), v(p.prev_n)]
        .concat()
        .into_iter()
        .chain([p.eta_scale.to_bits(), p.prev_pdf.to_bits(), p.depth, p.specular_bounce as u32])
        .collect()
}

fn ray_bits(r: &Ray) -> [u32; 8] {
    let [ox, oy, oz] = r.o.to_array().map(f32::to_bits);
    let [dx, dy, dz] = r.d.to_array().map(f32::to_bits);
    [ox, oy, oz, dx, dy, dz, r.t_max.to_bits(), r.time.to_bits()]
}

/// A light sample's bits: its segment, contribution, light and normal.
fn sample_bits(s: &Option<ShadowSample>) -> Option<Vec<u32>> {
    s.as_ref().map(|s| {
        let mut bits = ray_bits(&s.ray).to_vec();
        bits.extend(s.contribution.to_array().map(f32::to_bits));
        bits.push(s.light);
        bits.extend(s.normal.to_array().map(f32::to_bits));
        bits
    })
}

fn agree<const NEE: bool>(
    scene: &RenderScene,
    limits: PathLimits,
    kind: SamplerKind,
) -> (usize, usize, usize) {
    let inputs = vertices(scene, kind, 3000);
    assert!(inputs.len() > 2000, "only {} vertices", inputs.len());
    let vertices: Vec<DiffuseVertex> = inputs.iter().map(|(v, _, _)| *v).collect();
    let mut paths: Vec<CameraPath> = inputs.iter().map(|(_, p, _)| *p).collect();
    let mut rays: Vec<Ray> = vertices.iter().map(|v| v.ray).collect();
    let mut outcomes = vec![DiffuseOutcome::default(); vertices.len()];
    // An odd count: the last group has unused lanes.
    let n = vertices.len() - 3;
    diffuse_vertices::<NEE>(
        scene,
        limits,
        &vertices[..n],
        &mut paths[..n],
        &mut rays[..n],
        &mut outcomes[..n],
    );
    let (mut continued, mut sampled, mut killed) = (0, 0, 0);
    for (i, (v, path, sampler)) in inputs.iter().take(n).enumerate() {
        let (mut path, mut ray) = (*path, v.ray);
        let (continues, light_sample) =
            path_vertex::<NEE>(scene, limits, &v.hit, &mut ray, &mut path, *sampler, None);
        assert_eq!(outcomes[i].continues, continues, "vertex {i}: whether the path goes on");
        assert_eq!(
            sample_bits(&outcomes[i].light_sample),
            sample_bits(&light_sample),
            "vertex {i}: light sample"
        );
        assert_eq!(path_bits(&paths[i]), path_bits(&path), "vertex {i}: the path");
        assert_eq!(ray_bits(&rays[i]), ray_bits(&ray), "vertex {i}: the next ray");
        continued += continues as usize;
        sampled += light_sample.is_some() as usize;
        killed += !continues as usize;
    }
    (continued, sampled, killed)
}

/// Every field a vertex writes (whether the path goes on, its next ray, its throughput, radiance
/// and MIS state, the light sample's segment, contribution, light and normal) is the scalar
/// kernel's, bit for bit, for `pt` and `pt-naive`, both samplers, power and tree selection, with
/// Russian roulette and a depth limit in play.
#[test]
fn lanes_shade_as_the_scalar_kernel_does_bit_for_bit() {
    for selection in [LightSelection::Power, LightSelection::Tree] {
        let scene = RenderScene::build(&room(), selection);
        for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
            let limits = PathLimits { max_depth: 9, rr_depth: 2 };
            let (continued, sampled, ended) = agree::<true>(&scene, limits, kind);
            assert!(
                continued > 500 && sampled > 500 && ended > 50,
                "{continued} {sampled} {ended}: too few of each"
            );
            agree::<false>(&scene, PathLimits { max_depth: u32::MAX, rr_depth: 5 }, kind);
        }
    }
}
