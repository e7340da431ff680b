//! A balanced kd-tree over photons, stored implicitly in the photon array (Jensen 2001, §6.3).
//!
//! The node of a range is its median photon; its children are the sub-ranges left and right of it,
//! split on the axis of the range's largest extent (kept in the photon record). No pointers, no extra
//! memory. The build partitions with `select_nth_unstable_by`, which is deterministic, and runs the two
//! halves of large ranges in parallel with `rayon::join`: the same photons give the same array on any
//! number of threads.

use super::Photon;
use glam::Vec3;
use std::collections::BinaryHeap;

/// Ranges smaller than this are built on the current thread.
const PARALLEL_CUTOFF: usize = 4096;

/// A photon map: photons arranged as an implicit kd-tree.
#[derive(Clone, Debug, Default)]
pub struct PhotonMap {
    photons: Vec<Photon>,
}

/// The result of a k-nearest query, reusable across queries (it never reallocates once it has held
/// `k` photons): a max-heap on squared distance while searching.
#[derive(Clone, Debug, Default)]
pub struct Neighbors {
    /// (squared distance as ordered bits, photon index); non-negative floats order like their bits.
    heap: BinaryHeap<(u32, u32)>,
}

impl Neighbors {
    /// An empty result with room for `k` photons.
    pub fn with_capacity(k: usize) -> Self {
        Self { heap: BinaryHeap::with_capacity(k + 1) }
    }

    /// Photons found.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether nothing was found.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }

    /// Squared distance of the farthest photon kept (0 when empty).
    pub fn max_dist2(&self) -> f32 {
        self.heap.peek().map_or(0.0, |&(d2, _)| f32::from_bits(d2))
    }

    /// The photons found and their squared distances, in no particular order.
    pub fn iter<'a>(&'a self, map: &'a PhotonMap) -> impl Iterator<Item = (&'a Photon, f32)> + 'a {
        self.heap.iter().map(|&(d2, i)| (&map.photons[i as usize], f32::from_bits(d2)))
    }

    /// Indices into [`PhotonMap::photons`] and squared distances, in no particular order.
    pub fn indices(&self) -> impl Iterator<Item = (u32, f32)> + '_ {
        self.heap.iter().map(|&(d2, i)| (i, f32::from_bits(d2)))
    }
}

impl PhotonMap {
    /// Arrange `photons` into a kd-tree. Non-finite positions are dropped (they cannot be found).
    pub fn build(mut photons: Vec<Photon>) -> Self {
        photons.retain(|p| p.position().is_finite());
        build_range(&mut photons);
        Self { photons }
    }

    /// Number of photons.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// Whether the map holds no photon.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// The photons in tree order.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Bytes of photon storage.
    pub fn memory_bytes(&self) -> usize {
        self.photons.len() * size_of::<Photon>()
    }

    /// The `k` photons nearest to `p` within distance √`max_dist2`, into `out` (cleared first).
    pub fn knn(&self, p: Vec3, k: usize, max_dist2: f32, out: &mut Neighbors) {
        out.heap.clear();
        if k == 0 || !p.is_finite() || max_dist2.is_nan() {
            return;
        }
        self.knn_range(0, self.photons.len(), p.to_array(), k, max_dist2, &mut out.heap);
    }

    /// Call `visit(photon, squared distance)` for every photon within distance √`r2` of `p`.
    pub fn within(&self, p: Vec3, r2: f32, mut visit: impl FnMut(&Photon, f32)) {
        if !p.is_finite() || r2.is_nan() {
            return;
        }
        self.within_range(0, self.photons.len(), p.to_array(), r2, &mut visit);
    }

    fn knn_range(
        &self,
        lo: usize,
        hi: usize,
        p: [f32; 3],
        k: usize,
        max_dist2: f32,
        heap: &mut BinaryHeap<(u32, u32)>,
    ) {
        if lo >= hi {
            return;
        }
        let mid = lo + (hi - lo) / 2;
        let node = &self.photons[mid];
        let axis = node.axis();
        let delta = p[axis] - node.coordinate(axis);
        let (near, far) = if delta < 0.0 { ((lo, mid), (mid + 1, hi)) } else { ((mid + 1, hi), (lo, mid)) };
        self.knn_range(near.0, near.1, p, k, max_dist2, heap);
        let bound = |heap: &BinaryHeap<(u32, u32)>| {
            if heap.len() < k {
                max_dist2
            } else {
                heap.peek().map_or(max_dist2, |&(d, _)| f32::from_bits(d))
            }
        };
        let d2 = (node.position() - glam::Vec3::from_array(p)).length_squared();
        if d2 <= max_dist2 && (heap.len() < k || d2 < bound(heap)) {
            if heap.len() == k {
                heap.pop();
            }
            heap.push((d2.to_bits(), mid as u32));
        }
        if delta * delta < bound(heap) || (heap.len() < k && delta * delta <= max_dist2) {
            self.knn_range(far.0, far.1, p, k, max_dist2, heap);
        }
    }

