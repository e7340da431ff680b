//! The recursive MIS of vertex connection and merging (Georgiev, Křivánek, Davidovič & Slusallek
//! 2012, and Georgiev's implementation notes, "Implementing Vertex Connection and Merging"): each
//! subpath carries three running sums, so that the power-heuristic weight of any strategy that
//! ends on it costs O(1) however long the path is, instead of pbrt-v4's walk over every vertex.
//!
//! Names as in the notes: `dvcm`, `dvc`, `dvm` are d^VCM, d^VC and d^VM of the subpath's last
//! vertex; every density passes through [`mis`] (the power heuristic's square) where the notes
//! write Mis(·). Russian roulette stays out of the densities (as in pbrt-v4): each weight is a
//! function of the path alone, computed the same way from either end, so the weights of a path
//! still sum to one.

/// The heuristic's transform of a density (ratio): the power heuristic with exponent 2.
#[inline(always)]
pub fn mis(x: f32) -> f32 {
    x * x
}

/// What the weights of a unit share: how many light subpaths it traces and how merging weighs
/// against connection (zero without merging: bdpt).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MisFactors {
    /// Light subpaths in the unit (one per pixel): the light-tracing strategy uses all of them.
    pub light_paths: f32,
    /// Mis(η_VCM): merging's weight against a connection (0 without merging).
    pub vm: f32,
    /// Mis(1/η_VCM): a connection's weight against merging (0 without merging).
    pub vc: f32,
    /// The merging radius (0 without merging).
    pub radius: f32,
}

impl MisFactors {
    /// Bidirectional path tracing: connections only.
    pub fn connections_only(light_paths: u32) -> Self {
        Self { light_paths: light_paths as f32, vm: 0.0, vc: 0.0, radius: 0.0 }
    }

    /// Vertex connection and merging at `radius`: η_VCM = π r² N, the ratio of merging's density
    /// to a connection's for the same path (Georgiev et al. 2012, eq. 13).
    pub fn merging(light_paths: u32, radius: f32) -> Self {
        let eta = std::f32::consts::PI * radius * radius * light_paths as f32;
        Self { light_paths: light_paths as f32, vm: mis(eta), vc: mis(1.0 / eta), radius }
    }

    /// Whether light vertices are merged.
    #[inline]
    pub fn merges(&self) -> bool {
        self.radius > 0.0
    }

    /// What a merged light vertex's flux becomes at the camera vertex: 1 / (π r² N), the kernel's
    /// density over the unit's subpaths.
    #[inline]
    pub fn merge_normalization(&self) -> f32 {
        1.0 / (std::f32::consts::PI * self.radius * self.radius * self.light_paths)
    }
}

/// The running sums of a subpath at its last vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SubpathMis {
    /// d^VCM.
    pub dvcm: f32,
    /// d^VC.
    pub dvc: f32,
    /// d^VM.
    pub dvm: f32,
}

impl SubpathMis {
    /// A camera subpath leaving the camera in a direction of density `camera_pdf_w` (per unit solid
    /// angle, the film sampled at one sample per pixel).
    #[inline]
    pub fn camera(factors: &MisFactors, camera_pdf_w: f32) -> Self {
        Self { dvcm: mis(factors.light_paths / camera_pdf_w), dvc: 0.0, dvm: 0.0 }
    }

    /// A light subpath at its first hit, before [`SubpathMis::arrive`]: `direct_pdf` is the density
    /// with which light sampling from the hit picks its origin (per unit area for a finite light,
    /// solid angle for the sky, the selection alone for a delta light), `emission_pdf` the density
    /// with which emission started it, `cos_light` the cosine at its origin (1 for an infinite
    /// light).
    #[inline]
    pub fn light(
        factors: &MisFactors,
        direct_pdf: f32,
        emission_pdf: f32,
        cos_light: f32,
        delta: bool,
    ) -> Self {
        let dvc = if delta { 0.0 } else { mis(cos_light / emission_pdf) };
        Self { dvcm: mis(direct_pdf / emission_pdf), dvc, dvm: dvc * factors.vc }
    }

