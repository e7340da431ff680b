//! Textures real glTF files carry, beyond base colour: emissive textures and alpha (MASK cut-outs,
//! BLEND as stochastic transparency).

use crate::common;

use caustica::camera::look_at;
use caustica::scene::{
    AlphaMode, CameraDesc, IntegratorKind, MaterialDesc, Mesh, RunFile, Scene, Texture, TextureRef, Wrap,
};
use caustica::test_scenes::{diffuse, quad};
use glam::{Vec2, Vec3, Vec4};

/// A floor under a 1 m² lamp facing down whose emissive texture is a 4 × 4 checkerboard of white
/// and black, seen from the side so that both the floor and the lamp's underside are in view.
fn checker_lamp() -> Scene {
    let floor = quad("floor", 0.0, 3.0, true, 0);
    // Facing down: the lamp emits downwards.
    let lamp = quad("lamp", 1.0, 0.5, false, 1);
    let texels =
        (0..16).map(|i| if (i % 4 + i / 4) % 2 == 0 { Vec4::ONE } else { Vec4::new(0.0, 0.0, 0.0, 1.0) });
    let checker = Texture {
        name: "checker".into(),
        width: 4,
        height: 4,
        texels: texels.collect(),
        wrap_s: Wrap::ClampToEdge,
        wrap_t: Wrap::ClampToEdge,
        bytes: Vec::new(),
        srgb: false,
    };
    let mut lamp_material = diffuse("lamp", Vec3::ZERO, Vec3::splat(4.0));
    lamp_material.double_sided = false;
    lamp_material.emissive_texture = Some(TextureRef { texture: 0, tex_coord: 0, transform: None });
    Scene {
        meshes: vec![floor, lamp],
        materials: vec![diffuse("floor", Vec3::splat(0.7), Vec3::ZERO), lamp_material],
        textures: vec![checker],
        camera: Some(CameraDesc {
            name: "side".into(),
            camera_to_world: look_at(Vec3::new(0.0, 0.5, 2.5), Vec3::new(0.0, 0.4, 0.0), Vec3::Y),
            yfov: 60f32.to_radians(),
            aspect_ratio: None,
        }),
        resolution: Some((48, 36)),
        source: "checker lamp (procedural)".into(),
        ..Scene::default()
    }
}

fn render(integrator: IntegratorKind, spp: u32, seed: u64) -> caustica::film::Image {
    let mut run = RunFile::default();
    run.render.integrator = integrator;
    run.render.spp = spp;
    run.render.seed = seed;
    common::render(checker_lamp(), &run)
}

/// Light sampling picks points on the lamp uniformly and must weigh each by the texel there:
/// `pt` (light sampling with MIS) and `pt-naive` (emission found by hitting it, looked up at the
/// hit) are both unbiased, so their difference is zero within the noise, in the image and in every
/// block. Sampling the lamp as if it were uniformly white would make `pt`'s floor twice as bright.
#[test]
fn an_emissive_texture_lights_the_scene_as_seen_and_as_sampled() {
    let sampled = render(IntegratorKind::Pt, 64, 1);
    let hit = render(IntegratorKind::PtNaive, 256, 2);
    let (mean, se) = common::paired_difference(&sampled, &hit);
    assert!(mean.abs() < 4.0 * se, "pt − pt-naive = {mean} ± {se}");
    let worst = common::block_z_scores(&sampled, &hit, 4).into_iter().fold(0.0f64, |m, z| m.max(z.abs()));
    assert!(worst < 4.5, "a block at z = {worst}");
    assert!(sampled.mean().max_element() > 0.05, "black: {}", sampled.mean());
}

