//! The camera samples of a pass and how path entities take them, from every thread at once.
//!
//! Work item `k` is sample `spp_begin + k / pixels` of pixel `k % pixels`: sample-major, so the whole
//! image fills in evenly. A path that finishes takes the next item of its lane, so every entity stays
//! busy until the work runs out and only the last paths form a tail. Which entity renders which item
//! varies with the threads' timing; what is rendered does not (a sample's random numbers are a
//! function of its pixel and index, and the film's fixed-point sums do not depend on their order).
//!
//! One shared counter would have every finished path of every thread contend for one cache line
//! (measured: the splat took 1.8× as long as on one thread). So the items are dealt in blocks of
//! `ITEM_BLOCK` consecutive items to `lanes` lanes, block `b` to lane `b mod lanes`, one counter per
//! lane on its own cache line. Entities are dealt to lanes in blocks of `ENTITY_BLOCK`, in entity
//! order, and a finished path takes its next item from the lane of the item it finished: a batch of
//! consecutive entities, which one thread runs, touches one or two counters. Item blocks are short
//! so that every lane's items are spread over the whole image: lanes of whole rows ran out unevenly
//! (a lane over the black background finishes first) and lengthened the tail by 13%; and a path
//! whose lane has run out takes from the next open lane, so the tail is one counter's.

use bevy_ecs::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Entities per lane: enough that a lane's counter stays with one thread for a batch.
const ENTITY_BLOCK: u32 = 1024;
/// At most this many lanes (one bit each in the open-lanes mask).
const MAX_LANES: u32 = 64;
/// Consecutive items a lane hands out before the next lane's block.
const ITEM_BLOCK: u64 = 64;

/// A lane's counter, alone on its cache line.
#[derive(Debug, Default)]
#[repr(align(64))]
struct LaneCounter(AtomicU64);

/// The pixels a pass of adaptive sampling renders, in image order, and where each is in that list.
#[derive(Debug)]
pub struct PixelOrder {
    pixels: Vec<u32>,
    /// `slot[p]`: the place of pixel `p` in `pixels` (meaningless for a pixel not there).
    slot: Vec<u32>,
}

impl PixelOrder {
    /// `pixels` (increasing) of an image of `image_pixels`.
    pub fn new(pixels: Vec<u32>, image_pixels: u32) -> Self {
        let mut slot = vec![0; image_pixels as usize];
        for (i, &p) in pixels.iter().enumerate() {
            slot[p as usize] = i as u32;
        }
        Self { pixels, slot }
    }

    /// Pixels in the list.
    pub fn len(&self) -> u32 {
        self.pixels.len() as u32
    }

    /// Whether no pixel is.
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }
}

/// The samples of one pass of a sample integrator, shared: a clone hands out from the same counters
/// (each shard of a chunked render holds one).
#[derive(Resource, Clone, Debug)]
pub struct Workload(Arc<WorkItems>);

impl std::ops::Deref for Workload {
    type Target = WorkItems;
    fn deref(&self) -> &WorkItems {
        &self.0
    }
}

impl Workload {
    /// Work for `pixels` pixels and samples `spp_begin..spp_end` on `wavefront` entities, none handed
    /// out yet.
    pub fn new(pixels: u32, spp_begin: u32, spp_end: u32, wavefront: u32) -> Self {
        Self(Arc::new(WorkItems::new(pixels, spp_begin, spp_end, wavefront)))
    }

    /// Work for the pixels of `order` only (adaptive sampling), samples `spp_begin..spp_end` of each.
    pub fn over(order: Arc<PixelOrder>, spp_begin: u32, spp_end: u32, wavefront: u32) -> Self {
        Self(Arc::new(WorkItems::over(order, spp_begin, spp_end, wavefront)))
    }

    /// Work with nothing left to hand out (the progressive integrators' camera passes assign their
    /// samples themselves).
    pub fn exhausted(pixels: u32) -> Self {
        Self::new(pixels, 0, 0, pixels)
    }
}

