//! Compact nodes for trees larger than the cache: a node's eight child boxes as bytes on a grid of
//! the node's own box (Ylitie et al. 2017's quantisation, CWBVH; Embree's compressed nodes), two
//! cache lines where a full node takes four. A large tree's traversal waits on memory, so half the
//! lines a node pay for the dozen lane operations that decode them; a small tree's does not, and
//! keeps the full nodes.
//!
//! A child's decoded box always holds its true box: the bytes are chosen by the decoding's own
//! floating-point operations (origin + q · 2^e, the product exact), the lower bound rounded down
//! and the upper up, so a ray that enters the true box enters the decoded one.

use super::{BoxRay, Lanes, Node, WIDTH};
use wide::i32x8;

/// Eight child boxes as bytes over the node's grid, their child codes and visit orders.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct CompactNode {
    /// The grid's origin: the node's box's minimum.
    origin: [f32; 3],
    /// The grid's step per axis, 2^exponent.
    exponent: [i8; 3],
    /// Bit `i`: child `i` is present (an absent one is never entered).
    used: u8,
    /// `q[a][i]` and `q[3 + a][i]`: child `i`'s lower and upper bound on axis `a`, in steps.
    q: [[u8; WIDTH]; 6],
    pub(super) children: [u32; WIDTH],
    pub(super) order: [u32; 8],
}

/// The grid's step 2^e as a float (e within the normal exponents).
#[inline(always)]
fn step(exponent: i8) -> f32 {
    f32::from_bits(((exponent as i32 + 127) as u32) << 23)
}

/// Eight bytes as eight integer lanes: one load and one widening where the machine has AVX2 (a
/// lane at a time otherwise, which costs the decoding most of what the smaller node saves).
#[inline(always)]
fn widen(q: &[u8; WIDTH]) -> i32x8 {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        let bytes = safe_arch::set_i64_m128i_s(i64::from_le_bytes(*q));
        i32x8::new(<[i32; 8]>::from(safe_arch::convert_to_i16_m256i_from_lower8_u8_m128i(bytes)))
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        i32x8::new(q.map(|q| q as i32))
    }
}

/// A bound's value at `q` steps: the decoding, the same operations in lanes and in the build.
#[inline(always)]
fn decode(origin: f32, q: u8, step: f32) -> f32 {
    origin + q as f32 * step
}

impl CompactNode {
    /// `node` on a grid, or `None` where its box is not finite (the full node stays).
    pub(super) fn new(node: &Node) -> Option<Self> {
        let used = (0..WIDTH).filter(|&i| node.children[i] != u32::MAX).fold(0u8, |b, i| b | 1 << i);
        let (min, max) = node.bounds();
        if used == 0 || !min.iter().chain(&max).all(|v| v.is_finite()) {
            return None;
        }
        let mut compact = Self {
            origin: min,
            exponent: [0; 3],
            used,
            q: [[0; WIDTH]; 6],
            children: node.children,
            order: node.order,
        };
        for a in 0..3 {
            let lows = node.bounds[a].to_array();
            let highs = node.bounds[3 + a].to_array();
            let extent = max[a] - min[a];
            // The smallest step whose 255 steps span the box; one larger where rounding needs it.
            let mut exponent = if extent > 0.0 { (extent / 255.0).log2().ceil() as i32 } else { -126 };
            loop {
                let e = exponent.clamp(-126, 127) as i8;
                let s = step(e);
                let mut fits = true;
                for i in 0..WIDTH {
                    if used >> i & 1 == 0 {
                        // No ray enters a box whose lower bound lies above its upper one.
                        (compact.q[a][i], compact.q[3 + a][i]) = (255, 0);
                        continue;
                    }
                    let mut lo = ((lows[i] - min[a]) / s).floor().clamp(0.0, 255.0) as u8;
                    while lo > 0 && decode(min[a], lo, s) > lows[i] {
                        lo -= 1;
                    }
                    let mut hi = ((highs[i] - min[a]) / s).ceil().clamp(0.0, 255.0) as u8;
                    while hi < 255 && decode(min[a], hi, s) < highs[i] {
                        hi += 1;
                    }
                    fits &= decode(min[a], lo, s) <= lows[i] && decode(min[a], hi, s) >= highs[i];
                    (compact.q[a][i], compact.q[3 + a][i]) = (lo, hi);
                }
                if fits {
                    compact.exponent[a] = e;
                    break;
                }
                if exponent >= 127 {
                    return None;
                }
                exponent += 1;
            }
        }
        Some(compact)
    }

