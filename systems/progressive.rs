//! The driver of the progressive photon mappers (`ppm`, `sppm`, `appm`, `cppm`): one World with a
//! hit-point entity per pixel and a wavefront of photon entities, both spawned once, and the three
//! schedules of `integrators::ppm` run once per pass, like pbrt-v4's SPPM loop.

use super::components::{
    AdaptiveStats, Chi2Cells, HitPoint, PathHit, PathRay, PathState, PathStatus, PhotonHit, PhotonRay,
    PhotonState, ShadowRay,
};
use super::gather::PassPhotons;
use super::integrators::ppm::ProgressiveSchedules;
use super::integrators::{appm, cppm, ppm, sppm};
use super::radius::CHI2_FIRST_TEST;
use super::render::{MAX_WAVEFRONT, scene_world};
use super::resources::{
    PhotonBuffer, PhotonMapKind, PhotonStats, PhotonWork, ProgressiveConfig, RadiusRule, RenderConfig,
    RenderFilm, RenderStats, SceneFeatures, SceneGeometry, Workload,
};
use crate::error::{Error, Result};
use crate::film::Image;
use crate::photon::progressive::initial_radius;
use crate::scene::schedule::Pass;
use crate::scene::{IntegratorKind, ProgressiveSettings, RunFile, Scene};
use bevy_ecs::prelude::*;
use glam::Vec3;
use std::time::Instant;

/// Bytes a pixel costs: its hit point and the camera-path state that re-traces it.
pub const BYTES_PER_PIXEL: usize = size_of::<HitPoint>()
    + size_of::<PathRay>()
    + size_of::<PathHit>()
    + size_of::<PathState>()
    + size_of::<ShadowRay>()
    + size_of::<Chi2Cells>();
/// Bytes a photon of one pass costs: its deposit in the buffer and in the pass's kd-tree.
pub const BYTES_PER_PHOTON: usize = 2 * size_of::<crate::photon::Photon>();

/// A progressive render in progress.
pub struct ProgressiveRenderer {
    /// Scene, settings, film, hit points and photons.
    pub world: World,
    /// Camera, photon and statistics schedules.
    pub schedules: ProgressiveSchedules,
    /// What the scene uses.
    pub features: SceneFeatures,
    /// Which integrator.
    pub kind: IntegratorKind,
    /// Passes and photons.
    pub settings: ProgressiveSettings,
    /// Passes done.
    pub passes: u32,
    /// The order of the camera, photon and statistics schedules within a pass.
    pub pass_order: [Pass; 3],
    photon_entities: u32,
}

/// What one pass did.
#[derive(Clone, Copy, Debug, Default)]
pub struct PassReport {
    /// Passes done, this one included.
    pub passes: u32,
    /// Photons stored by this pass.
    pub stored: usize,
    /// Seconds of this pass: camera, photons, gather and update.
    pub camera_seconds: f64,
    /// Seconds tracing photons.
    pub photon_seconds: f64,
    /// Seconds building the pass's kd-tree, gathering and updating.
    pub gather_seconds: f64,
}

impl PassReport {
    /// Whole pass, seconds.
    pub fn seconds(&self) -> f64 {
        self.camera_seconds + self.photon_seconds + self.gather_seconds
    }
}

/// The memory the machine has, from /proc/meminfo (Linux); 8 GiB where it cannot be read.
fn physical_memory_bytes() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
            line.split_whitespace().nth(1)?.parse::<u64>().ok().map(|kib| kib * 1024)
        })
        .unwrap_or(8 << 30)
}

/// Total surface area of the scene's primitives (for the initial-radius heuristic).
fn surface_area(scene: &SceneGeometry) -> f32 {
    use crate::geometry::bvh::PrimitiveShape;
    scene
        .geometry
        .primitives()
        .map(|(_, shape, _, _)| match shape {
            PrimitiveShape::Triangle(t) => 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length(),
            PrimitiveShape::Sphere(_, radius) => 4.0 * std::f32::consts::PI * radius * radius,
        })
        .filter(|a| a.is_finite())
        .sum()
}