    fn within_range(&self, lo: usize, hi: usize, p: [f32; 3], r2: f32, visit: &mut impl FnMut(&Photon, f32)) {
        if lo >= hi {
            return;
        }
        let mid = lo + (hi - lo) / 2;
        let node = &self.photons[mid];
        let axis = node.axis();
        let delta = p[axis] - node.coordinate(axis);
        let (near, far) = if delta < 0.0 { ((lo, mid), (mid + 1, hi)) } else { ((mid + 1, hi), (lo, mid)) };
        self.within_range(near.0, near.1, p, r2, visit);
        let d2 = (node.position() - glam::Vec3::from_array(p)).length_squared();
        if d2 <= r2 {
            visit(node, d2);
        }
        if delta * delta <= r2 {
            self.within_range(far.0, far.1, p, r2, visit);
        }
    }
}

/// Put the median of `photons` (on its widest axis) in the middle, smaller coordinates before it, and
/// recurse into both sides.
fn build_range(photons: &mut [Photon]) {
    if photons.is_empty() {
        return;
    }
    let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for photon in photons.iter() {
        min = min.min(photon.position());
        max = max.max(photon.position());
    }
    let axis = (max - min).max_position();
    let mid = photons.len() / 2;
    photons.select_nth_unstable_by(mid, |a, b| a.coordinate(axis).total_cmp(&b.coordinate(axis)));
    photons[mid].set_axis(axis);
    let (left, rest) = photons.split_at_mut(mid);
    let right = &mut rest[1..];
    if left.len() >= PARALLEL_CUTOFF {
        rayon::join(|| build_range(left), || build_range(right));
    } else {
        build_range(left);
        build_range(right);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn points(n: u32, seed: u64, clustered: bool) -> Vec<Photon> {
        (0..n)
            .map(|i| {
                let s = Sampler::new(seed, i, 0);
                let mut p = Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2));
                if clustered {
                    // A few tight clusters and exact duplicates: ties and degenerate ranges.
                    p = (p * 4.0).floor() * 0.25 + (p - 0.5) * 0.001 * (i % 3) as f32;
                }
                Photon::new(p, Vec3::Z, Vec3::Z, Vec3::splat(i as f32))
            })
            .collect()
    }

    fn brute_knn(photons: &[Photon], p: Vec3, k: usize, max_d2: f32) -> Vec<f32> {
        let mut d: Vec<f32> = photons
            .iter()
            .map(|ph| (ph.position() - p).length_squared())
            .filter(|&d2| d2 <= max_d2)
            .collect();
        d.sort_by(f32::total_cmp);
        d.truncate(k);
        d
    }

    #[test]
    fn knn_and_radius_queries_equal_brute_force() {
        for (n, clustered) in
            [(0, false), (1, false), (2, false), (1000, false), (1000, true), (100_000, false)]
        {
            let map = PhotonMap::build(points(n, 9, clustered));
            assert_eq!(map.len(), n as usize);
            let mut out = Neighbors::with_capacity(64);
            for q in 0..50 {
                let s = Sampler::new(77, q, 0);
                let p = Vec3::new(s.get1d(0), s.get1d(1), s.get1d(2)) * 1.2 - 0.1;
                for (k, max_d2) in [(1, f32::INFINITY), (8, 0.01), (64, f32::INFINITY), (64, 0.001)] {
                    map.knn(p, k, max_d2, &mut out);
                    let mut got: Vec<f32> = out.indices().map(|(_, d2)| d2).collect();
                    got.sort_by(f32::total_cmp);
                    assert_eq!(got, brute_knn(map.photons(), p, k, max_d2), "n {n}, k {k}, query {p}");
                    // The indices name photons at the distances reported.
                    for (i, d2) in out.indices() {
                        assert_eq!((map.photons()[i as usize].position() - p).length_squared(), d2);
                    }
                }
                let r2 = 0.02;
                let mut found = Vec::new();
                map.within(p, r2, |ph, d2| found.push((ph.power().x, d2)));
                found.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut expected: Vec<(f32, f32)> = map
                    .photons()
                    .iter()
                    .map(|ph| (ph.power().x, (ph.position() - p).length_squared()))
                    .filter(|&(_, d2)| d2 <= r2)
                    .collect();
                expected.sort_by(|a, b| a.0.total_cmp(&b.0));
                assert_eq!(found, expected, "n {n}, radius query at {p}");
            }
        }
    }

    #[test]
    fn build_does_not_depend_on_the_thread_count() {
        let photons = points(50_000, 4, true);
        let build_with = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| PhotonMap::build(photons.clone()))
        };
        assert_eq!(build_with(1).photons(), build_with(2).photons());
    }

    #[test]
    fn odd_queries_return_nothing_without_panicking() {
        let map = PhotonMap::build(points(100, 1, false));
        let mut out = Neighbors::with_capacity(4);
        map.knn(Vec3::NAN, 4, 1.0, &mut out);
        assert!(out.is_empty());
        map.knn(Vec3::ZERO, 0, 1.0, &mut out);
        assert!(out.is_empty());
        map.knn(Vec3::ZERO, 500, f32::INFINITY, &mut out);
        assert_eq!(out.len(), 100);
    }
}
