//! Caustics against an exact answer: a sun shining through a glass slab onto a Lambertian floor.
//!
//! Light that reaches the floor only through a specular surface (L S+ D) is what photons alone carry:
//! next-event estimation is blocked by the glass and a camera path cannot hit a delta light. The
//! glass is a flat slab of thickness `SLAB` over a floor `GAP` below it, both much wider than the
//! floor the camera sees, so in the window the light is the same everywhere, and the answer follows
//! from the Fresnel equations alone (unpolarised, per interface, as pbrt and Mitsuba model them):
//! - a slab transmits T(θ) = (1 − F)² Σ F^2m = (1 − F)/(1 + F) and reflects 2F/(1 + F), summing
//!   every internal reflection (the inner interface's F equals the outer one's, Stokes);
//! - the floor gets E₀ = E_sun cos θ_sun T(θ_sun); what it reflects comes back from the slab's
//!   underside as ρ⟨R⟩E, with ⟨R⟩ the cosine-weighted mean of the slab's reflectance, so
//!   E = E₀ / (1 − ρ⟨R⟩) between two infinite planes;
//! - the camera, looking down through the slab, sees T(θ_view) ρ E / π in each pixel.
//!
//! The estimate's bias here is known: in light that is uniform over the gather disc, a fixed-radius
//! disc (or progressive radii, each chosen before its pass: τ_N/R_N² = Σ Φ_i/R_i² telescopes) is
//! unbiased, and `pm`'s k-nearest-neighbour disc is within 1/(k − 1) (exact for Poisson photons,
//! whose k − 1 inner neighbours are uniform in the disc; −1/k for photons on a lattice). What the
//! planes' finite width loses is below the grazing cone they leave open, bounded in `finite_planes`.
//! The rest is noise, from seed replicas.

use caustica::Renderer;
use caustica::camera::look_at;
use caustica::driver::init_thread_pools;
use caustica::film::Image;
use caustica::materials::ShadingParams;
use caustica::materials::fresnel::fresnel_dielectric;
use caustica::scene::punctual::{PunctualKind, PunctualLightDesc};
use caustica::scene::{CameraDesc, IntegratorKind, MaterialDesc, RunFile, Scene};
use caustica::test_scenes::{diffuse, quad};
use glam::Vec3;

/// The floor's albedo.
const ALBEDO: f32 = 0.5;
/// The slab's index of refraction.
const IOR: f32 = 1.5;
/// Air gap between the floor (y = 0) and the slab's underside.
const GAP: f32 = 0.002;
/// The slab's thickness.
const SLAB: f32 = 0.01;
/// Half-widths: the slab overhangs the floor so that no sunlight reaches the floor past its edge
/// (the sun's offset through gap and slab is under 1 cm).
const SLAB_HALF: f32 = 0.5;
const FLOOR_HALF: f32 = 0.45;
/// Half-width of the floor the camera sees (from 1 m up, looking straight down).
const VIEW_HALF: f32 = 0.2;
const CAMERA_HEIGHT: f32 = 1.0;
/// The sun's angle from the vertical, so that Fresnel is tested away from normal incidence.
const SUN_ANGLE_DEGREES: f32 = 40.0;
/// Sun irradiance on a surface facing it, W/m² (the lux a `PunctualLightDesc` takes is 683× this).
const SUN_IRRADIANCE: f32 = 10.0;
const SIZE: u32 = 32;
/// `pm`'s neighbour count: its k-NN bias is at most 1/(k − 1).
const PM_K: u32 = 200;
/// Independent renders per integrator.
const REPLICAS: u64 = 16;
/// Student's t, 15 degrees of freedom, one-sided 1e-4: six integrators, two sides, 1.2e-3 family-wise.
const T_QUANTILE: f64 = 4.88;

