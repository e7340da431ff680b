//! BSDFs of the glTF metallic-roughness model as one per-hit mixture.
//!
//! `f = metallic · conductor + (1 - metallic) · [(1 - transmission) · plastic + transmission · dielectric]`
//! where every lobe shares the GGX roughness alpha = roughness² ([`microfacet::Ggx`]):
//!
//! | lobe | file | model |
//! |---|---|---|
//! | conductor | `conductor.rs` | GGX, Schlick F0 = base colour, delta mirror when alpha < 1e-3 |
//! | plastic (glTF dielectric base) | `plastic.rs` | GGX specular with KHR_materials_specular Schlick Fresnel over a Fresnel-coupled Lambertian |
//! | dielectric (transmission) | `dielectric.rs` | exact Fresnel, smooth (delta) or rough (Walter et al. 2007) |
//!
//! `mixture.rs` weighs and samples the lobes together (with `clearcoat.rs` over them); this file
//! holds the per-hit [`Bsdf`], which skips the mixture for a plain Lambertian surface.
//!
//! Conventions follow pbrt-v4: directions are in the local shading frame (z = shading normal), both point
//! away from the surface, `eval` excludes the cosine, and delta lobes are only reached through `sample`.

pub mod clearcoat;
pub mod conductor;
pub mod dielectric;
pub mod fresnel;
pub mod microfacet;
mod mixture;
pub mod plastic;
#[cfg(test)]
pub(crate) mod tests;

pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use microfacet::Ggx;
pub use plastic::Plastic;

use crate::sampling::warp::cosine_hemisphere;
use glam::{Vec2, Vec3};
use mixture::Mixture;
use std::f32::consts::FRAC_1_PI;

/// The parameters a [`Bsdf`] is built from, in glTF metallic-roughness semantics. A material
/// (`scene::MaterialDesc::shading`) holds them as the file's factors; a hit's are a copy with its
/// textures and vertex colour applied (`RenderScene::shading_params`). One struct for both, so a
/// parameter is described once and a hit's copy is a plain copy of the material's, no indirection.
#[derive(Clone, Copy, Debug)]
pub struct ShadingParams {
    /// Linear RGB base colour (glTF `baseColorFactor`'s RGB): diffuse albedo, conductor F0 and
    /// transmission tint.
    pub base_color: Vec3,
    /// Conductor fraction in [0, 1] (`metallicFactor`).
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]; GGX alpha = roughness².
    pub roughness: f32,
    /// Transmission fraction of the dielectric part in [0, 1] (KHR_materials_transmission).
    pub transmission: f32,
    /// Index of refraction of the inside (KHR_materials_ior, default 1.5); the outside is vacuum.
    pub ior: f32,
    /// Specular factor of the dielectric base in [0, 1] (KHR_materials_specular, default 1); 0 gives
    /// a pure Lambertian base.
    pub specular: f32,
    /// Specular colour of the dielectric base (KHR_materials_specular; linear RGB, default 1).
    pub specular_color: Vec3,
    /// Clear coat weight in [0, 1] (KHR_materials_clearcoat).
    pub clearcoat: f32,
    /// Perceptual roughness of the coat in [0, 1] (KHR_materials_clearcoat).
    pub clearcoat_roughness: f32,
    /// KHR_materials_volume thickness: > 0 a closed solid, which transmission refracts into; 0 (glTF's
    /// default, without the extension) a thin-walled sheet.
    pub thickness: f32,
}

impl ShadingParams {
    /// The glTF 2.0 default material's: white, metallic 1, roughness 1, no transmission, thin-walled.
    pub const GLTF_DEFAULT: ShadingParams = ShadingParams {
        base_color: Vec3::ONE,
        metallic: 1.0,
        roughness: 1.0,
        transmission: 0.0,
        ior: 1.5,
        specular: 1.0,
        specular_color: Vec3::ONE,
        clearcoat: 0.0,
        clearcoat_roughness: 0.0,
        thickness: 0.0,
    };
}

