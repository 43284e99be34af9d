//! Error statistics of radiance estimates against references, and the fitted grid's error
//! split by the level of each query's cell.

use super::validation::ValidationSet;
use crate::tonemap::reinhard;
use crate::warp::Warp;
use crate::warp::corrective::{Blend, Correctives};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Error statistics of one set of estimates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    /// RMSE of linear RGB over the mean reference radiance.
    pub rel_rmse: f64,
    /// RMSE of RGB after tone mapping estimate and reference alike (`tonemap::reinhard` at
    /// the scene's key exposure): each lookup's error is bounded, so a few samples of a lamp
    /// or the sun cannot rule it.
    pub tm_rmse: f64,
    /// Mean absolute error (mean over RGB), radiance units.
    pub mae: f64,
    /// 95th percentile of the per-lookup error (mean abs over RGB).
    pub p95: f64,
    pub max: f64,
}

/// Per-lookup error statistics of `estimate` against `reference`; `exposure` is the tone
/// mapping's (see [`ErrorStats::tm_rmse`]).
pub fn error_stats(estimate: &[Vec3], reference: &[Vec3], exposure: f32) -> ErrorStats {
    let n = estimate.len().max(1) as f64;
    let mut sq = 0.0f64;
    let mut abs = Vec::with_capacity(estimate.len());
    let mut ref_sum = 0.0f64;
    let mut tm_sq = 0.0f64;
    for (e, r) in estimate.iter().zip(reference) {
        let d = *e - *r;
        sq += (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2);
        let t = reinhard(*e, exposure) - reinhard(*r, exposure);
        tm_sq += (t.x as f64).powi(2) + (t.y as f64).powi(2) + (t.z as f64).powi(2);
        abs.push(((d.x.abs() + d.y.abs() + d.z.abs()) / 3.0) as f64);
        ref_sum += ((r.x + r.y + r.z) / 3.0) as f64;
    }
    let rmse = (sq / (3.0 * n)).sqrt();
    let mean_ref = (ref_sum / n).max(1e-30);
    let mae = abs.iter().sum::<f64>() / n;
    abs.sort_by(f64::total_cmp);
    let p95 = abs.get(((abs.len() as f64 * 0.95) as usize).min(abs.len().saturating_sub(1))).copied().unwrap_or(0.0);
    let max = abs.last().copied().unwrap_or(0.0);
    ErrorStats { rel_rmse: rmse / mean_ref, tm_rmse: (tm_sq / (3.0 * n)).sqrt(), mae, p95, max }
}

/// A query whose reference is at least this share light seen straight from an emitter is
/// an emitter query: a lamp seen in the lobe, whose few bright samples rule a linear error
/// (`BucketSummary::emitter_queries` counts them).
pub const EMITTER_QUERY: f32 = 0.5;

/// Relative RMSE of the light apart from the emitters: every lookup and every reference
/// with its part seen straight from an emitter taken out (`estimate_emitted`: the same
/// lookups of probe A's emitted chain, `bake::probe::emitted_mips`; `reference_emitted`:
/// the references' own, `TracedQueries::emitted`), over every query. A lamp read where the
/// reference sees none, or seen where the lookup reads none, then costs nothing here, and
/// the light the lamps send onto the surfaces counts as any light does. Parts below 0
/// (a non-linear lookup, a sanitised sample) count as 0.
#[must_use]
pub fn rel_rmse_emitters_apart(
    estimate: &[Vec3],
    estimate_emitted: &[Vec3],
    reference: &[Vec3],
    reference_emitted: &[Vec3],
) -> f64 {
    let apart =
        |a: &[Vec3], b: &[Vec3]| -> Vec<Vec3> { a.iter().zip(b).map(|(x, y)| (*x - *y).max(Vec3::ZERO)).collect() };
    error_stats(&apart(estimate, estimate_emitted), &apart(reference, reference_emitted), 1.0).rel_rmse
}

/// Mean angle between paired unit vectors, in degrees.
#[must_use]
pub fn mean_angle_deg(a: &[Vec3], b: &[Vec3]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| libm::acos(x.dot(*y).clamp(-1.0, 1.0) as f64).to_degrees()).sum();
    sum / a.len().max(1) as f64
}

/// The fitted grid's error on the validation lookups whose position lies in cells of one
/// level, next to the grid's fallback method on the same lookups.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LevelEval {
    pub level: u8,
    pub lookups: usize,
    pub fitted_rel_rmse: f64,
    pub fallback: String,
    pub fallback_rel_rmse: f64,
    /// Tone-mapped RMSE (the fit's objective's measure) of both (0 in older eval.json).
    #[serde(default)]
    pub fitted_tm_rmse: f64,
    #[serde(default)]
    pub fallback_tm_rmse: f64,
}

