//! Camera vertices in lanes: `pt`'s and `pt-naive`'s work at a vertex for 8 paths at once (16 on
//! AVX-512), one lane each, grouped by class so that lanes agree.
//!
//! A vertex's class ([`LaneClass`]) is decided once per hit from its material's id
//! ([`classify`], a table made once per scene, [`LaneMaterials`]); scatter queues the rows of each
//! class and hands each queue to its class's lanes, which read the path's columns
//! ([`CameraColumns`]) and write back what the vertex changed. What no class holds goes through the
//! scalar kernel ([`super::path_vertex`]), which stays the reference: every lane runs the
//! floating-point operations of the scalar kernel in the same order, so a lane reports the scalar
//! kernel's bits and an image does not change with the paths its lanes hold (`tests.rs` holds every
//! field to it).
//!
//! | file | what |
//! |---|---|
//! | `classes.rs` | the classes and the per-material table |
//! | `columns.rs` | how lanes reach the paths' columns |
//! | `surface.rs` | the hit point, frames, offset origins |
//! | `light.rs` | next-event estimation |
//! | `tree.rs` | light selection: the light tree's descent in lanes |
//! | `triangle_light.rs` | a point on a triangle light, by solid angle or by area |
//! | `punctual.rs` | points, spots and suns |
//! | `shade.rs` | a class's vertices: materials resolved, then the vertex in lanes |
//! | `bsdf.rs` | the BSDFs of the classes: Lambert's, the metallic-roughness mixture |
//! | `coat.rs` | a clear coat over either |
//! | `ggx.rs` | GGX, Schlick's Fresnel and the warps in lanes |
//! | `v3.rs` | three-vectors of lanes in glam's order of operations |

mod bsdf;
mod classes;
mod coat;
mod columns;
mod environment_light;
mod ggx;
mod light;
mod punctual;
mod shade;
mod sphere_light;
mod surface;
mod tree;
mod triangle_light;
mod v3;

pub use classes::{CLASSES, LaneClass, LaneMaterials, classify, plain_lambert};
pub use columns::CameraColumns;
pub use shade::shade_class;

use super::dimensions::VertexSampler;
use crate::geometry::bvh::PlainTriangle;
use v3::{V3, select};

/// Sixteen lanes, one AVX-512 register, where the machine has them.
#[cfg(target_feature = "avx512f")]
pub type Lanes = wide::f32x16;
/// Eight lanes, one AVX register (without AVX, `wide` runs it as two SSE halves).
#[cfg(not(target_feature = "avx512f"))]
pub type Lanes = wide::f32x8;
/// The lanes' bits.
#[cfg(target_feature = "avx512f")]
type Bits = wide::u32x16;
#[cfg(not(target_feature = "avx512f"))]
type Bits = wide::u32x8;

/// Paths a group of lanes holds.
pub const WIDTH: usize = size_of::<Lanes>() / size_of::<f32>();

/// What a group's lanes read of their rows before their material: the triangle, where the ray met
/// it, the path's throughput and roulette state, its random numbers. Loaded from the columns once a
/// group; unused lanes repeat the first row.
pub struct Group {
    /// The light each lane's triangle is (`NO_LIGHT` for none): a light does not light itself.
    pub own_light: [u32; WIDTH],
    /// Distance along the ray.
    pub t: [f32; WIDTH],
    /// Barycentric weight of the triangle's vertex 1.
    pub b1: Lanes,
    /// Barycentric weight of its vertex 2.
    pub b2: Lanes,
    /// The ray's direction.
    pub d: V3,
    /// The ray's shutter time.
    pub time: Lanes,
    /// The path's throughput.
    pub beta: V3,
    /// Its η-scale.
    pub eta_scale: Lanes,
    /// The vertex's random numbers.
    pub u: [VertexSampler; WIDTH],
}

/// Load the group of `rows` (at most [`WIDTH`], at least one) from the columns, their triangles
/// `triangles` (unused lanes repeating the first).
#[inline(always)]
pub(crate) fn gather_group(
    rows: &[u32],
    triangles: &[PlainTriangle; WIDTH],
    columns: &mut impl CameraColumns,
) -> Group {
    let count = rows.len();
    debug_assert!((1..=WIDTH).contains(&count));
    let (mut t, mut b1, mut b2, mut time, mut eta) =
        ([0.0; WIDTH], [0.0; WIDTH], [0.0; WIDTH], [0.0; WIDTH], [0.0; WIDTH]);
    let mut d = [glam::Vec3::ZERO; WIDTH];
    let mut beta = [glam::Vec3::ZERO; WIDTH];
    let mut u = [VertexSampler::EMPTY; WIDTH];
    for i in 0..WIDTH {
        let row = rows[if i < count { i } else { 0 }];
        let hit = *columns.hit(row);
        let ray = *columns.ray(row);
        let path = columns.path(row);
        (beta[i], eta[i]) = (path.beta, path.eta_scale);
        let depth = path.depth;
        (t[i], b1[i], b2[i], time[i], d[i]) = (hit.t, hit.b1, hit.b2, ray.time, ray.d);
        u[i] = VertexSampler::new(columns.sampler(row), depth);
    }
    Group {
        own_light: std::array::from_fn(|i| triangles[i].light),
        t,
        b1: Lanes::new(b1),
        b2: Lanes::new(b2),
        d: V3::gather(|i| d[i]),
        time: Lanes::new(time),
        beta: V3::gather(|i| beta[i]),
        eta_scale: Lanes::new(eta),
        u,
    }
}

/// `mis::power_heuristic` in lanes.
#[inline(always)]
fn power_heuristic(pdf_a: Lanes, pdf_b: Lanes) -> Lanes {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let ratio = select((a + b).simd_eq(Lanes::ZERO), Lanes::ZERO, a / (a + b));
    select(a.is_inf(), Lanes::ONE, ratio)
}

/// `warp::sin_cos_quarter` in lanes.
#[inline(always)]
fn sin_cos_quarter(x: Lanes) -> (Lanes, Lanes) {
    let s = Lanes::splat;
    let z = x * x;
    let sin = x + x * z * (s(-1.666_665_5e-1) + z * (s(8.332_161e-3) + z * s(-1.951_529_6e-4)));
    let cos = Lanes::ONE - s(0.5) * z
        + z * z * (s(4.166_664_6e-2) + z * (s(-1.388_731_6e-3) + z * s(2.443_315_7e-5)));
    (sin, cos)
}

#[cfg(test)]
mod tests;
