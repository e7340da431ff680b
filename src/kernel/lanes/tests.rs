//! The lanes against the scalar kernel, path by path and bit for bit: every class, through the
//! columns they read in a render.

use super::*;
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::kernel::aov::FirstSurface;
use crate::kernel::path_vertex::path_vertex;
use crate::kernel::{CameraPath, PathLimits, ShadowSample};
use crate::render_scene::RenderScene;
use crate::sampling::warp::uniform_sphere;
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::{LightSelection, Scene, Sphere, Texture, TextureRef};
use crate::test_scenes::{diffuse, quad, uv_sphere};
use glam::{Vec3, Vec4};

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

/// Columns as a render holds them, and what the lanes reported of each row.
#[derive(Clone, Default)]
struct TestColumns {
    rays: Vec<Ray>,
    hits: Vec<Hit>,
    paths: Vec<CameraPath>,
    samplers: Vec<Sampler>,
    features: Option<Vec<FirstSurface>>,
    done: Vec<Option<(bool, Option<ShadowSample>)>>,
    /// Rows the lanes handed back to the scalar kernel.
    handed_back: Vec<u32>,
}

impl CameraColumns for TestColumns {
    fn ray(&mut self, row: u32) -> &mut Ray {
        &mut self.rays[row as usize]
    }
    fn hit(&self, row: u32) -> &Hit {
        &self.hits[row as usize]
    }
    fn path(&mut self, row: u32) -> &mut CameraPath {
        &mut self.paths[row as usize]
    }
    fn sampler(&self, row: u32) -> Sampler {
        self.samplers[row as usize]
    }
    fn vertex_done(&mut self, row: u32, continues: bool, light_sample: Option<ShadowSample>) {
        assert!(self.done[row as usize].is_none(), "row {row} shaded twice");
        self.done[row as usize] = Some((continues, light_sample));
    }
    fn scalar_vertex(&mut self, row: u32) {
        self.handed_back.push(row);
    }
    fn records_features(&self) -> bool {
        self.features.is_some()
    }
    fn reached(&mut self, row: u32, t: f32, albedo: Vec3, normal: Vec3, beta: Vec3) {
        if let Some(f) = &mut self.features {
            f[row as usize].reached_surface(t, albedo, normal, beta);
        }
    }
}

/// Rows of random rays from inside the room, with random path states, whose vertices `class`
/// takes.
fn rows_of(
    scene: &RenderScene,
    limits: PathLimits,
    class: LaneClass,
    kind: SamplerKind,
    n: u32,
) -> TestColumns {
    let mut c = TestColumns::default();
    for i in 0..n * 8 {
        let s = Sampler::new(11, i, 0);
        let o = (Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) - 0.5) * 1.2;
        let ray = Ray { o, d: uniform_sphere(s.get2d(3)), t_max: f32::INFINITY, time: s.get1d(4) };
        let hit = scene.geometry.intersect(&ray);
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
        if classify(scene, limits, &hit, &path) != class {
            continue;
        }
        c.rays.push(ray);
        c.hits.push(hit);
        c.paths.push(path);
        c.samplers.push(Sampler::of(kind, 3, i % 97, i / 97));
        if c.rays.len() == n as usize {
            break;
        }
    }
    c.done = vec![None; c.rays.len()];
    c
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