/// The items of a [`Workload`] and the counters that hand them out.
#[derive(Debug)]
pub struct WorkItems {
    /// Pixels the pass renders (the image's, or adaptive sampling's list of them).
    pub pixels: u32,
    /// Which pixels, when not the whole image: item `k` is pixel `order[k % pixels]`.
    order: Option<Arc<PixelOrder>>,
    /// First sample index.
    pub spp_begin: u32,
    /// One past the last sample index.
    pub spp_end: u32,
    /// Number of path entities.
    pub wavefront: u32,
    /// Entities per lane.
    entity_block: u32,
    /// Items each lane has handed out (past its end once its work has run out).
    lanes: Vec<LaneCounter>,
    /// Bit `l` set while lane `l` may have items left.
    open: AtomicU64,
    /// Items past this are not handed out: the total, or less once the pass is cut short.
    limit: AtomicU64,
}

impl WorkItems {
    fn new(pixels: u32, spp_begin: u32, spp_end: u32, wavefront: u32) -> Self {
        let entity_block = ENTITY_BLOCK.min(wavefront.max(1));
        let count = (wavefront / entity_block).clamp(1, MAX_LANES);
        let entity_block = wavefront.div_ceil(count).max(1);
        let lanes = (0..count).map(|_| LaneCounter::default()).collect();
        let open = (u64::MAX >> (64 - count)).into();
        let limit = (pixels as u64 * spp_end.saturating_sub(spp_begin) as u64).into();
        Self { pixels, order: None, spp_begin, spp_end, wavefront, entity_block, lanes, open, limit }
    }

    fn over(order: Arc<PixelOrder>, spp_begin: u32, spp_end: u32, wavefront: u32) -> Self {
        Self { order: Some(order.clone()), ..Self::new(order.len(), spp_begin, spp_end, wavefront) }
    }

    /// The pixel of item `k`'s place in a sample's list of pixels.
    #[inline]
    fn pixel_at(&self, place: u32) -> u32 {
        self.order.as_ref().map_or(place, |order| order.pixels[place as usize])
    }

    /// How many lanes hand items out.
    pub fn lane_count(&self) -> usize {
        self.lanes.len()
    }

    /// Whether every lane has run out (no item will be handed out any more).
    pub fn is_exhausted(&self) -> bool {
        self.open.load(Ordering::Relaxed) == 0
    }

    /// Total camera samples.
    pub fn total_samples(&self) -> u64 {
        self.pixels as u64 * (self.spp_end - self.spp_begin) as u64
    }

    /// The lane of the `ordinal`-th entity (in entity order) when work is first handed out.
    pub fn lane_of_entity(&self, ordinal: u32) -> usize {
        ((ordinal / self.entity_block) as usize).min(self.lanes.len() - 1)
    }

    /// The lane a path that has just rendered (pixel, sample) takes its next item from.
    pub fn lane_of_item(&self, pixel: u32, sample: u32) -> usize {
        let place = self.order.as_ref().map_or(pixel, |order| order.slot[pixel as usize]);
        let k = sample.saturating_sub(self.spp_begin) as u64 * self.pixels as u64 + place as u64;
        ((k / ITEM_BLOCK) % self.lanes.len() as u64) as usize
    }

    /// The next (pixel, sample) of `lane`, or, once it has run out, of the next lane that has any
    /// left (so that no entity idles while work remains); safe from any thread.
    #[inline]
    pub fn take(&self, lane: usize) -> Option<(u32, u32)> {
        if let Some(item) = self.take_from(lane) {
            return Some(item);
        }
        loop {
            let open = self.open.load(Ordering::Relaxed);
            if open == 0 {
                return None;
            }
            let next = (open.rotate_right(lane as u32 + 1).trailing_zeros() as usize + lane + 1) % 64;
            if let Some(item) = self.take_from(next) {
                return Some(item);
            }
        }
    }

    /// The index of the `j`-th item lane `lane` hands out.
    fn item(&self, lane: usize, j: u64) -> u64 {
        (lane as u64 + self.lanes.len() as u64 * (j / ITEM_BLOCK)) * ITEM_BLOCK + j % ITEM_BLOCK
    }

