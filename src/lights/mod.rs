//! Lights: emissive triangles and spheres, the environment, sampled for next-event estimation, and
//! light selection.

pub mod bidirectional;
pub mod environment;
pub mod light;
pub mod punctual;
pub mod sample;
pub mod select;
pub mod tree;
pub mod visibility;

pub use environment::Environment;
pub use light::{EmissionSample, Light, LightSample, LightShape, LightTexture};
pub use select::LightSelector;
pub use tree::LightTree;
pub use visibility::VisibilityGrid;

use crate::geometry::Geometry;
use crate::geometry::bvh::PrimitiveShape;
use crate::sampling::ONE_MINUS_EPSILON;
use crate::scene::environment::EnvironmentDesc;
use crate::scene::punctual::{PunctualKind, PunctualLightDesc};
use crate::scene::{LightSelection, MaterialDesc, Texture, TextureRef};
use glam::{Vec2, Vec3};

/// Share of light-tree selections that go to the infinite lights (environment, suns) when there are
/// also lights in the tree: the tree cannot bound an infinite light, so they are chosen beside its
/// root (pbrt-v4 `BVHLightSampler`'s infinite lights), among themselves by power.
const TREE_INFINITE_SHARE: f32 = 0.5;

/// Every emitter in the scene and the distribution that picks one for a shadow ray.
///
/// Light indices `0..lights.len()` are the area lights, then the punctual ones (points, spots,
/// suns); index `lights.len()` (see [`Lights::environment_index`]) is the environment, when there is
/// one.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    /// The area lights; index = light id stored on the emitting primitive.
    pub lights: Vec<Light>,
    /// The infinite environment light, if any.
    pub environment: Option<Environment>,
    selector: LightSelector,
    /// The light tree, when selection is by tree (then `selector` is unused for NEE).
    tree: Option<LightTree>,
    /// The learned visibility, when selection is visibility-aware (on top of the tree).
    visibility: Option<VisibilityGrid>,
    /// Selection in proportion to power, for photon emission (whatever `selector` does for NEE).
    by_power: LightSelector,
    /// With a tree: the lights it cannot hold (suns, then the environment) and their selection by
    /// power among themselves.
    infinite: Vec<u32>,
    infinite_selector: LightSelector,
}

impl Lights {
    /// Find the emissive primitives, give each a light id in `geometry`, add the punctual lights and
    /// the environment around the geometry's bounds, and build the selector.
    pub fn build(
        geometry: &mut Geometry,
        materials: &[MaterialDesc],
        textures: &[Texture],
        environment: Option<&EnvironmentDesc>,
        punctual: &[PunctualLightDesc],
        selection: LightSelection,
    ) -> Self {
        let mut lights = Vec::new();
        let mut ids = Vec::new();
        let emits = |material: u32| materials[material as usize].emission.max_element() > 0.0;
        for (prim, shape, info, motion) in geometry.primitives_of(emits) {
            let le = materials[info.material as usize].emission;
            if le.max_element() <= 0.0 {
                continue;
            }
            let shape = match *shape {
                PrimitiveShape::Triangle(p) => LightShape::triangle(p),
                PrimitiveShape::Sphere(c, r) => LightShape::Sphere { center: c, radius: r },
            };
            ids.push(prim);
            let mut light = Light::new(shape, le, motion, prim);
            if let (Some(t), LightShape::Triangle { .. }) =
                (&materials[info.material as usize].emissive_texture, shape)
            {
                let uv = geometry.triangle_uvs(prim, t.tex_coord);
                light.texture = Some(LightTexture { texture: *t, uv });
                light.mean_texel = mean_texel(t, textures, uv);
            }
            lights.push(light);
        }
        for (i, &prim) in ids.iter().enumerate() {
            geometry.set_light(prim, i as u32);
        }
        let (min, max) = geometry.bounds();
        lights.extend(punctual.iter().map(|desc| punctual_light(desc, min, max)));
        let environment = environment.map(|desc| Environment::new(desc, min, max));
        // Uniform and power selection treat the environment as one more light, by its power through
        // the scene's cross-section (pbrt-v4 `PowerLightSampler`).
        let power: Vec<f32> =
            lights.iter().map(Light::power).chain(environment.as_ref().map(Environment::power)).collect();
        let by_power = LightSelector::new(&power);
        let selector = match selection {
            LightSelection::Uniform => LightSelector::new(&vec![1.0; power.len()]),
            LightSelection::Power | LightSelection::Tree | LightSelection::Visibility => by_power.clone(),
        };
        let uses_tree = matches!(selection, LightSelection::Tree | LightSelection::Visibility);
        let tree = uses_tree.then(|| LightTree::build(&lights));
        let infinite: Vec<u32> = (0..power.len() as u32)
            .filter(|&i| lights.get(i as usize).is_none_or(|l| l.shape.is_infinite()))
            .collect();
        let infinite_selector =
            LightSelector::new(&infinite.iter().map(|&i| power[i as usize]).collect::<Vec<_>>());
        let visibility = match (&tree, selection) {
            (Some(tree), LightSelection::Visibility) if !lights.is_empty() => {
                let (min, max) = geometry.bounds();
                Some(VisibilityGrid::new(min, max, tree))
            }
            _ => None,
        };
        Self { selector, by_power, lights, environment, tree, visibility, infinite, infinite_selector }
    }

