//! The integral of a density over one bin: adaptive Simpson quadrature on a quadtree, guided by
//! where the samples fell so that a lobe narrower than the nodes is not missed.

/// An axis-aligned rectangle of the integration domain.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rect {
    pub(super) x0: f64,
    pub(super) x1: f64,
    pub(super) y0: f64,
    pub(super) y1: f64,
}

impl Rect {
    /// Quadrant `q` (0..4: x half = q / 2, y half = q % 2).
    fn quadrant(&self, q: usize) -> Rect {
        let (xm, ym) = (0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1));
        let (x0, x1) = if q / 2 == 0 { (self.x0, xm) } else { (xm, self.x1) };
        let (y0, y1) = if q.is_multiple_of(2) { (self.y0, ym) } else { (ym, self.y1) };
        Rect { x0, x1, y0, y1 }
    }

    /// The quadrant holding point `p` (points outside are clamped to the nearest).
    fn quadrant_of(&self, p: (f64, f64)) -> usize {
        let (xm, ym) = (0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1));
        2 * (p.0 >= xm) as usize + (p.1 >= ym) as usize
    }
}

/// Adaptive tensor Simpson quadrature on a quadtree (Lyness 1969, in 2D), guided by sample points.
pub(super) struct Quadrature<'a> {
    pub(super) f: &'a mut dyn FnMut(f64, f64) -> f64,
    /// Absolute error floor of a whole initial cell.
    pub(super) eps: f64,
    /// Scale from probability to expected count, for the sample guide.
    pub(super) n_samples: f64,
}

impl Quadrature<'_> {
    /// Quadtree levels below an initial cell.
    const MAX_DEPTH: u32 = 6;
    /// Levels within which disagreement with the samples alone forces refinement; deeper, only the
    /// Simpson error does (so a wrong pdf, which disagrees everywhere, costs no more than 4³ per cell).
    const GUIDED_DEPTH: u32 = 3;

    /// ∫∫ f over `rect`: `pieces` × `pieces` equal cells, each refined up to `MAX_DEPTH` quadtree levels.
    /// The initial split makes narrow peaks visible to the first estimates; a quadtree refines only
    /// around features, unlike nested 1D rules that refine whole lines.
    pub(super) fn integrate(&mut self, rect: Rect, points: &mut [(f64, f64)], pieces: u32) -> f64 {
        let (hx, hy) = ((rect.x1 - rect.x0) / pieces as f64, (rect.y1 - rect.y0) / pieces as f64);
        let cell_of = |p: &(f64, f64)| {
            let a = (((p.0 - rect.x0) / hx) as i64).clamp(0, pieces as i64 - 1);
            let b = (((p.1 - rect.y0) / hy) as i64).clamp(0, pieces as i64 - 1);
            (a * pieces as i64 + b) as usize
        };
        points.sort_unstable_by_key(cell_of);
        let eps = self.eps / (pieces * pieces) as f64;
        let mut total = 0.0;
        let mut rest = points;
        for a in 0..pieces {
            for b in 0..pieces {
                let index = (a * pieces + b) as usize;
                let count = rest.iter().take_while(|p| cell_of(p) == index).count();
                let (inside, tail) = rest.split_at_mut(count);
                rest = tail;
                let (x0, y0) = (rect.x0 + a as f64 * hx, rect.y0 + b as f64 * hy);
                let mut v = [[0.0; 3]; 3];
                for (k, row) in v.iter_mut().enumerate() {
                    for (l, value) in row.iter_mut().enumerate() {
                        *value = (self.f)(x0 + 0.5 * hx * k as f64, y0 + 0.5 * hy * l as f64);
                    }
                }
                let cell = Rect { x0, x1: x0 + hx, y0, y1: y0 + hy };
                total += self.refine(cell, &v, inside, eps, 0);
            }
        }
        total
    }

    /// Compare the cell's Simpson estimate with the sum over its four children; recurse where they
    /// disagree or where the cell holds far more samples than estimated, else Richardson-extrapolate.
    fn refine(
        &mut self,
        rect: Rect,
        v: &[[f64; 3]; 3],
        points: &mut [(f64, f64)],
        eps: f64,
        level: u32,
    ) -> f64 {
        let (hx, hy) = (0.25 * (rect.x1 - rect.x0), 0.25 * (rect.y1 - rect.y0));
        // 5 × 5 nodes: the even ones are the parent's.
        let mut g = [[0.0; 5]; 5];
        for (k, row) in g.iter_mut().enumerate() {
            for (l, value) in row.iter_mut().enumerate() {
                *value = if k % 2 == 0 && l % 2 == 0 {
                    v[k / 2][l / 2]
                } else {
                    (self.f)(rect.x0 + hx * k as f64, rect.y0 + hy * l as f64)
                };
            }
        }
        let coarse = simpson_3x3(rect, v);
        let mut values = [[[0.0; 3]; 3]; 4];
        let mut fine = 0.0;
        for (q, child) in values.iter_mut().enumerate() {
            let (a, b) = (2 * (q / 2), 2 * (q % 2));
            for k in 0..3 {
                for l in 0..3 {
                    child[k][l] = g[a + k][b + l];
                }
            }
            fine += simpson_3x3(rect.quadrant(q), child);
        }
        let delta = fine - coarse;
        // Relative accuracy of 1e-4 is far below the Poisson noise of any count the test can draw.
        let converged = delta.abs() <= 15.0 * eps.max(1e-4 * fine.abs());
        // A count more than 3σ from the estimate hints that the nodes missed a feature. Refining only
        // makes the integral more exact, so chasing the samples cannot make a wrong pdf pass.
        let expected = fine * self.n_samples;
        let consistent = (points.len() as f64 - expected).powi(2) <= 9.0 * (expected + 1.0);
        if level == Self::MAX_DEPTH || (converged && (consistent || level >= Self::GUIDED_DEPTH)) {
            return fine + delta / 15.0;
        }
        points.sort_unstable_by_key(|p| rect.quadrant_of(*p));
        let mut rest = points;
        let mut total = 0.0;
        for (q, child) in values.iter().enumerate() {
            let count = rest.iter().take_while(|p| rect.quadrant_of(**p) == q).count();
            let (inside, tail) = rest.split_at_mut(count);
            rest = tail;
            total += self.refine(rect.quadrant(q), child, inside, 0.25 * eps, level + 1);
        }
        total
    }
}

/// Tensor Simpson rule on a cell from its 3 × 3 node values.
fn simpson_3x3(rect: Rect, v: &[[f64; 3]; 3]) -> f64 {
    const W: [f64; 3] = [1.0, 4.0, 1.0];
    let mut sum = 0.0;
    for k in 0..3 {
        for l in 0..3 {
            sum += W[k] * W[l] * v[k][l];
        }
    }
    sum * (rect.x1 - rect.x0) * (rect.y1 - rect.y0) / 36.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn adaptive_simpson_integrates_a_narrow_peak() {
        // A normalised Gaussian of σ = 0.01 off the grid nodes.
        let var = 1e-4;
        let mut f = |x: f64, y: f64| {
            let r2 = (x - 0.3123).powi(2) + (y - 0.6789).powi(2);
            (-r2 / (2.0 * var)).exp() / (2.0 * PI * var)
        };
        let rect = Rect { x0: 0.0, x1: 1.0, y0: 0.0, y1: 1.0 };
        let mut quadrature = Quadrature { f: &mut f, eps: 1e-7, n_samples: 1.0 };
        let total = quadrature.integrate(rect, &mut [], 4);
        assert!((total - 1.0).abs() < 1e-6, "{total}");
    }
}
