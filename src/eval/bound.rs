//! Single-fetch bounds, per held-out query, in tone-mapped error against its reference:
//!
//! - `best-fetch`: the one fetch of probe A, any direction at any mip, found by a
//!   coarse-to-fine search over A's octahedral coordinates. No lookup that reads A once can
//!   beat it, whichever way it aims; it is nearly perfect (somewhere in A there is almost
//!   always a texel of the right colour), so it says a single fetch is not the limit.
//! - `best-aim`: the best point on the query's own ray B + t·dir to fetch A towards, t in
//!   (0, ∞] (∞: the query direction), by a coarse-to-fine search over t. Every warp of the
//!   seeds and every corrective map aims at a point on that ray, so this is the bound they
//!   share; `oracle` (t = the true hit) is one such point and can be far from the best where
//!   the hit is hidden from A. Every row's "gap closed" is measured against it.
//!
//! Searches can miss a narrower better optimum, so both rows are upper estimates of their
//! bounds. Bounds, not methods: they read the references, and their cost is the search's.

use super::methods::{MethodResult, RowId, RowKind, result};
use super::validation::ValidationSet;
use crate::tonemap::reinhard;
use crate::warp::Warp;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Whether a row (by name) is one of these per-query search bounds (whose cost is a
/// search's, not a lookup's: plots keep them off the cost axis).
#[must_use]
pub fn is_search(name: &str) -> bool {
    RowId::parse(name).is_some_and(|id| matches!(id.kind, RowKind::BestFetch | RowKind::BestAim))
}

/// Coarse grid of the search (per axis, at most the mip's resolution).
const COARSE: u32 = 32;
/// Halvings of the step around the best point after the coarse grid.
const REFINE: u32 = 5;

/// One mip's coarse search grid, the same for every query: its points' radiance and that
/// radiance tone-mapped, row by row.
struct CoarseGrid {
    lod: f32,
    n: u32,
    radiance: Vec<Vec3>,
    tone_mapped: Vec<Vec3>,
}

impl CoarseGrid {
    fn new(warp: &Warp, lod: f32, exposure: f32) -> CoarseGrid {
        let radiance_mips = &warp.probe.radiance;
        let n = COARSE.min((radiance_mips.levels[0].res >> (lod as u32)).max(1));
        let radiance: Vec<Vec3> =
            (0..n * n).map(|k| radiance_mips.sample_lod_uv(coarse_uv(n, k % n, k / n), lod)).collect();
        let tone_mapped = radiance.iter().map(|&l| reinhard(l, exposure)).collect();
        CoarseGrid { lod, n, radiance, tone_mapped }
    }
}

/// The octahedral coordinate of point (i, j) of an n × n coarse grid.
#[inline]
fn coarse_uv(n: u32, i: u32, j: u32) -> Vec2 {
    (Vec2::new(i as f32, j as f32) + 0.5) / n as f32
}

/// The radiance of the best single fetch for `reference` among the mips of `grids` (each
/// searched from its coarse grid).
fn best_fetch(warp: &Warp, reference: Vec3, grids: &[CoarseGrid], exposure: f32) -> Vec3 {
    let target = reinhard(reference, exposure);
    let radiance = &warp.probe.radiance;
    let mut best = (f32::INFINITY, Vec3::ZERO);
    for grid in grids {
        let (lod, n) = (grid.lod, grid.n);
        let eval = |uv: Vec2| {
            let l = radiance.sample_lod_uv(uv, lod);
            ((reinhard(l, exposure) - target).length_squared(), l)
        };
        let mut at = (f32::INFINITY, Vec2::splat(0.5), Vec3::ZERO);
        for (k, &t) in grid.tone_mapped.iter().enumerate() {
            let e = (t - target).length_squared();
            if e < at.0 {
                let k = k as u32;
                at = (e, coarse_uv(n, k % n, k / n), grid.radiance[k as usize]);
            }
        }
        let mut step = 1.0 / n as f32;
        for _ in 0..REFINE {
            step *= 0.5;
            let centre = at.1;
            for dj in -1..=1 {
                for di in -1..=1 {
                    if di == 0 && dj == 0 {
                        continue;
                    }
                    let uv = (centre + Vec2::new(di as f32, dj as f32) * step).clamp(Vec2::ZERO, Vec2::ONE);
                    let (e, l) = eval(uv);
                    if e < at.0 {
                        at = (e, uv, l);
                    }
                }
            }
        }
        if at.0 < best.0 {
            best = (at.0, at.2);
        }
    }
    best.1
}

/// The radiance of the best point on the ray (b, dir) to fetch A towards, among the mips
/// `lods`; `scale` sets where the search's t-axis is densest (t = scale·u/(1−u)).
fn best_aim(warp: &Warp, b: Vec3, dir: Vec3, reference: Vec3, lods: &[f32], exposure: f32) -> Vec3 {
    let target = reinhard(reference, exposure);
    let a = warp.probe.position;
    let scale = (b - a).length().max(1e-6);
    let radiance = &warp.probe.radiance;
    let mut best = (f32::INFINITY, Vec3::ZERO);
    for &lod in lods {
        let eval = |u: f32| {
            let v = if u >= 1.0 { dir } else { b + dir * (scale * u / (1.0 - u)) - a };
            let l = radiance.sample_lod_uv(crate::octa::encode(v), lod);
            ((reinhard(l, exposure) - target).length_squared(), l)
        };
        let n = 64;
        let mut at = eval(1.0);
        let mut u_at = 1.0f32;
        for i in 0..n {
            let u = (i as f32 + 0.5) / n as f32;
            let (e, l) = eval(u);
            if e < at.0 {
                (at, u_at) = ((e, l), u);
            }
        }
        let mut step = 1.0 / n as f32;
        for _ in 0..REFINE {
            step *= 0.5;
            let centre = u_at;
            for d in [-1.0f32, 1.0] {
                let u = (centre + d * step).clamp(0.0, 1.0);
                let (e, l) = eval(u);
                if e < at.0 {
                    (at, u_at) = ((e, l), u);
                }
            }
        }
        if at.0 < best.0 {
            best = at;
        }
    }
    best.1
}

/// The mips a bound searches: mip 0 for mirror queries; every mip of the chain and the
/// query's own fractional one for rough ones.
fn bound_lods(warp: &Warp, r: f32) -> Vec<f32> {
    let mut lods = vec![warp.probe.lod_of_roughness(r)];
    if r > 0.0 {
        lods.extend((0..warp.probe.radiance.levels.len()).map(|m| m as f32));
    }
    lods
}

/// The `best-aim` row of a bucket (mips as [`best_fetch_row`]'s).
pub fn best_aim_row(warp: &Warp, set: &ValidationSet, exposure: f32) -> MethodResult {
    let r = set.roughness.first().copied().unwrap_or(0.0);
    let lods = bound_lods(warp, r);
    let t0 = std::time::Instant::now();
    let est: Vec<Vec3> = (0..set.reference.len())
        .into_par_iter()
        .map(|k| best_aim(warp, set.position_of(k), set.dirs[k], set.reference[k], &lods, exposure))
        .collect();
    let threads = rayon::current_num_threads().max(1) as f64;
    let ns = t0.elapsed().as_secs_f64() * 1e9 * threads / set.reference.len().max(1) as f64;
    let note = "bound: the best point on the query ray to fetch A towards (what every warp aims at); cost = the search";
    result(set, &RowId::BEST_AIM.name(), note.into(), (&est, None), None, (ns, ns), exposure)
}

/// The `best-fetch` row of a bucket: mirror queries search mip 0; rough ones every mip of the
/// chain and the query's own fractional mip.
pub fn best_fetch_row(warp: &Warp, set: &ValidationSet, exposure: f32) -> MethodResult {
    let r = set.roughness.first().copied().unwrap_or(0.0);
    let lods = bound_lods(warp, r);
    let t0 = std::time::Instant::now();
    let grids: Vec<CoarseGrid> = lods.iter().map(|&lod| CoarseGrid::new(warp, lod, exposure)).collect();
    let est: Vec<Vec3> = (0..set.reference.len())
        .into_par_iter()
        .map(|k| best_fetch(warp, set.reference[k], &grids, exposure))
        .collect();
    let threads = rayon::current_num_threads().max(1) as f64;
    let ns = t0.elapsed().as_secs_f64() * 1e9 * threads / set.reference.len().max(1) as f64;
    let note = format!(
        "bound: the single fetch of A (any direction, mips {}) nearest each reference; cost = the search",
        if r > 0.0 { "all" } else { "0" }
    );
    result(set, &RowId::BEST_FETCH.name(), note, (&est, None), None, (ns, ns), exposure)
}

/// Sets every row's share of the `none` → `best-aim` gap it closes, in tone-mapped RMSE
/// (`none` with the plain rule at rough buckets).
pub fn set_gap_closed(results: &mut [MethodResult]) {
    let tm = |pred: &dyn Fn(&MethodResult) -> bool| results.iter().find(|m| pred(m)).map(|m| m.tm_rmse);
    let none_row = RowId::method(crate::warp::Method::None);
    let none = tm(&|m| m.is(none_row) && matches!(m.mip_rule, None | Some(crate::warp::glossy::MipRule::Plain)));
    let best = tm(&|m| m.is(RowId::BEST_AIM));
    if let (Some(none), Some(best)) = (none, best)
        && none - best > 1e-9
    {
        for m in results.iter_mut() {
            m.gap_closed = Some((none - m.tm_rmse) / (none - best));
        }
    }
}

/// How much of a bucket's errors is its references' own noise: some of its queries traced
/// again with quieter references from streams of their own (`validation::quiet_references`).
///
/// Both bounds pick, per query, the fetch nearest its reference, noise included: against
/// 16-sample mirror references `best-fetch` reproduces the reference's noise rather than
/// the radiance it estimates. Scored against the quiet references instead (still chosen on
/// the set's own), they lose that advantage. And a lookup with no error at all would still
/// score the references' noise against them: the quiet references themselves, scored
/// against the set's, show how far any lookup can get, so `ceiling_*` is the largest share
/// of the `none` → bound gap any row can close in the bucket's table.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct NoiseCeiling {
    /// Queries traced again (the set's first), and samples per quiet reference.
    pub queries: usize,
    pub spp: u32,
    /// Tone-mapped RMSE of the set's references against the quiet ones.
    pub reference_vs_quiet: f64,
    /// Tone-mapped RMSE on these queries against the set's references and against the
    /// quiet ones: `none`, `best-fetch` and `best-aim` (both chosen on the set's references).
    pub none: (f64, f64),
    pub best_fetch: (f64, f64),
    pub best_aim: (f64, f64),
    /// Share of the `none` → `best-fetch` (`best-aim`) gap, against the set's references,
    /// that the quiet references close as a lookup: no row can close more. (`best-aim` only
    /// searches the query's own ray, so with quiet enough references a lookup with no error
    /// beats it and its ceiling passes 1.)
    pub ceiling_fetch: f64,
    pub ceiling_aim: f64,
    /// The bucket claim's champion (the runtime where there is one): its name, its
    /// tone-mapped RMSE against the set's and the quiet references, and its share of the
    /// `none` → `best-fetch` and → `best-aim` gaps against the quiet references.
    pub champion: Option<(String, f64, f64)>,
    pub champion_gap_quiet: Option<(f64, f64)>,
    /// The same for `oracle`, the exact fetch towards the true hit: how much of those gaps
    /// a geometrically exact single fetch closes (absent in files written before it).
    #[serde(default)]
    pub oracle: Option<(f64, f64)>,
    #[serde(default)]
    pub oracle_gap_quiet: Option<(f64, f64)>,
}

