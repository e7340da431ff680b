//! What a progressive hit point keeps of the camera vertex it gathers at, packed into 20 bytes: the
//! outgoing direction and shading normal as octahedral 2 × 16 bits, the textured base colour,
//! metallic and roughness as 16-bit unorm, and the material index for the rest of the BSDF. The
//! gather rebuilds the BSDF from it; a checkpoint stores it as five 32-bit words.

use super::estimate::GatherPoint;
use super::record::{decode_octahedral, encode_octahedral};
use crate::materials::{Bsdf, ShadingParams};
use crate::render_scene::RenderScene;
use crate::sampling::warp::Frame;
use glam::Vec3;

/// A visible point's shading, packed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PackedShading {
    /// Outgoing direction (world, towards the camera), octahedral 2 × 16 bits.
    pub wo: u32,
    /// Shading normal, octahedral 2 × 16 bits.
    pub ns: u32,
    /// Base colour after textures and vertex colours, 16-bit unorm (the BSDF clamps it to [0, 1]).
    pub base_color: [u16; 3],
    /// Metallic and roughness after textures, 16-bit unorm.
    pub metallic_roughness: [u16; 2],
    /// Material index (the rest of the BSDF's parameters).
    pub material: u16,
}

/// Words of a [`PackedShading`] in a checkpoint.
pub const WORDS: usize = 5;

impl PackedShading {
    /// The shading of a vertex of `material` with shading normal `ns` and textured `params`, seen
    /// from direction `wo` (world, towards the camera).
    pub fn new(wo: Vec3, ns: Vec3, params: &ShadingParams, material: u32) -> Self {
        let unorm = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u16;
        Self {
            wo: encode_octahedral(wo, 16),
            ns: encode_octahedral(ns, 16),
            base_color: params.base_color.to_array().map(unorm),
            metallic_roughness: [unorm(params.metallic), unorm(params.roughness)],
            material: material as u16,
        }
    }

    /// The visible point at `p`, reached with throughput `beta`, as the gather sees it: its BSDF
    /// rebuilt from the packed parameters.
    pub fn gather_point(&self, scene: &RenderScene, p: Vec3, beta: Vec3) -> GatherPoint {
        let from_unorm = |x: u16| x as f32 / 65535.0;
        let m = &scene.materials[self.material as usize];
        let params = ShadingParams {
            base_color: Vec3::from_array(self.base_color.map(from_unorm)),
            metallic: from_unorm(self.metallic_roughness[0]),
            roughness: from_unorm(self.metallic_roughness[1]),
            ..m.shading
        };
        let frame = Frame::from_z(decode_octahedral(self.ns, 16));
        let wo = frame.to_local(decode_octahedral(self.wo, 16));
        GatherPoint { p, beta, bsdf: Bsdf::new(&params), frame, wo, transmits: m.shading.transmission > 0.0 }
    }

    /// As words: wo, ns, then the 16-bit fields two to a word.
    pub fn to_words(&self) -> [u32; WORDS] {
        let [r, g, b] = self.base_color.map(u32::from);
        let [metallic, roughness] = self.metallic_roughness.map(u32::from);
        [self.wo, self.ns, r | g << 16, b | metallic << 16, roughness | (self.material as u32) << 16]
    }

    /// Back from [`PackedShading::to_words`].
    pub fn from_words([wo, ns, rg, bm, rough_material]: [u32; WORDS]) -> Self {
        Self {
            wo,
            ns,
            base_color: [rg as u16, (rg >> 16) as u16, bm as u16],
            metallic_roughness: [(bm >> 16) as u16, rough_material as u16],
            material: (rough_material >> 16) as u16,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_hold_every_field() {
        let packed = PackedShading {
            wo: 0xdead_beef,
            ns: 0x0123_4567,
            base_color: [1, 65535, 300],
            metallic_roughness: [40000, 7],
            material: 65534,
        };
        assert_eq!(PackedShading::from_words(packed.to_words()), packed);
    }
}
