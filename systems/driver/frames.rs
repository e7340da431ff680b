//! A render frame by frame: the scene posed by its file's animations or moved by a host, the World
//! following each frame (the moved meshes' BVHs, the lights, the camera), what a frame keeps of the
//! one before (`pm`'s photon maps when only the camera moved), and a frame blurred over a shutter.

use super::Renderer;
use crate::report::Report;
use crate::resources::{CameraResource, SceneResource};
use caustica_core::error::{Error, Result};
use caustica_core::render_scene::{BvhUpdate, RenderScene, SceneUpdate};
use caustica_core::scene::pose::FrameScene;
use caustica_core::scene::{RunFile, Scene};
use std::time::Instant;

/// A render whose scene moves from frame to frame: it drives a [`Renderer`], which runs each frame's
/// passes and knows nothing of frames, and keeps the scene the poses and moves apply to.
pub struct FrameRun {
    renderer: Renderer,
    /// The scene as the frame poses it.
    frames: FrameScene,
    /// How the BVHs follow moved meshes.
    bvh_update: BvhUpdate,
}

impl FrameRun {
    /// A render of `scene` with `run`'s settings whose frames a host poses ([`FrameRun::set_time`])
    /// or whose nodes it moves ([`FrameRun::move_node`]); the file's animations, if any, are posed at
    /// time 0, as [`Renderer::new`] poses them.
    pub fn new(scene: Scene, run: &RunFile) -> Result<Self> {
        let frames = FrameScene::new(scene);
        let renderer = Renderer::with_dynamic(frames.scene().clone(), run, &frames.dynamic)?;
        Ok(Self { renderer, frames, bvh_update: BvhUpdate::default() })
    }

    /// The render of the frame at hand.
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The render of the frame at hand, to run, look at or extend (its World and plan).
    pub fn renderer_mut(&mut self) -> &mut Renderer {
        &mut self.renderer
    }

    /// Give glTF node `node` (its name, or its index) the transform `m`, applied to its geometry as
    /// posed (the identity puts it back), and start the image over with the moved scene: only the
    /// moving meshes' BVH is rebuilt once the node has moved before.
    pub fn move_node(&mut self, node: &str, m: glam::Mat4) -> Result<FrameUpdate> {
        let start = Instant::now();
        let changed = self.frames.move_node(node, m)?;
        self.follow_frame(&changed, start.elapsed().as_secs_f64(), false, true)
    }

    /// Pose the file's animations at `time` (seconds: meshes, the file's camera, lights) and start
    /// the image over: the next frame of an animation.
    pub fn set_time(&mut self, time: f32) -> Result<FrameUpdate> {
        let start = Instant::now();
        let changed = self.frames.set_time(time)?;
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
        if let Some(phase) = self.renderer.plan.phases.iter().find(|p| {
            matches!(p.when, crate::plan::When::FirstPassOfProcess | crate::plan::When::RenderStart)
        }) {
            return Err(Error::Setting {
                name: "shutter".into(),
                problem: format!(
                    "{} traces its {} phase once a render, so it would see one pose of the shutter: use pt, sppm or vcm",
                    self.renderer.integrator.name(),
                    phase.name
                ),
            });
        }
        let start = Instant::now();
        let target = self.renderer.target;
        let units = target.saturating_sub(self.renderer.done).max(1);
        let first = self.renderer.done;
        let mut report = self.renderer.report();
        while self.renderer.done < target && !self.renderer.stops.stopped {
            let k = self.renderer.done - first;
            let time = open + (k as f32 + 0.5) / units as f32 * (close - open);
            let changed = self.frames.set_time(time)?;
            let camera = self.animated_camera();
            self.follow_frame(&changed, 0.0, camera, false)?;
            self.renderer.set_target(self.renderer.done + 1);
            let left = time_limit.map(|limit| limit - start.elapsed().as_secs_f64());
            if left.is_some_and(|l| l <= 0.0) {
                break;
            }
            let before = self.renderer.done;
            report = self.renderer.run(left, &mut on_step);
            // Adaptive sampling that has converged stops a run without a sample (and without a
            // stop reason): the shutter's remaining times would be posed for nothing, forever.
            if report.stopped_by.is_some() || self.renderer.done == before {
                break;
            }
        }
        self.renderer.target = target;
        Ok(report)
    }