/// The [`NoiseCeiling`] of `set` on the queries `quiet` traced again (its first queries,
/// the same directions; `None` if they are not), given the `none` row's, the champion's
/// and the oracle's estimates for them.
pub fn noise_ceiling(
    warp: &Warp,
    set: &ValidationSet,
    (quiet, spp): (&crate::trace::truth::TracedQueries, u32),
    none: &[Vec3],
    champion: Option<(String, Vec<Vec3>)>,
    oracle: Option<Vec<Vec3>>,
    exposure: f32,
) -> Option<NoiseCeiling> {
    let n = quiet.dirs.len();
    if n == 0 || n > set.dirs.len() || quiet.dirs[..] != set.dirs[..n] || none.len() != n {
        return None;
    }
    let (reference, quiet_ref) = (&set.reference[..n], &quiet.reference[..]);
    let tm = |est: &[Vec3], r: &[Vec3]| super::metrics::error_stats(est, r, exposure).tm_rmse;
    let both = |est: &[Vec3]| (tm(est, reference), tm(est, quiet_ref));
    let lods = bound_lods(warp, 0.0);
    let grids: Vec<CoarseGrid> = lods.iter().map(|&lod| CoarseGrid::new(warp, lod, exposure)).collect();
    let fetch: Vec<Vec3> = (0..n).into_par_iter().map(|k| best_fetch(warp, reference[k], &grids, exposure)).collect();
    let aim: Vec<Vec3> = (0..n)
        .into_par_iter()
        .map(|k| best_aim(warp, set.position_of(k), set.dirs[k], reference[k], &lods, exposure))
        .collect();
    let (none, best_fetch, best_aim) = (both(none), both(&fetch), both(&aim));
    let reference_vs_quiet = tm(quiet_ref, reference);
    let share = |from: f64, to: f64, bound: f64| if from > bound { (from - to) / (from - bound) } else { 0.0 };
    let champion = champion.filter(|(_, e)| e.len() == n).map(|(name, e)| {
        let (a, b) = both(&e);
        (name, a, b)
    });
    let gaps = |quiet: f64| (share(none.1, quiet, best_fetch.1), share(none.1, quiet, best_aim.1));
    let champion_gap_quiet = champion.as_ref().map(|c| gaps(c.2));
    let oracle = oracle.filter(|e| e.len() == n).map(|e| both(&e));
    let oracle_gap_quiet = oracle.map(|o| gaps(o.1));
    Some(NoiseCeiling {
        queries: n,
        spp,
        reference_vs_quiet,
        none,
        best_fetch,
        best_aim,
        ceiling_fetch: share(none.0, reference_vs_quiet, best_fetch.0),
        ceiling_aim: share(none.0, reference_vs_quiet, best_aim.0),
        champion,
        champion_gap_quiet,
        oracle,
        oracle_gap_quiet,
    })
}
