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

/// Directions with a negative-zero component (`-Vec3::Z` is (-0, -0, -1)) hit what their positive-zero
/// twins hit: obvhs 0.4 reads the sign of -0.0 inconsistently, and these rays used to miss everything.
#[test]
fn directions_with_negative_zero_components_hit_like_positive_zero_ones() {
    let scene = scene_at_scale(1.0);
    let geometry = Geometry::build(&scene);
    let center = scene.spheres[0].center;
    for (offset, d) in [
        (Vec3::new(0.0, 0.0, 5.0), -Vec3::Z),
        (Vec3::new(0.0, 5.0, 0.0), -Vec3::Y),
        (Vec3::new(5.0, 0.0, 0.0), -Vec3::X),
        (Vec3::new(0.0, 0.0, -5.0), Vec3::new(-0.0, -0.0, 1.0)),
    ] {
        let ray = Ray { o: center + offset, d, t_max: f32::INFINITY, time: 0.0 };
        let twin = Ray { d: d + Vec3::ZERO, ..ray };
        let (hit, twin_hit) = (geometry.intersect(&ray), geometry.intersect(&twin));
        assert!(twin_hit.is_hit(), "direction {d}: the positive-zero twin misses");
        assert!(hit.is_hit() && hit.t == twin_hit.t, "direction {d:?}: {hit:?} vs {twin_hit:?}");
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

// ---------------------------------------------------------------------------------------------
// Whole renders of hard scenes, for every integrator.
// ---------------------------------------------------------------------------------------------

use crate::common;

use caustica::camera::look_at;
use caustica::film::Image;
use caustica::scene::{CameraDesc, IntegratorKind, MaterialDesc, RunFile, load, validate};
use caustica::test_scenes::furnace;
use glam::Mat4;
use std::path::Path;
use std::time::Instant;

/// Photons emitted by one render of [`tiny_run`]: per pass × passes for the progressive mappers, the
/// global map for `pm`.
const PROGRESSIVE_PHOTONS: f64 = 4.0 * 5000.0;
const PM_PHOTONS: f64 = 5000.0;

/// Few samples, passes and photons, fixed seed, `size`² pixels.
fn tiny_run(kind: IntegratorKind, size: u32) -> RunFile {
    let mut run = RunFile::default();
    run.render.integrator = kind;
    run.render.spp = 4;
    run.render.seed = 7;
    run.photons.photons = PM_PHOTONS as u32;
    run.photons.caustic_photons = PM_PHOTONS as u32;
    run.progressive.passes = 4;
    run.progressive.photons_per_pass = (PROGRESSIVE_PHOTONS / 4.0) as u32;
    run.film.width = Some(size);
    run.film.height = Some(size);
    run
}

fn assert_finite(image: &Image, what: &str) {
    for (i, p) in image.pixels.iter().enumerate() {
        assert!(p.is_finite() && p.min_element() >= 0.0, "{what}: pixel {i} is {p}");
    }
}

fn grey(image: &Image) -> Vec<f64> {
    image.pixels.iter().map(|p| (p.x + p.y + p.z) as f64 / 3.0).collect()
}

/// Mean and standard error of the grey pixel values (pixels of the path tracers are independent).
fn mean_and_standard_error(image: &Image) -> (f64, f64) {
    let v = grey(image);
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// How far the image mean of an unbiased-in-the-limit estimate may be from its expectation.
/// Path tracers: 4 standard errors of independent pixels, plus f32 accumulation rounding.
/// Photon mappers: pixels share photons, so the noise of the mean is that of the deposited power,
/// relative 1/√(photons) per pass set (binomial counts, Russian roulette on albedo ≤ 1); 4 of those.
/// Plus the density estimate's bias, [`furnace_edge_bias`]: the furnace's radiance is uniform, so
/// nothing is blurred, but a gather disc that reaches over an edge to a facet the estimate refuses
/// (normals apart by more than `NORMAL_COSINE`) finds no photons there.
fn tolerance(kind: IntegratorKind, image: &Image, expected: f64) -> f64 {
    match kind {
        IntegratorKind::Pt | IntegratorKind::PtNaive => {
            4.0 * mean_and_standard_error(image).1 + 1e-4 * expected
        }
        IntegratorKind::Pm => (4.0 / PM_PHOTONS.sqrt() + furnace_edge_bias(kind)) * expected,
        _ => (4.0 / PROGRESSIVE_PHOTONS.sqrt() + furnace_edge_bias(kind)) * expected,
    }
}

/// The relative darkening a gather disc's edge loss can cause on the unit furnace, at most. A disc of
/// radius r centred s from a straight edge loses the kernel's mass beyond it; integrated over s that
/// is E[x⁺] = E|x|/2 per unit of edge: 2r/(3π) for the uniform kernel, 8r/(15π) for Epanechnikov (the
/// uniform kernel's is the largest of the kernels used here). Summed over the edges between facets the estimate keeps
/// apart (both sides, which over-counts corners: an upper bound), divided by the area, with r the
/// largest radius the method uses (`pm`: the cap, 5% of the bounding-box diagonal; the progressive
/// mappers: the heuristic's first radius, which only shrinks), times the share of the radiance photons
/// carry: of L = Le/(1 − a) = 1, everything after the first bounce, a²Le/(1 − a) = 1/4, where direct
/// light is sampled (NEE), and a·Le/(1 − a) = 1/2 for `ppm`.
fn furnace_edge_bias(kind: IntegratorKind) -> f64 {
    use caustica::photon::estimate::NORMAL_COSINE;
    use caustica::photon::progressive::initial_radius;
    use std::collections::HashMap;
    let scene = furnace(0.5, 0.5);
    let mesh = &scene.meshes[0];
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        (b - a).cross(c - a)
    };
    let mut edges: HashMap<(u32, u32), Vec<Vec3>> = HashMap::new();
    let mut area = 0.0f64;
    for t in &mesh.indices {
        area += 0.5 * normal(t).length() as f64;
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            edges.entry((a.min(b), a.max(b))).or_default().push(normal(t).normalize_or_zero());
        }
    }
    let refused: f64 = edges
        .iter()
        .filter(|(_, normals)| normals.len() == 2 && normals[0].dot(normals[1]) < NORMAL_COSINE)
        .map(|((a, b), _)| 2.0 * mesh.positions[*a as usize].distance(mesh.positions[*b as usize]) as f64)
        .sum();
    let (lo, hi) = mesh.positions.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let diagonal = (hi - lo).length();
    let radius = match kind {
        IntegratorKind::Pm => 0.05 * diagonal,
        _ => initial_radius(area as f32, diagonal, (PROGRESSIVE_PHOTONS / 4.0) as u32),
    } as f64;
    let share = if kind == IntegratorKind::Ppm { 0.5 } else { 0.25 };
    2.0 * radius / (3.0 * std::f64::consts::PI) * refused / area * share
}

fn camera_looking(eye: Vec3, target: Vec3, yfov_degrees: f32) -> CameraDesc {
    CameraDesc {
        name: "test".into(),
        camera_to_world: look_at(eye, target, Vec3::Y),
        yfov: yfov_degrees.to_radians(),
        aspect_ratio: None,
    }
}

/// A quad `center ± u ± v` whose front (and emitting side) faces along u × v.
fn quad(name: &str, center: Vec3, u: Vec3, v: Vec3, material: u32) -> Mesh {
    Mesh {
        name: name.into(),
        positions: vec![center - u - v, center + u - v, center + u + v, center - u + v],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        ..Mesh::default()
    }
}

fn black_emitter(name: &str, le: f32) -> MaterialDesc {
    diffuse(name, Vec3::ZERO, Vec3::splat(le))
}

/// The closed furnace of `test_scenes::furnace` scaled by `scale` and moved to (3, −2, 5)·scale,
/// so that absolute float errors grow with the scale. L = le / (1 − albedo) = 1 at every scale.
fn scaled_furnace(scale: f32) -> Scene {
    let mut scene = furnace(0.5, 0.5);
    let offset = Vec3::new(3.0, -2.0, 5.0) * scale;
    for p in &mut scene.meshes[0].positions {
        *p = *p * scale + offset;
    }
    let camera = scene.camera.as_mut().unwrap();
    camera.camera_to_world = Mat4::from_translation(offset);
    scene
}

/// The image mean is 1 (the furnace) within [`tolerance`] and no pixel is NaN, Inf or negative.
fn assert_unit_furnace(kind: IntegratorKind, image: &Image, what: &str) -> f64 {
    assert_finite(image, what);
    let (mean, _) = mean_and_standard_error(image);
    let bound = tolerance(kind, image, 1.0);
    assert!((mean - 1.0).abs() < bound, "{what}: mean radiance {mean}, expected 1 ± {bound}");
    mean
}

/// The same furnace from 1 mm to 100 km. Every pixel is L = 1 analytically, within [`tolerance`].
/// For the path tracers, the same seed also gives the same paths up to rounding, so the mean at each
/// scale must match the mean at 1 m to 0.5% (a handful of the 256 pixels' samples may take another
/// branch at a rounding boundary). The photon mappers' kNN and radius decisions flip more often at
/// ties, so for them only the analytic bound applies.
#[test]
fn a_furnace_has_the_same_radiance_from_a_millimetre_to_a_hundred_kilometres() {
    for kind in caustica::integrators::kinds() {
        let run = tiny_run(kind, 16);
        let at_one =
            assert_unit_furnace(kind, &common::render(scaled_furnace(1.0), &run), &format!("{kind:?}, 1 m"));
        for scale in [1e-3f32, 1e-1, 1e2, 1e5] {
            let what = format!("{kind:?}, scale {scale} m");
            let mean = assert_unit_furnace(kind, &common::render(scaled_furnace(scale), &run), &what);
            if matches!(kind, IntegratorKind::Pt | IntegratorKind::PtNaive) {
                assert!((mean - at_one).abs() < 5e-3, "{what}: mean {mean} but {at_one} at 1 m");
            }
        }
    }
}

/// The furnace with every facet split into three coplanar triangles about its centroid (shared
/// edges and vertices inside the facets' planes, which a non-watertight test would leak through)
/// plus zero-area emitting triangles (a repeated vertex) and collinear slivers (a vertex at the
/// rounded midpoint of an edge: area ≈ 1e-16, not exactly 0, so validation keeps them as tiny lights).
/// Validation must drop every exactly-zero-area triangle (the UV sphere's poles have some too), and
/// the render must still give L = 1.
#[test]
fn coplanar_splits_and_zero_area_triangles_keep_the_furnace_at_unit_radiance() {
    let mut scene = furnace(0.5, 0.5);
    let mesh = &mut scene.meshes[0];
    let mut indices = Vec::new();
    for [a, b, c] in std::mem::take(&mut mesh.indices) {
        let p = [a, b, c].map(|i| mesh.positions[i as usize]);
        let centroid = mesh.positions.len() as u32;
        mesh.positions.push((p[0] + p[1] + p[2]) / 3.0);
        indices.extend([[a, b, centroid], [b, c, centroid], [c, a, centroid]]);
    }
    let degenerate = indices.len();
    for (i, &[a, b, _]) in indices.clone().iter().enumerate().step_by(7) {
        if i % 2 == 0 {
            indices.push([a, a, b]);
        } else {
            let mid = mesh.positions.len() as u32;
            mesh.positions.push(mesh.positions[a as usize].lerp(mesh.positions[b as usize], 0.5));
            indices.push([a, mid, b]);
        }
    }
    assert!(indices.len() > degenerate);
    let zero_area = indices
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            (b - a).cross(c - a).length_squared() == 0.0
        })
        .count();
    mesh.indices = indices;
    let summary = validate(&mut scene, Path::new("coplanar-furnace")).expect("valid");
    assert_eq!(summary.degenerate_triangles, zero_area, "validation dropped the wrong triangles");
    assert_eq!(summary.degenerate_emitter_triangles, zero_area);
    for kind in caustica::integrators::kinds() {
        let image = common::render(scene.clone(), &tiny_run(kind, 16));
        assert_unit_furnace(kind, &image, &format!("{kind:?}, coplanar + degenerate"));
    }
}