/// `c` (containing-cell lookup) on the validation lookups split by the level of their
/// position's cell.
#[must_use]
pub fn level_errors(warp: &Warp, set: &ValidationSet, c: &Correctives, exposure: f32) -> Vec<LevelEval> {
    let mut out = Vec::new();
    for stores_map in [false, true] {
        let (mut fit_est, mut fb_est, mut refs) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..set.dirs.len() {
            let b = set.position_of(k);
            if c.stores_map(c.geometry.cell_index(c.geometry.cell_of(b))) != stores_map {
                continue;
            }
            let d = set.dirs[k];
            let aim = c.fetch(Blend::Cell, warp, b, d, 0.0);
            fit_est.push(warp.probe_at(aim.probe.into()).radiance(aim.v));
            fb_est.push(warp.lookup(c.fallback, b, d));
            refs.push(set.reference[k]);
        }
        if !refs.is_empty() {
            let (fitted, fallback) = (error_stats(&fit_est, &refs, exposure), error_stats(&fb_est, &refs, exposure));
            out.push(LevelEval {
                level: if stores_map { 2 } else { 0 },
                lookups: refs.len(),
                fitted_rel_rmse: fitted.rel_rmse,
                fallback: c.fallback.name().to_string(),
                fallback_rel_rmse: fallback.rel_rmse,
                fitted_tm_rmse: fitted.tm_rmse,
                fallback_tm_rmse: fallback.tm_rmse,
            });
        }
    }
    out
}

/// Standard error that the references' own noise puts on the difference between two rows'
/// errors, `a` against `b` on the same references: (in rel RMSE, in tone-mapped RMSE).
///
/// RMSE_a = sqrt(Σ|a − ref|²/3N); a reference error ε_k moves it by −Σ_c(a_kc − ref_kc)ε_k/(3N·RMSE_a),
/// and the difference of two rows by the difference of those terms. With independent ε_k of
/// standard error σ_k (per query, luminance, applied to every channel) the variance of the
/// difference is Σ_k σ_k² g_k². The tone-mapped form propagates σ_k through the curve's slope.
pub fn difference_se(a: &[Vec3], b: &[Vec3], reference: &[Vec3], reference_se: &[f32], exposure: f32) -> (f64, f64) {
    let n = reference.len().max(1) as f64;
    let rmse = |x: &[Vec3], map: &dyn Fn(Vec3) -> Vec3| {
        let sq: f64 = x
            .iter()
            .zip(reference)
            .map(|(e, r)| {
                let d = map(*e) - map(*r);
                (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2)
            })
            .sum();
        (sq / (3.0 * n)).sqrt().max(1e-30)
    };
    let linear = |v: Vec3| v;
    let tm = |v: Vec3| reinhard(v, exposure);
    let var = |map: &dyn Fn(Vec3) -> Vec3, slope: &dyn Fn(Vec3) -> f64| {
        let (ma, mb) = (rmse(a, map), rmse(b, map));
        let mut v = 0.0f64;
        for k in 0..reference.len() {
            let (da, db) = (map(a[k]) - map(reference[k]), map(b[k]) - map(reference[k]));
            let g = (da.x + da.y + da.z) as f64 / (3.0 * n * ma) - (db.x + db.y + db.z) as f64 / (3.0 * n * mb);
            let sigma = reference_se[k] as f64 * slope(reference[k]);
            v += (sigma * g).powi(2);
        }
        v
    };
    let mean_ref = reference.iter().map(|r| ((r.x + r.y + r.z) / 3.0) as f64).sum::<f64>() / n;
    let rel = var(&linear, &|_| 1.0).sqrt() / mean_ref.max(1e-30);
    let tm_slope = |r: Vec3| {
        let y = crate::tonemap::luminance(r) * exposure;
        (exposure / (1.0 + y).powi(2)) as f64
    };
    (rel, var(&tm, &tm_slope).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lookup that reads a lamp the reference does not see, and a reference that sees a
    /// lamp the lookup misses, rule the relative RMSE; with the emitters apart only the rest
    /// of the light counts, and a lookup wrong in that rest is wrong there too.
    #[test]
    fn emitters_apart_leaves_out_the_lamps_and_nothing_else() {
        let wall = Vec3::splat(0.5);
        let lamp = Vec3::splat(500.0);
        let reference = [wall, wall + lamp, wall, wall];
        let reference_emitted = [Vec3::ZERO, lamp, Vec3::ZERO, Vec3::ZERO];
        // the lookup reads the lamp at query 0 (where the reference sees a wall) and misses it at 1
        let estimate = [wall + lamp, wall, wall, wall];
        let estimate_emitted = [lamp, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO];
        let all = error_stats(&estimate, &reference, 1.0).rel_rmse;
        assert!(all > 1.0, "{all}");
        assert_eq!(rel_rmse_emitters_apart(&estimate, &estimate_emitted, &reference, &reference_emitted), 0.0);
        // an error in the light apart from the lamps stays: wall 0.5 read as 0.25 at one query
        let wrong = [wall + lamp, wall, Vec3::splat(0.25), wall];
        let got = rel_rmse_emitters_apart(&wrong, &estimate_emitted, &reference, &reference_emitted);
        let want = error_stats(&[wall, wall, Vec3::splat(0.25), wall], &[wall; 4], 1.0).rel_rmse;
        assert!(got > 0.0 && (got - want).abs() < 1e-12, "{got} vs {want}");
        // no emitters anywhere: the relative RMSE itself
        let zero = [Vec3::ZERO; 4];
        let e = [wall, Vec3::splat(0.3), wall, wall];
        assert_eq!(rel_rmse_emitters_apart(&e, &zero, &[wall; 4], &zero), error_stats(&e, &[wall; 4], 1.0).rel_rmse);
    }
}
