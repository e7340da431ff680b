//! The weights of every strategy that makes one path sum to one (Veach 1997, §9.2: the condition
//! for an unbiased combination), for paths of one to four bounces in the closed furnace, where every
//! wall both emits and reflects so that every strategy can make every path. The sums are built by
//! the kernel's own weight functions, each subpath's sums by the recursion the systems run.

use super::camera_side::{CameraVertex, connection_weight, emission_weight, light_sample_weight, sky_weight};
use super::light_side::{LightOrigin, NewLightVertex, camera_connection_weight, first_vertex_mis};
use super::mis::{MisFactors, SubpathMis};
use crate::camera::Camera;
use crate::geometry::Ray;
use crate::kernel::{CameraPath, Vertex};
use crate::lights::LightSample;
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;
use crate::scene::run_file::CameraOverrides;
use crate::scene::{FilterKind, LightSelection};
use glam::Vec3;

/// The vertex where the ray from `from` towards `towards` lands, and the ray.
fn land(scene: &RenderScene, from: Vec3, towards: Vec3) -> (Ray, Vertex) {
    let ray = Ray { o: from, d: (towards - from).normalize(), t_max: f32::INFINITY, time: 0.0 };
    let hit = scene.geometry.intersect(&ray);
    assert!(hit.is_hit(), "the furnace is closed");
    (ray, Vertex::new(scene, &ray, scene.geometry.surface_hit(&ray, &hit)))
}

/// The vertex at `to` reached from `from`.
fn reach(scene: &RenderScene, from: Vec3, to: Vec3) -> Vertex {
    land(scene, from, to).1
}

/// Sum of the weights of all strategies for the path camera → y[0] → … → y[n-1] → light point.
fn weight_sum(
    scene: &RenderScene,
    camera: &Camera,
    factors: &MisFactors,
    y: &[Vec3],
    light_point: Vec3,
) -> f32 {
    let n = y.len();
    let mut points = vec![Vec3::ZERO];
    points.extend_from_slice(y);
    points.push(light_point);
    let dist2 = |a: usize, b: usize| (points[a] - points[b]).length_squared();
    // Camera subpath: the sums at points[1..=n+1] (the last: arriving at the light).
    let camera_vertices: Vec<Vertex> = (1..=n + 1).map(|i| reach(scene, points[i - 1], points[i])).collect();
    let mut camera_mis = Vec::new();
    let mut mis = SubpathMis::camera(factors, camera.pdf_w((points[1] - points[0]).normalize()));
    for i in 1..=n + 1 {
        let v = &camera_vertices[i - 1];
        mis.arrive(Some(dist2(i - 1, i)), v.wo.z.abs());
        camera_mis.push(mis);
        if i <= n {
            let wi = v.frame.to_local((points[i + 1] - points[i]).normalize());
            mis.scatter(factors, wi.z.abs(), v.bsdf.pdf(v.wo, wi), v.bsdf.pdf(wi, v.wo), false);
        }
    }
    // Light subpath from the light point back along the path: the sums at points[n], …, points[1].
    let light_vertex_at_light = &camera_vertices[n];
    let light = light_vertex_at_light.si.light;
    let normal = light_vertex_at_light.si.ng;
    let kind = scene.lights.emitter_kind(light);
    let out = (points[n] - points[n + 1]).normalize();
    let origin = LightOrigin {
        light,
        p: light_point,
        n: normal,
        emission_pdf: scene.lights.emission_pdf(light, normal, out),
        cos: normal.dot(out).abs(),
        kind,
    };
    let mut light_vertices = Vec::new();
    let mut mis = SubpathMis::default();
    for i in (1..=n).rev() {
        let (ray, v) = land(scene, points[i + 1], points[i]);
        if i == n {
            mis = first_vertex_mis(scene, factors, &origin, v.si.p, &ray, dist2(i, i + 1), 0.0);
        }
        mis.arrive(Some(dist2(i, i + 1)), v.wo.z.abs());
        light_vertices.push((i, v, mis));
        let wi = v.frame.to_local((points[i - 1] - points[i]).normalize());
        mis.scatter(factors, wi.z.abs(), v.bsdf.pdf(v.wo, wi), v.bsdf.pdf(wi, v.wo), false);
    }
    let light_at = |i: usize| light_vertices.iter().find(|(j, _, _)| *j == i).unwrap();
    let camera_at = |i: usize| CameraVertex {
        v: camera_vertices[i - 1],
        beta: Vec3::ONE,
        mis: camera_mis[i - 1],
        depth: i as u32 - 1,
        media: crate::kernel::media::Media::AIR,
    };

    // s = 0: the camera subpath hits the light.
    let path = CameraPath { prev_p: points[n], depth: n as u32, ..CameraPath::START };
    let wo = (points[n] - points[n + 1]).normalize();
    let mut sum =
        emission_weight(scene, &path, &camera_mis[n], light_vertex_at_light, wo, dist2(n, n + 1), 0.0);
    // s = 1: light sampling at the last camera vertex.
    let v = &camera_vertices[n - 1];
    let pdf = scene.lights.direct_pdf(light, points[n], light_point, normal, -wo, 0.0);
    let ls = LightSample { p: light_point, n: normal, le: Vec3::ONE, pdf, delta: false };
    sum += light_sample_weight(scene, factors, v, &camera_mis[n - 1], light, &ls);
    // 2 ≤ s ≤ n: camera vertex i connects to light vertex i + 1.
    for i in 1..n {
        let (_, lv, lmis) = light_at(i + 1);
        let l = NewLightVertex::new(lv, Vec3::ONE, *lmis, (n - i - 1) as u32);
        let (l, l_bsdf) = (l.vertex, l.bsdf);
        let d = points[i + 1] - points[i];
        let c = camera_at(i);
        let wi = (c.v.frame.to_local(d.normalize()), l.frame.to_local(-d.normalize()));
        sum += connection_weight(factors, &c, (&l, &l_bsdf), wi, d.length_squared());
    }
    // s = n + 1: the light subpath's last vertex seen by the camera.
    let (_, lv, lmis) = light_at(1);
    sum += camera_connection_weight(camera, factors, lv, lmis, Vec3::ZERO);
    // With merging: the two subpaths meet at each vertex, the camera's arriving from the camera's
    // side, the light's from the light's.
    if factors.merges() {
        for i in 1..=n {
            let c = camera_at(i);
            let (_, lv, lmis) = light_at(i);
            let wi = c.v.frame.to_local(lv.frame.to_world(lv.wo));
            let (pdf, pdf_rev) = (c.v.bsdf.pdf(c.v.wo, wi), c.v.bsdf.pdf(wi, c.v.wo));
            sum += super::mis::merging_weight(factors, &c.mis, lmis, pdf, pdf_rev);
        }
    }
    sum
}