/// Zero-area triangles of a non-emitting material that reach the renderer unvalidated (a host that
/// builds its Scene in memory) must not produce NaN normals or panics.
#[test]
fn unvalidated_zero_area_triangles_render_without_nan() {
    let mut scene = furnace(0.5, 0.5);
    scene.materials.push(diffuse("grey", Vec3::splat(0.5), Vec3::ZERO));
    let p = [Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.2, 0.0, -0.5), Vec3::new(0.4, 0.0, -0.5)];
    scene.meshes.push(Mesh {
        name: "degenerate".into(),
        positions: p.to_vec(),
        indices: vec![[0, 1, 2], [0, 0, 1], [2, 2, 2]],
        material: 1,
        ..Mesh::default()
    });
    for kind in caustica::integrators::kinds() {
        let image = common::render(scene.clone(), &tiny_run(kind, 16));
        assert_unit_furnace(kind, &image, &format!("{kind:?}, unvalidated zero-area triangles"));
    }
}

/// A 100 km emitting plane (albedo 0.5, Le = 0.5, nothing else in the scene) seen from 1 m above,
/// looking 2° below the horizon, so the far rows hit it at angles down to 1e-5 rad. Nothing reflects
/// light back to the plane, so every ray that hits it sees exactly Le and every ray that misses sees
/// 0: every pixel is in [0, Le], pixels wholly below the horizon are Le to float rounding, and only
/// the one row that straddles the horizon may be in between.
#[test]
fn grazing_views_of_a_large_plane_see_exactly_its_emission() {
    let le = 0.5f32;
    let scene = Scene {
        meshes: vec![quad("plane", Vec3::ZERO, Vec3::new(5e4, 0.0, 0.0), Vec3::new(0.0, 0.0, -5e4), 0)],
        materials: vec![diffuse("plane", Vec3::splat(0.5), Vec3::splat(le))],
        camera: Some(camera_looking(Vec3::Y, Vec3::new(0.0, 1.0 - 2f32.to_radians().tan(), -1.0), 20.0)),
        ..Scene::default()
    };
    assert!(scene.meshes[0].positions[1].cross(scene.meshes[0].positions[2]).y >= 0.0);
    let size = 32;
    for kind in caustica::integrators::kinds() {
        let image = common::render(scene.clone(), &tiny_run(kind, size));
        let what = format!("{kind:?}, grazing plane");
        assert_finite(&image, &what);
        let v = grey(&image);
        let eps = 1e-5 * le as f64;
        assert!(v.iter().all(|&x| x <= le as f64 + eps), "{what}: a pixel above Le: {v:?}");
        // The horizon is 2° above the centre row: rows 16.. and more are below it (0.625° per row).
        let bottom = &v[(size * size / 2) as usize..];
        assert!(
            bottom.iter().all(|&x| (x - le as f64).abs() <= eps),
            "{what}: bottom half not Le: {bottom:?}"
        );
        let between = v.iter().filter(|&&x| x > eps && x < le as f64 - eps).count();
        assert!(between <= size as usize, "{what}: {between} pixels neither 0 nor Le");
        assert!(v[0] == 0.0, "{what}: the sky is not black");
    }
}