    /// Whether the scene has no emitter and no environment.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() && self.environment.is_none()
    }

    /// The light index of the environment (one past the area lights).
    #[inline]
    pub fn environment_index(&self) -> u32 {
        self.lights.len() as u32
    }

    /// Total emitted power (luminance-weighted watts in renderer units), the environment's included.
    pub fn total_power(&self) -> f32 {
        self.lights.iter().map(Light::power).sum::<f32>()
            + self.environment.as_ref().map_or(0.0, Environment::power)
    }

    /// Radiance a ray that leaves the scene along `d` brings back, and the solid-angle pdf (selection
    /// included) with which light sampling from `p_ref` (normal `n_ref`) would have picked that
    /// direction: what MIS needs for a BSDF-sampled ray that escapes.
    #[inline]
    pub fn escaped(&self, d: Vec3, p_ref: Vec3, n_ref: Vec3) -> Option<(Vec3, f32)> {
        let env = self.environment.as_ref()?;
        Some((env.le(d), self.environment_pdf(d, p_ref, n_ref)))
    }

    /// Solid-angle pdf (selection included) with which [`Lights::sample`] picks direction `d` on the
    /// environment from `p_ref` (normal `n_ref`); 0 without an environment.
    #[inline]
    pub fn environment_pdf(&self, d: Vec3, p_ref: Vec3, n_ref: Vec3) -> f32 {
        self.environment
            .as_ref()
            .map_or(0.0, |env| self.pmf(self.environment_index(), p_ref, n_ref) * env.pdf(n_ref, d))
    }

    /// Share of tree selections that go to the infinite lights (all of them when no other light has
    /// power, so none made it into the tree).
    fn tree_infinite_share(&self) -> f32 {
        let tree_is_empty = self.tree.as_ref().is_none_or(LightTree::is_empty);
        match (self.infinite.is_empty(), tree_is_empty) {
            (true, _) => 0.0,
            (false, true) => 1.0,
            (false, false) => TREE_INFINITE_SHARE,
        }
    }

    /// Whether light `index` is infinitely far (a sun or the environment).
    fn is_infinite(&self, index: u32) -> bool {
        self.lights.get(index as usize).is_none_or(|l| l.shape.is_infinite())
    }

    /// Pick a light index for a shading point and its probability.
    #[inline]
    pub fn select(&self, p_ref: Vec3, n_ref: Vec3, u_select: f32) -> Option<(u32, f32)> {
        let Some(tree) = &self.tree else {
            return self.selector.sample(u_select);
        };
        let share = self.tree_infinite_share();
        let u = match self.split_tree_share(u_select) {
            Err(infinite) => return infinite,
            Ok(u) => u,
        };
        let (index, pmf) = match &self.visibility {
            Some(grid) => grid.sample(tree, p_ref, n_ref, u)?,
            None => tree.sample(p_ref, n_ref, u)?,
        };
        Some((index, pmf * (1.0 - share)))
    }

    /// With a tree, `u_select`'s choice between the infinite lights (the light chosen among them,
    /// as `Err`) and the tree (the number that descends it, as `Ok`).
    #[inline]
    pub(crate) fn split_tree_share(&self, u_select: f32) -> Result<f32, Option<(u32, f32)>> {
        let share = self.tree_infinite_share();
        if u_select < share {
            let chosen = self.infinite_selector.sample((u_select / share).min(ONE_MINUS_EPSILON));
            return Err(chosen.map(|(i, pmf)| (self.infinite[i as usize], pmf * share)));
        }
        Ok(((u_select - share) / (1.0 - share)).min(ONE_MINUS_EPSILON))
    }

    /// The tree and the share of selections it takes, where selection is by the tree alone (not
    /// visibility-aware): what the lanes descend (`kernel::lanes::tree`).
    #[inline]
    pub(crate) fn tree_alone(&self) -> Option<(&LightTree, f32)> {
        match (&self.tree, &self.visibility) {
            (Some(tree), None) => Some((tree, 1.0 - self.tree_infinite_share())),
            _ => None,
        }
    }

    /// The tree, the visibility grid and the share of selections they take, where selection is
    /// visibility-aware: what the lanes descend (`kernel::lanes::tree`).
    #[inline]
    pub(crate) fn tree_and_visibility(&self) -> Option<(&LightTree, &VisibilityGrid, f32)> {
        match (&self.tree, &self.visibility) {
            (Some(tree), Some(grid)) => Some((tree, grid, 1.0 - self.tree_infinite_share())),
            _ => None,
        }
    }

    /// [`Lights::select`] for the first `count` of `N` shading points at once, the same picks (the
    /// rest `None`): by the selector, `N` searches of its CDF interleaved; by the tree, one point
    /// after another.
    #[inline]
    pub fn select_many<const N: usize>(
        &self,
        p_ref: &[Vec3; N],
        n_ref: &[Vec3; N],
        u_select: &[f32; N],
        count: usize,
    ) -> [Option<(u32, f32)>; N] {
        if self.tree.is_none() {
            let mut chosen = self.selector.sample_many(u_select);
            chosen[count..].fill(None);
            return chosen;
        }
        std::array::from_fn(|i| if i < count { self.select(p_ref[i], n_ref[i], u_select[i]) } else { None })
    }

    /// Pick a light with `u_select` for a shading point `p_ref` with normal `n_ref` (zero: none; on the
    /// side the point is shaded from, which visibility-aware selection needs) and a point on it at `time`. The returned pdf is per unit solid angle at `p_ref` and includes the
    /// selection probability.
    #[inline]
    pub fn sample(
        &self,
        p_ref: Vec3,
        n_ref: Vec3,
        time: f32,
        u_select: f32,
        u: Vec2,
    ) -> Option<(u32, LightSample)> {
        let (index, pmf) = self.select(p_ref, n_ref, u_select)?;
        self.sample_chosen(index, pmf, p_ref, n_ref, time, u)
    }

    /// A point on light `index`, chosen with probability `pmf`, as seen from `p_ref` (normal
    /// `n_ref`): its pdf per unit solid angle with the choice's probability in it.
    #[inline]
    pub fn sample_chosen(
        &self,
        index: u32,
        pmf: f32,
        p_ref: Vec3,
        n_ref: Vec3,
        time: f32,
        u: Vec2,
    ) -> Option<(u32, LightSample)> {
        let mut s = match self.lights.get(index as usize) {
            Some(light) => light.sample(p_ref, n_ref, time, u)?,
            None => self.environment.as_ref()?.sample(p_ref, n_ref, u)?,
        };
        s.pdf *= pmf;
        Some((index, s))
    }

    /// Solid-angle pdf (selection included) with which [`Lights::sample`] picks the point `p` with normal
    /// `n` on light `index` from `p_ref` (normal `n_ref`): what MIS needs when a BSDF-sampled ray hits
    /// that light.
    #[inline]
    pub fn pdf(&self, index: u32, p_ref: Vec3, n_ref: Vec3, p: Vec3, n: Vec3, time: f32) -> f32 {
        debug_assert!(index < self.environment_index(), "the environment's pdf is Lights::escaped's");
        self.pmf(index, p_ref, n_ref) * self.lights[index as usize].pdf(p_ref, n_ref, p, n, time)
    }

    /// Start a photon: pick a light in proportion to its power, a point on it and a cosine-weighted
    /// direction. Returns the light index and the emission sample, whose `weight` is Le·cosθ / pdf
    /// (the photon's power before division by the number of photons).
    #[inline]
    pub fn sample_emission(
        &self,
        time: f32,
        u_select: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<(u32, EmissionSample)> {
        let (index, pmf) = self.by_power.sample(u_select)?;
        let mut s = match self.lights.get(index as usize) {
            Some(light) => light.sample_emission(time, u_pos, u_dir)?,
            None => self.environment.as_ref()?.sample_emission(u_pos, u_dir)?,
        };
        s.weight /= pmf;
        Some((index, s))
    }

    /// Probability of picking light `index` for a shading point `p_ref` with normal `n_ref`.
    pub fn pmf(&self, index: u32, p_ref: Vec3, n_ref: Vec3) -> f32 {
        let Some(tree) = &self.tree else {
            return self.selector.pmf(index);
        };
        let share = self.tree_infinite_share();
        if self.is_infinite(index) {
            let position = self.infinite.iter().position(|&i| i == index);
            return position.map_or(0.0, |i| share * self.infinite_selector.pmf(i as u32));
        }
        let in_tree = match &self.visibility {
            Some(grid) => grid.pmf(tree, index, p_ref, n_ref),
            None => tree.pmf(index, p_ref, n_ref),
        };
        in_tree * (1.0 - share)
    }

    /// Whether selection is visibility-aware and still learning from shadow rays.
    pub fn is_learning(&self) -> bool {
        self.visibility.as_ref().is_some_and(|g| !g.is_ready())
    }

    /// Learn from a shadow ray from `p` (normal `n` on the shaded side) to light `index`: whether it
    /// got through.
    pub fn record_visibility(&self, p: Vec3, n: Vec3, index: u32, unoccluded: bool) {
        // Infinite lights are selected beside the tree, so the grid has nothing to learn about them.
        if self.is_infinite(index) {
            return;
        }
        if let (Some(tree), Some(grid)) = (&self.tree, &self.visibility) {
            grid.record(p, n, tree.cluster(index, visibility::CLUSTER_DEPTH), unoccluded);
        }
    }

    /// End learning: later selections use the learned distributions.
    pub fn finish_learning(&mut self) {
        if let (Some(tree), Some(grid)) = (&self.tree, &mut self.visibility) {
            grid.finish_learning(tree);
        }
    }
}

