//! The one timing harness of the evaluation: single-threaded warm loops, best of three runs
//! after a warm-up, over queries in coherent or random order.

use super::validation::ValidationSet;
use crate::sampling::Sampler;
use crate::trace::Renderer;
use crate::trace::truth::Oracle;
use crate::warp::Warp;
use crate::warp::reproject::{HoleFill, reproject_with};
use glam::Vec3;
use std::hint::black_box;
use std::time::Instant;

/// Order in which timing loops issue lookups: per position, query directions sorted along a
/// Morton curve over their octahedral uv, the coherent order in which neighbouring pixels
/// of a shaded surface query a probe. `random = true` keeps the validation set's order.
pub fn timing_order(set: &ValidationSet, random: bool) -> Vec<usize> {
    let mut order: Vec<usize> = (0..set.dirs.len()).collect();
    if !random {
        let spread = |mut x: u64| {
            x &= 0xFFFF;
            x = (x | (x << 8)) & 0x00FF_00FF;
            x = (x | (x << 4)) & 0x0F0F_0F0F;
            x = (x | (x << 2)) & 0x3333_3333;
            (x | (x << 1)) & 0x5555_5555
        };
        order.sort_by_key(|&k| {
            let uv = crate::octa::encode(set.dirs[k]) * 65535.0;
            ((k / set.dirs_per_position) as u64) << 32 | spread(uv.x as u64) | spread(uv.y as u64) << 1
        });
    }
    order
}

/// ns per call of `radiance(B, query dir, oracle dir)` over the first `lookups` queries in
/// coherent or shuffled order; best of three warm runs.
pub fn time_queries(
    set: &ValidationSet,
    lookups: usize,
    random: bool,
    radiance: impl Fn(Vec3, Vec3, Oracle) -> Vec3,
) -> f64 {
    let order = timing_order(set, random);
    let n = lookups.min(set.dirs.len()).max(1);
    // (B, query dir, oracle dir) laid out in issue order, so the loop times only the lookup.
    let queries: Vec<(Vec3, Vec3, Oracle)> =
        order[..n.min(order.len())].iter().map(|&k| (set.position_of(k), set.dirs[k], set.oracle(k))).collect();
    best_of_three_ns(n, || {
        let mut acc = Vec3::ZERO;
        for &(b, dir, oracle) in &queries {
            acc += black_box(radiance(b, dir, oracle));
        }
        black_box(acc);
    })
}

/// Coherent- and random-order ns per lookup of `fetch` (B, query dir, oracle dir → fetch
/// vector) followed by the probe's mirror radiance lookup.
pub fn time_fetch(
    warp: &Warp,
    set: &ValidationSet,
    lookups: usize,
    fetch: impl Fn(Vec3, Vec3, Oracle) -> Vec3,
) -> (f64, f64) {
    let radiance = |b, dir, oracle| warp.probe.radiance(fetch(b, dir, oracle));
    (time_queries(set, lookups, false, radiance), time_queries(set, lookups, true, radiance))
}

/// The timing harness: ns per lookup of `run` (which makes `lookups` lookups), best of
/// three runs after one warm-up run.
pub fn best_of_three_ns(lookups: usize, mut run: impl FnMut()) -> f64 {
    run(); // warm
    (0..3)
        .map(|_| {
            let t = Instant::now();
            run();
            t.elapsed().as_nanos() as f64 / lookups.max(1) as f64
        })
        .fold(f64::INFINITY, f64::min)
}

/// ns per lookup of `warp1` through its batch API (`warp1_batch` then `radiance_batch`),
/// over the first `lookups` queries in coherent order; best of three warm runs.
pub fn time_warp1_batched(warp: &Warp, set: &ValidationSet, lookups: usize) -> f64 {
    let order = timing_order(set, false);
    let n = lookups.min(set.dirs.len()).max(1);
    let queries: Vec<(Vec3, Vec3)> =
        order[..n.min(order.len())].iter().map(|&k| (set.position_of(k), set.dirs[k])).collect();
    let (mut vectors, mut radiance) = (vec![Vec3::ZERO; queries.len()], vec![Vec3::ZERO; queries.len()]);
    best_of_three_ns(n, || {
        crate::warp::depth::warp1_batch(&warp.probe, &queries, warp.options.depth_lod, &mut vectors);
        warp.probe.radiance_batch(&vectors, &mut radiance);
        black_box(&radiance);
    })
}

/// Amortised ns per lookup of `reproject`: the per-location build spread over the lookups
/// it serves, plus the lookup.
pub fn time_reproject(warp: &Warp, set: &ValidationSet, fill: HoleFill) -> f64 {
    let res = warp.probe.radiance.levels[0].res;
    let count = set.positions.len().clamp(1, 8).min(set.positions.len());
    let t = Instant::now();
    let mut acc = Vec3::ZERO;
    for k in 0..count {
        let map = reproject_with(&warp.probe, set.positions[k], res, fill);
        for d in 0..set.dirs_per_position {
            acc += map.bilinear(set.dirs[k * set.dirs_per_position + d]);
        }
    }
    black_box(acc);
    t.elapsed().as_nanos() as f64 / (count * set.dirs_per_position).max(1) as f64
}

/// ns per reference ray (radiance of one sample, single-threaded).
pub fn time_reference(renderer: &Renderer, set: &ValidationSet, rays: usize) -> f64 {
    let n = rays.min(set.dirs.len()).max(1).min(set.dirs.len());
    let mut count = 0u64;
    let t = Instant::now();
    let mut acc = Vec3::ZERO;
    for k in 0..n {
        let mut s = Sampler::new(1, k as u64, 0);
        acc += renderer.sample(set.position_of(k), set.dirs[k], &mut s, &mut count).radiance;
    }
    black_box(acc);
    t.elapsed().as_nanos() as f64 / n.max(1) as f64
}