/// Seen directly, from below, the lamp shows its checkerboard: pixels at the centres of white
/// texels are near the full 4, those at black ones near 0 (bilinear filtering blends in between; a
/// lamp drawn without its texture would be 4 everywhere).
#[test]
fn an_emissive_texture_is_seen_directly() {
    let mut scene = checker_lamp();
    scene.camera.as_mut().unwrap().camera_to_world = look_at(Vec3::new(0.0, 0.2, 0.0), Vec3::Y, Vec3::Z);
    let mut run = RunFile::default();
    run.render.spp = 4;
    let image = common::render(scene, &run);
    let brightest = image.pixels.iter().map(|p| p.min_element()).fold(0.0f32, f32::max);
    let darkest = image.pixels.iter().map(|p| p.max_element()).fold(f32::INFINITY, f32::min);
    assert!(brightest > 3.5 && darkest < 0.5, "no checkerboard: pixels from {darkest} to {brightest}");
}

/// Photons leave a textured lamp weighted by the texel where they start: `ppm`, which takes even
/// direct light from photons, lights the floor as `pt` does, within its blur and noise (5%; photons
/// leaving the black squares at full power would make the floor twice as bright).
#[test]
fn photons_from_an_emissive_texture_carry_its_texels() {
    let floor = |image: &caustica::film::Image| {
        let rows = (image.height * 3 / 5)..image.height;
        let sum: f64 = rows
            .flat_map(|y| (0..image.width).map(move |x| (y, x)))
            .map(|(y, x)| image.pixels[(y * image.width + x) as usize].element_sum() as f64)
            .sum();
        sum
    };
    let reference = floor(&render(IntegratorKind::Pt, 64, 1));
    let mut run = RunFile::default();
    run.render.integrator = IntegratorKind::Ppm;
    run.progressive.passes = 16;
    run.progressive.photons_per_pass = 50_000;
    let photons = floor(&common::render(checker_lamp(), &run));
    let ratio = photons / reference;
    assert!((ratio - 1.0).abs() < 0.05, "ppm's floor is {ratio} of pt's");
}

/// A floor lit by a small lamp through a black 1 m² screen halfway up, seen from above at a slant,
/// with the screen's material `screen` (texture 0: a 4 × 4 checkerboard of alpha 0 and 1).
fn screened_lamp(screen: Option<MaterialDesc>) -> Scene {
    let mut lamp = diffuse("lamp", Vec3::ZERO, Vec3::splat(10.0));
    lamp.double_sided = false;
    let mut meshes = vec![quad("floor", 0.0, 3.0, true, 0), quad("lamp", 1.5, 0.25, false, 1)];
    let mut materials = vec![diffuse("floor", Vec3::splat(0.7), Vec3::ZERO), lamp];
    if let Some(screen) = screen {
        meshes.push(quad("screen", 0.5, 0.5, true, 2));
        materials.push(screen);
    }
    let texels = (0..16).map(|i| Vec4::new(0.0, 0.0, 0.0, if (i % 4 + i / 4) % 2 == 0 { 1.0 } else { 0.0 }));
    Scene {
        meshes,
        materials,
        textures: vec![Texture {
            name: "alpha checker".into(),
            width: 4,
            height: 4,
            texels: texels.collect(),
            wrap_s: Wrap::ClampToEdge,
            wrap_t: Wrap::ClampToEdge,
            bytes: Vec::new(),
            srgb: false,
        }],
        camera: Some(CameraDesc {
            name: "above".into(),
            camera_to_world: look_at(Vec3::new(0.0, 2.5, 2.5), Vec3::new(0.0, 0.2, 0.0), Vec3::Y),
            yfov: 50f32.to_radians(),
            aspect_ratio: None,
        }),
        resolution: Some((40, 40)),
        source: "screened lamp (procedural)".into(),
        ..Scene::default()
    }
}

fn screen(alpha_mode: AlphaMode, alpha: f32, textured: bool) -> MaterialDesc {
    let mut m = diffuse("screen", Vec3::ZERO, Vec3::ZERO);
    m.alpha_mode = alpha_mode;
    m.alpha = alpha;
    m.base_color_texture = textured.then_some(TextureRef { texture: 0, tex_coord: 0, transform: None });
    m
}

