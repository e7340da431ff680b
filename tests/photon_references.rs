//! Every photon integrator against the Mitsuba 3 reference of the Cornell box, with bounds derived from
//! the estimator itself: its variance from independent replicas, its bias from what density estimation
//! does by construction.
//!
//! **Variance.** `REPLICAS` renders with different seeds are independent; their mean image `m` has
//! per-pixel variance s²/K (s² the replicas' sample variance), and the replicas' image means give the
//! standard error of `m`'s image mean with K − 1 degrees of freedom. Pixels of a photon mapper share
//! photons, so no per-pixel formula would do: replicas see the correlation whole.
//!
//! **Bias, and only where the method has it.** A photon estimate at x is Σ K(d²/r²)/r² · f · ΔΦ over the
//! photons within r that lie on a surface of x's orientation (`NORMAL_COSINE`). Its expectation is the
//! kernel-weighted integral, over the part of the disc that lies on that surface, of the radiance the
//! photons carry: blurred where the light varies, and dark within r of an edge, where the disc runs off
//! the surface (the classic boundary bias). The Cornell box is Lambertian with flat, uniformly coloured
//! surfaces, so that integral is a sum over the pixels j near x on x's plane: K(d²/r²)/r² · L_j · A_j,
//! with A_j the pixel's footprint on its surface (solid angle × distance² / cos). L_j is what photons
//! carry: the reference less the direct light for `pm`, `sppm`, `appm`, `cppm` (which sample direct
//! light by NEE, unbiased; the direct light is `pt` to depth 1, whose accuracy `convergence.rs` holds
//! to Mitsuba), the whole reference for `ppm`, nothing on the lamp (black base). Pixel positions and
//! normals come from `sppm`'s hit points; the radii are the method's own: `pm`'s k-th neighbour
//! distance in each replica's map, and for the progressive mappers, whose estimate is the mean of every
//! pass's estimate at that pass's radius (τ_N / R_N² = Σ Φ_k / R_k²), the interval between the model
//! at each hit point's final radius and at the initial one.
//!
//! Two assertions per integrator:
//! - the grey image mean of `m` lies within t·SE of the model's interval, t = 7.06 (Student's t with 7
//!   degrees of freedom, one-sided 1e-4: a family-wise false alarm of 1e-3 over 5 integrators, two
//!   sides);
//! - relMSE(m) against the model's midpoint is below the variance term mean(s²/K / (ref² + 0.01)) plus
//!   the interval's half-width squared, times 1.5 for what the model leaves out (the pixel grid as a
//!   quadrature, the reference's own noise); the direct-light render's variance is added to the
//!   variance term.
//!
//! Measured (8 replicas at 64²): relMSE to the model 1.00–1.03× the variance term for all five; the
//! model's image mean explains the darkening at edges (pm 0.06916 rendered, 0.06912 modelled, 0.06946
//! the reference, over the 71% of pixels compared). Deliberate breakages each of these catches:
//! photon power +5% (all five, by the mean), photons of any orientation gathered (ppm, sppm, appm,
//! cppm by relMSE; pm's excess stays under its bound), the Epanechnikov kernel 5% low (pm), the
//! flux correction dropped from the shrinking rule (ppm, sppm). `PHOTON_REFERENCE_DUMP=DIR` writes
//! each integrator's difference from the model as a PNG there.

use crate::common;

use caustica::Renderer;
use caustica::components::{HitPoint, PathState};
use caustica::driver::init_thread_pools;
use caustica::film::Image;
use caustica::film::output::read_exr;
use caustica::photon::Neighbors;
use caustica::photon::estimate::NORMAL_COSINE;
use caustica::photon::record::decode_octahedral;
use caustica::resources::PhotonMaps;
use caustica::scene::{IntegratorKind, RunFile, Scene, load};
use glam::Vec3;

/// Independent renders per integrator.
const REPLICAS: u64 = 8;
/// Student's t, 7 degrees of freedom, one-sided tail 1e-4.
const T_QUANTILE: f64 = 7.06;
/// Resolution of the test renders (the 256² box-filtered reference, averaged in 4×4 blocks, is exactly
/// what a box-filtered 64² render converges to).
const SIZE: u32 = 64;
/// Resolution of the bias model: the reference's own, so that a gather disc (5 to 14 of its pixels
/// across) is integrated by many pixels.
const MODEL_SIZE: u32 = 4 * SIZE;
/// The largest gather radius `pm` may use here.
const PM_MAX_RADIUS: f32 = 0.025;

