//! What a host does to a render beyond running it: start over, and change the scene (replace it, or
//! move a node) between frames, on the same entities and plan.

use super::Renderer;
use crate::report::Report;
use crate::resources::{
    AdaptiveSampling, CameraResource, FilmResource, PhotonStats, RenderStats, SceneFeatures, SceneResource,
};
use caustica_core::error::{Error, Result};
use caustica_core::render_scene::RenderScene;
use caustica_core::render_scene::{BvhUpdate, SceneUpdate};
use caustica_core::scene::pose::FrameScene;
use caustica_core::scene::{RunFile, Scene};
use std::sync::atomic::Ordering;
use std::time::Instant;

impl Renderer {
    /// Start over on the same entities: a black film, zero counters, no passes (a host's next
    /// frame, after it has moved things and replaced `SceneResource`).
    pub fn restart(&mut self) {
        self.restart_frame(false);
    }

    /// As [`Renderer::restart`]; `light_unchanged` says that only the camera moved, and then what the
    /// integrator traced from the lights alone, if it made it (`pm`'s photon maps), is kept.
    fn restart_frame(&mut self, light_unchanged: bool) {
        self.light_kept = light_unchanged && self.photons_built();
        let (width, height) = {
            let film = self.world.resource::<FilmResource>();
            (film.width, film.height)
        };
        // The old film goes before its successor is made: the budget counted one film, and the
        // same size freed just before is there to be had again.
        let aovs = self.has_aovs();
        self.world.remove_resource::<FilmResource>();
        self.world.remove_resource::<crate::resources::AovFilmResource>();
        self.world.insert_resource(FilmResource::new(caustica_core::film::Film::new(width, height)));
        if aovs {
            let film = caustica_core::film::aov::AovFilm::new(width, height);
            self.world.insert_resource(crate::resources::AovFilmResource::new(film));
        }
        self.world.insert_resource(RenderStats::default());
        if let Some(mut adaptive) = self.world.get_resource_mut::<AdaptiveSampling>() {
            let (threshold, min_spp) = (adaptive.threshold, adaptive.min_spp);
            *adaptive = AdaptiveSampling::new(threshold, min_spp, width as usize * height as usize);
        }
        if self.world.contains_resource::<PhotonStats>() {
            self.world.insert_resource(PhotonStats::default());
        }
        if !self.light_kept {
            (self.plan.reset)(&mut self.world);
        }
        self.passes = 0;
        self.done = self.first;
        self.stopped = false;
        self.stopped_by = None;
        self.interrupt.store(false, Ordering::Relaxed);
        self.seconds = 0.0;
        self.phase_times.iter_mut().for_each(|t| (t.seconds, t.runs) = (0.0, 0));
    }

    /// A renderer whose scene's nodes a host can move ([`Renderer::move_node`]): it keeps the scene,
    /// which the moves apply to.
    pub fn movable(scene: Scene, run: &RunFile) -> Result<Self> {
        Self::with_frames(scene, run, true)
    }

    /// Render `scene` from here on, from a black film: the geometry, materials and lights a host has
    /// changed (a simulation's next frame), traced by the same entities and plan with the same
    /// camera and settings. Refused when the new scene needs systems the plan was built without
    /// (lights where there were none, motion, a lens, specular surfaces where there were none) or
    /// fails the integrator's checks: make a new `Renderer` for it.
    pub fn replace_scene(&mut self, scene: &Scene) -> Result<()> {
        (self.integrator.check)(scene, &self.run)?;
        let render_scene = RenderScene::build(scene, self.run.render.light_selection);
        self.check_features(&render_scene)?;
        self.world.insert_resource(SceneResource::new(render_scene));
        self.restart();
        Ok(())
    }

    /// Give glTF node `node` (its name, or its index) the transform `m`, applied to its geometry as
    /// posed (the identity puts it back), and start the image over with the moved scene: only the
    /// moving meshes' BVH is rebuilt once the node has moved before. For a renderer made by
    /// [`Renderer::movable`] or of an animated file.
    pub fn move_node(&mut self, node: &str, m: glam::Mat4) -> Result<FrameUpdate> {
        let start = Instant::now();
        let changed = self.frames_mut()?.move_node(node, m)?;
        self.follow_frame(&changed, start.elapsed().as_secs_f64(), false, true)
    }

    /// Pose the file's animations at `time` (seconds: meshes, the file's camera, lights) and start
    /// the image over: the next frame of an animation. For a renderer of an animated file (or made
    /// by [`Renderer::movable`]).
    pub fn set_time(&mut self, time: f32) -> Result<FrameUpdate> {
        let start = Instant::now();
        let changed = self.frames_mut()?.set_time(time)?;
        let camera = self.animated_camera();
        self.follow_frame(&changed, start.elapsed().as_secs_f64(), camera, true)
    }