    /// Hand out no more than the samples per pixel up to the first multiple of `unit` samples past
    /// every item handed out so far (at least one unit), and say where that is: the sample index
    /// the pass now ends at. The items below it not yet handed out still are, so the pass ends
    /// with whole units. Call it between steps, while no path takes work.
    pub fn cut_at_unit(&self, unit: u32) -> u32 {
        let last = self
            .lanes
            .iter()
            .enumerate()
            .filter_map(|(lane, counter)| {
                counter.0.load(Ordering::Relaxed).checked_sub(1).map(|j| self.item(lane, j))
            })
            .max();
        let limit = self.limit.load(Ordering::Relaxed);
        let unit_items = self.pixels as u64 * unit.max(1) as u64;
        let handed = last.map_or(0, |k| k.min(limit.saturating_sub(1)) + 1);
        let cut = handed.div_ceil(unit_items).max(1).saturating_mul(unit_items).min(limit);
        self.limit.store(cut, Ordering::Relaxed);
        self.spp_begin + (cut / self.pixels.max(1) as u64) as u32
    }

    /// Up to `want` items of `lane`, or, once it has run out, of the next lane that has any left:
    /// one atomic step for a run of samples instead of one a sample. `visit` receives each (pixel,
    /// sample); returns how many it got (0: the work has run out).
    #[inline]
    pub fn take_run(&self, lane: usize, want: u32, mut visit: impl FnMut(u32, u32)) -> u32 {
        let want = want.clamp(1, ITEM_BLOCK as u32);
        let mut lane = lane;
        loop {
            let got = self.take_run_from(lane, want, &mut visit);
            if got > 0 {
                return got;
            }
            let open = self.open.load(Ordering::Relaxed);
            if open == 0 {
                return 0;
            }
            lane = (open.rotate_right(lane as u32 + 1).trailing_zeros() as usize + lane + 1) % 64;
        }
    }

    /// A run of `lane`'s own items (see [`WorkItems::take_run`]); a lane found empty is marked
    /// closed.
    #[inline]
    fn take_run_from(&self, lane: usize, want: u32, visit: &mut impl FnMut(u32, u32)) -> u32 {
        let first = self.lanes[lane].0.fetch_add(want as u64, Ordering::Relaxed);
        let limit = self.limit.load(Ordering::Relaxed);
        let mut got = 0;
        // A lane's items increase with its count: the first past the limit ends the run.
        for j in first..first + want as u64 {
            let k = self.item(lane, j);
            if k >= limit {
                self.open.fetch_and(!(1 << lane), Ordering::Relaxed);
                break;
            }
            visit(
                self.pixel_at((k % self.pixels as u64) as u32),
                self.spp_begin + (k / self.pixels as u64) as u32,
            );
            got += 1;
        }
        got
    }

