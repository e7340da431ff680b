//! Absorbing media inside closed transmissive meshes (KHR_materials_volume's attenuation):
//! Beer–Lambert transmittance exp(−σa · t) along every segment a path or photon travels inside one.
//!
//! The medium a ray is in is tracked by a small stack of the interfaces it has entered: refracting
//! into a solid (thickness > 0) material pushes it, refracting out of one removes its topmost entry,
//! and the medium is the most recently entered one still open. So a glass in water is water until
//! the glass is entered and water again once it is left, whatever order the surfaces are met in. A
//! path starts in air (the camera and the lights are outside every solid); a thin-walled material
//! (thickness 0) is a sheet, not a volume, and changes nothing. Deeper nesting than the stack holds
//! forgets the outermost entries.

use crate::render_scene::RenderScene;
use glam::Vec3;

/// Interfaces a path remembers.
const DEPTH: usize = 4;
/// No material: the slot is free.
const NONE: u32 = u32::MAX;

/// The solids a ray is inside, innermost last.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Media {
    entered: [u32; DEPTH],
}

impl Default for Media {
    fn default() -> Self {
        Self::AIR
    }
}

impl Media {
    /// Outside every solid.
    pub const AIR: Self = Self { entered: [NONE; DEPTH] };

    /// The material whose volume the ray is in, if any.
    #[inline]
    pub fn current(&self) -> Option<u32> {
        self.entered.iter().rev().copied().find(|&m| m != NONE)
    }

    /// Update for a refraction through a surface of `material`: `entering` when the ray crosses to
    /// the back of the surface (into the solid).
    #[inline]
    pub fn cross(&mut self, scene: &RenderScene, material: u32, entering: bool) {
        if scene.is_volume(material) {
            self.cross_volume(material, entering);
        }
    }

    /// As [`Media::cross`] for a material known to bound a volume.
    #[inline]
    pub fn cross_volume(&mut self, material: u32, entering: bool) {
        if entering {
            match self.entered.iter().position(|&m| m == NONE) {
                Some(free) => self.entered[free] = material,
                None => {
                    self.entered.rotate_left(1);
                    self.entered[DEPTH - 1] = material;
                }
            }
        } else if let Some(at) = self.entered.iter().rposition(|&m| m == material) {
            // Close the entry and keep the others in order, innermost last.
            self.entered[at..].rotate_left(1);
            self.entered[DEPTH - 1] = NONE;
        }
    }

    /// Transmittance over a segment of length `distance` in the current medium (per channel).
    #[inline]
    pub fn transmittance(&self, scene: &RenderScene, distance: f32) -> Vec3 {
        match self.current() {
            None => Vec3::ONE,
            Some(m) => {
                let sigma = scene.materials[m as usize].attenuation;
                if sigma == Vec3::ZERO {
                    Vec3::ONE
                } else {
                    // exp(−σ · ∞) = 0: a ray that leaves an open "solid" is absorbed, not NaN.
                    (-sigma * distance).exp().max(Vec3::ZERO)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::ShadingParams;
    use crate::scene::{MaterialDesc, Scene};

    fn scene() -> RenderScene {
        let solid = |sigma: f32| MaterialDesc {
            shading: ShadingParams { thickness: 1.0, transmission: 1.0, ..ShadingParams::default() },
            attenuation: Vec3::splat(sigma),
            ..MaterialDesc::default()
        };
        let shading = ShadingParams { thickness: 0.0, transmission: 1.0, ..ShadingParams::default() };
        let thin = MaterialDesc { shading, ..MaterialDesc::default() };
        let scene = Scene { materials: vec![solid(1.0), solid(2.0), thin], ..Scene::default() };
        RenderScene::build(&scene, crate::scene::LightSelection::Power)
    }

    #[test]
    fn nested_solids_are_entered_and_left_in_any_order() {
        let scene = scene();
        let mut media = Media::default();
        assert_eq!(media.current(), None);
        media.cross(&scene, 0, true); // into water
        media.cross(&scene, 1, true); // into the glass in it
        assert_eq!(media.current(), Some(1));
        media.cross(&scene, 1, false); // out of the glass: water again
        assert_eq!(media.current(), Some(0));
        media.cross(&scene, 2, true); // a thin sheet changes nothing
        assert_eq!(media.current(), Some(0));
        media.cross(&scene, 0, false);
        assert_eq!(media.current(), None);
        // Leaving what was never entered (a path that started inside) changes nothing.
        media.cross(&scene, 1, false);
        assert_eq!(media, Media::default());
    }

    #[test]
    fn transmittance_is_beer_lambert_and_zero_at_infinity() {
        let scene = scene();
        let mut media = Media::default();
        assert_eq!(media.transmittance(&scene, 5.0), Vec3::ONE);
        media.cross(&scene, 1, true);
        assert!((media.transmittance(&scene, 0.5) - Vec3::splat((-1.0f32).exp())).abs().max_element() < 1e-7);
        assert_eq!(media.transmittance(&scene, f32::INFINITY), Vec3::ZERO);
    }

    #[test]
    fn a_deeper_nesting_forgets_the_outermost() {
        let scene = scene();
        let mut media = Media::default();
        for _ in 0..DEPTH {
            media.cross(&scene, 0, true);
        }
        media.cross(&scene, 1, true);
        assert_eq!(media.current(), Some(1));
        media.cross(&scene, 1, false);
        assert_eq!(media.current(), Some(0));
    }
}