    fn animated_camera(&self) -> bool {
        self.frames.scene().animation.as_ref().is_some_and(|a| a.camera.is_some())
    }

    /// The animation's length in seconds (its last keyframe); 0 for a scene without one.
    pub fn animation_duration(&self) -> f32 {
        self.frames.scene().animation.as_ref().map_or(0.0, |a| a.duration)
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
        let renderer = &mut self.renderer;
        let current = renderer.world.resource::<CameraResource>().0.clone();
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
        let mut run = renderer.run.clone();
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
        if camera.has_lens() != renderer.features.lens {
            return Err(bad(
                "the new camera has a lens where the render was planned without one, or the reverse",
            ));
        }
        renderer.world.insert_resource(CameraResource(camera));
        self.restart_frame(true);
        Ok(())
    }

    /// Whether this frame uses the light traced for an earlier one (`pm` after a camera-only move).
    pub fn photons_kept(&self) -> bool {
        self.renderer.light_kept
    }

    /// Follow moved meshes by `how` from here on (the default is [`BvhUpdate::TwoLevel`]; the others
    /// are there to be measured against it: `benches/animation.rs`); the BVHs are built anew for it.
    pub fn set_bvh_update(&mut self, how: BvhUpdate) -> Result<()> {
        self.bvh_update = how;
        let render_scene = RenderScene::build_dynamic(
            self.frames.scene(),
            self.renderer.run.render.light_selection,
            how.partition(&self.frames.dynamic),
        );
        self.renderer.check_features(&render_scene)?;
        self.renderer.world.insert_resource(SceneResource::new(render_scene));
        self.renderer.restart();
        Ok(())
    }

    /// Start the image over; `light_unchanged` says that only the camera moved, and then what the
    /// integrator traced from the lights alone, if it made it (`pm`'s photon maps), is kept.
    fn restart_frame(&mut self, light_unchanged: bool) {
        let keep_light = light_unchanged && self.photons_built();
        self.renderer.start_over(keep_light);
    }

    /// Whether the plan made view-independent light tracing (`pm`'s photon maps) in a pass already
    /// run, or kept from an earlier frame.
    fn photons_built(&self) -> bool {
        let renderer = &self.renderer;
        let view_independent =
            renderer.plan.phases.iter().any(|p| p.when == crate::plan::When::FirstPassOfProcess);
        view_independent && (renderer.passes > 0 || renderer.light_kept)
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
        let (renderer, frames) = (&mut self.renderer, &self.frames);
        let scene = frames.scene();
        (renderer.integrator.check)(scene, &renderer.run)?;
        let mut update = FrameUpdate { pose_seconds, ..FrameUpdate::default() };
        let light_selection = renderer.run.render.light_selection;
        let lights_moved = scene.animation.as_ref().is_some_and(|a| !a.lights.is_empty());
        let geometry_changed = !changed.is_empty() || lights_moved;
        if geometry_changed {
            let mut render_scene =
                renderer.world.remove_resource::<SceneResource>().expect("a scene").into_inner();
            update.scene =
                render_scene.update(scene, changed, &frames.dynamic, light_selection, self.bvh_update);
            if let Err(e) = renderer.check_features(&render_scene) {
                renderer.world.insert_resource(SceneResource::new(render_scene));
                return Err(e);
            }
            renderer.world.insert_resource(SceneResource::new(render_scene));
        }
        if camera {
            let start = Instant::now();
            let current = &renderer.world.resource::<CameraResource>().0;
            let (width, height) = (current.width, current.height);
            let render_scene = &**renderer.world.resource::<SceneResource>();
            let camera = crate::world::scene_camera(
                scene.camera.clone(),
                &scene.source,
                &renderer.run,
                render_scene,
                width,
                height,
            )?;
            renderer.world.insert_resource(CameraResource(camera));
            update.camera_seconds = start.elapsed().as_secs_f64();
        }
        // What light does is the same when only the camera moved.
        if restart {
            self.restart_frame(!geometry_changed);
        }
        update.photons_kept = self.renderer.light_kept;
        Ok(update)
    }
}

/// What following a frame cost ([`FrameRun::set_time`], [`FrameRun::move_node`]).
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
