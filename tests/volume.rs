//! Beer–Lambert absorption inside closed transmissive meshes (KHR_materials_volume attenuation),
//! for camera paths and photons.

use crate::common;

use caustica::camera::look_at;
use caustica::film::Image;
use caustica::materials::ShadingParams;
use caustica::scene::{CameraDesc, IntegratorKind, MaterialDesc, Mesh, RunFile, Scene};
use caustica::test_scenes::{diffuse, quad};
use glam::Vec3;

/// Thickness of the slab (m) and its absorption coefficients per channel (1/m).
const THICKNESS: f32 = 0.5;
const SIGMA: Vec3 = Vec3::new(0.5, 1.0, 2.0);
const SIZE: u32 = 16;
const YFOV_DEGREES: f32 = 20.0;

/// An axis-aligned box from `min` to `max`, faces counter-clockwise seen from outside.
fn cuboid(name: &str, min: Vec3, max: Vec3, material: u32) -> Mesh {
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let indices = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    Mesh { name: name.into(), positions: (0..8).map(corner).collect(), indices, material, ..Mesh::default() }
}

/// Clear "glass" of IOR 1 (no reflection, no bending: only absorption acts) that absorbs `sigma`.
fn absorber(sigma: Vec3) -> MaterialDesc {
    MaterialDesc {
        name: "absorber".into(),
        shading: ShadingParams {
            metallic: 0.0,
            roughness: 0.0,
            transmission: 1.0,
            ior: 1.0,
            thickness: THICKNESS,
            ..ShadingParams::default()
        },
        attenuation: sigma,
        double_sided: true,
        ..MaterialDesc::default()
    }
}

/// A camera on the z axis looking through a slab (z in ±THICKNESS/2, 2 m wide) at a white
/// emitting wall behind it (radiance 1, facing the camera).
fn slab_before_a_wall(sigma: Vec3) -> Scene {
    let wall = Mesh {
        name: "wall".into(),
        positions: vec![
            Vec3::new(-3.0, -3.0, -2.0),
            Vec3::new(3.0, -3.0, -2.0),
            Vec3::new(3.0, 3.0, -2.0),
            Vec3::new(-3.0, 3.0, -2.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: 1,
        ..Mesh::default()
    };
    let half = Vec3::new(1.0, 1.0, 0.5 * THICKNESS);
    Scene {
        meshes: vec![cuboid("slab", -half, half, 0), wall],
        materials: vec![absorber(sigma), diffuse("wall", Vec3::ZERO, Vec3::ONE)],
        camera: Some(CameraDesc {
            name: "front".into(),
            camera_to_world: look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y),
            yfov: YFOV_DEGREES.to_radians(),
            aspect_ratio: None,
        }),
        resolution: Some((SIZE, SIZE)),
        source: "slab before a wall (procedural)".into(),
        ..Scene::default()
    }
}

/// exp(−σ · d / cos θ) averaged over each pixel (a 4 × 4 midpoint grid): the path through the slab
/// of a ray at angle θ to its normal is d / cos θ.
fn analytic() -> Vec<Vec3> {
    let tan_half = (0.5 * YFOV_DEGREES.to_radians()).tan();
    let mut out = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let mut sum = Vec3::ZERO;
            for j in 0..4 {
                for i in 0..4 {
                    let sx = (x as f32 + (i as f32 + 0.5) / 4.0) / SIZE as f32;
                    let sy = (y as f32 + (j as f32 + 0.5) / 4.0) / SIZE as f32;
                    let d =
                        Vec3::new((2.0 * sx - 1.0) * tan_half, (1.0 - 2.0 * sy) * tan_half, -1.0).normalize();
                    sum += (-SIGMA * (THICKNESS / -d.z)).exp();
                }
            }
            out.push(sum / 16.0);
        }
    }
    out
}

fn render(scene: Scene, integrator: IntegratorKind) -> Image {
    let mut run = RunFile::default();
    run.render.integrator = integrator;
    run.render.spp = 16;
    run.progressive.passes = 4;
    run.progressive.photons_per_pass = 1000;
    common::render(scene, &run)
}

/// Seen through the slab, the wall is exp(−σ d / cos θ) per channel, in `pt` and in `sppm` (whose
/// camera paths follow specular chains to what they see directly): the analytic value within the
/// spread of the pixel's footprint (1/cos θ varies by 0.2% across one) and float rounding.
#[test]
fn a_slab_transmits_exp_minus_sigma_d_to_camera_paths() {
    let exact = analytic();
    for integrator in [IntegratorKind::Pt, IntegratorKind::Sppm] {
        let image = render(slab_before_a_wall(SIGMA), integrator);
        for (p, e) in image.pixels.iter().zip(&exact) {
            let error = ((*p - *e) / *e).abs().max_element();
            assert!(error < 3e-3, "{integrator:?}: pixel {p}, expected {e}");
        }
        // A clear slab (σ = 0) of IOR 1 is invisible.
        let clear = render(slab_before_a_wall(Vec3::ZERO), integrator);
        assert!(clear.pixels.iter().all(|p| (*p - Vec3::ONE).abs().max_element() < 1e-5), "{integrator:?}");
    }
}

