//! The single-fetch bound (`best-fetch`): per held-out query, the one fetch of probe A, any
//! direction at any mip, whose radiance is nearest its reference in tone-mapped error,
//! found by a coarse-to-fine search over A's octahedral coordinates. No lookup that reads
//! A once can beat it on that query, whichever way it aims or picks its mip; `oracle`
//! (aiming at the true hit) is the geometric row and can be far from it where the hit is
//! hidden from A. The search can miss a narrower better texel, so the row is an upper
//! estimate of the bound. A bound, not a method: it reads the references, and its cost is
//! the search's.

use super::methods::MethodResult;
use super::metrics::error_stats;
use super::validation::ValidationSet;
use crate::tonemap::reinhard;
use crate::warp::Warp;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// The bound's row name.
pub const NAME: &str = "best-fetch";

/// Coarse grid of the search (per axis, at most the mip's resolution).
const COARSE: u32 = 32;
/// Halvings of the step around the best point after the coarse grid.
const REFINE: u32 = 5;

/// The radiance of the best single fetch for `reference` among the mips `lods`.
fn best_fetch(warp: &Warp, reference: Vec3, lods: &[f32], exposure: f32) -> Vec3 {
    let target = reinhard(reference, exposure);
    let radiance = &warp.probe.radiance;
    let res0 = radiance.levels[0].res;
    let mut best = (f32::INFINITY, Vec3::ZERO);
    for &lod in lods {
        let eval = |uv: Vec2| {
            let l = radiance.sample_lod_uv(uv, lod);
            ((reinhard(l, exposure) - target).length_squared(), l)
        };
        let n = COARSE.min((res0 >> (lod as u32)).max(1));
        let mut at = (f32::INFINITY, Vec2::splat(0.5), Vec3::ZERO);
        for j in 0..n {
            for i in 0..n {
                let uv = (Vec2::new(i as f32, j as f32) + 0.5) / n as f32;
                let (e, l) = eval(uv);
                if e < at.0 {
                    at = (e, uv, l);
                }
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

/// The `best-fetch` row of a bucket: mirror queries search mip 0; rough ones every mip of the
/// chain and the query's own fractional mip.
pub fn best_fetch_row(warp: &Warp, set: &ValidationSet, exposure: f32) -> MethodResult {
    let r = set.roughness.first().copied().unwrap_or(0.0);
    let mut lods = vec![warp.probe.lod_of_roughness(r)];
    if r > 0.0 {
        lods.extend((0..warp.probe.radiance.levels.len()).map(|m| m as f32));
    }
    let t0 = std::time::Instant::now();
    let est: Vec<Vec3> =
        (0..set.reference.len()).into_par_iter().map(|k| best_fetch(warp, set.reference[k], &lods, exposure)).collect();
    let threads = rayon::current_num_threads().max(1) as f64;
    let ns = t0.elapsed().as_secs_f64() * 1e9 * threads / set.reference.len().max(1) as f64;
    let e = error_stats(&est, &set.reference, exposure);
    MethodResult {
        name: NAME.into(),
        roughness: r,
        mip_rule: None,
        rel_rmse: e.rel_rmse,
        tm_rmse: e.tm_rmse,
        mae: e.mae,
        p95: e.p95,
        max: e.max,
        flip: None,
        angular_deg: None,
        ns_per_lookup: ns,
        ns_per_lookup_random: ns,
        ns_per_lookup_batched: None,
        gap_closed: None,
        note: format!(
            "bound: the single fetch of A (any direction, mips {}) nearest each reference; cost = the search",
            if r > 0.0 { "all" } else { "0" }
        ),
    }
}

/// Sets every row's share of the `none` → `best-fetch` gap it closes, in tone-mapped RMSE
/// (`none` with the plain rule at rough buckets).
pub fn set_gap_closed(results: &mut [MethodResult]) {
    let tm = |pred: &dyn Fn(&MethodResult) -> bool| results.iter().find(|m| pred(m)).map(|m| m.tm_rmse);
    let none = tm(&|m| m.name == "none" && matches!(m.mip_rule, None | Some(crate::warp::glossy::MipRule::Plain)));
    let best = tm(&|m| m.name == NAME);
    if let (Some(none), Some(best)) = (none, best)
        && none - best > 1e-9
    {
        for m in results.iter_mut() {
            m.gap_closed = Some((none - m.tm_rmse) / (none - best));
        }
    }
}