fn glass() -> MaterialDesc {
    MaterialDesc {
        name: "glass".into(),
        shading: ShadingParams {
            metallic: 0.0,
            roughness: 0.0,
            transmission: 1.0,
            ior: IOR,
            thickness: SLAB,
            ..ShadingParams::default()
        },
        ..MaterialDesc::default()
    }
}

fn sun_direction() -> Vec3 {
    let angle = SUN_ANGLE_DEGREES.to_radians();
    Vec3::new(angle.sin(), -angle.cos(), 0.0)
}

fn camera() -> CameraDesc {
    CameraDesc {
        name: "above".into(),
        camera_to_world: look_at(Vec3::new(0.0, CAMERA_HEIGHT, 0.0), Vec3::ZERO, Vec3::Z),
        yfov: 2.0 * (VIEW_HALF / CAMERA_HEIGHT).atan(),
        aspect_ratio: None,
    }
}

/// The slab is two faces, outward normals up and down: its sides are far from what the camera sees.
fn slab_over_floor() -> Scene {
    let mut top = quad("slab top", GAP + SLAB, SLAB_HALF, true, 1);
    let mut bottom = quad("slab bottom", GAP, SLAB_HALF, false, 1);
    top.uvs.clear();
    bottom.uvs.clear();
    Scene {
        meshes: vec![quad("floor", 0.0, FLOOR_HALF, true, 0), top, bottom],
        materials: vec![diffuse("floor", Vec3::splat(ALBEDO), Vec3::ZERO), glass()],
        camera: Some(camera()),
        resolution: Some((SIZE, SIZE)),
        punctual_lights: vec![PunctualLightDesc {
            name: "sun".into(),
            kind: PunctualKind::Sun,
            position: Vec3::ZERO,
            direction: sun_direction(),
            color: Vec3::ONE,
            intensity: SUN_IRRADIANCE * caustica::scene::punctual::LUMENS_PER_WATT,
        }],
        source: "glass slab over a floor (procedural)".into(),
        ..Scene::default()
    }
}

/// Fresnel reflectance of the air–glass interface, computed here from the Fresnel equations (the
/// renderer's own routine is not the answer it is tested against).
fn interface_reflectance(cos_i: f64) -> f64 {
    let eta = IOR as f64;
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

fn slab_transmittance(cos_i: f64) -> f64 {
    let f = interface_reflectance(cos_i);
    (1.0 - f) / (1.0 + f)
}

fn slab_reflectance(cos_i: f64) -> f64 {
    let f = interface_reflectance(cos_i);
    2.0 * f / (1.0 + f)
}

/// ⟨R⟩ = ∫₀¹ R(μ) 2μ dμ, by the midpoint rule on 20 000 intervals (R is smooth; its error is ~1e-9).
fn cosine_weighted_slab_reflectance() -> f64 {
    let n = 20_000;
    (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            slab_reflectance(mu) * 2.0 * mu / n as f64
        })
        .sum()
}

/// The floor's irradiance in the window: the sun through the slab, plus what the slab's underside
/// returns of the floor's own light.
fn floor_irradiance() -> f64 {
    let cos_sun = SUN_ANGLE_DEGREES.to_radians().cos() as f64;
    let direct = SUN_IRRADIANCE as f64 * cos_sun * slab_transmittance(cos_sun);
    direct / (1.0 - ALBEDO as f64 * cosine_weighted_slab_reflectance())
}

/// Relative bound on what the planes' finite width changes in the window. Light the floor sends at
/// more than θ_c from the vertical, with tan θ_c = (margin − in-slab spread) / (2 · gap), could come
/// back from past the uniform region; the cosine-weighted share of those directions is cos² θ_c, and
/// the slab returns at most all of it: ρ cos² θ_c. (The in-slab spread allows four internal round
/// trips at the critical angle; a fifth carries F⁸ < 1e-10.)
fn finite_planes() -> f64 {
    let critical_tan = (1.0 / (IOR as f64 * IOR as f64 - 1.0)).sqrt();
    let spread = 4.0 * 2.0 * SLAB as f64 * critical_tan;
    let margin = (FLOOR_HALF - VIEW_HALF) as f64 - spread;
    let tan_c = margin / (2.0 * GAP as f64);
    ALBEDO as f64 / (1.0 + tan_c * tan_c)
}