fn cornell_box() -> (Scene, RunFile) {
    load(&common::data("cornell-box.gltf")).expect("test scene loads")
}

fn run_for(kind: IntegratorKind, seed: u64) -> RunFile {
    let (_, mut run) = cornell_box();
    run.render.integrator = kind;
    run.render.seed = seed;
    run.render.spp = 4;
    run.photons.photons = 100_000;
    run.photons.caustic_photons = 100_000;
    run.photons.max_radius = Some(PM_MAX_RADIUS);
    run.progressive.passes = 8;
    run.progressive.photons_per_pass = 16_384;
    (run.film.width, run.film.height) = (Some(SIZE), Some(SIZE));
    run
}

fn render(run: &RunFile) -> Renderer {
    init_thread_pools(None);
    let mut renderer = Renderer::new(cornell_box().0, run).expect("scene prepares");
    renderer.run(None, |_| {});
    renderer
}

/// What each pixel sees: position, normal, footprint area, and whether it is the lamp.
struct PixelGeometry {
    p: Vec<Vec3>,
    /// Distance from the eye (0: nothing seen).
    d: Vec<f32>,
    /// The pixel's angular size.
    pixel_angle: f32,
    /// The eye.
    eye: Vec3,
    /// Direction through each pixel's centre, and the pixel's solid angle.
    dir: Vec<Vec3>,
    solid_angle: Vec<f32>,
    n: Vec<Vec3>,
    lamp: Vec<bool>,
}

fn pixel_geometry() -> PixelGeometry {
    let size = MODEL_SIZE;
    let (scene, _) = cornell_box();
    let camera = scene.camera.clone().expect("the box has a camera");
    let eye = camera.camera_to_world.w_axis.truncate();
    let forward = -camera.camera_to_world.z_axis.truncate().normalize();
    let pixel_angle = 2.0 * (0.5 * camera.yfov).tan() / size as f32;
    let mut run = run_for(IntegratorKind::Sppm, 0);
    run.progressive.passes = 1;
    run.progressive.photons_per_pass = 1000;
    (run.film.width, run.film.height) = (Some(size), Some(size));
    let renderer = render(&run);
    let n = (size * size) as usize;
    let mut geometry = PixelGeometry {
        p: vec![Vec3::ZERO; n],
        d: vec![0.0; n],
        pixel_angle,
        eye,
        dir: vec![Vec3::ZERO; n],
        solid_angle: vec![0.0; n],
        n: vec![Vec3::ZERO; n],
        lamp: vec![false; n],
    };
    let tan = (0.5 * camera.yfov).tan();
    for i in 0..n {
        let (x, y) = ((i as u32 % size) as f32 + 0.5, (i as u32 / size) as f32 + 0.5);
        let centre = forward + camera.camera_to_world.x_axis.truncate() * (2.0 * x / size as f32 - 1.0) * tan
            - camera.camera_to_world.y_axis.truncate() * (2.0 * y / size as f32 - 1.0) * tan;
        geometry.dir[i] = centre.normalize();
        geometry.solid_angle[i] = pixel_angle * pixel_angle * geometry.dir[i].dot(forward).powi(3);
    }
    let world = &renderer.world;
    let mut query = world.try_query::<(&PathState, &HitPoint)>().expect("sppm has hit points");
    for (state, hp) in query.iter(world) {
        let i = state.pixel as usize;
        if !hp.is_valid() {
            continue;
        }
        // The hit point lies at the pixel's filter sample; the quadrature wants the pixel's centre, on
        // the same plane (every surface of the box is flat; a pixel across an edge keeps its sample's
        // plane).
        let normal = decode_octahedral(hp.shading.ns, 16);
        let dir = geometry.dir[i];
        let t = normal.dot(hp.p - eye) / normal.dot(dir);
        let centre_hit = eye + dir * t;
        if t <= 0.0 {
            continue;
        }
        geometry.p[i] = centre_hit;
        geometry.d[i] = t;
        geometry.n[i] = normal;
        geometry.lamp[i] = scene.materials[hp.shading.material as usize].emission != Vec3::ZERO;
    }
    geometry
}