/// A floor lit through an absorbing slab by a lamp above it: photons (`ppm` takes even direct light
/// from them) lose what the slab absorbs as camera paths do, so `ppm`'s floor matches `pt`'s
/// within its blur and noise (5%; photons passing unabsorbed would make it 2.4 times as bright
/// under the slab); and the absorbing slab darkens the floor against a clear one.
#[test]
fn photons_are_absorbed_in_the_slab_as_camera_paths_are() {
    let scene = |sigma: Vec3| {
        let floor = quad("floor", 0.0, 3.0, true, 1);
        let lamp = quad("lamp", 2.0, 1.0, false, 2);
        let mut lamp_material = diffuse("lamp", Vec3::ZERO, Vec3::splat(3.0));
        lamp_material.double_sided = false;
        Scene {
            meshes: vec![
                cuboid("slab", Vec3::new(-1.5, 0.8, -1.5), Vec3::new(1.5, 0.8 + THICKNESS, 1.5), 0),
                floor,
                lamp,
            ],
            materials: vec![absorber(sigma), diffuse("floor", Vec3::splat(0.7), Vec3::ZERO), lamp_material],
            camera: Some(CameraDesc {
                name: "below".into(),
                camera_to_world: look_at(Vec3::new(0.0, 0.6, 2.8), Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
                yfov: 50f32.to_radians(),
                aspect_ratio: None,
            }),
            resolution: Some((32, 24)),
            source: "slab over a floor (procedural)".into(),
            ..Scene::default()
        }
    };
    let floor_sum = |image: &Image| image.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>();
    let mut run = RunFile::default();
    run.render.spp = 64;
    let pt = floor_sum(&common::render(scene(SIGMA), &run));
    let clear = floor_sum(&common::render(scene(Vec3::ZERO), &run));
    run.render.integrator = IntegratorKind::Ppm;
    run.progressive.passes = 16;
    run.progressive.photons_per_pass = 50_000;
    let ppm = floor_sum(&common::render(scene(SIGMA), &run));
    assert!((ppm / pt - 1.0).abs() < 0.05, "ppm {ppm} against pt {pt}");
    assert!(pt < 0.8 * clear, "the slab absorbs nothing: {pt} against {clear} clear");
}

/// A lamp and a floor both inside one absorbing box (IOR 1), seen from outside: light reaches the
/// floor through the medium whether `pt` samples the lamp (the shadow ray must be attenuated over
/// its length) or `pt-naive` hits it (the path is attenuated as it travels), so the two agree
/// within their noise.
#[test]
fn light_sampled_inside_a_medium_is_attenuated_along_the_shadow_ray() {
    let scene = || {
        let floor = quad("floor", 0.0, 1.5, true, 1);
        let lamp = quad("lamp", 1.5, 0.5, false, 2);
        let mut lamp_material = diffuse("lamp", Vec3::ZERO, Vec3::splat(5.0));
        lamp_material.double_sided = false;
        Scene {
            meshes: vec![
                cuboid("tank", Vec3::new(-2.0, -0.5, -2.0), Vec3::new(2.0, 2.0, 2.0), 0),
                floor,
                lamp,
            ],
            materials: vec![absorber(SIGMA), diffuse("floor", Vec3::splat(0.7), Vec3::ZERO), lamp_material],
            camera: Some(CameraDesc {
                name: "outside".into(),
                camera_to_world: look_at(Vec3::new(0.0, 1.2, 4.0), Vec3::new(0.0, 0.2, 0.0), Vec3::Y),
                yfov: 40f32.to_radians(),
                aspect_ratio: None,
            }),
            resolution: Some((32, 24)),
            source: "lamp in a tank (procedural)".into(),
            ..Scene::default()
        }
    };
    let mut run = RunFile::default();
    run.render.spp = 64;
    let sampled = common::render(scene(), &run);
    run.render.integrator = IntegratorKind::PtNaive;
    run.render.spp = 512;
    run.render.seed = 2;
    let hit = common::render(scene(), &run);
    let (mean, se) = common::paired_difference(&sampled, &hit);
    assert!(mean.abs() < 4.0 * se, "pt − pt-naive = {mean} ± {se}");
    let worst = common::block_z_scores(&sampled, &hit, 4).into_iter().fold(0.0f64, |m, z| m.max(z.abs()));
    assert!(worst < 4.5, "a block at z = {worst}");
}
