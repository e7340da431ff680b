//! What a checkpoint of a progressive photon mapper (`sppm`, `appm`, `cppm`, `ppm`) holds beyond its
//! film: every hit point's statistics as 32-bit words in entity order (and for `ppm`, which traces
//! them once, the visible points), and the initial radius the first pass chose.

use crate::components::{AdaptiveStats, Chi2Cells, HitPoint};
use crate::resources::ProgressiveConfig;
use bevy_ecs::prelude::*;
use caustica_core::error::{Error, Result};
use caustica_core::film::accumulator::HitPointState;
use caustica_core::photon::progressive::CHI2_CELLS;
use caustica_core::photon::visible_point::PackedShading;
use glam::{DVec3, Vec3};

/// Words of a `HitPoint`'s statistics: τ, N and R². What a pass gathers (M, Φ) is zero between
/// passes.
const STATISTICS_WORDS: usize = 9;
/// Words of a `HitPoint`'s visible point, which `ppm` traces once and the others every pass.
const HIT_WORDS: usize = 11;
/// Words of an `AdaptiveStats`.
const ADAPTIVE_WORDS: usize = 6;
/// Words of a `Chi2Cells`.
const CHI2_WORDS: usize = CHI2_CELLS + 1;

fn push_f64(words: &mut Vec<u32>, v: f64) {
    let bits = v.to_bits();
    words.extend([bits as u32, (bits >> 32) as u32]);
}

fn push_vec3(words: &mut Vec<u32>, v: Vec3) {
    words.extend(v.to_array().map(f32::to_bits));
}

/// Reads words back in the order they were pushed.
struct Words<'a>(std::slice::Iter<'a, u32>);

impl Words<'_> {
    fn u32(&mut self) -> u32 {
        *self.0.next().expect("the word count was checked")
    }
    fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }
    fn f64(&mut self) -> f64 {
        let lo = self.u32() as u64;
        f64::from_bits(lo | (self.u32() as u64) << 32)
    }
    fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
}

fn push_hit_point(words: &mut Vec<u32>, hp: &HitPoint, with_hit: bool) {
    let start = words.len();
    for c in hp.tau.to_array() {
        push_f64(words, c);
    }
    push_f64(words, hp.n);
    words.push(hp.r2.to_bits());
    if with_hit {
        push_vec3(words, hp.p);
        push_vec3(words, hp.beta);
        words.extend(hp.shading.to_words());
    }
    debug_assert_eq!(words.len() - start, STATISTICS_WORDS + if with_hit { HIT_WORDS } else { 0 });
}

fn read_hit_point(w: &mut Words, hp: &mut HitPoint, with_hit: bool) {
    hp.tau = DVec3::new(w.f64(), w.f64(), w.f64());
    hp.n = w.f64();
    hp.r2 = w.f32();
    (hp.m, hp.phi) = (0, Vec3::ZERO);
    if with_hit {
        (hp.p, hp.beta) = (w.vec3(), w.vec3());
        hp.shading = PackedShading::from_words(std::array::from_fn(|_| w.u32()));
    }
}

/// What is impossible in a hit point read back, if anything: statistics that are not finite, a
/// radius that is not positive, a visible point off the scene's materials.
fn damage(hp: &HitPoint, with_hit: bool, materials: usize) -> Option<String> {
    if !(hp.tau.is_finite() && hp.n.is_finite() && hp.n >= 0.0) {
        return Some(format!("τ = {}, N = {}", hp.tau, hp.n));
    }
    if !(hp.r2.is_finite() && hp.r2 > 0.0) {
        return Some(format!("radius² = {}", hp.r2));
    }
    if with_hit && !(hp.p.is_finite() && hp.beta.is_finite()) {
        return Some(format!("visible point {} with throughput {}", hp.p, hp.beta));
    }
    if with_hit && hp.shading.material as usize >= materials {
        return Some(format!("material {} of {materials}", hp.shading.material));
    }
    None
}

/// What a World's hit points are made of: how many, and the words each takes.
struct Layout {
    points: usize,
    adaptive: bool,
    chi2: bool,
    words_per_point: usize,
}

fn layout(world: &World, with_hits: bool) -> Option<Layout> {
    let points = world.try_query::<&HitPoint>()?.iter(world).len();
    // A component type the World never saw makes its query fail: then no hit point has it.
    let adaptive = world.try_query::<&AdaptiveStats>().is_some_and(|mut q| q.iter(world).next().is_some());
    let chi2 = world.try_query::<&Chi2Cells>().is_some_and(|mut q| q.iter(world).next().is_some());
    let words_per_point = STATISTICS_WORDS
        + if with_hits { HIT_WORDS } else { 0 }
        + if adaptive { ADAPTIVE_WORDS } else { 0 }
        + if chi2 { CHI2_WORDS } else { 0 };
    Some(Layout { points, adaptive, chi2, words_per_point })
}