    /// The subpath arrives at a vertex over a segment of squared length `dist2` (`None`: from an
    /// infinite light, which has no distance), meeting it at cosine `cos` (|ω·n|, shading normal).
    #[inline]
    pub fn arrive(&mut self, dist2: Option<f32>, cos: f32) {
        if let Some(dist2) = dist2 {
            self.dvcm *= mis(dist2);
        }
        let c = 1.0 / mis(cos);
        self.dvcm *= c;
        self.dvc *= c;
        self.dvm *= c;
    }

    /// The subpath scatters: leaving at cosine `cos_out` with density `pdf` (per solid angle), the
    /// reverse direction having density `pdf_rev`; a delta lobe contributes its cosine alone.
    #[inline]
    pub fn scatter(&mut self, factors: &MisFactors, cos_out: f32, pdf: f32, pdf_rev: f32, specular: bool) {
        if specular {
            self.dvcm = 0.0;
            self.dvc *= mis(cos_out);
            self.dvm *= mis(cos_out);
            return;
        }
        let g = mis(cos_out / pdf);
        let rev = mis(pdf_rev);
        self.dvc = g * (self.dvc * rev + self.dvcm + factors.vm);
        self.dvm = g * (self.dvm * rev + self.dvcm * factors.vc + 1.0);
        self.dvcm = mis(1.0 / pdf);
    }

    /// The camera subpath's side of the weight of the light it hit (s = 0): light sampling at the
    /// previous vertex picks the point with density `direct_pdf` (per unit area, per solid angle
    /// for the sky), emission starts a subpath there along the path with `emission_pdf`.
    #[inline]
    pub fn hitting_light(&self, direct_pdf: f32, emission_pdf: f32) -> f32 {
        mis(direct_pdf) * self.dvcm + mis(emission_pdf) * self.dvc
    }

    /// The subpath's side of a connection's weight: the density with which the other side would
    /// have made this subpath's last vertex (`pdf_a`, per unit area) times what the strategies that
    /// lengthen the other side add, `pdf_rev` being this vertex's density of scattering back along
    /// the subpath.
    #[inline]
    pub fn towards(&self, factors: &MisFactors, pdf_a: f32, pdf_rev: f32) -> f32 {
        mis(pdf_a) * (factors.vm + self.dvcm + self.dvc * mis(pdf_rev))
    }
}

/// Whether `x` is a positive number (NaN is not): what a density or a contribution must be to count.
#[inline(always)]
pub fn positive(x: f32) -> bool {
    x > 0.0
}

/// The weight of merging camera vertex sums `camera` with light vertex sums `light` at one point:
/// `pdf` is the camera BSDF's density of the light vertex's incoming direction, `pdf_rev` that of
/// the camera's outgoing direction from it (SmallVCM's `RangeQuery`).
#[inline]
pub fn merging_weight(
    factors: &MisFactors,
    camera: &SubpathMis,
    light: &SubpathMis,
    pdf: f32,
    pdf_rev: f32,
) -> f32 {
    let w_light = light.dvcm * factors.vc + light.dvm * mis(pdf);
    let w_camera = camera.dvcm * factors.vc + camera.dvm * mis(pdf_rev);
    weight(w_light, w_camera)
}

/// The balance of the two sides' sums into the weight of the strategy itself.
#[inline]
pub fn weight(light_side: f32, camera_side: f32) -> f32 {
    let w = 1.0 / (light_side + 1.0 + camera_side);
    if w.is_finite() { w } else { 0.0 }
}

/// A density per unit solid angle at a vertex, as a density per unit area at a point `dist` away
/// met at cosine `cos` there.
#[inline]
pub fn to_area(pdf_w: f32, dist2: f32, cos: f32) -> f32 {
    pdf_w * cos / dist2
}
