//! What a host does to a render beyond running it: take a share of a split render, start over, and
//! change the scene (replace it, or move a node) between frames, on the same entities and plan.

use super::Renderer;
use crate::integrators;
use crate::resources::{
    AdaptiveSampling, CameraResource, FilmResource, PhotonStats, RenderStats, SceneFeatures, SceneResource,
};
use caustica_core::error::{Error, Result};
use caustica_core::film::accumulator::PartInfo;
use caustica_core::render_scene::RenderScene;
use caustica_core::scene::pose::NodeMoves;
use caustica_core::scene::{RunFile, Scene};
use std::sync::atomic::Ordering;

impl Renderer {
    /// A renderer of share `part` (from 1) of `parts` of the render `run` sets up of `scene` (a
    /// render split across processes or machines), stopping only between passes, and what its
    /// accumulator records (`film::accumulator::write_part`): the one sequence the command and the
    /// hosts use.
    pub fn for_share(scene: Scene, run: &RunFile, part: u32, parts: u32) -> Result<(Self, PartInfo)> {
        let units = integrators::of_run(run).units(run);
        let mut info = PartInfo::of_share(&scene, run, units, part, parts)
            .map_err(|problem| caustica_core::error::Error::Setting { name: "part".into(), problem })?;
        let mut renderer = Self::new(scene, run)?;
        renderer.set_whole_passes(true);
        renderer.set_samples(info.samples.clone())?;
        info.per_unit = renderer.camera_samples_per_unit();
        Ok((renderer, info))
    }

    /// Render only samples (or passes) `samples` of every pixel: one share of a render split across
    /// processes or machines (`caustica render --part`). The film then holds their sums, which merge
    /// with the other shares' into the same bits as one run of all of them. Before the first pass, and
    /// only where [`share_refusal`] has no objection.
    pub fn set_samples(&mut self, samples: std::ops::Range<u32>) -> Result<()> {
        let refuse = |problem: &str| {
            Err(caustica_core::error::Error::Setting { name: "part".into(), problem: problem.into() })
        };
        if let Some(problem) = self.integrator.share_refusal(&self.run) {
            return refuse(&problem);
        }
        if self.passes > 0 {
            return refuse("the render has started");
        }
        if samples.is_empty() {
            return refuse("the share holds no samples");
        }
        (self.first, self.done, self.target) = (samples.start, samples.start, samples.end);
        Ok(())
    }

    /// Start over on the same entities: a black film, zero counters, no passes (a host's next
    /// frame, after it has moved things and replaced `SceneResource`).
    pub fn restart(&mut self) {
        let (width, height) = {
            let film = self.world.resource::<FilmResource>();
            (film.width, film.height)
        };
        self.world.insert_resource(FilmResource(caustica_core::film::Film::new(width, height)));
        if self.has_aovs() {
            let film = caustica_core::film::aov::AovFilm::new(width, height);
            self.world.insert_resource(crate::resources::AovFilmResource(film));
        }
        self.world.insert_resource(RenderStats::default());
        if let Some(mut adaptive) = self.world.get_resource_mut::<AdaptiveSampling>() {
            let (threshold, min_spp) = (adaptive.threshold, adaptive.min_spp);
            *adaptive = AdaptiveSampling::new(threshold, min_spp, width as usize * height as usize);
        }
        if self.world.contains_resource::<PhotonStats>() {
            self.world.insert_resource(PhotonStats::default());
        }
        (self.plan.reset)(&mut self.world);
        self.passes = 0;
        self.done = self.first;
        self.stopped = false;
        self.stopped_by = None;
        self.interrupt.store(false, Ordering::Relaxed);
        self.seconds = 0.0;
        self.phase_times.iter_mut().for_each(|t| (t.seconds, t.runs) = (0.0, 0));
    }

    /// A renderer whose scene's nodes a host can move ([`Renderer::move_node`]): it keeps the scene
    /// as loaded, which the moves apply to.
    pub fn movable(scene: Scene, run: &RunFile) -> Result<Self> {
        let moves = NodeMoves::new(scene.clone());
        let mut renderer = Self::new(scene, run)?;
        renderer.moves = Some(moves);
        Ok(renderer)
    }

    /// Render `scene` from here on, from a black film: the geometry, materials and lights a host has
    /// changed (a simulation's next frame), traced by the same entities and plan with the same
    /// camera and settings. Refused when the new scene needs systems the plan was built without
    /// (lights where there were none, motion, a lens, specular surfaces where there were none) or
    /// fails the integrator's checks: make a new `Renderer` for it.
    pub fn replace_scene(&mut self, scene: &Scene) -> Result<()> {
        (self.integrator.check)(scene, &self.run)?;
        let render_scene = RenderScene::build(scene, self.run.render.light_selection);
        let features = SceneFeatures::of(self.world.resource::<CameraResource>(), &render_scene);
        if features != self.features {
            return Err(Error::Setting {
                name: "scene".into(),
                problem: format!(
                    "the new scene uses {features:?}, the render was planned for {:?}: make a new renderer for it",
                    self.features
                ),
            });
        }
        self.world.insert_resource(SceneResource(render_scene));
        self.restart();
        Ok(())
    }

    /// Give glTF node `node` (its name, or its index) the transform `m`, applied to its geometry as
    /// loaded (the identity puts it back), and start the image over with the moved scene. For a
    /// renderer made by [`Renderer::movable`].
    pub fn move_node(&mut self, node: &str, m: glam::Mat4) -> Result<()> {
        let Some(moves) = &mut self.moves else {
            return Err(Error::Setting {
                name: "node".into(),
                problem: "this renderer does not keep its scene as loaded: make it with Renderer::movable"
                    .into(),
            });
        };
        moves.set(node, m)?;
        let moved = moves.scene();
        self.replace_scene(&moved)
    }
}

/// Why a share of the render `run` sets up cannot be rendered alone and merged, if it cannot: what a
/// host asks before it splits (`Renderer::set_samples` has the last word).
pub fn share_refusal(run: &RunFile) -> Option<String> {
    integrators::of_run(run).share_refusal(run)
}