/// A thin wall with a bright light right behind it (1e-4 m from the back face), in a void: the camera
/// side has nothing that could bring light around the wall, so every pixel must be exactly 0 for
/// every integrator, whether the wall is one double-sided quad or a 1e-5 m thick slab. Photons on the
/// back face lie within the front's gather discs, but the wall's Lambertian BSDF gives light from
/// behind nothing, whichever side the photon is said to face: the gather's side test is what
/// [`a_sheet_lit_on_its_back_is_as_bright_for_every_integrator`] checks.
#[test]
fn no_light_leaks_through_a_thin_wall() {
    for thickness in [0.0f32, 1e-5] {
        let (u, v) = (Vec3::new(10.0, 0.0, 0.0), Vec3::new(0.0, 10.0, 0.0));
        let mut meshes = vec![quad("front", Vec3::ZERO, u, v, 0)];
        if thickness > 0.0 {
            meshes.push(quad("back", Vec3::new(0.0, 0.0, -thickness), v, u, 0));
        }
        let light_z = -thickness - 1e-4;
        meshes.push(quad("light", Vec3::new(0.0, 0.0, light_z), u * 0.05, v * 0.05, 1));
        let scene = Scene {
            meshes,
            materials: vec![diffuse("wall", Vec3::splat(0.8), Vec3::ZERO), black_emitter("light", 100.0)],
            camera: Some(camera_looking(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 40.0)),
            ..Scene::default()
        };
        for kind in caustica::integrators::kinds() {
            let image = common::render(scene.clone(), &tiny_run(kind, 16));
            let what = format!("{kind:?}, wall {thickness} m thick");
            assert_finite(&image, &what);
            let lit = image.pixels.iter().filter(|p| p.max_element() > 0.0).count();
            let max = image.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
            assert_eq!(lit, 0, "{what}: {lit} pixels lit through the wall, max {max}");
        }
    }
}

