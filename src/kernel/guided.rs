//! A camera vertex of path tracing guided by a learned distribution of the light arriving there
//! (path guiding, [`crate::guiding`]): the continuation is drawn from a one-sample mixture of the
//! BSDF (probability `bsdf_share`) and the vertex's guide, and both the continuation and light
//! sampling's MIS weight use the mixture's pdf, so nothing is counted twice; the BSDF's share keeps
//! every direction it can reach possible, so a guide that missed some light cannot bias the image.
//!
//! Guided vertices are those whose BSDF has a non-delta part and does not refract (a guide knows
//! nothing of the relative IOR a refraction crosses); the others continue as [`super::path_vertex`]
//! does. A leaf that has learnt nothing is uniform over the sphere: there the BSDF alone samples.

use super::aov::FirstSurface;
use super::continuation::continue_along;
use super::direct::sample_light_against;
use super::{CameraPath, PathLimits, ShadowSample, Vertex, VertexSampler};
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::guiding::{Leaf, SdTree};
use crate::materials::{BsdfSample, TransportMode};
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;
use glam::Vec3;

/// The direction a guided vertex continued along, for training: where, which way (world), the pdf
/// it was drawn with (the mixture's, or the BSDF's where the guide took no part), and the BSDF's
/// density of it (for the leaf to learn its BSDF share).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuidedStep {
    /// The vertex.
    pub p: Vec3,
    /// The continuation, world space, unit length.
    pub wi: Vec3,
    /// Its solid-angle pdf.
    pub pdf: f32,
    /// The BSDF's solid-angle pdf of it.
    pub bsdf_pdf: f32,
}

/// One vertex of `pt` (`NEE`) or `pt-naive` guided by `guide`: whether the path goes on (its next
/// ray in `ray`), the light sample to test, and the step to train the guide with, if the vertex is
/// a guided one and the path went on by a non-delta lobe.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn guided_path_vertex<const NEE: bool>(
    scene: &RenderScene,
    limits: PathLimits,
    hit: &Hit,
    ray: &mut Ray,
    path: &mut CameraPath,
    sampler: Sampler,
    aov: Option<&mut FirstSurface>,
    guide: &SdTree,
) -> (bool, Option<ShadowSample>, Option<GuidedStep>) {
    let (mut light_sample, mut step) = (None, None);
    let continues = super::path_vertex::arrival::<NEE>(limits).arrive(
        scene,
        ray,
        hit,
        path,
        sampler,
        aov,
        |path, ray, v, u| {
            let guided = is_guided(scene, v);
            let leaf = guided.then(|| guide.leaf(v.si.p));
            let mixture = Mixture::new(leaf);
            if NEE && !v.bsdf.is_delta() {
                light_sample = sample_light_against(scene, v, path, ray.time, u, true, |wi, wi_world| {
                    mixture.pdf(v.bsdf.pdf(v.wo, wi), wi_world)
                });
            }
            if path.depth >= limits.max_depth {
                return false;
            }
            let Some((bs, bsdf_pdf)) = mixture.sample(v, u) else { return false };
            let (wi_world, pdf, delta) = (v.frame.to_world(bs.wi), bs.pdf, bs.is_specular);
            match continue_along(path, v, ray.time, u, limits, bs) {
                Some(next) => {
                    if guided && !delta {
                        step = Some(GuidedStep { p: v.si.p, wi: wi_world, pdf, bsdf_pdf });
                    }
                    *ray = next;
                    true
                }
                None => false,
            }
        },
    );
    (continues, light_sample, step)
}

/// Whether the vertex is guided: a BSDF with a non-delta part that does not refract.
#[inline]
fn is_guided(scene: &RenderScene, v: &Vertex) -> bool {
    !v.bsdf.is_delta() && scene.materials[v.si.material as usize].shading.transmission <= 0.0
}

/// The one-sample mixture of the BSDF and a leaf's guide.
struct Mixture<'a> {
    /// The guide, where it takes part (a guided vertex whose leaf has learnt something and chose to
    /// use it).
    leaf: Option<Leaf<'a>>,
    /// The BSDF's probability: 1 without a guide.
    bsdf_share: f32,
}

impl<'a> Mixture<'a> {
    fn new(leaf: Option<Leaf<'a>>) -> Self {
        match leaf.filter(|leaf| !leaf.distribution().is_uniform() && leaf.bsdf_share() < 1.0) {
            Some(leaf) => Self { leaf: Some(leaf), bsdf_share: leaf.bsdf_share().clamp(0.0, 1.0) },
            None => Self { leaf: None, bsdf_share: 1.0 },
        }
    }