fn render_scene(scene: Scene, integrator: IntegratorKind, spp: u32, seed: u64) -> caustica::film::Image {
    let mut run = RunFile::default();
    run.render.integrator = integrator;
    run.render.spp = spp;
    run.render.seed = seed;
    run.progressive.passes = 16;
    run.progressive.photons_per_pass = 50_000;
    common::render(scene, &run)
}

/// Camera rays (`pt-naive` finds the lamp only through them) and shadow rays (`pt`) see the same
/// holes: their renders agree within the noise, in the image and in every block.
fn assert_unbiased(screen: MaterialDesc, what: &str) {
    let sampled = render_scene(screened_lamp(Some(screen.clone())), IntegratorKind::Pt, 64, 1);
    let hit = render_scene(screened_lamp(Some(screen)), IntegratorKind::PtNaive, 512, 2);
    let (mean, se) = common::paired_difference(&sampled, &hit);
    assert!(mean.abs() < 4.0 * se, "{what}: pt − pt-naive = {mean} ± {se}");
    let worst = common::block_z_scores(&sampled, &hit, 4).into_iter().fold(0.0f64, |m, z| m.max(z.abs()));
    assert!(worst < 4.5, "{what}: a block at z = {worst}");
}

/// MASK: the checkerboard's transparent squares let light through to the floor, for camera rays,
/// shadow rays and photons alike. The screen's shadow is then lighter than an opaque screen's and
/// darker than no screen's; with an alpha factor of 0 every texel is cut and the image is exactly
/// the one without a screen.
#[test]
fn a_masked_cut_out_lets_light_through_for_every_ray() {
    let checker = screen(AlphaMode::Mask { cutoff: 0.5 }, 1.0, true);
    assert_unbiased(checker.clone(), "mask");
    let mean = |scene: Scene| render_scene(scene, IntegratorKind::Pt, 64, 1).mean().element_sum();
    let opaque = mean(screened_lamp(Some(screen(AlphaMode::Opaque, 1.0, true))));
    let masked = mean(screened_lamp(Some(checker.clone())));
    let clear = mean(screened_lamp(None));
    assert!(opaque < masked && masked < clear, "opaque {opaque}, masked {masked}, clear {clear}");
    let invisible = render_scene(
        screened_lamp(Some(screen(AlphaMode::Mask { cutoff: 0.5 }, 0.0, true))),
        IntegratorKind::Pt,
        4,
        1,
    );
    let without = render_scene(screened_lamp(None), IntegratorKind::Pt, 4, 1);
    assert_eq!(invisible.pixels, without.pixels, "a screen cut out everywhere changed the image");
    // Photons pass the holes too: ppm (direct light from photons) agrees with pt within 5%.
    let pt =
        render_scene(screened_lamp(Some(checker.clone())), IntegratorKind::Pt, 64, 1).mean().element_sum();
    let ppm = render_scene(screened_lamp(Some(checker)), IntegratorKind::Ppm, 1, 1).mean().element_sum();
    assert!((ppm / pt - 1.0).abs() < 0.05, "ppm {ppm} against pt {pt}");
}

/// BLEND as stochastic transparency: a ray passes a screen of alpha 0.3 with probability 0.7,
/// whichever kind of ray it is, and photons too.
#[test]
fn a_blended_surface_is_stochastically_transparent_to_every_ray() {
    let veil = screen(AlphaMode::Blend, 0.3, false);
    assert_unbiased(veil.clone(), "blend");
    let pt = render_scene(screened_lamp(Some(veil.clone())), IntegratorKind::Pt, 64, 1).mean().element_sum();
    let ppm = render_scene(screened_lamp(Some(veil)), IntegratorKind::Ppm, 1, 1).mean().element_sum();
    assert!((ppm / pt - 1.0).abs() < 0.05, "ppm {ppm} against pt {pt}");
}

