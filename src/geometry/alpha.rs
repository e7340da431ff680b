//! Alpha cut-outs (glTF `alphaMode`): a triangle whose material is MASK lets every ray through
//! where its alpha is below the cutoff; one that is BLEND lets a ray through with probability
//! 1 − alpha (stochastic transparency, decided by a hash of the ray, so the same ray always decides
//! alike and images stay identical for any thread count). Tested inside the BVH traversal, so camera
//! rays, shadow rays and photons all see the same holes.
//!
//! Only the triangles of such materials carry a test; a scene without them pays one empty-vector
//! check per candidate.

use crate::geometry::Ray;
use crate::scene::{AlphaMode, Scene, Texture, TextureRef};
use glam::{Vec2, Vec3};

/// `PrimitiveSet::cutout` of a primitive without an alpha test.
pub const NO_CUTOUT: u32 = u32::MAX;

/// How a material's alpha decides.
#[derive(Clone, Debug)]
struct CutoutMaterial {
    /// The base colour factor's alpha.
    factor: f32,
    /// The base colour texture (its alpha channel), with the index of its copy in `textures`.
    texture: Option<(TextureRef, usize)>,
    /// MASK's cutoff, or none for BLEND.
    cutoff: Option<f32>,
}

/// One alpha-tested triangle: its vertices' texture coordinates and its material's rule.
#[derive(Clone, Copy, Debug)]
struct CutoutTriangle {
    uv: [Vec2; 3],
    material: u32,
}

/// Every alpha-tested triangle of a scene.
#[derive(Clone, Debug, Default)]
pub struct Cutouts {
    materials: Vec<CutoutMaterial>,
    /// Copies of the textures whose alpha is read (only those).
    textures: Vec<Texture>,
    triangles: Vec<CutoutTriangle>,
}

impl Cutouts {
    /// The rules of `scene`'s materials; `None` for a material that is opaque everywhere (OPAQUE, or
    /// a mask or blend that no texel or factor can open).
    pub fn new(scene: &Scene) -> (Self, Vec<Option<u32>>) {
        let mut cutouts = Self::default();
        let mut by_material = Vec::with_capacity(scene.materials.len());
        for m in &scene.materials {
            let cutoff = match m.alpha_mode {
                AlphaMode::Opaque => {
                    by_material.push(None);
                    continue;
                }
                AlphaMode::Mask { cutoff } => Some(cutoff),
                AlphaMode::Blend => None,
            };
            let texture = m.base_color_texture.filter(|t| {
                scene.textures.get(t.texture as usize).is_some_and(|tex| tex.texels().any(|v| v.w < 1.0))
            });
            let always_opaque = texture.is_none()
                && match cutoff {
                    Some(c) => m.alpha >= c,
                    None => m.alpha >= 1.0,
                };
            if always_opaque {
                by_material.push(None);
                continue;
            }
            let texture = texture.map(|t| {
                cutouts.textures.push(scene.textures[t.texture as usize].clone());
                (t, cutouts.textures.len() - 1)
            });
            cutouts.materials.push(CutoutMaterial { factor: m.alpha, texture, cutoff });
            by_material.push(Some(cutouts.materials.len() as u32 - 1));
        }
        (cutouts, by_material)
    }

    /// Register an alpha-tested triangle with texture coordinates `uvs` (of each set, per vertex):
    /// its id for `PrimitiveSet::cutout`.
    pub fn add_triangle(&mut self, material: u32, uvs: [[Vec2; 3]; 2]) -> u32 {
        let set = self.materials[material as usize].texture.map_or(0, |(t, _)| t.tex_coord.min(1) as usize);
        self.triangles.push(CutoutTriangle { uv: uvs[set], material });
        self.triangles.len() as u32 - 1
    }

    /// Whether `ray` passes through triangle cut-out `id` at barycentrics (`b1`, `b2`).
    #[inline]
    pub fn lets_through(&self, id: u32, b1: f32, b2: f32, ray: &Ray, prim: u32) -> bool {
        let triangle = &self.triangles[id as usize];
        let m = &self.materials[triangle.material as usize];
        let mut alpha = m.factor;
        if let Some((t, copy)) = &m.texture {
            let [a, b, c] = triangle.uv;
            let uv = (1.0 - b1 - b2) * a + b1 * b + b2 * c;
            let uv = match t.transform {
                Some([x, y, o]) => x * uv.x + y * uv.y + o,
                None => uv,
            };
            alpha *= self.textures[*copy].sample(uv).w;
        }
        match m.cutoff {
            Some(cutoff) => alpha < cutoff,
            None => alpha < ray_hash(ray, prim),
        }
    }
}

/// A number in [0, 1) fixed by the ray and the primitive: the coin of stochastic transparency.
#[inline]
fn ray_hash(ray: &Ray, prim: u32) -> f32 {
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    let mut h = prim.wrapping_mul(0x9E37_79B9);
    for word in bits(ray.o).into_iter().chain(bits(ray.d)) {
        h = (h ^ word).wrapping_mul(0x85EB_CA6B);
        h ^= h >> 13;
        h = h.wrapping_mul(0xC2B2_AE35);
        h ^= h >> 16;
    }
    (h >> 8) as f32 / (1u32 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_blend_coin_is_uniform_over_rays() {
        let n = 100_000;
        let mut below = [0u32; 4];
        for i in 0..n {
            let f = i as f32;
            let ray = Ray {
                o: Vec3::new(f * 0.001, 0.3, -f),
                d: Vec3::new(0.1, -1.0, f.sin()),
                t_max: 1.0,
                time: 0.0,
            };
            let u = ray_hash(&ray, 7);
            assert!((0.0..1.0).contains(&u));
            below[(u * 4.0) as usize] += 1;
        }
        // Each quarter holds n/4 ± 4σ (σ = √(n · 1/4 · 3/4) ≈ 137).
        for count in below {
            assert!((count as f64 - n as f64 / 4.0).abs() < 4.0 * 137.0, "{below:?}");
        }
    }
}