    /// Render the frame over the shutter `[open, close]` (seconds of the file's animation): unit k
    /// of n (a sample per pixel, or a pass) traced with the scene posed at open + (k + ½)/n·(close −
    /// open), the film kept across the poses. This is accumulation-buffer motion blur with one time
    /// per unit, stratified over the shutter: the meshes, camera and lights move as the animation
    /// moves them (rotations too), each pose costing a dynamic-set rebuild. Refused for integrators
    /// that trace something once a render (`pm`'s photon maps, `ppm`'s visible points): they would
    /// see one pose only.
    pub fn run_over_shutter(
        &mut self,
        (open, close): (f32, f32),
        time_limit: Option<f64>,
        mut on_step: impl FnMut(&Renderer),
    ) -> Result<Report> {
        if !(open.is_finite() && close.is_finite() && open <= close) {
            return Err(Error::Setting {
                name: "shutter".into(),
                problem: format!("[{open}, {close}] must be finite with open <= close"),
            });
        }
        if let Some(phase) = self.plan.phases.iter().find(|p| {
            matches!(p.when, crate::plan::When::FirstPassOfProcess | crate::plan::When::RenderStart)
        }) {
            return Err(Error::Setting {
                name: "shutter".into(),
                problem: format!(
                    "{} traces its {} phase once a render, so it would see one pose of the shutter: use pt, sppm or vcm",
                    self.integrator.name(),
                    phase.name
                ),
            });
        }
        self.frames_mut()?;
        let start = Instant::now();
        let target = self.target;
        let units = target.saturating_sub(self.done).max(1);
        let first = self.done;
        let mut report = self.report();
        while self.done < target && !self.stopped {
            let k = self.done - first;
            let time = open + (k as f32 + 0.5) / units as f32 * (close - open);
            let changed = self.frames_mut()?.set_time(time)?;
            let camera = self.animated_camera();
            self.follow_frame(&changed, 0.0, camera, false)?;
            self.set_target(self.done + 1);
            let left = time_limit.map(|limit| limit - start.elapsed().as_secs_f64());
            if left.is_some_and(|l| l <= 0.0) {
                break;
            }
            let before = self.done;
            report = self.run(left, &mut on_step);
            // Adaptive sampling that has converged stops a run without a sample (and without a
            // stop reason): the shutter's remaining times would be posed for nothing, forever.
            if report.stopped_by.is_some() || self.done == before {
                break;
            }
        }
        self.target = target;
        Ok(report)
    }

    fn animated_camera(&self) -> bool {
        self.frames.as_ref().and_then(|f| f.scene().animation.as_ref()).is_some_and(|a| a.camera.is_some())
    }

    /// The animation's length in seconds (its last keyframe); 0 for a scene without one.
    pub fn animation_duration(&self) -> f32 {
        self.frames.as_ref().and_then(|f| f.scene().animation.as_ref()).map_or(0.0, |a| a.duration)
    }

