//! A hash grid over points for fixed-radius queries (vcm's merging; Georgiev et al. 2012 and
//! SmallVCM use one): cells twice the radius wide, so a query visits at most 2 × 2 × 2 cells, their
//! points sorted by bucket with a counting sort. The grid holds the points themselves, not their
//! ids: a query tests and hands out the candidates of a cell from one contiguous run (in vcm a point
//! is what a merge reads of a light vertex, and fetching each from the vertex table by id was a
//! cache miss a merge, the larger part of the render's connection stage). Built in the order the
//! points come, so the order a query visits them in is the same for any thread count.

use glam::Vec3;

/// A point the grid can sort: anything with a position.
pub trait GridPoint: Copy + Default {
    /// Where it is.
    fn position(&self) -> Vec3;
}

impl GridPoint for (u32, Vec3) {
    #[inline]
    fn position(&self) -> Vec3 {
        self.1
    }
}

/// The points of one pass by cell.
#[derive(Clone, Debug, Default)]
pub struct HashGrid<T = (u32, Vec3)> {
    /// 1 / the cell's width.
    inv_cell: f32,
    /// Buckets − 1 (a power of two).
    mask: u32,
    /// Where each bucket's points start in `items`; one more entry than buckets.
    starts: Vec<u32>,
    /// The points, bucket by bucket.
    items: Vec<T>,
    /// Each point's bucket (kept between the counting and the filling pass).
    buckets: Vec<u32>,
}

impl<T: GridPoint> HashGrid<T> {
    /// Rebuild over `points` for queries of radius `radius`, keeping the memory.
    pub fn build(&mut self, points: &[T], radius: f32) {
        self.build_from(|| points.iter().copied(), radius);
    }

    /// Rebuild over the points `points()` yields (the same ones, in the same order, each call: it is
    /// walked twice, to count and to fill) for queries of radius `radius`, keeping the memory. No
    /// copy of the points is made besides the grid's own.
    pub fn build_from<I: Iterator<Item = T>>(&mut self, points: impl Fn() -> I, radius: f32) {
        self.inv_cell = 1.0 / (2.0 * radius);
        self.buckets.clear();
        for point in points() {
            // The bucket needs the mask, which needs the count: cells first, buckets below.
            let [x, y, z] = self.cell(point.position());
            self.buckets.push(Self::hash([x, y, z]));
        }
        let count = self.buckets.len();
        let buckets = (2 * count).next_power_of_two().max(1);
        self.mask = buckets as u32 - 1;
        self.starts.clear();
        self.starts.resize(buckets + 1, 0);
        for bucket in &mut self.buckets {
            *bucket &= self.mask;
            self.starts[*bucket as usize + 1] += 1;
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        self.items.clear();
        self.items.resize(count, T::default());
        let mut next = self.starts.clone();
        for (point, &bucket) in points().zip(&self.buckets) {
            let slot = &mut next[bucket as usize];
            self.items[*slot as usize] = point;
            *slot += 1;
        }
    }

    /// Whether the grid holds no point.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Call `visit` with every point within `radius` of `x` (distance ≤ radius), each once.
    /// `radius` is at most the one the grid was built for.
    #[inline]
    pub fn for_each_within(&self, x: Vec3, radius: f32, mut visit: impl FnMut(&T)) {
        if self.items.is_empty() {
            return;
        }
        let (lo, hi) = (self.cell(x - Vec3::splat(radius)), self.cell(x + Vec3::splat(radius)));
        let mut buckets = [u32::MAX; 8];
        let mut count = 0;
        for cx in lo[0]..=hi[0].min(lo[0] + 1) {
            for cy in lo[1]..=hi[1].min(lo[1] + 1) {
                for cz in lo[2]..=hi[2].min(lo[2] + 1) {
                    let bucket = self.bucket([cx, cy, cz]);
                    // Two cells may share a bucket: visit it once.
                    if !buckets[..count].contains(&bucket) {
                        buckets[count] = bucket;
                        count += 1;
                    }
                }
            }
        }
        let radius2 = radius * radius;
        for &bucket in &buckets[..count] {
            let (start, end) = (self.starts[bucket as usize], self.starts[bucket as usize + 1]);
            for point in &self.items[start as usize..end as usize] {
                if (point.position() - x).length_squared() <= radius2 {
                    visit(point);
                }
            }
        }
    }

    #[inline]
    fn cell(&self, p: Vec3) -> [i32; 3] {
        let c = (p * self.inv_cell).floor();
        [c.x as i32, c.y as i32, c.z as i32]
    }

    #[inline]
    fn bucket(&self, c: [i32; 3]) -> u32 {
        Self::hash(c) & self.mask
    }

    #[inline]
    fn hash(c: [i32; 3]) -> u32 {
        (c[0] as u32).wrapping_mul(73_856_093)
            ^ (c[1] as u32).wrapping_mul(19_349_663)
            ^ (c[2] as u32).wrapping_mul(83_492_791)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    /// Every point within the radius is visited exactly once, and no other, against a brute-force search.
    #[test]
    fn a_query_visits_every_point_within_the_radius_once() {
        let sampler = Sampler::new(3, 0, 0);
        let points: Vec<(u32, Vec3)> = (0..2000)
            .map(|i| {
                let (a, b) = (sampler.get2d(3 * i), sampler.get1d(3 * i + 2));
                (i, Vec3::new(a.x, a.y, b) * 2.0 - 1.0)
            })
            .collect();
        let radius = 0.07;
        let mut grid = HashGrid::default();
        grid.build(&points, radius);
        for q in 0..200 {
            let x = points[q * 7].1 + Vec3::splat(0.01);
            let mut seen = Vec::new();
            grid.for_each_within(x, radius, |&(id, _)| seen.push(id));
            let mut within = seen;
            let before = within.len();
            within.sort_unstable();
            within.dedup();
            assert_eq!(before, within.len(), "query {q} visits a point twice");
            let expected: Vec<u32> = points
                .iter()
                .filter(|(_, p)| (*p - x).length_squared() <= radius * radius)
                .map(|&(id, _)| id)
                .collect();
            assert_eq!(within, expected, "query {q}");
        }
    }
}