/// The expected image of a photon estimate with squared radius `r2[i]` at pixel i and kernel `k2`:
/// the reference with its photon-carried part `carried` replaced by its kernel integral over the
/// pixel's plane.
fn expected_image(
    reference: &Image,
    carried: &[Vec3],
    geometry: &PixelGeometry,
    r2: &[f32],
    k2: impl Fn(f32) -> f32,
) -> Vec<Vec3> {
    let size = MODEL_SIZE as i32;
    // A world distance r covers at most r / (nearest distance × pixel angle) pixels.
    let nearest = geometry.d.iter().copied().filter(|&d| d > 0.0).fold(f32::INFINITY, f32::min);
    let largest = r2.iter().copied().fold(0.0f32, f32::max).sqrt();
    let reach = (largest / (nearest * geometry.pixel_angle)).ceil() as i32 + 1;
    (0..reference.pixels.len())
        .map(|i| {
            if geometry.lamp[i] || geometry.d[i] == 0.0 {
                return reference.pixels[i];
            }
            let (x, y) = ((i as i32) % size, (i as i32) / size);
            // Σ over every pixel ray, met on pixel i's plane, of the kernel times the footprint: the
            // grid's integral of the kernel over the whole disc (1 but for the lattice's error), which
            // normalizes the sum over the part of the disc the surface covers.
            let (mut integral, mut whole) = (Vec3::ZERO, 0.0f32);
            let (p, n) = (geometry.p[i], geometry.n[i]);
            let plane_distance = n.dot(p - geometry.eye);
            for j_y in (y - reach).max(0)..(y + reach + 1).min(size) {
                for j_x in (x - reach).max(0)..(x + reach + 1).min(size) {
                    let j = (j_y * size + j_x) as usize;
                    let cos = n.dot(geometry.dir[j]);
                    let t = plane_distance / cos;
                    let q = geometry.eye + geometry.dir[j] * t;
                    let d2 = q.distance_squared(p);
                    if !(t > 0.0 && d2 <= r2[i]) {
                        continue;
                    }
                    let w = k2(d2 / r2[i]) / r2[i] * geometry.solid_angle[j] * t * t / cos.abs();
                    whole += w;
                    let on_plane = geometry.n[j].dot(n) >= NORMAL_COSINE && geometry.p[j].distance(q) < 2e-3;
                    if on_plane && !geometry.lamp[j] {
                        integral += carried[j] * w;
                    }
                }
            }
            let integral = integral / whole;
            reference.pixels[i] - carried[i] + integral
        })
        .collect()
}

/// Direct light and emission seen directly, `pt` to depth 1 (emission is counted at the last vertex
/// and nothing sampled there, as in pbrt-v4), at the model's resolution; and the variance of each
/// render pixel's mean of it (from two independent halves).
fn direct_light() -> (Image, Vec<Vec3>) {
    let half = |seed| {
        let mut run = run_for(IntegratorKind::Pt, seed);
        run.render.spp = 16;
        run.render.max_depth = Some(1);
        (run.film.width, run.film.height) = (Some(MODEL_SIZE), Some(MODEL_SIZE));
        render(&run).image()
    };
    let (a, b) = (half(1), half(2));
    let pixels = a.pixels.iter().zip(&b.pixels).map(|(a, b)| 0.5 * (*a + *b)).collect();
    let down = |image: &Image| common::downsample2(&common::downsample2(image));
    let variance =
        down(&a).pixels.iter().zip(&down(&b).pixels).map(|(a, b)| (*a - *b) * (*a - *b) / 4.0).collect();
    (Image { width: MODEL_SIZE, height: MODEL_SIZE, pixels }, variance)
}

fn grey(p: Vec3) -> f64 {
    p.element_sum() as f64 / 3.0
}

fn grey_mean(pixels: &[Vec3]) -> f64 {
    pixels.iter().map(|&p| grey(p)).sum::<f64>() / pixels.len() as f64
}