/// A punctual light as an emitter, a sun sized to the scene's bounds `min`, `max`.
fn punctual_light(desc: &PunctualLightDesc, min: Vec3, max: Vec3) -> Light {
    let shape = match desc.kind {
        PunctualKind::Point => LightShape::Point { position: desc.position, spot: None },
        PunctualKind::Spot { inner_cone, outer_cone } => LightShape::Point {
            position: desc.position,
            spot: Some(punctual::SpotCone {
                axis: desc.direction.normalize(),
                cos_inner: inner_cone.cos(),
                cos_outer: outer_cone.cos(),
            }),
        },
        PunctualKind::Sun => {
            let (center, radius) = if min.cmple(max).all() {
                (0.5 * (min + max), (0.5 * (max - min).length()).max(f32::MIN_POSITIVE))
            } else {
                (Vec3::ZERO, 1.0)
            };
            LightShape::Sun { direction: desc.direction.normalize(), center, radius }
        }
    };
    Light::new(shape, desc.radiometric(), Vec3::ZERO, u32::MAX)
}

/// The mean of an emissive texture over a triangle with vertex coordinates `uv`, from a stratified
/// 8 × 8 set of points (what selection by power needs: a good guess, not an exact integral).
fn mean_texel(t: &TextureRef, textures: &[Texture], uv: [Vec2; 3]) -> Vec3 {
    const N: u32 = 8;
    let mut sum = Vec3::ZERO;
    for i in 0..N * N {
        let u = Vec2::new(((i % N) as f32 + 0.5) / N as f32, ((i / N) as f32 + 0.5) / N as f32);
        let b = crate::sampling::warp::uniform_triangle(u);
        sum += t.lookup(textures, (1.0 - b.x - b.y) * uv[0] + b.x * uv[1] + b.y * uv[2]).truncate();
    }
    sum / (N * N) as f32
}
