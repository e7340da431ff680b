//! Pass films: a whole-pass integrator (`lt`, `bdpt`, `vcm`) renders each pass into films of its
//! own, folded into the render's at the pass's end. Such a pass is one estimate — its camera samples
//! count the light subpaths' splats, which land anywhere on the film — so a part of it in the film
//! would be wrong; and a pass can be long (a unit is as many light subpaths as pixels: 67 million
//! at 8192², a minute on two cores). With the pass apart, a stop (a signal, the time limit) drops
//! the running pass at once instead of waiting for its end, and the film keeps whole passes. The
//! sums are integers, so folding gives the bits of adding every sample to the one film.

use super::Renderer;
use crate::resources::{AovFilmResource, CommittedFilms, FilmResource};
use bevy_ecs::world::World;
use caustica_core::error::Result;
use caustica_core::film::Film;
use caustica_core::film::aov::AovFilm;

/// Black films of the render's size, kept between passes for the next one to render into.
pub(super) struct PassFilms {
    film: FilmResource,
    aov: Option<AovFilmResource>,
}

impl PassFilms {
    /// Films for the passes of the render whose films `world` holds, within `budget` bytes (the
    /// memory count has them: [`crate::integrators::memory::render_need`]).
    pub(super) fn try_new(world: &World, budget: u64) -> Result<Self> {
        let (width, height) = {
            let film = world.resource::<FilmResource>();
            (film.width, film.height)
        };
        let film = FilmResource::new(Film::try_new(width, height, budget)?);
        let aov = match world.contains_resource::<AovFilmResource>() {
            true => Some(AovFilmResource::new(AovFilm::try_new(width, height, budget)?)),
            false => None,
        };
        Ok(Self { film, aov })
    }
}

impl Renderer {
    /// Give the pass its films: the render's wait in [`CommittedFilms`] until the pass ends.
    pub(super) fn begin_pass_films(&mut self) {
        let Some(pass) = self.pass_films.take() else { return };
        let film = std::mem::replace(&mut *self.world.resource_mut::<FilmResource>(), pass.film);
        let aov =
            pass.aov.map(|pass| std::mem::replace(&mut *self.world.resource_mut::<AovFilmResource>(), pass));
        self.world.insert_resource(CommittedFilms { film, aov });
    }

    /// Put the render's films back, with the pass's samples added if it is `kept` (it ran whole),
    /// and keep the pass's films, black, for the next pass.
    pub(super) fn end_pass_films(&mut self, kept: bool) {
        let Some(committed) = self.world.remove_resource::<CommittedFilms>() else { return };
        let film = std::mem::replace(&mut *self.world.resource_mut::<FilmResource>(), committed.film);
        let aov = committed
            .aov
            .map(|render| std::mem::replace(&mut *self.world.resource_mut::<AovFilmResource>(), render));
        if kept {
            self.world.resource::<FilmResource>().take_from(&film);
        } else {
            film.clear();
        }
        if let Some(pass) = &aov {
            match (kept, self.world.get_resource::<AovFilmResource>()) {
                (true, Some(render)) => render.take_from(pass),
                _ => pass.clear(),
            }
        }
        self.pass_films = Some(PassFilms { film, aov });
    }
}