/// Each pixel's expected radiance: the floor's ρE/π through the slab at the pixel-centre ray's angle
/// (T varies by 2e-4 across a pixel at these angles), row by row.
fn expected_pixels() -> Vec<f64> {
    let camera = camera();
    let tan = (0.5 * camera.yfov).tan();
    let axes = camera.camera_to_world;
    let floor_radiance = ALBEDO as f64 * floor_irradiance() / std::f64::consts::PI;
    let mut pixels = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let u = 2.0 * (x as f32 + 0.5) / SIZE as f32 - 1.0;
            let v = 2.0 * (y as f32 + 0.5) / SIZE as f32 - 1.0;
            let d = (-axes.z_axis.truncate() + axes.x_axis.truncate() * u * tan
                - axes.y_axis.truncate() * v * tan)
                .normalize();
            pixels.push(slab_transmittance(-d.y as f64) * floor_radiance);
        }
    }
    pixels
}

/// The image's expected mean.
fn expected_mean() -> f64 {
    let pixels = expected_pixels();
    pixels.iter().sum::<f64>() / pixels.len() as f64
}

fn run_for(kind: IntegratorKind, seed: u64) -> RunFile {
    let mut run = RunFile::default();
    run.render.integrator = kind;
    run.render.seed = seed;
    run.render.spp = 4;
    run.photons.caustic_photons = 200_000;
    run.photons.photons = 50_000;
    run.photons.k = PM_K;
    run.progressive.passes = 8;
    run.progressive.photons_per_pass = 32_768;
    run
}

fn grey_mean(image: &Image) -> f64 {
    image.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>() / image.pixels.len() as f64
}

