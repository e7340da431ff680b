//! Starting a render over on the same entities and plan: from a black film, with the scene it had or
//! with another version of it (a host's next frame).

use super::Renderer;
use crate::resources::{
    AdaptiveSampling, CameraResource, FilmResource, PhotonStats, RenderStats, SceneFeatures, SceneResource,
};
use caustica_core::error::{Error, Result};
use caustica_core::render_scene::RenderScene;
use caustica_core::scene::Scene;
use std::sync::atomic::Ordering;

impl Renderer {
    /// Start over on the same entities: a black film, zero counters, no passes (a host's next
    /// frame, after it has moved things and replaced `SceneResource`).
    pub fn restart(&mut self) {
        self.start_over(false);
    }

    /// As [`Renderer::restart`]; with `light_kept`, what the integrator traced from the lights alone
    /// (`pm`'s photon maps) stays, and the phases that trace it do not run again: a frame whose
    /// light is the last one's ([`super::FrameRun`] decides).
    pub(super) fn start_over(&mut self, light_kept: bool) {
        self.light_kept = light_kept;
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
        self.stops.stopped = false;
        self.stops.reason = None;
        self.stops.interrupt.store(false, Ordering::Relaxed);
        self.seconds = 0.0;
        self.phase_times.iter_mut().for_each(|t| (t.seconds, t.runs) = (0.0, 0));
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

    /// Refuse a scene that uses what the plan was built without.
    pub(super) fn check_features(&self, render_scene: &RenderScene) -> Result<()> {
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