/// Shade rows of `class` in lanes and by the scalar kernel, and hold every field to the scalar
/// kernel's bits. Returns how many went on, took a light sample and ended.
fn agree<const NEE: bool>(
    scene: &RenderScene,
    limits: PathLimits,
    class: LaneClass,
    kind: SamplerKind,
    features: bool,
    shade: impl Fn(&RenderScene, PathLimits, &[u32], &mut TestColumns),
) -> (usize, usize, usize, usize) {
    let mut lanes = rows_of(scene, limits, class, kind, 3000);
    assert!(lanes.rays.len() > 2000, "only {} vertices of {class:?}", lanes.rays.len());
    if features {
        lanes.features = Some(vec![FirstSurface::start(Vec3::X, Vec3::X); lanes.rays.len()]);
    }
    let scalar = lanes.clone();
    // An odd count: the last group has unused lanes.
    let n = lanes.rays.len() - 3;
    let rows: Vec<u32> = (0..n as u32).collect();
    shade(scene, limits, &rows, &mut lanes);
    let (mut continued, mut sampled, mut killed) = (0, 0, 0);
    for i in 0..n {
        let scalar_kernel = |c: &TestColumns| {
            let (mut path, mut ray) = (c.paths[i], c.rays[i]);
            let mut feature = c.features.as_ref().map(|f| f[i]);
            let (continues, light_sample) = path_vertex::<NEE>(
                scene,
                limits,
                &c.hits[i],
                &mut ray,
                &mut path,
                c.samplers[i],
                feature.as_mut(),
            );
            (continues, light_sample, path, ray, feature)
        };
        let (continues, light_sample, path, ray, feature) = scalar_kernel(&scalar);
        if lanes.handed_back.contains(&(i as u32)) {
            assert!(lanes.done[i].is_none(), "row {i} handed back and shaded");
            let (c, s, p, r, f) = scalar_kernel(&lanes);
            lanes.done[i] = Some((c, s));
            (lanes.paths[i], lanes.rays[i]) = (p, r);
            if let (Some(features), Some(f)) = (&mut lanes.features, f) {
                features[i] = f;
            }
        }
        let (lane_continues, lane_sample) = lanes.done[i].expect("every row is shaded");
        assert_eq!(lane_continues, continues, "vertex {i}: whether the path goes on");
        assert_eq!(sample_bits(&lane_sample), sample_bits(&light_sample), "vertex {i}: light sample");
        assert_eq!(path_bits(&lanes.paths[i]), path_bits(&path), "vertex {i}: the path");
        assert_eq!(ray_bits(&lanes.rays[i]), ray_bits(&ray), "vertex {i}: the next ray");
        if let (Some(lane), Some(scalar)) = (lanes.features.as_ref().map(|f| f[i]), feature) {
            assert_eq!(lane, scalar, "vertex {i}: the feature images' first surface");
        }
        continued += continues as usize;
        sampled += light_sample.is_some() as usize;
        killed += !continues as usize;
    }
    assert!(lanes.done[n..].iter().all(Option::is_none), "rows beyond the queue were shaded");
    assert!(lanes.handed_back.len() * 10 < n, "{} of {n} rows handed back", lanes.handed_back.len());
    (continued, sampled, killed, lanes.handed_back.len())
}

/// Every field a vertex writes (whether the path goes on, its next ray, its throughput, radiance
/// and MIS state, the light sample's segment, contribution, light and normal, the feature images'
/// first surface) is the scalar kernel's, bit for bit, for `pt` and `pt-naive`, both samplers,
/// power and tree selection, with Russian roulette and a depth limit in play.
fn agree_everywhere(scene: &Scene, class: LaneClass) -> usize {
    let mut handed_back = 0;
    for selection in [LightSelection::Power, LightSelection::Tree] {
        let scene = RenderScene::build(scene, selection);
        for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
            let limits = PathLimits { max_depth: 9, rr_depth: 2 };
            let shade = |s: &RenderScene, l, rows: &[u32], c: &mut TestColumns| {
                shade_class::<true, _>(s, l, class, rows, c)
            };
            let (continued, sampled, ended, back) = agree::<true>(&scene, limits, class, kind, false, shade);
            assert!(
                continued > 500 && sampled > 300 && ended > 50,
                "{class:?}: {continued} {sampled} {ended}: too few of each"
            );
            let limits = PathLimits { max_depth: u32::MAX, rr_depth: 5 };
            let shade = |s: &RenderScene, l, rows: &[u32], c: &mut TestColumns| {
                shade_class::<false, _>(s, l, class, rows, c)
            };
            handed_back += back + agree::<false>(&scene, limits, class, kind, true, shade).3;
        }
    }
    handed_back
}