/// Build the World and schedules of a progressive integrator for `scene`.
pub fn prepare_progressive(scene: Scene, run: &RunFile) -> Result<ProgressiveRenderer> {
    let settings = run.progressive;
    let kind = run.render.integrator;
    settings.check().map_err(|problem| Error::Setting { name: "progressive".into(), problem })?;
    run.schedule.check(kind).map_err(|problem| Error::Setting { name: "schedule".into(), problem })?;
    let (stage_order, pass_order, nee) = (
        run.schedule.stage_order().unwrap_or(crate::scene::schedule::CYCLE),
        run.schedule.pass_order().unwrap_or([Pass::Camera, Pass::Photons, Pass::Statistics]),
        run.schedule.nee_for(kind),
    );
    if !kind.is_progressive() {
        return Err(Error::Setting {
            name: "integrator".into(),
            problem: format!("{kind:?} is not progressive: prepare it with systems::render::prepare"),
        });
    }
    if scene.materials.len() > u16::MAX as usize + 1 {
        return Err(Error::Setting {
            name: "integrator".into(),
            problem: format!(
                "progressive photon mapping holds material indices in 16 bits; the scene has {} materials",
                scene.materials.len()
            ),
        });
    }
    let pixels = {
        let (w, h) = super::render::resolution(&scene, run)?;
        w as u64 * h as u64
    };
    // Refuse before allocating anything big: hit points for every pixel plus one pass of photons.
    let photon_wavefront = settings.photons_per_pass.min(MAX_WAVEFRONT);
    let needed = pixels * BYTES_PER_PIXEL as u64
        + settings.photons_per_pass as u64 * BYTES_PER_PHOTON as u64
        + photon_wavefront as u64
            * (size_of::<PhotonState>() + size_of::<PhotonRay>() + size_of::<PhotonHit>()) as u64;
    let budget = settings.memory_budget_mib.map_or(physical_memory_bytes() / 2, |mib| mib << 20);
    if needed > budget {
        return Err(Error::Setting {
            name: "progressive.memory_budget_mib".into(),
            problem: format!(
                "{pixels} hit points ({BYTES_PER_PIXEL} bytes each) and {} photons per pass need {} MiB, over the \
                 budget of {} MiB: lower the resolution or photons_per_pass, or raise the budget",
                settings.photons_per_pass,
                needed >> 20,
                budget >> 20
            ),
        });
    }

    let (mut world, features) = scene_world(scene, run)?;
    if features.learns_visibility {
        tracing::warn!(
            "visibility-aware light selection learns only in pt; progressive passes use the light tree"
        );
        world.resource_mut::<SceneGeometry>().lights.finish_learning();
    }
    let (area, diagonal) = {
        let scene = world.resource::<SceneGeometry>();
        let (min, max) = scene.geometry.bounds();
        (surface_area(scene), (max - min).length())
    };
    let r0 =
        settings.initial_radius.unwrap_or_else(|| initial_radius(area, diagonal, settings.photons_per_pass));
    let rule = match kind {
        IntegratorKind::Appm => RadiusRule::Adaptive,
        IntegratorKind::Cppm => RadiusRule::ChiSquare,
        _ => RadiusRule::Shrinking,
    };
    world.insert_resource(ProgressiveConfig {
        rule,
        alpha: settings.alpha,
        r0,
        photons_per_pass: settings.photons_per_pass,
        pass: 0,
    });

    // One entity per pixel: its camera path and its hit point, in pixel order.
    let pixels = pixels as u32;
    let path =
        |pixel| (PathRay::default(), PathHit::default(), PathState::new(pixel, 0), ShadowRay::default());
    let hit_point = HitPoint::new(r0 * r0);
    match rule {
        RadiusRule::Shrinking => {
            world.spawn_batch((0..pixels).map(|p| (path(p), hit_point)));
        }
        RadiusRule::Adaptive => {
            world.spawn_batch((0..pixels).map(|p| (path(p), hit_point, AdaptiveStats::default())));
        }
        RadiusRule::ChiSquare => {
            let cells = Chi2Cells {
                counts: [0; crate::photon::progressive::CHI2_CELLS],
                min_photons: CHI2_FIRST_TEST,
            };
            world.spawn_batch((0..pixels).map(|p| (path(p), hit_point, cells)));
        }
    }
    let mut workload = Workload::new(pixels, 0, 1, pixels);
    workload.next = workload.total_samples();
    world.insert_resource(workload);

    let config = world.resource::<RenderConfig>().clone();
    // Without light sampling at the hit points, photons carry direct light too.
    let stored = if nee { PhotonMapKind::Bounced } else { PhotonMapKind::Global };
    world.insert_resource(PhotonWork::new(stored, settings.photons_per_pass, &config, features.motion));
    world.insert_resource(PhotonBuffer::default());
    world.insert_resource(PhotonStats::default());
    world.insert_resource(PassPhotons::default());
    super::photons::spawn_photon_wavefront(&mut world, photon_wavefront, PathStatus::Idle);

    let mut schedules = ProgressiveSchedules::with_order(stage_order);
    match kind {
        IntegratorKind::Ppm => ppm::build(&mut schedules, features),
        IntegratorKind::Appm => appm::build(&mut schedules, features, nee),
        IntegratorKind::Cppm => cppm::build(&mut schedules, features, nee),
        _ => sppm::build(&mut schedules, features, nee),
    }
    Ok(ProgressiveRenderer {
        world,
        schedules,
        features,
        kind,
        settings,
        passes: 0,
        pass_order,
        photon_entities: photon_wavefront,
    })
}

