//! Density estimators on the line and in the plane/space (Silverman 1986, chapters 2–5).
//!
//! All take the sample once ([`Sample`] keeps it sorted, so nearest-neighbour distances cost
//! O(k + log n)) and evaluate anywhere.

use super::Kernel;

/// A 1-D sample, sorted.
#[derive(Clone, Debug)]
pub struct Sample {
    sorted: Vec<f64>,
}

impl Sample {
    /// The sample `data`; non-finite values are dropped.
    pub fn new(data: &[f64]) -> Self {
        let mut sorted: Vec<f64> = data.iter().copied().filter(|x| x.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        Self { sorted }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.sorted.len()
    }

    /// Whether the sample is empty.
    pub fn is_empty(&self) -> bool {
        self.sorted.is_empty()
    }

    /// The points in increasing order.
    pub fn values(&self) -> &[f64] {
        &self.sorted
    }

    /// Distance from `x` to its `k`-th nearest sample point (k ≥ 1), skipping the point at index
    /// `skip` (for a point's distance to its neighbours). Infinite when there are too few points.
    pub fn kth_distance(&self, x: f64, k: usize, skip: Option<usize>) -> f64 {
        let v = &self.sorted;
        // Merge outwards from the insertion point: the next nearest is on the left or on the right.
        let mut right = v.partition_point(|&p| p < x);
        let mut left = right;
        let mut found = 0;
        loop {
            let dl = if left > 0 { x - v[left - 1] } else { f64::INFINITY };
            let dr = if right < v.len() { v[right] - x } else { f64::INFINITY };
            if dl.is_infinite() && dr.is_infinite() {
                return f64::INFINITY;
            }
            let (d, index) = if dl <= dr {
                left -= 1;
                (dl, left)
            } else {
                right += 1;
                (dr, right - 1)
            };
            if Some(index) == skip {
                continue;
            }
            found += 1;
            if found == k {
                return d;
            }
        }
    }
}

/// The histogram with bins [origin + j·width, origin + (j+1)·width).
#[derive(Clone, Copy, Debug)]
pub struct Histogram {
    /// Left edge of bin 0.
    pub origin: f64,
    /// Bin width.
    pub width: f64,
}

impl Histogram {
    /// The bin of `x`.
    pub fn bin(&self, x: f64) -> i64 {
        ((x - self.origin) / self.width).floor() as i64
    }

    /// (bin, count) for every non-empty bin, in bin order.
    pub fn counts(&self, sample: &Sample) -> Vec<(i64, usize)> {
        let mut counts: Vec<(i64, usize)> = Vec::new();
        for &x in sample.values() {
            let b = self.bin(x);
            match counts.last_mut() {
                Some((last, n)) if *last == b => *n += 1,
                _ => counts.push((b, 1)),
            }
        }
        counts
    }

    /// Density at `x`: count of its bin / (n · width).
    pub fn density(&self, sample: &Sample, x: f64) -> f64 {
        let b = self.bin(x);
        let lo = self.origin + b as f64 * self.width;
        let v = sample.values();
        let count = v.partition_point(|&p| p < lo + self.width) - v.partition_point(|&p| p < lo);
        count as f64 / (sample.len() as f64 * self.width)
    }
}

/// The fixed-bandwidth kernel estimate f(x) = 1/(n h) Σ K((x − Xᵢ)/h).
#[derive(Clone, Copy, Debug)]
pub struct KernelEstimate {
    /// Kernel.
    pub kernel: Kernel,
    /// Bandwidth.
    pub h: f64,
}

impl KernelEstimate {
    /// Density at `x`; only the points within the kernel's support are visited.
    pub fn density(&self, sample: &Sample, x: f64) -> f64 {
        let v = sample.values();
        let reach = self.kernel.support() * self.h;
        let (lo, hi) = if reach.is_finite() {
            (v.partition_point(|&p| p < x - reach), v.partition_point(|&p| p <= x + reach))
        } else {
            (0, v.len())
        };
        let sum: f64 = v[lo..hi].iter().map(|&p| self.kernel.k1((x - p) / self.h)).sum();
        sum / (v.len() as f64 * self.h)
    }

