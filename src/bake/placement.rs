//! Where a scene's specular probes stand: probe A, the scene's explicit positions, then,
//! with `[probes] auto = true`, probes placed greedily.
//!
//! Placement covers sampled reflection hits: from the open position of every cell (its
//! centre, relocated as its grid probe is), rays in [`HIT_DIRECTIONS`] directions find the
//! surface points a reflection there would see, the points the fit's queries are traced to
//! (sky and sphere lights, the same from every probe that sees them, are not counted). A
//! candidate position (every open cell position) covers a hit when it sees it
//! (`truth::sees`: a shadow ray). Starting from the fixed probes, each step adds the
//! candidate that covers the most hits still uncovered (the lowest cell on ties) until the
//! next would add less than `min_gain` of all hits or `max` probes stand: a closed room whose
//! probe sees every wall places none, a level of rooms one per room it needs.
//!
//! The sets are thinned to bound the work ([`MAX_HIT_POSITIONS`], [`MAX_CANDIDATES`]: cells
//! taken at an even stride in index order), and every step is a pure function of the scene,
//! so every shard of a farm computes the same probes.

use super::grid::{GridSettings, open_position};
use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::trace::{Renderer, truth};
use glam::Vec3;
use rayon::prelude::*;

/// Stream domain of the placement's directions.
pub const DOMAIN_PLACEMENT: u64 = 0x504C_4143; // "PLAC"
/// Directions traced from each hit position.
pub const HIT_DIRECTIONS: u32 = 16;
/// Most cells hit positions are taken from.
pub const MAX_HIT_POSITIONS: usize = 512;
/// Most cells a probe is placed at.
pub const MAX_CANDIDATES: usize = 384;

/// The probes a scene bakes and how much of its sampled reflection hits they see.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Placement {
    /// Probe A first, then the explicit positions, then the placed ones.
    pub positions: Vec<Vec3>,
    /// Of them, how many were placed automatically (the last ones).
    pub placed: usize,
    /// Sampled reflection hits (rays from the open cell positions that hit something).
    pub hits: usize,
    /// The share of them probe A does not see.
    pub hidden_probe_a: f64,
    /// The share of them no probe sees.
    pub hidden: f64,
    /// Rays traced (hits, visibility, positions).
    pub rays: u64,
}

/// Probe A and the explicit positions of a scene, in order.
#[must_use]
pub fn fixed_positions(scene: &Scene) -> Vec<Vec3> {
    let c = &scene.config;
    std::iter::once(c.probe.position).chain(c.probes.positions.iter().copied()).map(Vec3::from_array).collect()
}

/// Every `stride`-th of `n` items so that at most `most` are taken, in order.
fn thinned(n: usize, most: usize) -> impl Iterator<Item = usize> {
    let stride = n.div_ceil(most.max(1)).max(1);
    (0..n).step_by(stride)
}

/// The scene's probes (see the module docs), the hidden shares measured either way. Without
/// `auto`, the fixed probes are measured and nothing is placed.
#[must_use]
pub fn place(renderer: &Renderer, s: &GridSettings) -> Placement {
    let scene = renderer.scene;
    let cfg = &scene.config.probes;
    let cells = s.geometry.cell_count();
    // open positions of the thinned cells (for hits and for candidates), in cell order
    let wanted: Vec<usize> = {
        let mut w: Vec<usize> = thinned(cells, MAX_HIT_POSITIONS).chain(thinned(cells, MAX_CANDIDATES)).collect();
        w.sort_unstable();
        w.dedup();
        w
    };
    let open: Vec<(usize, Option<Vec3>, u64)> = wanted
        .par_iter()
        .map(|&cell| {
            let mut rays = 0;
            let p = open_position(renderer, s, cell, &mut rays);
            (cell, p, rays)
        })
        .collect();
    let mut rays: u64 = open.iter().map(|o| o.2).sum();
    let at = |cell: usize| open.binary_search_by_key(&cell, |o| o.0).ok().and_then(|k| open[k].1);
    // the sampled hits
    let sources: Vec<Vec3> = thinned(cells, MAX_HIT_POSITIONS).filter_map(at).collect();
    let hits: Vec<Vec3> = sources
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, &b)| {
            (0..HIT_DIRECTIONS).filter_map(move |d| {
                let mut u = Sampler::new(s.seed, hash_pair(DOMAIN_PLACEMENT, k as u64), d);
                let dir = uniform_sphere(u.next_2d());
                // a lamp in front of the geometry: any probe that sees the lamp reads it
                // right (it is uniform), so only surfaces count
                let t = truth::first_visible(scene, renderer.tracer, b, dir);
                let surface = renderer.tracer.closest_hit(b, dir, f32::INFINITY).is_some_and(|h| h.t <= t);
                (t.is_finite() && surface).then(|| b + dir * t)
            })
        })
        .collect();
    rays += sources.len() as u64 * u64::from(HIT_DIRECTIONS);
    let sees = |p: Vec3| -> Vec<u64> {
        let mut bits = vec![0u64; hits.len().div_ceil(64)];
        for (k, &h) in hits.iter().enumerate() {
            if truth::sees(scene, renderer.tracer, p, h) {
                bits[k / 64] |= 1 << (k % 64);
            }
        }
        bits
    };
    let count = |bits: &[u64]| bits.iter().map(|w| w.count_ones() as usize).sum::<usize>();
    let share_hidden = |seen: usize| if hits.is_empty() { 0.0 } else { 1.0 - seen as f64 / hits.len() as f64 };
    let mut positions = fixed_positions(scene);
    let fixed: Vec<Vec<u64>> = positions.par_iter().map(|&p| sees(p)).collect();
    rays += (positions.len() * hits.len()) as u64;
    let hidden_probe_a = share_hidden(count(&fixed[0]));
    let mut covered = vec![0u64; hits.len().div_ceil(64)];
    for f in &fixed {
        covered.iter_mut().zip(f).for_each(|(c, b)| *c |= b);
    }
    let mut placed = 0;
    let max = cfg.max.min(crate::scene::config::MAX_PROBES) as usize;
    if cfg.auto && positions.len() < max && !hits.is_empty() {
        let candidates: Vec<Vec3> = thinned(cells, MAX_CANDIDATES).filter_map(at).collect();
        let seen: Vec<Vec<u64>> = candidates.par_iter().map(|&p| sees(p)).collect();
        rays += (candidates.len() * hits.len()) as u64;
        let min_gain = (cfg.min_gain as f64 * hits.len() as f64).ceil().max(1.0) as usize;
        while positions.len() < max {
            let gain = |bits: &Vec<u64>| -> usize {
                bits.iter().zip(&covered).map(|(b, c)| (b & !c).count_ones() as usize).sum()
            };
            // the most new hits, the first candidate on ties
            let best =
                seen.iter().enumerate().map(|(k, b)| (gain(b), k)).max_by(|x, y| x.0.cmp(&y.0).then(y.1.cmp(&x.1)));
            match best {
                Some((g, k)) if g >= min_gain => {
                    covered.iter_mut().zip(&seen[k]).for_each(|(c, b)| *c |= b);
                    positions.push(candidates[k]);
                    placed += 1;
                }
                _ => break,
            }
        }
    }
    Placement { positions, placed, hits: hits.len(), hidden_probe_a, hidden: share_hidden(count(&covered)), rays }
}
