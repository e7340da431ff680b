//! The ranges serde cannot express, checked however a setting arrives (run file, `--set`, flags).

use super::{PhotonSettings, ProgressiveSettings, RunFile};

impl RunFile {
    /// Ranges serde cannot express; the message names the key. Run after the command line's
    /// overrides too (`scene::load_with`), so a setting is checked the same way however it arrives.
    pub fn check_settings(&self) -> Result<(), String> {
        let finite = |key: &str, values: &[f32]| {
            if values.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(format!("{key} must be finite")) }
        };
        let frames = &self.frames;
        if !(frames.fps > 0.0 && frames.fps.is_finite()) {
            return Err(format!("frames.fps is {}, must be finite and > 0", frames.fps));
        }
        if !(frames.shutter >= 0.0 && frames.shutter.is_finite()) {
            return Err(format!("frames.shutter is {}, must be finite and >= 0 (in frames)", frames.shutter));
        }
        if let Some(end) = frames.end
            && end <= frames.start
        {
            return Err(format!("frames.end is {end}, must be after frames.start ({})", frames.start));
        }
        if self.render.spp == 0 {
            return Err("render.spp is 0, must be at least 1".to_owned());
        }
        if !(1..=MAX_CHUNK).contains(&self.render.chunk) {
            return Err(format!("render.chunk is {}, must be in 1..={MAX_CHUNK}", self.render.chunk));
        }
        self.environment.check()?;
        if self.film.width == Some(0) || self.film.height == Some(0) {
            return Err("film.width and film.height must be at least 1".to_owned());
        }
        finite("film.exposure", &[self.film.exposure])?;
        let stops = crate::film::output::MAX_EXPOSURE_STOPS;
        if self.film.exposure.abs() > stops {
            return Err(format!("film.exposure is {} stops, must be within ±{stops}", self.film.exposure));
        }
        let camera = &self.camera;
        for (key, value) in
            [("camera.eye", camera.eye), ("camera.target", camera.target), ("camera.up", camera.up)]
        {
            finite(key, &value.unwrap_or_default())?;
        }
        if let Some(yfov) = camera.yfov_degrees
            && !(yfov > 0.0 && yfov < 180.0)
        {
            return Err(format!("camera.yfov_degrees is {yfov}, must be in (0, 180)"));
        }
        if !(camera.aperture_radius >= 0.0 && camera.aperture_radius.is_finite()) {
            return Err(format!(
                "camera.aperture_radius is {}, must be finite and >= 0",
                camera.aperture_radius
            ));
        }
        if let Some(focus) = camera.focus_distance
            && !(focus > 0.0 && focus.is_finite())
        {
            return Err(format!("camera.focus_distance is {focus}, must be finite and > 0"));
        }
        if let Some([open, close]) = camera.shutter
            && !(open.is_finite() && close.is_finite() && open <= close)
        {
            return Err(format!("camera.shutter is [{open}, {close}], must be finite with open <= close"));
        }
        for (i, sphere) in self.spheres.iter().enumerate() {
            finite(&format!("sphere[{i}].center"), &sphere.center)?;
            finite(&format!("sphere[{i}].motion"), &sphere.motion.unwrap_or_default())?;
        }
        for (i, motion) in self.motion.iter().enumerate() {
            finite(&format!("motion[{i}].translate"), &motion.translate)?;
        }
        for (i, light) in self.lights.iter().enumerate() {
            light.to_desc(i)?;
        }
        self.progressive.check().map_err(|e| format!("progressive.{e}"))?;
        self.photons.check().map_err(|e| format!("photons.{e}"))?;
        self.guiding.check().map_err(|e| format!("guiding.{e}"))?;
        if self.output.write_every == Some(0) {
            return Err("output.write_every is 0, must be at least 1 (or absent)".to_owned());
        }
        self.schedule.check()?;
        if let Some(t) = self.render.time_limit
            && !(t.is_finite() && t > 0.0)
        {
            return Err(format!("render.time_limit is {t}, must be finite and > 0"));
        }
        self.check_adaptive_sampling()?;
        if let Some(mib) = self.render.memory_budget_mib
            && mib > MAX_MEMORY_BUDGET_MIB
        {
            return Err(format!(
                "render.memory_budget_mib is {mib}, more than {MAX_MEMORY_BUDGET_MIB} (1 EiB)"
            ));
        }
        Ok(())
    }
}