#[test]
fn lambert_lanes_shade_as_the_scalar_kernel_does_bit_for_bit() {
    assert_eq!(agree_everywhere(&room(), LaneClass::Lambert), 0, "a plain Lambertian is never handed back");
}

/// The metallic-roughness mixture, untextured on the walls and the ball and textured on the floor
/// (base colour, metallic-roughness and a normal map): its rows whose roughness texel makes a
/// mirror are handed back to the scalar kernel, and there are some.
#[test]
fn metal_rough_lanes_shade_as_the_scalar_kernel_does_bit_for_bit() {
    assert!(agree_everywhere(&glossy_room(), LaneClass::MetalRough) > 0, "no textured mirror texel was met");
}

/// A textured Lambertian with a normal map whose tangents are mirrored (w = −1).
#[test]
fn textured_lambert_lanes_shade_as_the_scalar_kernel_does_bit_for_bit() {
    assert_eq!(agree_everywhere(&glossy_room(), LaneClass::Lambert), 0);
}

/// Next-event estimation towards points, spots and suns in lanes: the room lit by its two quads,
/// a point light, a spot whose cone covers part of the room, a narrow spot and a sun, every light
/// sample the scalar kernel's.
#[test]
fn punctual_lights_in_lanes_light_as_the_scalar_kernel_does_bit_for_bit() {
    use crate::scene::punctual::{PunctualKind, PunctualLightDesc};
    let light = |name: &str, kind, position, direction: Vec3, intensity| PunctualLightDesc {
        name: name.into(),
        kind,
        position,
        direction: direction.normalize(),
        color: Vec3::new(1.0, 0.8, 0.6),
        intensity,
    };
    let spot = |inner: f32, outer: f32| PunctualKind::Spot { inner_cone: inner, outer_cone: outer };
    let lights = vec![
        light("point", PunctualKind::Point, Vec3::new(0.3, 0.5, -0.2), Vec3::Y, 900.0),
        light("spot", spot(0.3, 0.7), Vec3::new(-0.3, 0.6, 0.3), Vec3::new(0.2, -1.0, 0.1), 2000.0),
        light("narrow spot", spot(0.05, 0.0502), Vec3::new(0.0, 0.6, 0.0), -Vec3::Y, 3000.0),
        light("sun", PunctualKind::Sun, Vec3::ZERO, Vec3::new(0.3, -1.0, 0.2), 700.0),
    ];
    for mut scene in [room(), glossy_room()] {
        scene.punctual_lights = lights.clone();
        agree_everywhere(&scene, LaneClass::Lambert);
    }
    let mut scene = glossy_room();
    scene.punctual_lights = lights;
    agree_everywhere(&scene, LaneClass::MetalRough);
}

/// Next-event estimation towards spherical lamps in lanes: a large lamp near the walls (wide
/// cones), a small one (cones on both sides of the Taylor expansion's bound), one inside the ball (no sample
/// from outside it) and one that moves over the shutter, every light sample the scalar kernel's.
#[test]
fn sphere_lamps_in_lanes_light_as_the_scalar_kernel_does_bit_for_bit() {
    let lamp = |name: &str, center, radius, material, motion| Sphere {
        name: name.into(),
        center,
        radius,
        material,
        motion,
    };
    for mut scene in [room(), glossy_room()] {
        let emitter = scene.materials.len() as u32;
        scene.materials.push(diffuse("sphere lamp", Vec3::ZERO, Vec3::new(6.0, 5.0, 4.0)));
        scene.spheres = vec![
            lamp("large", Vec3::new(-0.5, 0.4, -0.4), 0.3, emitter, None),
            lamp("small", Vec3::new(0.4, 0.6, 0.3), 0.02, emitter, None),
            lamp("in the ball", Vec3::new(0.2, -0.3, 0.1), 0.05, emitter, None),
            lamp("moving", Vec3::new(0.1, 0.2, -0.6), 0.1, emitter, Some(Vec3::new(0.3, 0.0, 0.1))),
        ];
        let class = if scene.textures.is_empty() { LaneClass::Lambert } else { LaneClass::MetalRough };
        agree_everywhere(&scene, class);
    }
}