#[test]
fn the_weights_of_every_strategy_of_a_path_sum_to_one() {
    furnace_paths_sum_their_weights_to_one(MisFactors::connections_only(16 * 16));
}

/// With merging (vcm), at radii from a hundredth to a tenth of the furnace's: the merges at every
/// vertex join the connections' sum.
#[test]
fn with_merging_the_weights_of_every_strategy_of_a_path_sum_to_one() {
    for radius in [0.01, 0.1] {
        furnace_paths_sum_their_weights_to_one(MisFactors::merging(16 * 16, radius));
    }
}

fn furnace_paths_sum_their_weights_to_one(factors: MisFactors) {
    let scene = RenderScene::build(&crate::test_scenes::furnace(0.6, 1.0), LightSelection::Power);
    let desc = crate::test_scenes::furnace(0.6, 1.0).camera.unwrap();
    let camera = Camera::new(&desc, &CameraOverrides::default(), 16, 16, FilterKind::Box).unwrap();
    let sampler = Sampler::new(7, 0, 0);
    let mut checked = 0;
    for path in 0..40u32 {
        let bounces = 1 + path as usize % 4;
        // The first vertex within the camera's view, the others anywhere on the wall.
        let u = sampler.get2d(100 * path);
        let mut y = vec![land(&scene, Vec3::ZERO, Vec3::new(u.x - 0.5, u.y - 0.5, -1.5)).1.si.p];
        for b in 0..bounces {
            let u = sampler.get2d(100 * path + 2 + 2 * b as u32);
            let inside = Vec3::new(u.x - 0.5, u.y - 0.5, (u.x * 7.3).fract() - 0.5);
            y.push(land(&scene, *y.last().unwrap(), inside).1.si.p);
        }
        let light_point = y.pop().unwrap();
        let sum = weight_sum(&scene, &camera, &factors, &y, light_point);
        assert!(
            (sum - 1.0).abs() < 2e-3,
            "path {path} ({bounces} bounces, radius {}): the weights sum to {sum}",
            factors.radius
        );
        checked += 1;
    }
    assert_eq!(checked, 40);
}