impl PhotonSettings {
    /// Which setting is out of range, if any (named as in the run file, without the table).
    pub fn check(&self) -> Result<(), String> {
        // With k = 1 the one photon lies on the rim of its own disc, where every kernel but the
        // uniform one is zero: the estimate would be black.
        if self.k < 2 {
            return Err(format!("k is {}, must be at least 2 (100 by default)", self.k));
        }
        if let Some(r) = self.max_radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("max_radius is {r}, must be finite and > 0"));
        }
        Ok(())
    }
}

/// Camera paths a worker keeps in flight by default (`render.chunk`): their columns, about 200 bytes
/// a path, stay within a core's L2 from stage to stage.
pub const DEFAULT_CHUNK: u32 = 4096;
/// Largest chunk.
pub const MAX_CHUNK: u32 = 1 << 20;

/// Samples a pixel takes before adaptive sampling may stop it: enough for a variance estimate that is
/// not fooled by a pixel whose rare bright paths have not turned up yet.
pub const DEFAULT_MIN_SPP: u32 = 16;

impl RunFile {
    /// Whether adaptive sampling is on.
    pub fn is_adaptive(&self) -> bool {
        self.render.noise_threshold > 0.0
    }

    /// Whether path guiding takes part: asked for, with samples to train (a render of one sample per
    /// pixel has none, and renders unguided with a warning).
    pub fn is_guided(&self) -> bool {
        self.guiding.enabled && self.guiding.training_passes(self.render.spp) > 0
    }

    /// What is wrong with the adaptive-sampling settings, if anything.
    fn check_adaptive_sampling(&self) -> Result<(), String> {
        let render = &self.render;
        let t = render.noise_threshold;
        if !(t.is_finite() && t >= 0.0) {
            return Err(format!("render.noise_threshold is {t}, must be finite and >= 0 (0 turns it off)"));
        }
        if self.is_adaptive() && render.min_spp < 2 {
            return Err(format!(
                "render.min_spp is {}, must be at least 2 (a variance needs two samples)",
                render.min_spp
            ));
        }
        Ok(())
    }
}

/// Largest memory budget, MiB: 2^40 MiB = 1 EiB, so that its bytes fit a u64 (and no machine has more).
pub const MAX_MEMORY_BUDGET_MIB: u64 = 1 << 40;

impl RunFile {
    /// The memory budget in bytes: `[render]`'s, else `[progressive]`'s, else half the machine's
    /// memory.
    pub fn memory_budget_bytes(&self) -> u64 {
        let given = self.render.memory_budget_mib.or(self.progressive.memory_budget_mib);
        given.map_or_else(|| crate::memory::physical_bytes() / 2, |mib| mib << 20)
    }
}

/// Most hit points a pixel may have.
pub const MAX_HIT_POINTS_PER_PIXEL: u32 = 256;

impl ProgressiveSettings {
    /// Which setting is out of range, if any (named as in the run file, without the table).
    pub fn check(&self) -> Result<(), String> {
        if self.passes == 0 {
            return Err("passes is 0, must be at least 1".into());
        }
        if self.photons_per_pass == 0 {
            return Err("photons_per_pass is 0, must be at least 1".into());
        }
        // α = 0 keeps no photon statistics (the radius collapses at once); α > 1 would grow N faster
        // than photons arrive and the radius would never shrink.
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(format!("alpha is {}, must be in (0, 1]", self.alpha));
        }
        if let Some(r) = self.initial_radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("initial_radius is {r}, must be finite and > 0"));
        }
        if let Some(mib) = self.memory_budget_mib
            && mib > MAX_MEMORY_BUDGET_MIB
        {
            return Err(format!("memory_budget_mib is {mib}, more than {MAX_MEMORY_BUDGET_MIB} (1 EiB)"));
        }
        if let Some(n) = self.hit_points_per_pixel
            && !(n.is_power_of_two() && n <= MAX_HIT_POINTS_PER_PIXEL)
        {
            return Err(format!(
                "hit_points_per_pixel is {n}, must be a power of two from 1 to {MAX_HIT_POINTS_PER_PIXEL} (1, 2, 4, 8, …): \
                 the hit points of a pixel are the points of a (0, m, 2)-net over it"
            ));
        }
        Ok(())
    }
}
