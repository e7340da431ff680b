//! Punctual lights in lanes (`lights::punctual::{sample_point, sample_sun}`): a point, a spot or a
//! sun chosen by each lane, its radiance towards the lane's shading point and the end of the shadow
//! ray, in the scalar code's order of operations. Each lane's light may be any of the three; a lane
//! computes all and keeps its own.

use super::ggx::clamp;
use super::v3::{Mask, MaskBits, V3, select};
use super::{Lanes, WIDTH};
use crate::lights::punctual::MIN_FALLOFF_WIDTH;
use crate::lights::{Light, LightShape};

/// What a lane's punctual light gives: the light point (for a sun, beyond the scene), the radiance
/// (intensity × falloff / r² or irradiance) and which lanes have a sample (`sample_point` returns
/// `None` at the light's own position and outside a spot's cone).
pub struct PunctualLanes {
    /// The point the shadow ray ends at.
    pub p: V3,
    /// The radiance it brings.
    pub le: V3,
    /// Lanes with a sample.
    pub drawn: Mask,
}

/// Whether `light` is one these lanes take.
#[inline(always)]
pub fn is_punctual(light: &Light) -> bool {
    matches!(light.shape, LightShape::Point { .. } | LightShape::Sun { .. })
}

/// The samples of `lights` (each lane's, punctual, unused lanes repeating one) from the shading
/// points `p_ref`.
#[inline(always)]
pub fn sample_punctual(lights: &[&Light; WIDTH], p_ref: V3) -> PunctualLanes {
    let zero = Lanes::ZERO;
    let one = Lanes::ONE;
    // Each lane's light: a point's position, a spot's cone (no cone: a falloff of one), a sun's
    // direction and the scene's sphere.
    let (mut position, mut direction, mut center) =
        ([glam::Vec3::ZERO; WIDTH], [glam::Vec3::Z; WIDTH], [glam::Vec3::ZERO; WIDTH]);
    let (mut radius, mut cos_inner, mut cos_outer) = ([0.0; WIDTH], [0.0; WIDTH], [0.0; WIDTH]);
    let (mut sun, mut spot) = (0u32, 0u32);
    for (i, light) in lights.iter().enumerate() {
        match light.shape {
            LightShape::Point { position: at, spot: cone } => {
                position[i] = at;
                if let Some(cone) = cone {
                    (direction[i], cos_inner[i], cos_outer[i]) = (cone.axis, cone.cos_inner, cone.cos_outer);
                    spot |= 1 << i;
                }
            }
            LightShape::Sun { direction: d, center: c, radius: r } => {
                (direction[i], center[i], radius[i]) = (d, c, r);
                sun |= 1 << i;
            }
            _ => {}
        }
    }
    let (sun, spot) = (Mask::from_fn(|i| sun >> i & 1 == 1), Mask::from_fn(|i| spot >> i & 1 == 1));
    let intensity = V3::gather(|i| lights[i].le);
    let position = V3::gather(|i| position[i]);
    let direction = V3::gather(|i| direction[i]);

    // `sample_point`.
    let to_ref = p_ref - position;
    let dist2 = to_ref.dot(to_ref);
    let n = to_ref.scale_div(dist2.sqrt());
    let (cos_inner, cos_outer) = (Lanes::new(cos_inner), Lanes::new(cos_outer));
    let scale = one / (cos_inner - cos_outer).max(Lanes::splat(MIN_FALLOFF_WIDTH));
    let t = clamp((direction.dot(n) - cos_outer) * scale, zero, one);
    let falloff = select(spot, t * t, one);
    let point_drawn = !dist2.simd_le(zero) & !dist2.is_nan() & !falloff.simd_le(zero);
    let point_le = intensity.scale(falloff / dist2);

    // `sample_sun`.
    let to_center = p_ref - V3::gather(|i| center[i]);
    let beyond = Lanes::splat(2.0) * Lanes::new(radius) + to_center.dot(to_center).sqrt();
    let sun_p = p_ref - direction.scale(beyond);

    PunctualLanes {
        p: V3::select(sun, sun_p, position),
        le: V3::select(sun, intensity, point_le),
        drawn: sun | point_drawn,
    }
}