/// The render pixels the model speaks for. Left out: those whose 4×4 model pixels touch the lamp
/// (emission seen directly, which every method adds exactly; at its edge only coverage noise), and
/// those whose gather disc of `radius` can reach surface hidden behind a nearer object (the wall behind
/// a block: photons land there, but the image does not hold what they carry).
fn compared_pixels(geometry: &PixelGeometry, radius: f32) -> Vec<bool> {
    let size = MODEL_SIZE as i32;
    let mut keep = vec![true; (SIZE * SIZE) as usize];
    for i in 0..geometry.p.len() {
        let (x, y) = ((i as i32) % size, (i as i32) / size);
        let render_pixel = |x: i32, y: i32| ((y / 4) * SIZE as i32 + x / 4) as usize;
        if geometry.lamp[i] {
            for (dx, dy) in [(0, 0), (-4, 0), (4, 0), (0, -4), (0, 4), (-4, -4), (4, 4), (-4, 4), (4, -4)] {
                let (px, py) = ((x + dx).clamp(0, size - 1), (y + dy).clamp(0, size - 1));
                keep[render_pixel(px, py)] = false;
            }
            continue;
        }
        if geometry.d[i] == 0.0 {
            continue;
        }
        let reach = (radius / (geometry.d[i] * geometry.pixel_angle)).ceil() as i32 + 1;
        let hidden = ((y - reach).max(0)..(y + reach + 1).min(size)).any(|j_y| {
            ((x - reach).max(0)..(x + reach + 1).min(size)).any(|j_x| {
                let j = (j_y * size + j_x) as usize;
                let other_plane = geometry.n[j].dot(geometry.n[i]) < NORMAL_COSINE
                    || geometry.n[i].dot(geometry.p[j] - geometry.p[i]).abs() > 0.01;
                geometry.d[j] > 0.0 && geometry.d[j] < geometry.d[i] - 0.01 && other_plane
            })
        });
        if hidden {
            keep[render_pixel(x, y)] = false;
        }
    }
    keep
}

