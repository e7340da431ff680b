//! Three-vectors of lanes, with glam's `Vec3` operations in glam's order of operations (a lane of
//! `a.dot(b)` is the bits of the scalar `dot`), and the masks that select between them.

use super::{Lanes, WIDTH};
use glam::Vec3;
use std::ops::{Add, Mul, Neg, Sub};

/// A mask of lanes: all bits set where true (what `wide`'s comparisons return).
pub type Mask = Lanes;

/// Building and reading masks.
pub trait MaskBits {
    /// The mask whose lane `i` is `f(i)`.
    fn from_fn(f: impl Fn(usize) -> bool) -> Self;
    /// Bit `i` set where lane `i` is true.
    fn bits(self) -> u32;
}

impl MaskBits for Mask {
    #[inline(always)]
    fn from_fn(f: impl Fn(usize) -> bool) -> Self {
        Lanes::from_bits(wide_bits(std::array::from_fn(|i| if f(i) { u32::MAX } else { 0 })))
    }

    #[inline(always)]
    fn bits(self) -> u32 {
        self.to_bitmask()
    }
}

#[cfg(target_feature = "avx512f")]
fn wide_bits(bits: [u32; WIDTH]) -> wide::u32x16 {
    wide::u32x16::new(bits)
}

#[cfg(not(target_feature = "avx512f"))]
fn wide_bits(bits: [u32; WIDTH]) -> wide::u32x8 {
    wide::u32x8::new(bits)
}

/// `if_true` where `mask` holds, else `if_false`.
#[inline(always)]
pub fn select(mask: Mask, if_true: Lanes, if_false: Lanes) -> Lanes {
    mask.select(if_true, if_false)
}

/// glam's `Vec3::max_element` in lanes: `max(x, max(y, z))` with `if a > b { a } else { b }`, which
/// a NaN resolves to the second operand.
#[inline(always)]
pub fn max_element(v: V3) -> Lanes {
    let max = |a: Lanes, b: Lanes| select(a.simd_gt(b), a, b);
    max(v.x, max(v.y, v.z))
}

/// A `Vec3` per lane.
#[derive(Clone, Copy, Debug)]
pub struct V3 {
    pub x: Lanes,
    pub y: Lanes,
    pub z: Lanes,
}

impl V3 {
    /// Lane `i` holds `f(i)`.
    #[inline(always)]
    pub fn gather(f: impl Fn(usize) -> Vec3) -> Self {
        let v: [Vec3; WIDTH] = std::array::from_fn(f);
        Self {
            x: Lanes::new(std::array::from_fn(|i| v[i].x)),
            y: Lanes::new(std::array::from_fn(|i| v[i].y)),
            z: Lanes::new(std::array::from_fn(|i| v[i].z)),
        }
    }

    /// Every lane holds (`c`, `c`, `c`).
    #[inline(always)]
    pub fn splat(c: f32) -> Self {
        Self { x: Lanes::splat(c), y: Lanes::splat(c), z: Lanes::splat(c) }
    }

    /// The lanes' vectors.
    #[inline(always)]
    pub fn lanes(self) -> [Vec3; WIDTH] {
        let (x, y, z) = (self.x.to_array(), self.y.to_array(), self.z.to_array());
        std::array::from_fn(|i| Vec3::new(x[i], y[i], z[i]))
    }

    /// `if_true` where `mask` holds, else `if_false`.
    #[inline(always)]
    pub fn select(mask: Mask, if_true: Self, if_false: Self) -> Self {
        Self {
            x: select(mask, if_true.x, if_false.x),
            y: select(mask, if_true.y, if_false.y),
            z: select(mask, if_true.z, if_false.z),
        }
    }

    /// `Vec3 * f32`.
    #[inline(always)]
    pub fn scale(self, s: Lanes) -> Self {
        Self { x: self.x * s, y: self.y * s, z: self.z * s }
    }

    /// `Vec3 / f32`.
    #[inline(always)]
    pub fn scale_div(self, s: Lanes) -> Self {
        Self { x: self.x / s, y: self.y / s, z: self.z / s }
    }

    /// `Vec3::dot`: `(x·x') + (y·y') + (z·z')`.
    #[inline(always)]
    pub fn dot(self, rhs: Self) -> Lanes {
        self.x * rhs.x + self.y * rhs.y + self.z * rhs.z
    }

    /// `Vec3::cross`.
    #[inline(always)]
    pub fn cross(self, rhs: Self) -> Self {
        Self {
            x: self.y * rhs.z - rhs.y * self.z,
            y: self.z * rhs.x - rhs.z * self.x,
            z: self.x * rhs.y - rhs.x * self.y,
        }
    }

    /// `Vec3::abs`.
    #[inline(always)]
    pub fn abs(self) -> Self {
        Self { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// `Vec3::normalize`: times `1 / length`.
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self.scale(Lanes::ONE / self.dot(self).sqrt())
    }

    /// `Vec3::normalize_or_zero`: times `1 / length` where that is finite and positive, else zero.
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Self {
        let rcp = Lanes::ONE / self.dot(self).sqrt();
        let ok = rcp.is_finite() & rcp.simd_gt(Lanes::ZERO);
        Self::select(ok, self.scale(rcp), Self::splat(0.0))
    }

    /// Where every component is zero (`== Vec3::ZERO`, so −0 too).
    #[inline(always)]
    pub fn is_zero(self) -> Mask {
        self.x.simd_eq(Lanes::ZERO) & self.y.simd_eq(Lanes::ZERO) & self.z.simd_eq(Lanes::ZERO)
    }

    /// `Vec3::is_finite`.
    #[inline(always)]
    pub fn is_finite(self) -> Mask {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }
}

impl Add for V3 {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        Self { x: self.x + rhs.x, y: self.y + rhs.y, z: self.z + rhs.z }
    }
}

impl Sub for V3 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: Self) -> Self {
        Self { x: self.x - rhs.x, y: self.y - rhs.y, z: self.z - rhs.z }
    }
}

impl Mul for V3 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        Self { x: self.x * rhs.x, y: self.y * rhs.y, z: self.z * rhs.z }
    }
}

impl Neg for V3 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self { x: -self.x, y: -self.y, z: -self.z }
    }
}