/// A 4 m plane with u along +x and v along +z, tangents given (+x, w = 1, so the bitangent
/// n × t = −z), a normal map of one texel `texel`, seen from straight above.
fn normal_mapped_plane(texel: Option<Vec3>) -> Scene {
    let l = 2.0;
    let plane = Mesh {
        name: "plane".into(),
        positions: vec![
            Vec3::new(-l, 0.0, -l),
            Vec3::new(-l, 0.0, l),
            Vec3::new(l, 0.0, l),
            Vec3::new(l, 0.0, -l),
        ],
        normals: Some(vec![Vec3::Y; 4]),
        uvs: vec![vec![Vec2::new(0.0, 0.0), Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0)]],
        tangents: Some(vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 4]),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: 0,
        ..Mesh::default()
    };
    let mut material = diffuse("plane", Vec3::splat(0.5), Vec3::ZERO);
    let mut textures = Vec::new();
    if let Some(texel) = texel {
        textures.push(Texture {
            name: "normals".into(),
            width: 1,
            height: 1,
            texels: vec![texel.extend(1.0)],
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            bytes: Vec::new(),
            srgb: false,
        });
        material.normal_texture = Some(TextureRef { texture: 0, tex_coord: 0, transform: None });
    }
    Scene {
        meshes: vec![plane],
        materials: vec![material],
        textures,
        camera: Some(CameraDesc {
            name: "above".into(),
            camera_to_world: look_at(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, Vec3::NEG_Z),
            yfov: 30f32.to_radians(),
            aspect_ratio: None,
        }),
        resolution: Some((8, 8)),
        source: "normal-mapped plane (procedural)".into(),
        ..Scene::default()
    }
}

/// A sun of 1 W/m² (683 lux) whose rays travel along `direction`.
fn sun(direction: Vec3) -> caustica::scene::punctual::PunctualLightDesc {
    caustica::scene::punctual::PunctualLightDesc {
        name: "sun".into(),
        kind: caustica::scene::punctual::PunctualKind::Sun,
        position: Vec3::ZERO,
        direction: direction.normalize(),
        color: Vec3::ONE,
        intensity: 683.0,
    }
}

/// A Lambertian plane under a sun shades with the cosine between the sun and its *mapped* normal:
/// L = ρ/π · E · cos. The map tilts the normal 30° towards the tangent (+x) or the bitangent (−z by
/// glTF's n × t · w); the sun comes from 45° on the tilted side, so the mapped cosine is
/// cos 15° = 0.966 where the flat plane gives cos 45° = 0.707 (a bitangent of the wrong sign: 0.259).
/// Every pixel sees the same exact value (a single bounce into an empty sky).
#[test]
fn a_normal_map_turns_the_shading_normal_in_gltfs_tangent_space() {
    let (s, c) = (0.5f32, 0.75f32.sqrt());
    let encode = |local: Vec3| (local + Vec3::ONE) * 0.5;
    let diagonal = std::f32::consts::FRAC_1_SQRT_2;
    for (texel, direction, cosine) in [
        (None, Vec3::new(-diagonal, -diagonal, 0.0), diagonal),
        (Some(encode(Vec3::new(s, 0.0, c))), Vec3::new(-diagonal, -diagonal, 0.0), 15f32.to_radians().cos()),
        (Some(encode(Vec3::new(0.0, s, c))), Vec3::new(0.0, -diagonal, diagonal), 15f32.to_radians().cos()),
        (Some(encode(Vec3::new(0.0, 0.0, 1.0))), Vec3::new(0.0, -diagonal, diagonal), diagonal),
    ] {
        let mut scene = normal_mapped_plane(texel);
        scene.punctual_lights = vec![sun(direction)];
        let mut run = RunFile::default();
        run.render.spp = 4;
        let image = common::render(scene, &run);
        let expected = 0.5 / std::f32::consts::PI * cosine;
        for p in &image.pixels {
            assert!((p.x - expected).abs() < 1e-4 * expected, "{texel:?}: pixel {p}, expected {expected}");
        }
    }
}

