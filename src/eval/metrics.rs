//! Error statistics of radiance estimates against references, and the fitted grid's error
//! split by the level of each query's cell.

use super::validation::ValidationSet;
use crate::warp::Warp;
use crate::warp::corrective::{Blend, Correctives};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Error statistics of one set of estimates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    /// RMSE of linear RGB over the mean reference radiance.
    pub rel_rmse: f64,
    /// Mean absolute error (mean over RGB), radiance units.
    pub mae: f64,
    /// 95th percentile of the per-lookup error (mean abs over RGB).
    pub p95: f64,
    pub max: f64,
}

/// Per-lookup error statistics of `estimate` against `reference`.
pub fn error_stats(estimate: &[Vec3], reference: &[Vec3]) -> ErrorStats {
    let n = estimate.len().max(1) as f64;
    let mut sq = 0.0f64;
    let mut abs = Vec::with_capacity(estimate.len());
    let mut ref_sum = 0.0f64;
    for (e, r) in estimate.iter().zip(reference) {
        let d = *e - *r;
        sq += (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2);
        abs.push(((d.x.abs() + d.y.abs() + d.z.abs()) / 3.0) as f64);
        ref_sum += ((r.x + r.y + r.z) / 3.0) as f64;
    }
    let rmse = (sq / (3.0 * n)).sqrt();
    let mean_ref = (ref_sum / n).max(1e-30);
    let mae = abs.iter().sum::<f64>() / n;
    abs.sort_by(f64::total_cmp);
    let p95 = abs.get(((abs.len() as f64 * 0.95) as usize).min(abs.len().saturating_sub(1))).copied().unwrap_or(0.0);
    let max = abs.last().copied().unwrap_or(0.0);
    ErrorStats { rel_rmse: rmse / mean_ref, mae, p95, max }
}

/// Mean angle between paired unit vectors, in degrees.
#[must_use]
pub fn mean_angle_deg(a: &[Vec3], b: &[Vec3]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| (x.dot(*y).clamp(-1.0, 1.0) as f64).acos().to_degrees()).sum();
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
}

/// `c` (containing-cell lookup) on the validation lookups split by the level of their
/// position's cell.
#[must_use]
pub fn level_errors(warp: &Warp, set: &ValidationSet, c: &Correctives) -> Vec<LevelEval> {
    let mut out = Vec::new();
    for stores_map in [false, true] {
        let (mut fit_est, mut fb_est, mut refs) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..set.dirs.len() {
            let b = set.position_of(k);
            if c.stores_map(c.geometry.cell_index(c.geometry.cell_of(b))) != stores_map {
                continue;
            }
            let d = set.dirs[k];
            fit_est.push(warp.probe.radiance(c.fetch_vector(Blend::Cell, warp, b, d)));
            fb_est.push(warp.lookup(c.fallback, b, d));
            refs.push(set.reference[k]);
        }
        if !refs.is_empty() {
            out.push(LevelEval {
                level: if stores_map { 2 } else { 0 },
                lookups: refs.len(),
                fitted_rel_rmse: error_stats(&fit_est, &refs).rel_rmse,
                fallback: c.fallback.name().to_string(),
                fallback_rel_rmse: error_stats(&fb_est, &refs).rel_rmse,
            });
        }
    }
    out
}