impl ProgressiveRenderer {
    /// Run one pass: camera paths to hit points (every pass but `ppm`'s later ones), a photon pass,
    /// then gather and update.
    pub fn run_pass(&mut self) -> PassReport {
        let pass = self.passes;
        let _span = tracing::info_span!("pass", index = pass).entered();
        let seed = self.world.resource::<RenderConfig>().seed;
        // One shutter time per pass, shared by the camera and the photons (Hachisuka & Jensen 2009, §5).
        let time = self.features.motion.then(|| crate::sampling::Sampler::new(seed, u32::MAX, pass).get1d(0));

        let mut report = PassReport::default();
        for stage in self.pass_order {
            let start = Instant::now();
            match stage {
                Pass::Camera => {
                    self.camera_pass(pass, time);
                    report.camera_seconds = start.elapsed().as_secs_f64();
                }
                Pass::Photons => {
                    self.photon_pass(pass, time);
                    report.photon_seconds = start.elapsed().as_secs_f64();
                }
                Pass::Statistics => {
                    self.world.resource_mut::<ProgressiveConfig>().pass = pass;
                    self.schedules.statistics.run(&mut self.world);
                    report.stored = self.world.resource::<PassPhotons>().map.len();
                    report.gather_seconds = start.elapsed().as_secs_f64();
                }
            }
        }
        self.passes += 1;
        report.passes = self.passes;
        report
    }

    /// Trace every pixel's camera path to its hit point (`ppm`: the first pass only).
    fn camera_pass(&mut self, pass: u32, time: Option<f32>) {
        if self.kind == IntegratorKind::Ppm && pass > 0 {
            return;
        }
        self.world.resource_mut::<RenderConfig>().pass_time = time;
        let mut paths = self.world.query::<&mut PathState>();
        for mut state in paths.iter_mut(&mut self.world) {
            state.sample = pass;
            state.status = PathStatus::NeedsCamera;
        }
        loop {
            self.schedules.camera.run(&mut self.world);
            if self.world.resource::<RenderStats>().active_paths == 0 {
                break;
            }
        }
        if pass == 0 && self.settings.initial_radius.is_none() {
            self.cap_initial_radius_by_footprint();
        }
    }

    /// Trace this pass's photons into `PhotonBuffer`.
    fn photon_pass(&mut self, pass: u32, time: Option<f32>) {
        {
            let mut work = self.world.resource_mut::<PhotonWork>();
            work.pass = pass;
            work.time = time;
            work.next = self.photon_entities;
        }
        let mut photons = self.world.query::<&mut PhotonState>();
        for (index, mut state) in photons.iter_mut(&mut self.world).enumerate() {
            state.index = index as u32;
            state.status = PathStatus::NeedsCamera;
        }
        loop {
            self.schedules.photons.run(&mut self.world);
            if self.world.resource::<PhotonStats>().active == 0 {
                break;
            }
        }
    }

