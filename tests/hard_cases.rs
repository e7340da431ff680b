//! Numerically hard cases: rays spawned from surfaces at every scale and at grazing angles.

use caustica::geometry::offset::offset_ray_origin;
use caustica::geometry::{Geometry, PrimitiveKind, Ray};
use caustica::sampling::Sampler;
use caustica::sampling::warp::{Frame, uniform_sphere};
use caustica::scene::{Mesh, Scene, Sphere};
use caustica::test_scenes::diffuse;
use glam::Vec3;

/// A tilted quad and a sphere of size `scale`, far from the origin (so absolute errors are large).
fn scene_at_scale(scale: f32) -> Scene {
    let offset = Vec3::new(3.0, -2.0, 5.0) * scale;
    let corners = [
        Vec3::new(-1.0, 0.1, -1.0),
        Vec3::new(1.0, -0.2, -1.0),
        Vec3::new(1.0, 0.2, 1.0),
        Vec3::new(-1.0, -0.1, 1.0),
    ]
    .map(|c| c * scale + offset);
    let plane = Mesh {
        name: "plane".into(),
        positions: corners.to_vec(),
        indices: vec![[0, 2, 1], [0, 3, 2]],
        ..Mesh::default()
    };
    Scene {
        meshes: vec![plane],
        spheres: vec![Sphere {
            name: "ball".into(),
            center: offset + Vec3::new(0.0, 3.0, 0.0) * scale,
            radius: scale,
            material: 0,
            motion: None,
        }],
        materials: vec![diffuse("grey", Vec3::splat(0.5), Vec3::ZERO)],
        ..Scene::default()
    }
}

#[test]
fn rays_spawned_from_a_surface_never_rehit_it_at_any_scale() {
    for scale in [1e-3f32, 1e-1, 1.0, 1e2, 1e4] {
        let scene = scene_at_scale(scale);
        let geometry = Geometry::build(&scene);
        let mut rehits = 0;
        let mut tested = 0;
        for i in 0..4000u32 {
            let s = Sampler::new(11, i, 0);
            // Aim at the plane or the sphere from a random point far above.
            let target = if i % 2 == 0 {
                scene.meshes[0].positions[0].lerp(scene.meshes[0].positions[2], s.get1d(0))
                    + (scene.meshes[0].positions[1] - scene.meshes[0].positions[3]) * (s.get1d(1) - 0.5) * 0.9
            } else {
                scene.spheres[0].center
            };
            let o = target + uniform_sphere(s.get2d(2)) * 10.0 * scale;
            let ray = Ray { o, d: (target - o).normalize(), t_max: f32::INFINITY, time: 0.0 };
            let hit = geometry.intersect(&ray);
            if !hit.is_hit() {
                continue;
            }
            let si = geometry.surface_hit(&ray, &hit);
            // Leave on the side the ray came from (reflection), at angles down to grazing.
            let frame = Frame::from_z(if si.ng.dot(ray.d) < 0.0 { si.ng } else { -si.ng });
            let cos = [0.5, 1e-2, 1e-4][(i / 2 % 3) as usize];
            let phi = s.get1d(4) * std::f32::consts::TAU;
            let sin = (1.0f32 - cos * cos).sqrt();
            let w = frame.to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos));
            let spawned = Ray {
                o: offset_ray_origin(si.p, si.p_error, si.ng, w),
                d: w,
                t_max: f32::INFINITY,
                time: 0.0,
            };
            let again = geometry.intersect(&spawned);
            tested += 1;
            // The plane is flat and the sphere convex: a ray leaving either on its outer side cannot hit it again.
            if again.is_hit() && again.prim == hit.prim {
                rehits += 1;
            }
        }
        assert!(tested > 1000, "scale {scale}: only {tested} rays hit");
        assert_eq!(rehits, 0, "scale {scale}: {rehits} of {tested} spawned rays re-hit their own surface");
    }
}

#[test]
fn refracted_rays_enter_a_sphere_and_leave_from_the_far_side() {
    for scale in [1e-3f32, 1.0, 1e4] {
        let scene = scene_at_scale(scale);
        let geometry = Geometry::build(&scene);
        let ball = &scene.spheres[0];
        for i in 0..1000u32 {
            let s = Sampler::new(5, i, 0);
            let o = ball.center + uniform_sphere(s.get2d(0)) * 5.0 * scale;
            let ray = Ray { o, d: (ball.center - o).normalize(), t_max: f32::INFINITY, time: 0.0 };
            let hit = geometry.intersect(&ray);
            if geometry.primitive(hit.prim).1.kind != PrimitiveKind::Sphere {
                continue; // blocked by the plane on the way in
            }
            let si = geometry.surface_hit(&ray, &hit);
            // Continue straight in: the next hit must be the far side, about a diameter away.
            let inner = Ray {
                o: offset_ray_origin(si.p, si.p_error, si.ng, ray.d),
                d: ray.d,
                t_max: f32::INFINITY,
                time: 0.0,
            };
            let exit = geometry.intersect(&inner);
            assert!(exit.is_hit(), "scale {scale}: ray escaped the sphere from inside");
            assert!(
                exit.t > 1.9 * ball.radius,
                "scale {scale}: re-hit at t = {} (radius {})",
                exit.t,
                ball.radius
            );
        }
    }
}
