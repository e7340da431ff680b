//! Procedural scenes for tests and benches (no files needed), like obvhs's `test_util`.

use crate::materials::ShadingParams;
use crate::scene::{CameraDesc, MaterialDesc, Mesh, Scene};
use glam::{Mat4, Vec2, Vec3};

/// A diffuse material with the given albedo and emission.
pub fn diffuse(name: &str, albedo: Vec3, emission: Vec3) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        shading: ShadingParams {
            base_color: albedo,
            metallic: 0.0,
            specular: 0.0,
            ..ShadingParams::default()
        },
        emission,
        double_sided: true,
        ..MaterialDesc::default()
    }
}

/// A horizontal square of half-width `half` at height `y` whose front (counter-clockwise) side faces
/// up or down, with texture coordinates 0 to 1 along +x and +z.
pub fn quad(name: &str, y: f32, half: f32, up: bool, material: u32) -> Mesh {
    let h = half;
    let positions = vec![Vec3::new(-h, y, -h), Vec3::new(h, y, -h), Vec3::new(h, y, h), Vec3::new(-h, y, h)];
    let uvs = vec![vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]];
    let indices = if up { vec![[0, 2, 1], [0, 3, 2]] } else { vec![[0, 1, 2], [0, 2, 3]] };
    Mesh { name: name.into(), positions, uvs, indices, material, ..Mesh::default() }
}

/// A UV sphere of `radius` at `center` with `rings` × `2·rings` quads; `inward` makes the front faces
/// (and normals) point to the centre.
pub fn uv_sphere(name: &str, center: Vec3, radius: f32, rings: u32, inward: bool, material: u32) -> Mesh {
    let segments = 2 * rings;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            positions.push(center + radius * n);
            normals.push(if inward { -n } else { n });
        }
    }
    let mut indices = Vec::new();
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (i * row + j, i * row + j + 1, (i + 1) * row + j, (i + 1) * row + j + 1);
            // Outward counter-clockwise order seen from outside; reversed for an inward sphere.
            for tri in [[a, b, d], [a, d, c]] {
                indices.push(if inward { [tri[0], tri[2], tri[1]] } else { tri });
            }
        }
    }
    Mesh { name: name.into(), positions, normals: Some(normals), indices, material, ..Mesh::default() }
}

/// The closed furnace: the camera at the centre of a sphere whose inside is Lambertian with `albedo`
/// and emits `le`. Every path sees L = le / (1 − albedo) exactly, whatever the tessellation, as long
/// as shading uses the facets' own normals (interpolated normals tilt the hemisphere below the facet
/// and let energy escape, which is a property of shading normals, not of the integrator).
pub fn furnace(albedo: f32, le: f32) -> Scene {
    let mut sphere = uv_sphere("furnace", Vec3::ZERO, 1.0, 12, true, 0);
    sphere.normals = None;
    Scene {
        meshes: vec![sphere],
        materials: vec![diffuse("furnace", Vec3::splat(albedo), Vec3::splat(le))],
        camera: Some(CameraDesc {
            name: "centre".into(),
            camera_to_world: Mat4::IDENTITY,
            yfov: 1.2,
            aspect_ratio: None,
        }),
        resolution: Some((16, 16)),
        source: "furnace (procedural)".into(),
        ..Scene::default()
    }
}

/// The environment furnace: a convex Lambertian sphere of `albedo` (flat facets) at the origin under a
/// constant environment of radiance `le`, seen from +Z at distance 3 with a 50° field of view. Each
/// facet sees the whole environment over its hemisphere and nothing of the sphere, so it reflects
/// exactly `albedo · le`; the background is `le`.
pub fn environment_furnace(albedo: f32, le: f32) -> Scene {
    let mut sphere = uv_sphere("ball", Vec3::ZERO, 1.0, 24, false, 0);
    sphere.normals = None;
    Scene {
        meshes: vec![sphere],
        materials: vec![diffuse("ball", Vec3::splat(albedo), Vec3::ZERO)],
        camera: Some(CameraDesc {
            name: "front".into(),
            camera_to_world: Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0)),
            yfov: 50f32.to_radians(),
            aspect_ratio: None,
        }),
        resolution: Some((32, 32)),
        environment: Some(crate::scene::environment::EnvironmentDesc::constant(Vec3::splat(le))),
        source: "environment furnace (procedural)".into(),
        ..Scene::default()
    }
}

/// `n` lights of varied power, colour, size and orientation scattered through a cube of side
/// `extent` (one in 17 a sphere, the rest one-sided triangles), for light-selection tests and
/// benches. Deterministic.
pub fn scattered_lights(n: u32, extent: f32) -> Vec<crate::lights::Light> {
    use crate::lights::{Light, LightShape};
    use crate::sampling::Sampler;
    use crate::sampling::warp::{Frame, uniform_sphere};
    let size = extent / 10.0;
    (0..n)
        .map(|i| {
            let s = Sampler::new(5, i, 0);
            let c = Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) * extent;
            let le = Vec3::new(s.get1d(3), s.get1d(4), s.get1d(5)) * (1.0 + 50.0 * s.get1d(6));
            let shape = if i % 17 == 0 {
                LightShape::Sphere { center: c, radius: size * (0.05 + 0.1 * s.get1d(7)) }
            } else {
                let f = Frame::from_z(uniform_sphere(s.get2d(8)));
                let r = size * (0.05 + 0.2 * s.get1d(10));
                LightShape::triangle([c, c + f.x * r, c + f.y * r])
            };
            Light::new(shape, le, Vec3::ZERO, i)
        })
        .collect()
}
