//! A stored photon in 32 bytes: position and power as floats, directions octahedral-encoded.
//!
//! Power stays in f32: a map of 10⁷ photons from a dim light carries ~1e-8 each, below the range of
//! shared-exponent formats such as RGB9E5. The unit vectors take 16 bits per coordinate in the
//! octahedral map (Cigolle et al. 2014), under 1e-4 rad of error; the normal gives up one bit per
//! coordinate to hold the kd-tree's split axis.

use glam::{Vec2, Vec3};

/// A photon at rest on a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    p: [f32; 3],
    power: [f32; 3],
    /// Incident direction (towards where the photon came from), 2 × 16 bits.
    direction: u32,
    /// Surface normal on the side the photon arrived from, 2 × 15 bits; the top 2 bits are the split axis.
    normal_axis: u32,
}

const _: () = assert!(size_of::<Photon>() <= 32);

impl Photon {
    /// A photon at `p` that arrived from direction `wi` (unit, pointing away from the surface) on the
    /// side with normal `n`, carrying `power`.
    pub fn new(p: Vec3, wi: Vec3, n: Vec3, power: Vec3) -> Self {
        Self {
            p: p.to_array(),
            power: power.to_array(),
            direction: encode_octahedral(wi, 16),
            normal_axis: encode_octahedral(n, 15),
        }
    }

    /// Position.
    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.p)
    }

    /// Incident direction, unit, pointing away from the surface.
    #[inline]
    pub fn direction(&self) -> Vec3 {
        decode_octahedral(self.direction, 16)
    }

    /// Normal of the side the photon arrived on.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        decode_octahedral(self.normal_axis & 0x3fff_ffff, 15)
    }

    /// Power (flux) per channel.
    #[inline]
    pub fn power(&self) -> Vec3 {
        Vec3::from_array(self.power)
    }

    /// Coordinate `axis` (0, 1, 2) of the position.
    #[inline]
    pub(crate) fn coordinate(&self, axis: usize) -> f32 {
        self.p[axis]
    }

    /// The kd-tree split axis of the node this photon is.
    #[inline]
    pub(crate) fn axis(&self) -> usize {
        (self.normal_axis >> 30) as usize
    }

    pub(crate) fn set_axis(&mut self, axis: usize) {
        self.normal_axis = (self.normal_axis & 0x3fff_ffff) | ((axis as u32) << 30);
    }
}

/// A unit vector in the octahedral map (Cigolle et al. 2014), `bits` per coordinate.
pub fn encode_octahedral(v: Vec3, bits: u32) -> u32 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    let v = if l1 > 0.0 && l1.is_finite() { v / l1 } else { Vec3::Z };
    let e = if v.z >= 0.0 {
        Vec2::new(v.x, v.y)
    } else {
        Vec2::new((1.0 - v.y.abs()) * sign(v.x), (1.0 - v.x.abs()) * sign(v.y))
    };
    let max = ((1u32 << bits) - 1) as f32;
    let q = |c: f32| ((c.clamp(-1.0, 1.0) * 0.5 + 0.5) * max).round() as u32;
    q(e.x) | (q(e.y) << bits)
}

/// The unit vector of an octahedral code made by [`encode_octahedral`].
pub fn decode_octahedral(code: u32, bits: u32) -> Vec3 {
    let mask = (1u32 << bits) - 1;
    let max = mask as f32;
    let f = |q: u32| (q & mask) as f32 / max * 2.0 - 1.0;
    let (x, y) = (f(code), f(code >> bits));
    let z = 1.0 - x.abs() - y.abs();
    let v = if z >= 0.0 {
        Vec3::new(x, y, z)
    } else {
        Vec3::new((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y), z)
    };
    v.normalize()
}

#[inline]
fn sign(x: f32) -> f32 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::sampling::warp::uniform_sphere;

    #[test]
    fn directions_and_normals_survive_encoding() {
        let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let random = (0..20_000).map(|i| uniform_sphere(Sampler::new(3, i, 0).get2d(0)));
        for v in axes.into_iter().chain(random) {
            let mut photon = Photon::new(Vec3::ONE, v, v, Vec3::new(1e-9, 2.0, 3e5));
            photon.set_axis(2);
            // The chord length equals the angle to first order; acos near 1 is too coarse in f32.
            assert!((photon.direction() - v).length() < 1e-4, "{v} -> {}", photon.direction());
            assert!((photon.normal() - v).length() < 2e-4, "{v} -> {}", photon.normal());
            assert_eq!(photon.axis(), 2);
            assert_eq!(photon.power(), Vec3::new(1e-9, 2.0, 3e5));
        }
    }
}