impl Default for ShadingParams {
    /// [`ShadingParams::GLTF_DEFAULT`].
    fn default() -> Self {
        Self::GLTF_DEFAULT
    }
}

impl ShadingParams {
    /// Whether transmission crosses a thin-walled sheet rather than entering a solid.
    #[inline]
    pub fn thin_walled(&self) -> bool {
        self.thickness <= 0.0
    }
}

/// Which quantity a path carries; it matters only for refraction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera paths: transmitted radiance is scaled by 1 / eta² (pbrt-v4 `TransportMode::Radiance`).
    Radiance,
    /// Light paths (photons): no 1 / eta² scaling.
    Importance,
}

/// A direction drawn by [`Bsdf::sample`].
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction, local frame, unit length.
    pub wi: Vec3,
    /// BSDF value: the non-delta mixture for rough samples, the delta lobe's weight for specular ones.
    pub f: Vec3,
    /// Solid-angle mixture pdf for rough samples; the discrete probability for specular ones.
    pub pdf: f32,
    /// True when `wi` came from a Dirac delta lobe.
    pub is_specular: bool,
    /// True when `wi` is on the other side of the surface from `wo`.
    pub is_transmission: bool,
    /// Relative IOR crossed along `wi` (pbrt-v4 `etap`); 1 for reflection.
    pub eta: f32,
}

/// The BSDF at one hit: small, `Copy`, built per hit without allocation. Most surfaces of most
/// scenes are plain Lambertian (glTF's dielectric base with no specular layer and no coat): they are
/// a variant of their own, built from the base colour alone and evaluated without the mixture (in a
/// diffuse Cornell box, building the mixture was 2.6% of a `pt` profile).
#[derive(Clone, Copy, Debug)]
pub struct Bsdf(Repr);

#[derive(Clone, Copy, Debug)]
enum Repr {
    /// Albedo (base colour clamped to [0, 1]); reflects on both sides.
    Lambert(Vec3),
    /// Everything else.
    Mixture(Mixture),
}

impl Bsdf {
    /// Build the BSDF from glTF parameters (clamped to their valid ranges; a non-positive or
    /// non-finite IOR falls back to 1.5).
    #[inline]
    pub fn new(p: &ShadingParams) -> Self {
        let unit = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
        let (metallic, transmission, specular) = (unit(p.metallic), unit(p.transmission), unit(p.specular));
        let coated = unit(p.clearcoat) > 0.0;
        if metallic == 0.0 && transmission == 0.0 && specular == 0.0 && !coated {
            return Self(Repr::Lambert(p.base_color.max(Vec3::ZERO).min(Vec3::ONE)));
        }
        Self(Repr::Mixture(Mixture::new(p)))
    }

    /// Give the clear coat its own shading normal `n` (unit, in this BSDF's local frame).
    pub fn set_coat_normal(&mut self, n: Vec3) {
        if let Repr::Mixture(m) = &mut self.0 {
            m.set_coat_normal(n);
        }
    }

    /// True when every lobe is a Dirac delta (perfect mirror, smooth glass): no light sampling there.
    #[inline]
    pub fn is_delta(&self) -> bool {
        match &self.0 {
            Repr::Lambert(_) => false,
            Repr::Mixture(m) => m.is_delta(),
        }
    }