    /// Place the camera: at `eye`, looking at `target`, `up` up, with vertical field of view `yfov`
    /// (radians; `None` keeps the one it has); start the image over.
    pub fn set_camera(
        &mut self,
        eye: glam::Vec3,
        target: glam::Vec3,
        up: glam::Vec3,
        yfov: Option<f32>,
    ) -> Result<()> {
        let current = self.world.resource::<CameraResource>().0.clone();
        let bad = |problem: &str| Error::Setting { name: "camera".into(), problem: problem.into() };
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(bad("eye, target and up must be finite"));
        }
        // Normalised first: a distance whose square overflows f32 is as unusable as none.
        let forward = (target - eye).normalize_or_zero();
        if forward == glam::Vec3::ZERO || forward.cross(up.normalize_or_zero()).length_squared() < 1e-12 {
            return Err(bad(
                "the eye must differ from the target (by a distance whose square is finite), and up must not be along the view",
            ));
        }
        if yfov.is_some_and(|y| !(y > 0.0 && y < std::f32::consts::PI)) {
            return Err(bad("yfov must be in (0, π) radians"));
        }
        let view = caustica_core::camera::look_at(eye, target, up);
        let desc = caustica_core::scene::CameraDesc {
            name: "host camera".into(),
            camera_to_world: view,
            yfov: yfov.unwrap_or(current.yfov()),
            aspect_ratio: None,
        };
        let mut run = self.run.clone();
        run.camera.eye = None;
        run.camera.target = None;
        run.camera.up = None;
        run.camera.yfov_degrees = None;
        let camera = caustica_core::camera::Camera::new(
            &desc,
            &run.camera,
            current.width,
            current.height,
            run.film.filter,
        )
        .map_err(|e| bad(&e.to_string()))?;
        if camera.has_lens() != self.features.lens {
            return Err(bad(
                "the new camera has a lens where the render was planned without one, or the reverse",
            ));
        }
        self.world.insert_resource(CameraResource(camera));
        self.restart_frame(true);
        Ok(())
    }

    /// Whether the plan made view-independent light tracing (`pm`'s photon maps) in a pass already
    /// run, or kept from an earlier frame.
    fn photons_built(&self) -> bool {
        let view_independent =
            self.plan.phases.iter().any(|p| p.when == crate::plan::When::FirstPassOfProcess);
        view_independent && (self.passes > 0 || self.light_kept)
    }

    /// Whether this frame uses the light traced for an earlier one (`pm` after a camera-only move).
    pub fn photons_kept(&self) -> bool {
        self.light_kept
    }

    /// Follow moved meshes by `how` from here on (the default is [`BvhUpdate::TwoLevel`]; the others
    /// are there to be measured against it: `benches/animation.rs`); the BVHs are built anew for it.
    pub fn set_bvh_update(&mut self, how: BvhUpdate) -> Result<()> {
        self.bvh_update = how;
        let frames = self.frames.as_ref().ok_or_else(|| Error::Setting {
            name: "bvh update".into(),
            problem: "this renderer does not keep its scene for frames: make it with Renderer::movable"
                .into(),
        })?;
        let render_scene = RenderScene::build_dynamic(
            frames.scene(),
            self.run.render.light_selection,
            how.partition(&frames.dynamic),
        );
        self.check_features(&render_scene)?;
        self.world.insert_resource(SceneResource::new(render_scene));
        self.restart();
        Ok(())
    }

    fn frames_mut(&mut self) -> Result<&mut FrameScene> {
        self.frames.as_mut().ok_or_else(|| Error::Setting {
            name: "node".into(),
            problem: "this renderer does not keep its scene for frames: make it with Renderer::movable"
                .into(),
        })
    }

    /// The World follows the frame the scene now stands at, its meshes `changed` moved: the BVHs,
    /// the lights, the camera when `camera` (the file's moved), and the image started over when
    /// `restart` (else the film goes on accumulating: a pose within the shutter).
    fn follow_frame(
        &mut self,
        changed: &[usize],
        pose_seconds: f64,
        camera: bool,
        restart: bool,
    ) -> Result<FrameUpdate> {
        let frames = self.frames.as_ref().expect("called with frames");
        let scene = frames.scene();
        (self.integrator.check)(scene, &self.run)?;
        let mut update = FrameUpdate { pose_seconds, ..FrameUpdate::default() };
        let light_selection = self.run.render.light_selection;
        let lights_moved = scene.animation.as_ref().is_some_and(|a| !a.lights.is_empty());
        let geometry_changed = !changed.is_empty() || lights_moved;
        if geometry_changed {
            let mut render_scene =
                self.world.remove_resource::<SceneResource>().expect("a scene").into_inner();
            update.scene =
                render_scene.update(scene, changed, &frames.dynamic, light_selection, self.bvh_update);
            if let Err(e) = self.check_features(&render_scene) {
                self.world.insert_resource(SceneResource::new(render_scene));
                return Err(e);
            }
            self.world.insert_resource(SceneResource::new(render_scene));
        }
        if camera {
            let start = Instant::now();
            let current = &self.world.resource::<CameraResource>().0;
            let (width, height) = (current.width, current.height);
            let render_scene = &**self.world.resource::<SceneResource>();
            let camera = crate::world::scene_camera(
                scene.camera.clone(),
                &scene.source,
                &self.run,
                render_scene,
                width,
                height,
            )?;
            self.world.insert_resource(CameraResource(camera));
            update.camera_seconds = start.elapsed().as_secs_f64();
        }
        // What light does is the same when only the camera moved.
        if restart {
            self.restart_frame(!geometry_changed);
        }
        update.photons_kept = self.light_kept;
        Ok(update)
    }

    fn check_features(&self, render_scene: &RenderScene) -> Result<()> {
        let features = SceneFeatures::of(self.world.resource::<CameraResource>(), render_scene);
        if !self.features.covers(features) {
            return Err(Error::Setting {
                name: "scene".into(),
                problem: format!(
                    "the new scene uses {features:?}, the render was planned for {:?}: make a new renderer for it",
                    self.features
                ),
            });
        }
        Ok(())
    }
}

/// What following a frame cost ([`Renderer::set_time`], [`Renderer::move_node`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameUpdate {
    /// Seconds posing the meshes (animations and moves).
    pub pose_seconds: f64,
    /// The BVHs and lights.
    pub scene: SceneUpdate,
    /// Seconds placing the camera.
    pub camera_seconds: f64,
    /// Whether the integrator kept what it had traced from the lights (`pm`'s photon map).
    pub photons_kept: bool,
}