/// Next-event estimation towards triangle lamps that move over the shutter, in lanes: the room's
/// bright lamp moving sideways and its dim one up, every light sample the scalar kernel's.
#[test]
fn moving_lamps_in_lanes_light_as_the_scalar_kernel_does_bit_for_bit() {
    for (mut scene, class) in [(room(), LaneClass::Lambert), (glossy_room(), LaneClass::MetalRough)] {
        scene.meshes[3].motion = Some(Vec3::new(0.3, 0.0, -0.2));
        scene.meshes[4].motion = Some(Vec3::new(0.0, 0.2, 0.1));
        agree_everywhere(&scene, class);
    }
}

/// Next-event estimation towards the environment in lanes: a constant sky (by the cosine about the
/// normal) and a rotated map with dark rows and a bright spot (by its luminance), every light
/// sample the scalar kernel's. The room is closed, so the samples are tested, not what they light.
#[test]
fn environment_in_lanes_lights_as_the_scalar_kernel_does_bit_for_bit() {
    use crate::film::Image;
    use crate::scene::environment::{EnvironmentDesc, EnvironmentRadiance};
    let (width, height) = (16, 8);
    let pixels = (0..width * height)
        .map(|i| match (i % width, i / width) {
            (_, 0 | 7) => Vec3::ZERO,
            (5, 2) => Vec3::new(400.0, 300.0, 200.0),
            _ => Vec3::new(texel_number(i, 10), texel_number(i, 11), texel_number(i, 12)),
        })
        .collect();
    let skies = [
        EnvironmentRadiance::Constant(Vec3::new(0.4, 0.5, 0.7)),
        EnvironmentRadiance::Map(Image { width, height, pixels }),
    ];
    for radiance in skies {
        let environment = EnvironmentDesc {
            name: "sky".into(),
            radiance,
            strength: 1.5,
            rotation: glam::Quat::from_rotation_y(0.7) * glam::Quat::from_rotation_x(0.3),
        };
        for (mut scene, class) in [(room(), LaneClass::Lambert), (glossy_room(), LaneClass::MetalRough)] {
            scene.environment = Some(environment.clone());
            agree_everywhere(&scene, class);
        }
    }
}

/// The metallic-roughness mixture under a clear coat: rough walls and a gold ball under coats of
/// their own weight and roughness, and the textured floor under a coat whose weight and roughness
/// are textured too (its roughness texels down to a mirror coat, whose rows are handed back).
#[test]
fn coated_metal_rough_lanes_shade_as_the_scalar_kernel_does_bit_for_bit() {
    assert!(
        agree_everywhere(&coated(glossy_room()), LaneClass::MetalRoughCoated) > 0,
        "no mirror coat was met"
    );
}

/// Lambert's BSDF under a clear coat: the room's plain walls, and its textured table top with a
/// normal map.
#[test]
fn coated_lambert_lanes_shade_as_the_scalar_kernel_does_bit_for_bit() {
    let mut scene = coated(room());
    scene.materials[1].clearcoat_roughness_texture = None;
    agree_everywhere(&scene, LaneClass::LambertCoated);
    assert_eq!(
        agree_everywhere(&coated(glossy_room()), LaneClass::LambertCoated),
        0,
        "a rough coat handed back"
    );
}

/// `scene` with a clear coat on its first three materials (walls, floor, ball) and its table, if
/// any: the floor's weight in the colour texture's red channel and its roughness in the
/// metallic-roughness texture's green (squared random numbers: a few texels mirror smooth).
fn coated(mut scene: Scene) -> Scene {
    let s = texel_number;
    let first = scene.textures.len() as u32;
    scene.textures.push(texture("coat", &|i| Vec4::new(0.2 + 0.8 * s(i, 8), 1.0, 1.0, 1.0)));
    scene.textures.push(texture("coat roughness", &|i| Vec4::new(1.0, s(i, 9) * s(i, 9), 1.0, 1.0)));
    let texture_ref = |texture| Some(TextureRef { texture, tex_coord: 0, transform: None });
    let coats = [(0, 0.8, 0.3), (1, 1.0, 0.6), (2, 0.5, 0.2), (5, 0.9, 0.45)];
    for (material, weight, roughness) in coats {
        if let Some(m) = scene.materials.get_mut(material) {
            m.shading.clearcoat = weight;
            m.shading.clearcoat_roughness = roughness;
        }
    }
    scene.materials[1].clearcoat_texture = texture_ref(first);
    scene.materials[1].clearcoat_roughness_texture = texture_ref(first + 1);
    scene
}