/// A single quad lit only on its back (the side its geometric normal points away from), by light off
/// a wall: a one-sided emitter faces the wall, not the sheet, so every photon the sheet gets has
/// bounced, and the camera looks at that back. A photon that arrives there must be stored facing where
/// it came from (against the normal): stored with the geometric normal, the gather's side test takes
/// it for a photon from the other side and the photon mappers see the sheet black. The bound is half
/// of `pt`'s mean either way: the failure it catches loses all of the light, and each integrator's
/// accuracy is tested against references elsewhere.
#[test]
fn a_sheet_lit_on_its_back_is_as_bright_for_every_integrator() {
    let (x, y) = (Vec3::X, Vec3::Y);
    let scene = Scene {
        meshes: vec![
            quad("sheet", Vec3::ZERO, x, y, 0),
            quad("wall", Vec3::new(0.0, 0.0, -1.0), 2.0 * x, 2.0 * y, 0),
            // u × v = −z: the light shines at the wall, away from the sheet, and the camera cannot see it.
            quad("light", Vec3::new(0.0, 0.6, -0.5), 0.15 * x, -0.15 * y, 1),
        ],
        materials: vec![diffuse("white", Vec3::splat(0.8), Vec3::ZERO), black_emitter("light", 20.0)],
        camera: Some(camera_looking(Vec3::new(0.0, 0.0, -0.8), Vec3::ZERO, 50.0)),
        ..Scene::default()
    };
    let mut reference_run = tiny_run(IntegratorKind::Pt, 16);
    reference_run.render.spp = 64;
    let (reference, _) = mean_and_standard_error(&common::render(scene.clone(), &reference_run));
    assert!(reference > 0.01, "pt sees the sheet lit: mean {reference}");
    let mut wrong = Vec::new();
    for kind in caustica::integrators::kinds() {
        let image = common::render(scene.clone(), &tiny_run(kind, 16));
        assert_finite(&image, &format!("{kind:?}, sheet lit on its back"));
        let (mean, _) = mean_and_standard_error(&image);
        eprintln!("{kind:?}: mean {mean:.4} ({:.2} of pt's)", mean / reference);
        if !(0.5 * reference..=1.5 * reference).contains(&mean) {
            wrong.push(format!("{kind:?} {mean:.4}"));
        }
    }
    assert!(wrong.is_empty(), "the sheet's back against pt's mean {reference:.4}: {}", wrong.join(", "));
}