/// Bytes [`save`] copies out of `world`: every word of every hit point (0 without hit points).
pub fn saved_bytes(world: &World, with_hits: bool) -> u64 {
    layout(world, with_hits).map_or(0, |l| (l.points * l.words_per_point * size_of::<u32>()) as u64)
}

/// The hit points' state, or `None` for an integrator without hit points; `with_hits` for `ppm`,
/// whose visible points are traced in the render's first pass only.
pub fn save(world: &World, with_hits: bool) -> Option<HitPointState> {
    let config = *world.get_resource::<ProgressiveConfig>()?;
    let layout = layout(world, with_hits)?;
    // Not `vec![…; n]`: its clones would drop the capacity and each channel grow by doubling.
    let mut channels: Vec<Vec<u32>> =
        (0..layout.words_per_point).map(|_| Vec::with_capacity(layout.points)).collect();
    // One query per component, visiting the hit points' one table in the same order.
    let mut stats = world.try_query::<&AdaptiveStats>().filter(|_| layout.adaptive);
    let mut cells = world.try_query::<&Chi2Cells>().filter(|_| layout.chi2);
    let mut stats = stats.as_mut().map(|q| q.iter(world));
    let mut cells = cells.as_mut().map(|q| q.iter(world));
    // One hit point's words, then dealt to the channels.
    let mut words = Vec::with_capacity(layout.words_per_point);
    for hp in world.try_query::<&HitPoint>()?.iter(world) {
        words.clear();
        push_hit_point(&mut words, hp, with_hits);
        if let Some(s) = stats.as_mut().and_then(Iterator::next) {
            let s = &s.0;
            push_f64(&mut words, s.laplacian_sum);
            push_f64(&mut words, s.variance_sum);
            words.extend([s.passes, s.laplacian.to_bits()]);
        }
        if let Some(cells) = cells.as_mut().and_then(Iterator::next) {
            words.extend(cells.counts);
            words.push(cells.min_photons.to_bits());
        }
        for (channel, &word) in channels.iter_mut().zip(&words) {
            channel.push(word);
        }
    }
    Some(HitPointState { points_per_pixel: config.hit_points_per_pixel, r0: config.r0, channels })
}

/// Put saved hit points back, in the same entity order; the first pass's radius cap is not redone.
pub fn restore(world: &mut World, state: &HitPointState, with_hits: bool) -> Result<()> {
    let refuse = |problem: String| Err(Error::Setting { name: "resume".into(), problem });
    let (Some(config), Some(layout)) = (world.get_resource::<ProgressiveConfig>(), layout(world, with_hits))
    else {
        return refuse("this integrator has no hit points".into());
    };
    if (layout.words_per_point, config.hit_points_per_pixel, layout.points)
        != (state.channels.len(), state.points_per_pixel, state.points())
    {
        return refuse(format!(
            "the checkpoint holds {} hit points of {} words, the render has {} of {}",
            state.points(),
            state.channels.len(),
            layout.points,
            layout.words_per_point
        ));
    }
    if !(state.r0.is_finite() && state.r0 > 0.0) {
        return refuse(format!("the initial radius is {}: the checkpoint is damaged", state.r0));
    }
    let materials = world.resource::<crate::resources::SceneResource>().materials.len();
    let mut words = Vec::with_capacity(layout.words_per_point);
    let mut query = world.query::<(&mut HitPoint, Option<&mut AdaptiveStats>, Option<&mut Chi2Cells>)>();
    for (i, (mut hp, stats, cells)) in query.iter_mut(world).enumerate() {
        words.clear();
        words.extend(state.channels.iter().map(|c| c[i]));
        let mut w = Words(words.iter());
        read_hit_point(&mut w, &mut hp, with_hits);
        if let Some(problem) = damage(&hp, with_hits, materials) {
            return refuse(format!("hit point {i}: {problem}: the checkpoint is damaged"));
        }
        if let Some(mut stats) = stats {
            let s = &mut stats.0;
            (s.laplacian_sum, s.variance_sum) = (w.f64(), w.f64());
            (s.passes, s.laplacian) = (w.u32(), w.f32());
            if ![s.laplacian_sum, s.variance_sum, s.laplacian as f64].iter().all(|v| v.is_finite()) {
                return refuse(format!(
                    "hit point {i}: its adaptive statistics are not finite: the checkpoint is damaged"
                ));
            }
        }
        if let Some(mut cells) = cells {
            for c in &mut cells.counts {
                *c = w.u32();
            }
            cells.min_photons = w.f32();
            if !(cells.min_photons.is_finite() && cells.min_photons >= 0.0) {
                return refuse(format!(
                    "hit point {i}: its χ² threshold is {}: the checkpoint is damaged",
                    cells.min_photons
                ));
            }
        }
    }
    let mut config = world.resource_mut::<ProgressiveConfig>();
    (config.r0, config.r0_given) = (state.r0, true);
    Ok(())
}