/// A wild normal map (every texel a different steep normal) on a white Lambertian plane in a
/// uniform white environment, seen at a slant. Light from below the geometric surface does not
/// reach its top whatever the shading normal says, so where the map tilts the lobe into the surface
/// the plane reflects less than ρ · L, but never nothing: no pixel is black (the view is bent out
/// of the surface, not lost), and light sampling and BSDF sampling, which both refuse directions
/// through the surface, agree.
#[test]
fn a_steep_normal_map_leaves_no_black_spots() {
    let wild = || {
        let texels: Vec<Vec4> = (0..64)
            .map(|i| {
                let a = i as f32 * 2.399;
                Vec3::new(0.5 + 0.45 * a.cos(), 0.5 + 0.45 * a.sin(), 0.55).extend(1.0)
            })
            .collect();
        let mut scene = normal_mapped_plane(None);
        scene.textures = vec![Texture {
            name: "wild".into(),
            width: 8,
            height: 8,
            texels,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            bytes: Vec::new(),
            srgb: false,
        }];
        scene.materials[0].normal_texture = Some(TextureRef { texture: 0, tex_coord: 0, transform: None });
        scene.materials[0].shading.base_color = Vec3::splat(0.8);
        scene.materials[0].double_sided = false;
        scene.environment = Some(caustica::scene::environment::EnvironmentDesc::constant(Vec3::ONE));
        scene.camera.as_mut().unwrap().camera_to_world =
            look_at(Vec3::new(0.0, 0.6, 2.5), Vec3::ZERO, Vec3::Y);
        scene.resolution = Some((32, 32));
        scene
    };
    let mut run = RunFile::default();
    run.render.spp = 64;
    let sampled = common::render(wild(), &run);
    run.render.integrator = IntegratorKind::PtNaive;
    run.render.spp = 256;
    run.render.seed = 2;
    let hit = common::render(wild(), &run);
    let (mean, se) = common::paired_difference(&sampled, &hit);
    assert!(mean.abs() < 4.0 * se, "pt − pt-naive = {mean} ± {se}");
    let plane = &sampled.pixels[(16 * 32) as usize..];
    let darkest = plane.iter().map(|p| p.element_sum() / 3.0).fold(f32::INFINITY, f32::min);
    assert!(darkest > 0.2, "a black spot: {darkest}");
}

/// KHR_materials_clearcoat's textures (which the gltf crate does not parse) are read from the file:
/// ClearCoatTest's partial coat and roughness variations carry theirs, and a texel scales the
/// factor where a hit looks it up (red: the coat's weight, green: its roughness).
#[test]
fn clearcoat_textures_are_read_and_scale_their_factors() {
    let path = common::data("gltf-samples-2/ClearCoatTest/ClearCoatTest.gltf");
    let (scene, _) = caustica::scene::load(&path).expect("loads");
    let material = |name: &str| scene.materials.iter().find(|m| m.name == name).expect(name);
    assert!(material("Partial_Coated").clearcoat_texture.is_some());
    assert!(material("RoughVariations_Coated").clearcoat_roughness_texture.is_some());
    assert!(
        material("Simple_Coated").shading.clearcoat > 0.0
            && material("Simple_Coated").clearcoat_texture.is_none()
    );

    let mut coated = diffuse("coated", Vec3::splat(0.5), Vec3::ZERO);
    coated.shading.clearcoat = 1.0;
    coated.shading.clearcoat_roughness = 0.5;
    coated.clearcoat_texture = Some(TextureRef { texture: 0, tex_coord: 0, transform: None });
    coated.clearcoat_roughness_texture = Some(TextureRef { texture: 0, tex_coord: 0, transform: None });
    let texel = Texture {
        name: "coat".into(),
        width: 1,
        height: 1,
        texels: vec![Vec4::new(0.25, 0.5, 0.0, 1.0)],
        wrap_s: Wrap::Repeat,
        wrap_t: Wrap::Repeat,
        bytes: Vec::new(),
        srgb: false,
    };
    let scene = Scene {
        meshes: vec![quad("plane", 0.0, 1.0, true, 0)],
        materials: vec![coated],
        textures: vec![texel],
        ..Scene::default()
    };
    let render_scene = caustica::RenderScene::build(&scene, caustica::scene::LightSelection::Power);
    let ray = caustica::geometry::Ray {
        o: Vec3::new(0.1, 1.0, 0.2),
        d: Vec3::NEG_Y,
        t_max: f32::INFINITY,
        time: 0.0,
    };
    let hit = render_scene.geometry.intersect(&ray);
    let params = render_scene.shading_params(&render_scene.geometry.surface_hit(&ray, &hit));
    assert_eq!((params.clearcoat, params.clearcoat_roughness), (0.25, 0.25));
}