fn assert_matches_the_reference(kind: IntegratorKind) {
    let full = read_exr(&common::data("cornell-box.ref.exr")).unwrap();
    let reference = common::downsample2(&common::downsample2(&full));
    let geometry = pixel_geometry();
    let n = reference.pixels.len();
    let (carried, direct_variance): (Vec<Vec3>, Vec<Vec3>) = match kind {
        IntegratorKind::Ppm => (full.pixels.clone(), vec![Vec3::ZERO; n]),
        _ => {
            let (direct, variance) = direct_light();
            let carried =
                full.pixels.iter().zip(&direct.pixels).map(|(r, d)| (*r - *d).max(Vec3::ZERO)).collect();
            (carried, variance)
        }
    };
    let model_n = full.pixels.len();
    // A model pixel's render pixel.
    let render_pixel =
        |i: usize| (i / MODEL_SIZE as usize / 4) * SIZE as usize + (i % MODEL_SIZE as usize) / 4;
    let k = REPLICAS as f64;
    let (mut images, mut r2, mut r0) = (Vec::new(), vec![0.0f32; model_n], 0.0f32);
    let mut kernel = caustica::density::Kernel::Uniform;
    for seed in 0..REPLICAS {
        let renderer = render(&run_for(kind, 100 + seed));
        images.push(renderer.image());
        let world = &renderer.world;
        if kind == IntegratorKind::Pm {
            let maps = world.resource::<PhotonMaps>();
            let map = maps.indirect.as_ref().expect("pm without final gathering has an indirect map");
            let mut neighbors = Neighbors::with_capacity(maps.k);
            for (i, r2) in r2.iter_mut().enumerate() {
                map.knn(geometry.p[i], maps.k, maps.max_radius2, &mut neighbors);
                let r2_here = if neighbors.len() < maps.k { maps.max_radius2 } else { neighbors.max_dist2() };
                *r2 += r2_here / k as f32;
            }
            kernel = maps.kernel;
        } else {
            let (mut sum, mut count) = (vec![0.0f32; n], vec![0.0f32; n]);
            let mut query = world.try_query::<(&PathState, &HitPoint)>().expect("hit points");
            for (state, hp) in query.iter(world) {
                sum[state.pixel as usize] += hp.r2;
                count[state.pixel as usize] += 1.0;
            }
            for (i, r2) in r2.iter_mut().enumerate() {
                let j = render_pixel(i);
                *r2 += sum[j] / count[j].max(1.0) / k as f32;
            }
            r0 = renderer.report().hit_points.expect("hit points").initial_radius;
        }
    }
    let model = |r2: &[f32]| {
        let pixels = expected_image(&full, &carried, &geometry, r2, |s2| kernel.k2(s2));
        common::downsample2(&common::downsample2(&Image { width: MODEL_SIZE, height: MODEL_SIZE, pixels }))
    };
    let at_final = model(&r2);
    let at_first = if kind == IntegratorKind::Pm { at_final.clone() } else { model(&vec![r0 * r0; model_n]) };
    let low: Vec<Vec3> = at_final.pixels.iter().zip(&at_first.pixels).map(|(a, b)| a.min(*b)).collect();
    let high: Vec<Vec3> = at_final.pixels.iter().zip(&at_first.pixels).map(|(a, b)| a.max(*b)).collect();
    let keep = compared_pixels(&geometry, r0.max(PM_MAX_RADIUS));
    let kept = |pixels: &[Vec3]| -> Vec<Vec3> {
        pixels.iter().zip(&keep).filter(|(_, keep)| **keep).map(|(p, _)| *p).collect()
    };
    let mean_image: Vec<Vec3> =
        (0..n).map(|i| images.iter().map(|img| img.pixels[i]).sum::<Vec3>() / k as f32).collect();
    let means: Vec<f64> = images.iter().map(|img| grey_mean(&kept(&img.pixels))).collect();
    let mean = means.iter().sum::<f64>() / k;
    let se = (means.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
    let (lo, hi) = (grey_mean(&kept(&low)), grey_mean(&kept(&high)));
    let (mut relmse, mut variance, mut width) = (0.0f64, 0.0f64, 0.0f64);
    for i in (0..n).filter(|&i| keep[i]) {
        for c in 0..3 {
            let r = reference.pixels[i][c] as f64;
            let mid = 0.5 * (low[i][c] + high[i][c]) as f64;
            let m = mean_image[i][c] as f64;
            let s2 = images.iter().map(|img| (img.pixels[i][c] as f64 - m).powi(2)).sum::<f64>() / (k - 1.0);
            let half = 0.5 * (high[i][c] - low[i][c]) as f64;
            relmse += (m - mid).powi(2) / (r * r + 0.01);
            variance += (s2 / k + direct_variance[i][c] as f64) / (r * r + 0.01);
            width += half * half / (r * r + 0.01);
        }
    }
    if let Ok(dir) = std::env::var("PHOTON_REFERENCE_DUMP") {
        let image = |v: Vec<Vec3>| Image { width: SIZE, height: SIZE, pixels: v };
        let d = (0..n)
            .map(|i| {
                if keep[i] {
                    (mean_image[i] - 0.5 * (low[i] + high[i])) * 4.0 + Vec3::splat(0.5)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let path = std::path::Path::new(&dir).join(format!("{kind:?}-difference.png"));
        caustica::film::output::write_image(&image(d), &path, 0.0).expect("dump");
    }
    let cells = (3 * keep.iter().filter(|k| **k).count()) as f64;
    let reference_mean = grey_mean(&kept(&reference.pixels));
    let (relmse, variance, width) = (relmse / cells, variance / cells, width / cells);
    let share = cells / (3 * n) as f64;
    eprintln!(
        "{kind:?}: mean {mean:.5} ± {se:.5}, model [{lo:.5}, {hi:.5}], reference {reference_mean:.5} over {:.0}% of the pixels; \
         relMSE to the model {relmse:.3e} (variance {variance:.3e}, width {width:.3e})",
        100.0 * share
    );
    let slack = T_QUANTILE * se;
    assert!(
        mean >= lo - slack && mean <= hi + slack,
        "{kind:?}: image mean {mean} outside the model's [{lo}, {hi}] ± {slack} (the reference's is {reference_mean})"
    );
    let bound = 1.5 * (variance + width);
    assert!(relmse <= bound, "{kind:?}: relMSE to the model {relmse} above {bound}");
}

#[test]
fn pm_matches_the_reference_within_its_variance_and_boundary_bias() {
    assert_matches_the_reference(IntegratorKind::Pm);
}

#[test]
fn ppm_matches_the_reference_within_its_variance_and_boundary_bias() {
    assert_matches_the_reference(IntegratorKind::Ppm);
}

#[test]
fn sppm_matches_the_reference_within_its_variance_and_boundary_bias() {
    assert_matches_the_reference(IntegratorKind::Sppm);
}

#[test]
fn appm_matches_the_reference_within_its_variance_and_boundary_bias() {
    assert_matches_the_reference(IntegratorKind::Appm);
}

#[test]
fn cppm_matches_the_reference_within_its_variance_and_boundary_bias() {
    assert_matches_the_reference(IntegratorKind::Cppm);
}

#[test]
fn pppm_matches_the_reference_within_its_variance_and_boundary_bias() {
    assert_matches_the_reference(IntegratorKind::Pppm);
}