/// One bounce under the sky: the camera path escaping (s = 0), light sampling of the sky (s = 1),
/// and a subpath from the sky's disc seen by the camera (s = 2), whose densities are per unit solid
/// angle and per unit area of the disc, with no distance to convert.
#[test]
fn the_weights_of_a_path_from_the_sky_sum_to_one() {
    sky_paths_sum_their_weights_to_one(MisFactors::connections_only(32 * 32));
    sky_paths_sum_their_weights_to_one(MisFactors::merging(32 * 32, 0.05));
}

fn sky_paths_sum_their_weights_to_one(factors: MisFactors) {
    let furnace = crate::test_scenes::environment_furnace(0.5, 1.0);
    let scene = RenderScene::build(&furnace, LightSelection::Power);
    let camera =
        Camera::new(furnace.camera.as_ref().unwrap(), &CameraOverrides::default(), 32, 32, FilterKind::Box)
            .unwrap();
    let sky = scene.lights.environment_index();
    let eye = Vec3::new(0.0, 0.0, 3.0);
    let sampler = Sampler::new(11, 0, 0);
    for path in 0..20u32 {
        let u = sampler.get2d(10 * path);
        let (ray, v) = land(&scene, eye, Vec3::new(0.6 * u.x - 0.3, 0.6 * u.y - 0.3, 0.0));
        // A direction towards the sky above the facet.
        let u = sampler.get2d(10 * path + 2);
        let local = crate::sampling::warp::cosine_hemisphere(u);
        let w = v.frame.to_world(local);
        let dist2 = (v.si.p - eye).length_squared();
        // The camera subpath.
        let mut camera_mis = SubpathMis::camera(&factors, camera.pdf_w(ray.d));
        camera_mis.arrive(Some(dist2), v.wo.z.abs());
        let at_vertex = camera_mis;
        let wi = v.frame.to_local(w);
        camera_mis.scatter(&factors, wi.z.abs(), v.bsdf.pdf(v.wo, wi), v.bsdf.pdf(wi, v.wo), false);
        let escaped = CameraPath { prev_p: v.si.p, depth: 1, ..CameraPath::START };
        let mut sum = sky_weight(&scene, &escaped, &camera_mis, w);
        let far = v.si.p + w * 100.0;
        let pdf = scene.lights.direct_pdf(sky, v.si.p, far, -w, w, 0.0);
        let ls = LightSample { p: far, n: -w, le: Vec3::ONE, pdf, delta: false };
        sum += light_sample_weight(&scene, &factors, &v, &at_vertex, sky, &ls);
        // The light subpath from the sky's disc, arriving along −w.
        let origin = LightOrigin {
            light: sky,
            p: far,
            n: -w,
            emission_pdf: scene.lights.emission_pdf(sky, -w, -w),
            cos: 1.0,
            kind: scene.lights.emitter_kind(sky),
        };
        let (light_ray, lv) = land(&scene, far, v.si.p);
        let mut light_mis = first_vertex_mis(&scene, &factors, &origin, lv.si.p, &light_ray, 1.0, 0.0);
        light_mis.arrive(None, lv.wo.z.abs());
        sum += camera_connection_weight(&camera, &factors, &lv, &light_mis, eye);
        if factors.merges() {
            let c = CameraVertex {
                v,
                beta: Vec3::ONE,
                mis: at_vertex,
                depth: 0,
                media: crate::kernel::media::Media::AIR,
            };
            let wi = v.frame.to_local(lv.frame.to_world(lv.wo));
            let (pdf, pdf_rev) = (v.bsdf.pdf(v.wo, wi), v.bsdf.pdf(wi, v.wo));
            sum += super::mis::merging_weight(&factors, &c.mis, &light_mis, pdf, pdf_rev);
        }
        assert!(
            (sum - 1.0).abs() < 2e-3,
            "path {path} (radius {}): the weights sum to {sum}",
            factors.radius
        );
    }
}