/// Random number `d` of texel `i`, the same in every test scene.
fn texel_number(i: u32, d: u32) -> f32 {
    Sampler::new(21, i, 0).get1d(d)
}

/// An 8×8 texture whose texel `i` is `texel(i)`.
fn texture(name: &str, texel: &dyn Fn(u32) -> Vec4) -> Texture {
    Texture {
        name: name.into(),
        width: 8,
        height: 8,
        texels: (0..64).map(texel).collect(),
        ..Texture::default()
    }
}

/// [`room`] with the metallic-roughness mixture: rough metal and plastic walls, a gold ball, a
/// floor textured in base colour, metallic-roughness and normal, and a table top that is a
/// textured Lambertian with a normal map on mirrored tangents.
fn glossy_room() -> Scene {
    let mut scene = room();
    let s = texel_number;
    scene.textures = vec![
        texture("colour", &|i| Vec4::new(s(i, 0), s(i, 1), s(i, 2), 1.0)),
        // Roughness in G down to a mirror, metallic in B.
        texture("metallic-roughness", &|i| Vec4::new(1.0, s(i, 3) * s(i, 3), s(i, 4), 1.0)),
        texture("normal", &|i| Vec4::new(s(i, 5), s(i, 6), 0.6 + 0.4 * s(i, 7), 1.0)),
    ];
    let texture_ref = |texture| Some(TextureRef { texture, tex_coord: 0, transform: None });
    let m = &mut scene.materials;
    m[0].shading.metallic = 0.3;
    m[0].shading.roughness = 0.5;
    m[0].shading.specular = 1.0;
    m[0].shading.specular_color = Vec3::new(0.8, 1.0, 0.9);
    m[1].shading.metallic = 0.8;
    m[1].shading.roughness = 0.9;
    m[1].shading.specular = 0.7;
    m[1].base_color_texture = texture_ref(0);
    m[1].metallic_roughness_texture = texture_ref(1);
    m[1].normal_texture = texture_ref(2);
    m[1].normal_scale = 0.8;
    m[2].shading.metallic = 1.0;
    m[2].shading.roughness = 0.35;
    m[2].shading.base_color = Vec3::new(1.0, 0.78, 0.34);
    let mut table = diffuse("table", Vec3::new(0.6, 0.9, 0.7), Vec3::ZERO);
    table.base_color_texture = texture_ref(0);
    table.normal_texture = texture_ref(2);
    table.normal_scale = 1.0;
    m.push(table);
    scene.meshes[1].tangents = Some(vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 4]);
    let mut table = quad("table", 0.3, 0.4, true, 5);
    table.tangents = Some(vec![Vec4::new(1.0, 0.0, 0.0, -1.0); 4]);
    scene.meshes.push(table);
    scene
}

/// The class table: a Lambertian without textures takes the lanes, an emitter's hits and misses
/// do not.
#[test]
fn hits_on_emitters_and_misses_are_the_scalar_kernels() {
    let scene = RenderScene::build(&room(), LightSelection::Power);
    let limits = PathLimits { max_depth: 9, rr_depth: 5 };
    assert_eq!(classify(&scene, limits, &Hit::MISS, &CameraPath::START), LaneClass::Scalar);
    let (mut lamp, mut wall) = (0, 0);
    for i in 0..2000 {
        let s = Sampler::new(5, i, 0);
        let ray = Ray { o: Vec3::ZERO, d: uniform_sphere(s.get2d(0)), t_max: f32::INFINITY, time: 0.0 };
        let hit = scene.geometry.intersect(&ray);
        let material = scene.geometry.surface_hit(&ray, &hit).material;
        let class = classify(&scene, limits, &hit, &CameraPath::START);
        if material >= 3 {
            assert_eq!(class, LaneClass::Scalar, "an emitter's hit");
            lamp += 1;
        } else {
            assert_eq!(class, LaneClass::Lambert, "material {material}");
            wall += 1;
        }
        let last = CameraPath { depth: 9, ..CameraPath::START };
        assert_eq!(classify(&scene, limits, &hit, &last), LaneClass::Scalar, "the last depth");
    }
    assert!(lamp > 10 && wall > 1000, "{lamp} {wall}");
}