    /// The next item of `lane` itself; a lane found empty is marked closed.
    #[inline]
    fn take_from(&self, lane: usize) -> Option<(u32, u32)> {
        let j = self.lanes[lane].0.fetch_add(1, Ordering::Relaxed);
        let k = self.item(lane, j);
        if k >= self.limit.load(Ordering::Relaxed) {
            self.open.fetch_and(!(1 << lane), Ordering::Relaxed);
            return None;
        }
        Some((
            self.pixel_at((k % self.pixels as u64) as u32),
            self.spp_begin + (k / self.pixels as u64) as u32,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every item is handed out exactly once, whatever lanes are asked in whatever order, and no lane
    /// says "done" while another has work.
    #[test]
    fn the_lanes_hand_out_every_item_once() {
        for (pixels, spp, wavefront) in [(7, 3, 7), (5000, 3, 4096), (65_536, 2, 65_536), (3000, 5, 2500)] {
            let workload = Workload::new(pixels, 10, 10 + spp, wavefront);
            let mut seen = vec![0u8; (pixels * spp) as usize];
            let mut open: Vec<usize> = (0..workload.lanes.len()).collect();
            let mut turn = 0usize;
            while !open.is_empty() {
                turn = (turn * 31 + 7) % open.len();
                match workload.take(open[turn]) {
                    Some((pixel, sample)) => seen[((sample - 10) * pixels + pixel) as usize] += 1,
                    None => {
                        // Only when every lane is empty: an empty lane takes from the others.
                        assert!(seen.iter().all(|&n| n > 0), "a lane gave up while work remained");
                        open.remove(turn);
                    }
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{pixels} px × {spp}: an item missed or repeated");
        }
    }

    /// Runs of items hand out every item exactly once too, whatever their lengths and lanes.
    #[test]
    fn runs_hand_out_every_item_once() {
        for (pixels, spp, wavefront) in [(7, 3, 7), (5000, 3, 4096), (3000, 5, 2500)] {
            let workload = Workload::new(pixels, 2, 2 + spp, wavefront);
            let mut seen = vec![0u8; (pixels * spp) as usize];
            let lanes = workload.lane_count();
            let mut turn = 0usize;
            loop {
                turn = (turn * 31 + 7) % 97;
                let got = workload.take_run(turn % lanes, (turn % 70) as u32 + 1, |pixel, sample| {
                    seen[((sample - 2) * pixels + pixel) as usize] += 1;
                });
                if got == 0 {
                    break;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{pixels} px × {spp}: an item missed or repeated");
        }
    }

    /// A pass cut short ends at the first whole unit past everything handed out, and hands out
    /// exactly the items below it.
    #[test]
    fn a_cut_pass_hands_out_whole_units() {
        let (pixels, unit) = (3000u32, 2u32);
        let workload = Workload::new(pixels, 4, 14, 2048);
        let lanes = workload.lanes.len();
        let mut seen = vec![0u8; (pixels * 10) as usize];
        let mut take =
            |lane: usize| workload.take(lane).map(|(p, s)| seen[((s - 4) * pixels + p) as usize] += 1);
        // A little over two units handed out unevenly across lanes.
        for i in 0..(2 * unit * pixels + 1000) as usize {
            take((i * 7) % lanes.max(1));
        }
        let end = workload.cut_at_unit(unit);
        assert_eq!(end, 4 + 3 * unit, "the first unit boundary past the items handed out");
        for i in 0.. {
            if take(i % lanes).is_none() && workload.open.load(Ordering::Relaxed) == 0 {
                break;
            }
        }
        let whole = (3 * unit * pixels) as usize;
        assert!(seen[..whole].iter().all(|&n| n == 1), "every item below the cut, once");
        assert!(seen[whole..].iter().all(|&n| n == 0), "nothing past it");
    }

    /// Over a list of pixels, every sample of every listed pixel is handed out once and no other.
    #[test]
    fn a_list_of_pixels_gets_its_samples_and_no_other_pixel_does() {
        let listed: Vec<u32> = (0..5000).filter(|p| p % 3 != 1).collect();
        let order = Arc::new(PixelOrder::new(listed.clone(), 5000));
        let workload = Workload::over(order, 20, 23, 2048);
        let mut seen = vec![0u8; 5000 * 3];
        let mut lane = 0;
        while let Some((pixel, sample)) = workload.take(lane) {
            seen[((sample - 20) * 5000 + pixel) as usize] += 1;
            lane = workload.lane_of_item(pixel, sample);
        }
        for (i, &n) in seen.iter().enumerate() {
            assert_eq!(
                n,
                listed.contains(&(i as u32 % 5000)) as u8,
                "pixel {}, sample {}",
                i % 5000,
                i / 5000
            );
        }
    }

    /// The first hand-out gives the entities the first `wavefront` items, as one counter would.
    #[test]
    fn the_first_hand_out_is_the_first_items() {
        let workload = Workload::new(10_000, 0, 4, 8192);
        let mut items: Vec<u32> = (0..8192)
            .map(|e| workload.take(workload.lane_of_entity(e)).map(|(p, s)| s * 10_000 + p).unwrap())
            .collect();
        items.sort_unstable();
        assert!(items.iter().enumerate().all(|(i, &k)| k == i as u32));
    }
}