/// A run file under scenes/hard, with the render settings of [`tiny_run`] and its own camera and film.
fn hard_scene(name: &str, kind: IntegratorKind) -> (Scene, RunFile) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard").join(name);
    let (scene, file) = load(&path).expect("hard scene loads");
    let run = RunFile { camera: file.camera, film: file.film, spheres: file.spheres, ..tiny_run(kind, 16) };
    (scene, run)
}

/// scenes/hard/light-in-glass.toml: an emitter of radiance 4 and albedo 0 inside a glass ball, in a
/// void. Every camera path is a chain of smooth-dielectric events whose branch weights (R or T,
/// chosen with probability R or T) are exactly one, ending on the emitter (Le = 4, converted by
/// 1/η² or not on the way out, ≤ 4 either way) or in the void (0); photons land only on the black
/// emitter, so they add nothing. So no sample, and no pixel, exceeds 4; the light must get out.
#[test]
fn a_light_inside_glass_gets_out_and_never_exceeds_its_emission() {
    for kind in caustica::integrators::kinds() {
        let (scene, run) = hard_scene("light-in-glass.toml", kind);
        let image = common::render(scene, &run);
        let what = format!("{kind:?}, light in glass");
        assert_finite(&image, &what);
        let v = grey(&image);
        assert!(v.iter().all(|&x| x <= 4.0 * (1.0 + 1e-5)), "{what}: a pixel above Le = 4: {v:?}");
        let brightest = v.iter().cloned().fold(0.0, f64::max);
        assert!(brightest > 0.1, "{what}: the light does not get out of the glass (brightest {brightest})");
    }
}

/// scenes/hard/light-above-surface.toml: an emitting ball (Le = 1, albedo 0) 1e-4 m above a 1 km
/// diffuse ball of albedo 0.5 (float error at its top ≈ 1e-4 m). The irradiance of the ground is at
/// most π·Le (the light fills at most the hemisphere) and nothing else lights it (the emitter absorbs
/// what comes back), so ground pixels have expectation ≤ 0.5 and emitter pixels exactly 1: the
/// image mean is at most f + 0.5·(1 − f), f the emitter's share of pixels, which pt measures exactly
/// (pixels seeing the emitter at the first hit are exactly 1 in every sample: they are the pixels
/// ≥ 1 − 1e-6 in pt's image up to the few the ground's noise may push there; f is bounded above by
/// counting those). Plus the estimator tolerance. The ground near the contact must be lit.
#[test]
fn a_light_just_above_a_surface_lights_it_without_blowing_up() {
    let (scene, run) = hard_scene("light-above-surface.toml", IntegratorKind::Pt);
    let reference = common::render(scene, &run);
    let f = grey(&reference).iter().filter(|&&x| x >= 1.0 - 1e-6).count() as f64 / 256.0;
    let expected_max = f + 0.5 * (1.0 - f);
    for kind in caustica::integrators::kinds() {
        let (scene, run) = hard_scene("light-above-surface.toml", kind);
        let image = common::render(scene, &run);
        let what = format!("{kind:?}, light 1e-4 above a surface");
        assert_finite(&image, &what);
        let (mean, _) = mean_and_standard_error(&image);
        let bound = expected_max + tolerance(kind, &image, expected_max);
        assert!(mean <= bound, "{what}: mean {mean} above the energy bound {bound} (emitter share {f})");
        assert!(mean > f, "{what}: mean {mean}: the ground is not lit (emitter share {f})");
    }
}