    /// Bound the heuristic initial radius by `FOOTPRINT_PIXELS` pixel footprints at the median
    /// distance of the first pass's hit points: the area heuristic alone fails where a huge ground
    /// plane or backdrop dominates the area, and a radius of metres would make every hit point
    /// gather every photon.
    fn cap_initial_radius_by_footprint(&mut self) {
        /// A first estimate blurred over up to ten pixels is smooth enough and sharpens within passes.
        const FOOTPRINT_PIXELS: f32 = 10.0;
        let camera = self.world.resource::<super::resources::RenderCamera>();
        let (cx, cy) = (camera.width / 2, camera.height / 2);
        let ray = |x| camera.generate_ray(x, cy, glam::Vec2::splat(0.5), glam::Vec2::splat(0.5), 0.0);
        let pixel_angle = ray(cx).d.normalize().angle_between(ray(cx + 1).d.normalize());
        let origin = camera.origin;
        let mut distances: Vec<f32> = self
            .world
            .query::<&HitPoint>()
            .iter(&self.world)
            .filter(|hp| hp.is_valid())
            .map(|hp| (hp.p - origin).length())
            .collect();
        if distances.is_empty() || pixel_angle.is_nan() || pixel_angle <= 0.0 {
            return;
        }
        let mid = distances.len() / 2;
        let median = *distances.select_nth_unstable_by(mid, f32::total_cmp).1;
        let cap = FOOTPRINT_PIXELS * pixel_angle * median;
        let mut config = self.world.resource_mut::<ProgressiveConfig>();
        if !(cap > 0.0 && cap < config.r0) {
            return;
        }
        config.r0 = cap;
        for mut hp in self.world.query::<&mut HitPoint>().iter_mut(&mut self.world) {
            hp.r2 = cap * cap;
        }
    }

    /// Run passes until `self.settings.passes` are done or `time_limit` seconds have passed (the pass
    /// running then finishes), calling `on_pass` after each.
    pub fn run(&mut self, time_limit: Option<f64>, mut on_pass: impl FnMut(&mut Self, &PassReport)) -> f64 {
        let start = Instant::now();
        while self.passes < self.settings.passes {
            let report = self.run_pass();
            on_pass(self, &report);
            if time_limit.is_some_and(|limit| start.elapsed().as_secs_f64() >= limit) {
                break;
            }
        }
        start.elapsed().as_secs_f64()
    }

    /// The image so far: emission and direct light from the film, plus each pixel's photon estimate.
    pub fn image(&mut self) -> Image {
        let mut image = self.world.resource::<RenderFilm>().image();
        let passes = self.passes.max(1) as f64;
        let rule = self.world.resource::<ProgressiveConfig>().rule;
        let mut hit_points = self.world.query::<(&PathState, &HitPoint)>();
        for (state, hp) in hit_points.iter(&self.world) {
            let area = match rule {
                RadiusRule::Shrinking => std::f64::consts::PI * hp.r2 as f64,
                RadiusRule::Adaptive | RadiusRule::ChiSquare => std::f64::consts::PI,
            };
            let l = (hp.tau / (area * passes)).as_vec3();
            image.pixels[state.pixel as usize] += if l.is_finite() { l } else { Vec3::ZERO };
        }
        image
    }

    /// Mean gather radius over the hit points.
    pub fn mean_radius(&mut self) -> f32 {
        let mut hit_points = self.world.query::<&HitPoint>();
        let (sum, count) = hit_points
            .iter(&self.world)
            .fold((0.0f64, 0u32), |(s, c), hp| (s + (hp.r2 as f64).sqrt(), c + 1));
        (sum / count.max(1) as f64) as f32
    }

    /// Photon contributions dropped for being NaN or infinite.
    pub fn dropped_photons(&self) -> u64 {
        self.world.resource::<PassPhotons>().dropped.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Photons emitted so far.
    pub fn photons_emitted(&self) -> u64 {
        self.passes as u64 * self.settings.photons_per_pass as u64
    }
}