    /// The estimate at `Xᵢ` without `Xᵢ` itself (for cross-validation).
    pub fn leave_one_out(&self, sample: &Sample, i: usize) -> f64 {
        let v = sample.values();
        let x = v[i];
        let n = v.len() as f64;
        let all = self.density(sample, x) * n * self.h;
        (all - self.kernel.k1(0.0)) / ((n - 1.0) * self.h)
    }
}

/// The k-nearest-neighbour estimate f(x) = k / (2 n d_k(x)).
#[derive(Clone, Copy, Debug)]
pub struct KnnEstimate {
    /// Neighbours counted.
    pub k: usize,
}

impl KnnEstimate {
    /// Density at `x`.
    pub fn density(&self, sample: &Sample, x: f64) -> f64 {
        let d = sample.kth_distance(x, self.k.max(1), None);
        if d > 0.0 { self.k as f64 / (2.0 * sample.len() as f64 * d) } else { f64::INFINITY }
    }
}

/// The variable (adaptive) kernel estimate f(x) = 1/n Σ K((x − Xᵢ)/(h dᵢ)) / (h dᵢ), with dᵢ the
/// distance from Xᵢ to its k-th nearest other point: wide kernels where the data are sparse.
#[derive(Clone, Debug)]
pub struct VariableKernel {
    kernel: Kernel,
    h: f64,
    widths: Vec<f64>,
}

impl VariableKernel {
    /// Precompute the point bandwidths h·d_{i,k}.
    pub fn new(sample: &Sample, kernel: Kernel, h: f64, k: usize) -> Self {
        let widths = (0..sample.len())
            .map(|i| {
                let d = sample.kth_distance(sample.values()[i], k.max(1), Some(i));
                // Coincident points would give a zero width; a tiny floor keeps the estimate finite.
                h * d.max(f64::EPSILON * sample.values()[i].abs().max(1.0))
            })
            .collect();
        Self { kernel, h, widths }
    }

    /// The bandwidth factor h.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Density at `x`.
    pub fn density(&self, sample: &Sample, x: f64) -> f64 {
        let sum: f64 = sample
            .values()
            .iter()
            .zip(&self.widths)
            .filter(|&(_, w)| w.is_finite())
            .map(|(&p, &w)| self.kernel.k1((x - p) / w) / w)
            .sum();
        sum / sample.len() as f64
    }
}

/// The kernel estimate in the plane with a disc kernel: f(x) = 1/(n h²) Σ K₂(|x − Xᵢ|²/h²), the form
/// the photon-map radiance estimate takes.
pub fn kernel_density_2d(points: &[[f64; 2]], kernel: Kernel, h: f64, x: [f64; 2]) -> f64 {
    let h2 = h * h;
    let sum: f64 = points
        .iter()
        .map(|p| {
            let d2 = (x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2);
            kernel.k2((d2 / h2) as f32) as f64
        })
        .sum();
    sum / (points.len() as f64 * h2)
}

/// The k-nearest-neighbour estimate in D dimensions: k / (n · V_D · r_k^D), V_D the unit ball's volume.
pub fn knn_density<const D: usize>(points: &[[f64; D]], k: usize, x: [f64; D]) -> f64 {
    let mut d2: Vec<f64> = points.iter().map(|p| (0..D).map(|a| (x[a] - p[a]).powi(2)).sum()).collect();
    let k = k.clamp(1, d2.len().max(1));
    if d2.is_empty() {
        return 0.0;
    }
    let (_, kth, _) = d2.select_nth_unstable_by(k - 1, f64::total_cmp);
    let r = kth.sqrt();
    let unit_ball = match D {
        1 => 2.0,
        2 => std::f64::consts::PI,
        3 => 4.0 / 3.0 * std::f64::consts::PI,
        _ => std::f64::consts::PI.powf(D as f64 / 2.0) / gamma_half_integer(D + 2),
    };
    k as f64 / (points.len() as f64 * unit_ball * r.powi(D as i32))
}

/// Γ(m/2) for a positive integer m.
fn gamma_half_integer(m: usize) -> f64 {
    match m {
        1 => std::f64::consts::PI.sqrt(),
        2 => 1.0,
        _ => (m as f64 / 2.0 - 1.0) * gamma_half_integer(m - 2),
    }
}