/// Light selection in lanes picks the light and probability `Lights::select` picks, bit for bit:
/// a tree over hundreds of emitting triangles (two lamp spheres and the room's quads) with and
/// without an environment beside it (the tree's share), power selection's interleaved searches,
/// from points inside and outside the lamps' bounds, with and without a normal.
#[test]
fn light_selection_in_lanes_picks_what_the_scalar_selection_picks() {
    let mut scene = room();
    scene.meshes.push(uv_sphere("lamp ball", Vec3::new(-0.4, 0.3, -0.2), 0.15, 12, false, 3));
    scene.meshes.push(uv_sphere("dim ball", Vec3::new(0.5, -0.2, 0.4), 0.1, 9, false, 4));
    let mut with_sky = scene.clone();
    with_sky.environment = Some(crate::scene::environment::EnvironmentDesc::constant(Vec3::splat(0.3)));
    let mut compared = 0;
    let selections =
        [LightSelection::Tree, LightSelection::Visibility, LightSelection::Power, LightSelection::Uniform];
    for scene in [&scene, &with_sky] {
        for selection in selections {
            let mut render_scene = RenderScene::build(scene, selection);
            if selection == LightSelection::Visibility {
                learn_visibility(&mut render_scene);
            }
            let lights = &render_scene.lights;
            assert!(lights.lights.len() > 300, "{} lights", lights.lights.len());
            for group in 0..300u32 {
                let s = Sampler::new(17, group, 0);
                let p = V3::gather(|i| {
                    let d = 3 * i as u32;
                    (Vec3::new(s.get1d(d), s.get1d(d + 1), s.get1d(d + 2)) - 0.5) * 2.4
                });
                let n = V3::gather(|i| {
                    if (group as usize + i).is_multiple_of(5) {
                        Vec3::ZERO
                    } else {
                        uniform_sphere(s.get2d(40 + 2 * i as u32))
                    }
                });
                let u: [f32; WIDTH] = std::array::from_fn(|i| s.get1d(80 + i as u32));
                let count = WIDTH - (group as usize % 3);
                let lanes = tree::select_lights(lights, p, n, u, count);
                let (p, n) = (p.lanes(), n.lanes());
                for i in 0..WIDTH {
                    let scalar = if i < count { lights.select(p[i], n[i], u[i]) } else { None };
                    let bits = |c: Option<(u32, f32)>| c.map(|(light, pmf)| (light, pmf.to_bits()));
                    assert_eq!(bits(lanes[i]), bits(scalar), "{selection:?}, group {group}, lane {i}");
                    compared += scalar.is_some() as usize;
                }
            }
        }
    }
    assert!(compared > 10_000, "only {compared} selections compared");
}

/// Visibility-aware selection that has learned: random shadow-ray outcomes recorded over the room
/// (a third of the cells' lights blocked), most cells left with a distribution of their own, some
/// (outside the room) with none.
fn learn_visibility(scene: &mut RenderScene) {
    let lights = scene.lights.lights.len() as u32;
    for k in 0..400_000u32 {
        let s = Sampler::new(23, k, 0);
        let p = (Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) - 0.5) * 2.0;
        let n = uniform_sphere(s.get2d(3));
        let light = ((s.get1d(5) * lights as f32) as u32).min(lights - 1);
        scene.lights.record_visibility(p, n, light, s.get1d(6) > 0.33);
    }
    scene.lights.finish_learning();
}