/// A normal map tilted 60° towards +x, and a point light below the plane on that side: the light is
/// above the *shading* hemisphere but behind the surface, so it must light nothing (no leak).
#[test]
fn a_normal_map_does_not_let_light_through_the_surface() {
    let local = Vec3::new(60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
    let mut scene = normal_mapped_plane(Some((local + Vec3::ONE) * 0.5));
    scene.punctual_lights = vec![caustica::scene::punctual::PunctualLightDesc {
        name: "below".into(),
        kind: caustica::scene::punctual::PunctualKind::Point,
        position: Vec3::new(3.0, -0.2, 0.0),
        direction: Vec3::NEG_Z,
        color: Vec3::ONE,
        intensity: 683.0 * 100.0,
    }];
    let mut run = RunFile::default();
    run.render.spp = 4;
    let image = common::render(scene, &run);
    assert_eq!(image.mean(), Vec3::ZERO, "light leaked through the plane");
}

/// Mirrored UVs (v running along −z, as on the mirrored half of a symmetric model) flip the
/// bitangent: glTF's is (n × t) · w, and a mirrored face carries w = −1, so a map tilting the normal
/// towards the bitangent tilts it towards +z here. Given as w = −1, and made by MikkTSpace from the
/// UVs when the file has no tangents, the sun from 45° on the +z side shades with cos 15°; a
/// handedness ignored (w taken as +1) tilts it the other way, cos 75°.
#[test]
fn a_normal_map_on_mirrored_uvs_follows_the_bitangents_handedness() {
    let (s, c) = (0.5f32, 0.75f32.sqrt());
    let texel = (Vec3::new(0.0, s, c) + Vec3::ONE) * 0.5;
    let diagonal = std::f32::consts::FRAC_1_SQRT_2;
    let mirrored = vec![Vec2::new(0.0, 1.0), Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)];
    for made in [false, true] {
        let what = if made { "MikkTSpace's tangents" } else { "tangents with w = -1" };
        let mut scene = normal_mapped_plane(Some(texel));
        scene.meshes[0].uvs = vec![mirrored.clone()];
        scene.meshes[0].tangents = Some(vec![Vec4::new(1.0, 0.0, 0.0, -1.0); 4]);
        if made {
            // What the loader makes for a file without tangents.
            let tangents = caustica::scene::tangents::generate(&scene.meshes[0], 0).expect("tangents");
            assert!(
                tangents.iter().all(|t| t.w == -1.0),
                "MikkTSpace's handedness on mirrored UVs: {tangents:?}"
            );
            scene.meshes[0].tangents = Some(tangents);
        }
        scene.punctual_lights = vec![sun(Vec3::new(0.0, -diagonal, -diagonal))];
        let mut run = RunFile::default();
        run.render.spp = 4;
        let image = common::render(scene, &run);
        let expected = 0.5 / std::f32::consts::PI * 15f32.to_radians().cos();
        for p in &image.pixels {
            assert!((p.x - expected).abs() < 1e-4 * expected, "{what}: pixel {p}, expected {expected}");
        }
    }
}