/// Radiance is linear in emission, and with the same seed every random decision (Russian roulette
/// on throughput, light choice by relative power, photon paths by albedo) is the same: the Cornell
/// box with its emission times 1e-6 or 1e6 must be the same image times 1e-6 or 1e6, to float
/// rounding (1e-4 of the image's largest value per pixel).
#[test]
fn images_scale_linearly_from_tiny_to_huge_radiance() {
    for kind in caustica::integrators::kinds() {
        let (scene, _) = load(&common::data("cornell-box.gltf")).expect("test scene loads");
        let run = tiny_run(kind, 16);
        let reference = common::render(scene.clone(), &run);
        assert_finite(&reference, &format!("{kind:?}, cornell box"));
        let peak = reference.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
        for k in [1e-6f32, 1e6] {
            let mut scaled = scene.clone();
            for m in &mut scaled.materials {
                m.emission *= k;
            }
            let image = common::render(scaled, &run);
            let what = format!("{kind:?}, emission × {k}");
            assert_finite(&image, &what);
            for (i, (a, b)) in image.pixels.iter().zip(&reference.pixels).enumerate() {
                let error = (*a / k - *b).abs().max_element();
                assert!(error <= 1e-4 * peak, "{what}: pixel {i} is {a} / k, not {b} (peak {peak})");
            }
        }
    }
}

/// A height field of 2·(n−1)² triangles under an emitting quad, seen from above.
fn big_mesh_scene(n: u32) -> Scene {
    let mut positions = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let (x, z) = (i as f32 / (n - 1) as f32 * 2.0 - 1.0, j as f32 / (n - 1) as f32 * 2.0 - 1.0);
            positions.push(Vec3::new(x, 0.05 * (17.0 * x).sin() * (13.0 * z).cos(), z));
        }
    }
    let mut indices = Vec::with_capacity((2 * (n - 1) * (n - 1)) as usize);
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let (a, b, c, d) = (j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1);
            // Counter-clockwise seen from +y.
            indices.extend([[a, c, b], [b, c, d]]);
        }
    }
    let ground = Mesh { name: "height field".into(), positions, indices, material: 0, ..Mesh::default() };
    let light =
        quad("light", Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 0.3), Vec3::new(0.3, 0.0, 0.0), 1);
    Scene {
        meshes: vec![ground, light],
        materials: vec![diffuse("ground", Vec3::splat(0.5), Vec3::ZERO), black_emitter("light", 5.0)],
        camera: Some(camera_looking(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, 40.0)),
        ..Scene::default()
    }
}

fn big_mesh_renders_for_every_integrator(n: u32) {
    let scene = big_mesh_scene(n);
    let triangles = scene.meshes[0].indices.len();
    for kind in caustica::integrators::kinds() {
        let start = Instant::now();
        let mut run = tiny_run(kind, 16);
        run.render.spp = 1;
        let image = common::render(scene.clone(), &run);
        let what = format!("{kind:?}, {triangles} triangles");
        assert_finite(&image, &what);
        assert!(image.mean().max_element() > 0.0, "{what}: black image");
        eprintln!("{what}: {:.2} s", start.elapsed().as_secs_f64());
    }
}

/// 1e5 triangles: BVH build and traversal at a size CI can afford for every integrator.
#[test]
fn a_hundred_thousand_triangle_mesh_renders_for_every_integrator() {
    big_mesh_renders_for_every_integrator(225); // 2 · 224² = 100 352 triangles
}

/// 1e6 triangles.
#[test]
fn a_million_triangle_mesh_renders_for_every_integrator() {
    big_mesh_renders_for_every_integrator(708); // 2 · 707² = 999 698 triangles
}