fn assert_matches_the_slab_answer(kind: IntegratorKind) {
    init_thread_pools(None);
    let means: Vec<f64> = (0..REPLICAS)
        .map(|seed| {
            let mut renderer =
                Renderer::new(slab_over_floor(), &run_for(kind, 100 + seed)).expect("prepares");
            renderer.run(None, |_| {});
            grey_mean(&renderer.image())
        })
        .collect();
    let k = REPLICAS as f64;
    let mean = means.iter().sum::<f64>() / k;
    let se = (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
    let want = expected_mean();
    let knn_bias = if kind == IntegratorKind::Pm { 1.0 / (PM_K as f64 - 1.0) } else { 0.0 };
    let bound = T_QUANTILE * se + (knn_bias + finite_planes()) * want;
    eprintln!(
        "{kind:?}: mean {mean:.5} ± {se:.5}, exact {want:.5} ({:+.2}%), bound {bound:.5} (k-NN {knn_bias:.4}, planes {:.5})",
        100.0 * (mean / want - 1.0),
        finite_planes()
    );
    assert!(
        (mean - want).abs() <= bound,
        "{kind:?}: caustic {mean} vs exact {want}: off by more than {bound}"
    );
}

#[test]
fn the_answer_itself_is_right() {
    // Normal incidence: F = ((n − 1)/(n + 1))² = 0.04, T = 0.96/1.04.
    assert!((slab_transmittance(1.0) - 0.96 / 1.04).abs() < 1e-12);
    // The test's Fresnel agrees with the renderer's (which the dielectric lobe's furnace holds).
    for mu in [0.05, 0.3, 0.7, 1.0] {
        assert!((interface_reflectance(mu) - fresnel_dielectric(mu as f32, IOR) as f64).abs() < 1e-6);
    }
    // Energy: what the slab neither reflects nor transmits is nothing.
    assert!((slab_reflectance(0.4) + slab_transmittance(0.4) - 1.0).abs() < 1e-12);
    assert!(finite_planes() < 5e-4, "the planes are wide enough: {}", finite_planes());
    // The corner ray meets the floor well inside it (refraction through the slab only narrows it).
    let tan = (0.5 * camera().yfov).tan() as f64;
    assert!(CAMERA_HEIGHT as f64 * tan * 2f64.sqrt() < (FLOOR_HALF - 0.05) as f64);
}

#[test]
fn pm_carries_the_caustic_through_a_glass_slab_exactly() {
    assert_matches_the_slab_answer(IntegratorKind::Pm);
}

#[test]
fn ppm_carries_the_caustic_through_a_glass_slab_exactly() {
    assert_matches_the_slab_answer(IntegratorKind::Ppm);
}

#[test]
fn sppm_carries_the_caustic_through_a_glass_slab_exactly() {
    assert_matches_the_slab_answer(IntegratorKind::Sppm);
}

#[test]
fn appm_carries_the_caustic_through_a_glass_slab_exactly() {
    assert_matches_the_slab_answer(IntegratorKind::Appm);
}

#[test]
fn cppm_carries_the_caustic_through_a_glass_slab_exactly() {
    assert_matches_the_slab_answer(IntegratorKind::Cppm);
}

#[test]
fn pppm_carries_the_caustic_through_a_glass_slab_exactly() {
    assert_matches_the_slab_answer(IntegratorKind::Pppm);
}

#[test]
fn vcm_carries_the_caustic_through_a_glass_slab_exactly() {
    // Only merging makes these paths: the sun's light reaches the floor through the glass, and the
    // camera sees the floor through it, so no connection, light sample or splat can.
    assert_matches_the_slab_answer(IntegratorKind::Vcm);
}

/// vcm's merges are consistent at the rate their radii set: unit u merges at r_u² ∝ u^(α−1), so the
/// average of U units has variance ∝ U^−2 Σ_u u^(1−α) ∝ U^−α, and in light that is uniform over the
/// merging disc the bias is nil (the module's note). Eight times the units then divide the per-pixel
/// squared error by 8^α = 4 at the default α = 2/3. The bounds are the geometric midpoints to the
/// rates of the estimators it could wrongly be: radii that never shrink (8, variance ∝ 1/U) and an
/// estimate that stops converging (1).
#[test]
fn vcm_error_falls_at_the_consistent_rate() {
    init_thread_pools(None);
    let want = expected_pixels();
    let squared_error = |units: u32| -> f64 {
        let seeds = 0..6u64;
        let mut sum = 0.0;
        for seed in seeds.clone() {
            let mut run = run_for(IntegratorKind::Vcm, 500 + seed);
            run.render.spp = units;
            let mut renderer = Renderer::new(slab_over_floor(), &run).expect("prepares");
            renderer.run(None, |_| {});
            let image = renderer.image();
            sum += image
                .pixels
                .iter()
                .zip(&want)
                .map(|(p, w)| (p.element_sum() as f64 / 3.0 - w).powi(2))
                .sum::<f64>()
                / want.len() as f64;
        }
        sum / seeds.count() as f64
    };
    let (few, many) = (squared_error(4), squared_error(32));
    let ratio = few / many;
    eprintln!(
        "vcm: per-pixel squared error {few:.3e} at 4 units, {many:.3e} at 32: ratio {ratio:.2} (rate 4)"
    );
    assert!((2.0f64.sqrt() * 2.0..=4.0 * 2.0f64.sqrt()).contains(&ratio), "ratio {ratio}: not 8^(2/3) = 4");
}

/// The slab scene with a black strip in the air gap over x < 0: the floor beyond it is in shadow and
/// hidden from the camera, so the caustic the camera sees ends at a straight edge down the middle of
/// the image, lit on one side and black (the strip) on the other.
fn slab_over_half_shadowed_floor() -> Scene {
    let mut scene = slab_over_floor();
    let (y, h) = (0.5 * GAP, SLAB_HALF);
    scene.meshes.push(caustica::scene::Mesh {
        name: "strip".into(),
        positions: vec![
            Vec3::new(-h, y, -h),
            Vec3::new(0.0, y, -h),
            Vec3::new(0.0, y, h),
            Vec3::new(-h, y, h),
        ],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        material: 2,
        ..caustica::scene::Mesh::default()
    });
    scene.materials.push(diffuse("black", Vec3::ZERO, Vec3::ZERO));
    scene
}

/// Light lost at the caustic's edge, in lines of pixels: Σ (1 − line / far) over the lit lines
/// across the edge nearer than `far_from` lines, `far` the mean of the lines beyond (the image is
/// `size`² pixels, the edge down its middle).
fn edge_loss(image: &Image, size: u32, far_from: usize) -> f64 {
    let grey = |x: u32, y: u32| image.pixels[(y * size + x) as usize].element_sum() as f64 / 3.0;
    let columns: Vec<f64> = (0..size).map(|x| (0..size).map(|y| grey(x, y)).sum::<f64>()).collect();
    let rows: Vec<f64> = (0..size).map(|y| (0..size).map(|x| grey(x, y)).sum::<f64>()).collect();
    // The edge runs along one image axis: across it, one half of the lines sees the black strip.
    let dark =
        |v: &[f64]| v[..size as usize / 2].iter().sum::<f64>().min(v[size as usize / 2..].iter().sum());
    let mut lines = if dark(&columns) < dark(&rows) { columns } else { rows };
    if lines[0] > lines[size as usize - 1] {
        lines.reverse();
    }
    let lit = &lines[size as usize / 2..];
    let far = lit[far_from..].iter().sum::<f64>() / (lit.len() - far_from) as f64;
    lit[..far_from].iter().map(|l| 1.0 - l / far).sum()
}

/// vcm's radii shrink, so a merge's blur across an edge fades as units add up; a radius that never
/// shrinks keeps it. At the edge of a merged-only caustic, a gather disc of radius r centred s from
/// the edge misses the share of its kernel beyond it; summed over the lines next to the edge that is
/// E[x⁺] = 2r/(3π) of a line's light per unit of edge (uniform kernel), linear in r. At α = 0.25 the
/// radii of 64 units average r₀ · (1/64) ∫₁⁶⁴ u^−0.375 du ≈ 0.31 r₀, so the loss falls to about a
/// third of a render at α = 1 (r₀ throughout) — plus what both lose alike (the pixel filter, and the
/// floor's light the strip keeps from returning off the slab, and the shadow's edge 0.27 pixels past
/// the strip's: about a third of a line, so the ratio is ≈ 0.45). Radii that never shrink keep the
/// ratio at one; the bound is the geometric midpoint, 2/3.
#[test]
fn vcm_merges_at_radii_that_shrink_unit_by_unit() {
    init_thread_pools(None);
    let size = 128;
    let loss = |alpha: f32| -> f64 {
        let mut run = run_for(IntegratorKind::Vcm, 900);
        run.render.spp = 64;
        (run.film.width, run.film.height) = (Some(size), Some(size));
        // 0.02 m is 6.4 pixels of the floor at 128².
        run.progressive.initial_radius = Some(0.02);
        run.progressive.alpha = alpha;
        let mut renderer = Renderer::new(slab_over_half_shadowed_floor(), &run).expect("prepares");
        renderer.run(None, |_| {});
        edge_loss(&renderer.image(), size, 16)
    };
    let (fixed, shrinking) = (loss(1.0), loss(0.25));
    eprintln!(
        "vcm: {fixed:.3} lines of light lost at the edge at a fixed radius, {shrinking:.3} with shrinking radii"
    );
    assert!(fixed > 1.0, "a fixed radius of 6.4 pixels loses 1.4 lines at the edge: {fixed}");
    assert!(shrinking < 2.0 / 3.0 * fixed, "radii that shrink lose {shrinking} lines, a fixed one {fixed}");
}
