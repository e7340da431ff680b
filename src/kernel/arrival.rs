//! What every camera vertex does first, whichever integrator it belongs to: the medium's
//! transmittance along the ray, the sky or the surface's emission by the integrator's weighting rule,
//! the vertex's random numbers, its BSDF, and the feature images at the first surface; then the
//! integrator's own work at the vertex.

use super::aov::FirstSurface;
use super::emission::{add_escaped_radiance, add_surface_emission};
use super::{CameraPath, EmissionWeight, Vertex, VertexSampler};
use crate::geometry::Ray;
use crate::geometry::bvh::Hit;
use crate::render_scene::RenderScene;
use crate::sampling::Sampler;

/// How a camera path arrives at a vertex.
#[derive(Clone, Copy, Debug)]
pub struct Arrival {
    /// How emission found here counts; `None`: it does not (a final-gather ray, whose light the
    /// photon map it reads holds already).
    pub emission: Option<EmissionWeight>,
    /// The depth at which the path ends once emission is counted, before any sampling (pbrt-v4's
    /// `maxDepth`): `pt`'s limit; `u32::MAX` where the integrator ends its paths by its own rule.
    pub last_depth: u32,
}

impl Arrival {
    /// The path travels along `ray` to `hit` (its pixel and sample drive `sampler`); at a surface,
    /// `at_surface` goes on from the vertex there with its random numbers and says whether the path
    /// continues. False when the path ends: it left the scene, reached `last_depth`, or `at_surface`
    /// ended it. (The vertex is handed on, not returned: a few hundred bytes that a return would
    /// copy on the hottest path of every integrator.)
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn arrive(
        self,
        scene: &RenderScene,
        ray: &mut Ray,
        hit: &Hit,
        path: &mut CameraPath,
        sampler: Sampler,
        aov: Option<&mut FirstSurface>,
        at_surface: impl FnOnce(&mut CameraPath, &mut Ray, &Vertex, &VertexSampler) -> bool,
    ) -> bool {
        path.travel(scene, hit);
        if !hit.is_hit() {
            if let Some(rule) = self.emission {
                add_escaped_radiance(scene, rule, path, ray.d);
            }
            if let Some(aov) = aov {
                aov.escaped(scene, ray.d, path.beta);
            }
            return false;
        }
        // Drawn first: the numbers are a long chain of multiplies that the out-of-order core can run
        // beside the surface's and the material's work, which does not need them.
        let u = VertexSampler::new(sampler, path.depth);
        let si = scene.geometry.surface_hit(ray, hit);
        if let Some(rule) = self.emission {
            add_surface_emission(scene, rule, path, &si, -ray.d, ray.time);
        }
        if path.depth >= self.last_depth {
            return false;
        }
        let v = Vertex::new(scene, ray, si);
        if let Some(aov) = aov {
            aov.reached(&v, hit.t, path.beta);
        }
        at_surface(path, ray, &v, &u)
    }
}