    /// The mixture's pdf towards `wi_world`, whose BSDF pdf is `bsdf_pdf`.
    #[inline]
    fn pdf(&self, bsdf_pdf: f32, wi_world: Vec3) -> f32 {
        match &self.leaf {
            Some(leaf) => self.bsdf_share * bsdf_pdf + (1.0 - self.bsdf_share) * leaf.pdf(wi_world),
            None => bsdf_pdf,
        }
    }

    /// A continuation from the mixture, as a BSDF sample whose pdf is the mixture's (a delta lobe's
    /// discrete probability scaled by the BSDF's share: the guide never draws it), and the BSDF's
    /// own pdf of it.
    #[inline]
    fn sample(&self, v: &Vertex, u: &VertexSampler) -> Option<(BsdfSample, f32)> {
        let Some(leaf) = &self.leaf else {
            let bs =
                v.bsdf.sample_with(v.wo, || u.bsdf_lobe(), u.bsdf_direction(), TransportMode::Radiance)?;
            return Some((bs, bs.pdf));
        };
        let pick = u.bsdf_lobe();
        if pick < self.bsdf_share {
            // The pick, stretched back over [0, 1), chooses the BSDF's lobe.
            let lobe = pick / self.bsdf_share;
            let mut bs = v.bsdf.sample_with(v.wo, || lobe, u.bsdf_direction(), TransportMode::Radiance)?;
            let bsdf_pdf = bs.pdf;
            bs.pdf = if bs.is_specular {
                self.bsdf_share * bs.pdf
            } else {
                self.pdf(bs.pdf, v.frame.to_world(bs.wi))
            };
            return Some((bs, bsdf_pdf));
        }
        let (wi_world, guide_pdf) = leaf.sample(u.bsdf_direction());
        let wi = v.frame.to_local(wi_world);
        let bsdf_pdf = v.bsdf.pdf(v.wo, wi);
        let bs = BsdfSample {
            wi,
            f: v.bsdf.eval(v.wo, wi, TransportMode::Radiance),
            pdf: self.bsdf_share * bsdf_pdf + (1.0 - self.bsdf_share) * guide_pdf,
            is_specular: false,
            is_transmission: wi.z * v.wo.z < 0.0,
            eta: 1.0,
        };
        Some((bs, bsdf_pdf))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::warp::Frame;

    /// A guide trained on light from one narrow cone only, mixed with a Lambertian BSDF: every
    /// direction of the upper hemisphere keeps at least the BSDF's share of the BSDF's pdf, so light
    /// the guide never saw is still found (with bsdf_share 0 it would not be, and the image would
    /// lose it).
    #[test]
    fn the_bsdf_share_keeps_every_direction_the_bsdf_reaches() {
        let config = crate::guiding::GuidingConfig { fixed_bsdf_share: Some(0.25), ..Default::default() };
        let mut tree = SdTree::with_config(Vec3::splat(-1.0), Vec3::splat(1.0), config);
        let cone = Vec3::new(0.3, 0.2, 0.93).normalize();
        for iteration in 0..3 {
            for _ in 0..20_000 {
                tree.record(Vec3::ZERO, cone, 1.0);
            }
            tree.refine(iteration);
        }
        let leaf = tree.leaf(Vec3::ZERO);
        assert!(!leaf.distribution().is_uniform());
        let mixture = Mixture::new(Some(leaf));
        let frame = Frame::from_z(Vec3::Z);
        let lambert = crate::materials::Bsdf::lambert(Vec3::splat(0.5));
        let wo = Vec3::Z;
        let (mut dark, mut total) = (0, 0);
        for i in 0..64 {
            for j in 1..32 {
                let phi = i as f32 / 64.0 * std::f32::consts::TAU;
                let cos = j as f32 / 32.0;
                let sin = (1.0 - cos * cos).sqrt();
                let wi = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
                let bsdf_pdf = lambert.pdf(wo, wi);
                let guide_pdf = leaf.pdf(frame.to_world(wi));
                let pdf = mixture.pdf(bsdf_pdf, frame.to_world(wi));
                assert!(pdf >= 0.25 * bsdf_pdf * (1.0 - 1e-6), "{wi}: {pdf} < a quarter of {bsdf_pdf}");
                dark += usize::from(guide_pdf < 1e-3 * bsdf_pdf);
                total += 1;
            }
        }
        assert!(dark * 2 > total, "the guide should leave most directions dark: {dark} of {total}");
    }

    #[test]
    fn an_untrained_leaf_leaves_the_bsdf_alone() {
        let tree = SdTree::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let mixture = Mixture::new(Some(tree.leaf(Vec3::ZERO)));
        assert!(mixture.leaf.is_none() && mixture.bsdf_share == 1.0);
        assert_eq!(mixture.pdf(0.3, Vec3::Z), 0.3);
    }
}