    /// f(wo, wi) WITHOUT the cosine, local shading frame (z = shading normal), both vectors unit and
    /// pointing away from the surface. Delta lobes contribute 0 here.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match &self.0 {
            Repr::Lambert(albedo) => lambert_eval(*albedo, wo, wi),
            Repr::Mixture(m) => m.eval(wo, wi, mode),
        }
    }

    /// Solid-angle pdf of sample() producing wi (non-delta part only; delta lobes 0).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match &self.0 {
            Repr::Lambert(_) => lambert_pdf(wo, wi),
            Repr::Mixture(m) => m.pdf(wo, wi),
        }
    }

    /// Sample wi. u_lobe picks the lobe, u the direction. f is the full BSDF value (sum over non-delta
    /// lobes, or the delta lobe's weight for specular samples), pdf the full mixture pdf (for delta
    /// samples: the discrete probability of that lobe, pbrt-v4 convention so f·|cos|/pdf is the weight).
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        self.sample_with(wo, || u_lobe, u, mode)
    }

    /// [`Bsdf::sample`] drawing the lobe's number only when there is a lobe to choose (a Lambertian
    /// surface has one): a sampler's draw costs more than the Lambertian sample itself.
    #[inline]
    pub fn sample_with(
        &self,
        wo: Vec3,
        u_lobe: impl FnOnce() -> f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        match &self.0 {
            Repr::Lambert(albedo) => lambert_sample(*albedo, wo, u),
            Repr::Mixture(m) => m.sample(wo, u_lobe(), u, mode),
        }
    }

    /// The plain Lambertian BSDF of `albedo` (already in [0, 1]), as [`Bsdf::new`] makes it for a
    /// diffuse material: what a kept light vertex rebuilds from the albedo it keeps.
    #[inline]
    pub fn lambert(albedo: Vec3) -> Self {
        Self(Repr::Lambert(albedo))
    }

    /// The albedo of a plain Lambertian BSDF (what lanes of shading take), `None` for any other.
    #[inline]
    pub fn lambert_albedo(&self) -> Option<Vec3> {
        match &self.0 {
            Repr::Lambert(albedo) => Some(*albedo),
            Repr::Mixture(_) => None,
        }
    }

    /// Whether the BSDF is zero for every pair of directions (a black Lambertian): light arriving
    /// there is absorbed and lights nothing.
    #[inline]
    pub fn reflects_nothing(&self) -> bool {
        match &self.0 {
            Repr::Lambert(albedo) => *albedo == Vec3::ZERO,
            Repr::Mixture(m) => m.reflects_nothing(),
        }
    }

    /// Cheap hemispherical-albedo estimate per channel, independent of wo, for Russian roulette of
    /// photons (take its max component as the survival probability); see the mixture's for how each
    /// lobe is estimated.
    #[inline]
    pub fn albedo_hint(&self) -> Vec3 {
        match &self.0 {
            Repr::Lambert(albedo) => *albedo,
            Repr::Mixture(m) => m.albedo_hint(),
        }
    }
}

/// A Lambertian surface's f, reflecting on both sides.
#[inline]
fn lambert_eval(albedo: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z * wi.z > 0.0 { albedo * FRAC_1_PI } else { Vec3::ZERO }
}

/// The cosine-weighted pdf of a Lambertian sample.
#[inline]
fn lambert_pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z * wi.z > 0.0 { wi.z.abs() * FRAC_1_PI } else { 0.0 }
}

/// A cosine-weighted direction on `wo`'s side.
#[inline]
fn lambert_sample(albedo: Vec3, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    if wo.z == 0.0 || !wo.is_finite() || albedo.max_element() <= 0.0 {
        return None;
    }
    let wi = cosine_hemisphere(u);
    let wi = if wo.z < 0.0 { flip_z(wi) } else { wi };
    let pdf = wi.z.abs() * FRAC_1_PI;
    (pdf > 0.0).then(|| reflection_sample(wi, albedo * FRAC_1_PI, pdf, false, false))
}

/// Mirror a direction through the tangent plane (z → -z).
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

/// Map (wo, wi) so that wo is in the upper hemisphere: opaque lobes are two-sided (pbrt-v4), and mirroring
/// both vectors keeps every isotropic quantity unchanged. Returns whether a flip happened.
#[inline]
fn to_upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
    if wo.z < 0.0 { (flip_z(wo), flip_z(wi), true) } else { (wo, wi, false) }
}

/// A reflection sample in the upper frame, mapped back to wo's side.
#[inline]
fn reflection_sample(wi: Vec3, f: Vec3, pdf: f32, is_specular: bool, flipped: bool) -> BsdfSample {
    let wi = if flipped { flip_z(wi) } else { wi };
    BsdfSample { wi, f, pdf, is_specular, is_transmission: false, eta: 1.0 }
}