    /// The decoded child boxes, as a full node's lanes (`bounds[a]` minimum, `bounds[3 + a]` maximum).
    #[inline(always)]
    pub(super) fn bounds(&self) -> [Lanes; 6] {
        std::array::from_fn(|k| {
            let a = k % 3;
            Lanes::splat(self.origin[a])
                + Lanes::from_i32x8(widen(&self.q[k])) * Lanes::splat(step(self.exponent[a]))
        })
    }

    /// Which children the ray enters before `t_max` (a bit each), and where: the full node's test
    /// on the decoded boxes, absent children masked.
    #[inline(always)]
    pub(super) fn intersect(&self, ray: &BoxRay, t_max: f32) -> (u32, Lanes) {
        let (mask, near) = super::slab_test(&self.bounds(), ray, t_max);
        (mask & self.used as u32, near)
    }

    /// Ask for the node's two cache lines.
    #[inline(always)]
    pub(super) fn prefetch(&self) {
        super::prefetch_line(&self.origin);
        super::prefetch_line(&self.children);
    }

    /// The full node of the decoded boxes (absent children empty).
    pub(super) fn full(&self) -> Node {
        let mut node = Node::EMPTY;
        let bounds = self.bounds();
        for k in 0..6 {
            for i in (0..WIDTH).filter(|&i| self.used >> i & 1 == 1) {
                node.bounds[k].as_mut_array()[i] = bounds[k].to_array()[i];
            }
        }
        node.children = self.children;
        node.order = self.order;
        node
    }

    /// The decoded box of child `lane`, as min and max.
    pub(super) fn child_box(&self, lane: usize) -> ([f32; 3], [f32; 3]) {
        let b = self.bounds();
        (std::array::from_fn(|a| b[a].to_array()[lane]), std::array::from_fn(|a| b[3 + a].to_array()[lane]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    /// Every decoded child box holds its true box, and is not much larger (a step of the grid on
    /// each side): random boxes over many scales, thin, flat and absent ones among them.
    #[test]
    fn decoded_boxes_hold_the_true_ones_and_little_more() {
        for n in 0..3000u32 {
            let s = Sampler::new(31, n, 0);
            let scale = 10f32.powf(s.get1d(0) * 12.0 - 6.0);
            let offset = (s.get1d(1) - 0.5) * 1e4 * scale.max(1.0);
            let mut node = Node::EMPTY;
            let used = 1 + (n as usize % WIDTH);
            for i in 0..used {
                for a in 0..3 {
                    let d = 2 + 6 * (i as u32 * 3 + a as u32);
                    let lo = offset + s.get1d(d) * scale;
                    // Some boxes flat on an axis.
                    let hi = if (n + i as u32) % 7 == 0 { lo } else { lo + s.get1d(d + 1) * scale * 0.3 };
                    node.bounds[a].as_mut_array()[i] = lo;
                    node.bounds[3 + a].as_mut_array()[i] = hi;
                }
                node.children[i] = i as u32;
            }
            let compact = CompactNode::new(&node).expect("finite boxes compress");
            let extent = {
                let (min, max) = node.bounds();
                (0..3).map(|a| max[a] - min[a]).fold(0.0f32, f32::max)
            };
            for i in 0..WIDTH {
                let present = compact.used >> i & 1 == 1;
                assert_eq!(present, i < used, "node {n}, child {i}");
                if !present {
                    continue;
                }
                let (lo, hi) = compact.child_box(i);
                for a in 0..3 {
                    let (true_lo, true_hi) = (node.bounds[a].as_array()[i], node.bounds[3 + a].as_array()[i]);
                    assert!(lo[a] <= true_lo && hi[a] >= true_hi, "node {n}, child {i}, axis {a}");
                    // Two steps of the grid (each at most 2·extent/255) and an ulp of the origin.
                    let slack = 4.0 * extent / 255.0 + 2.0 * offset.abs() * f32::EPSILON + f32::MIN_POSITIVE;
                    assert!(true_lo - lo[a] <= slack && hi[a] - true_hi <= slack, "node {n}: loose box");
                }
            }
        }
    }
}
