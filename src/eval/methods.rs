//! Every method's row of the evaluation: the seed methods and the oracle, corrective grids
//! (fitted and unfitted), and a loaded fitted grid through the runtime sampler.

use super::metrics::{error_stats, mean_angle_deg};
use super::timing::{self, time_fetch};
use super::validation::ValidationSet;
use crate::runtime::FittedGrid;
use crate::warp::corrective::{Blend, Correctives};
use crate::warp::reproject::reproject;
use crate::warp::{Method, Warp};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Error and cost of one method on the validation set. Keys as in `eval.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MethodResult {
    pub name: String,
    /// RMSE of linear RGB radiance over the mean reference radiance.
    pub rel_rmse: f64,
    /// Mean absolute error (mean over RGB), radiance units.
    pub mae: f64,
    /// 95th percentile of the per-lookup error (mean abs over RGB).
    pub p95: f64,
    pub max: f64,
    /// Mean angle between the method's fetch direction and the oracle's, degrees (null for
    /// methods without a single fetch direction).
    pub angular_deg: Option<f64>,
    /// Single-threaded warm-loop cost per lookup, queries in coherent order (see
    /// `timing::timing_order`).
    pub ns_per_lookup: f64,
    /// The same with queries in random order (cache-hostile).
    pub ns_per_lookup_random: f64,
    /// Per lookup through the method's batch API (queries in coherent order, [`LANES`](crate::octa::LANES)
    /// lookups in lockstep), for methods that have one.
    #[serde(default)]
    pub ns_per_lookup_batched: Option<f64>,
    pub note: String,
}

/// The corrective grids the evaluation judges beside the warp methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CorrectiveVariant {
    /// Unfitted maps from the grid's raytraced distances in every active cell.
    Celldepth,
    /// The fitted grid as stored (maps where selection kept them), containing cell.
    Fitted,
    /// The fitted map of every active cell, before model selection.
    FittedL2All,
    /// The fitted grid as stored, blended over 8 cells.
    FittedTrilinear,
}

impl CorrectiveVariant {
    pub const ALL: [CorrectiveVariant; 4] = [
        CorrectiveVariant::Celldepth,
        CorrectiveVariant::Fitted,
        CorrectiveVariant::FittedL2All,
        CorrectiveVariant::FittedTrilinear,
    ];

    pub fn name(self) -> &'static str {
        match self {
            CorrectiveVariant::Celldepth => "celldepth",
            CorrectiveVariant::Fitted => "fitted",
            CorrectiveVariant::FittedL2All => "fitted-L2-all",
            CorrectiveVariant::FittedTrilinear => "fitted-trilinear",
        }
    }

    pub fn note(self) -> &'static str {
        match self {
            CorrectiveVariant::Celldepth => "unfitted warp maps from the grid's raytraced distances, containing cell",
            CorrectiveVariant::Fitted => "fitted warp maps (levels as stored), containing cell",
            CorrectiveVariant::FittedL2All => {
                "level 2 in every active cell (fitted maps before model selection), containing cell"
            }
            CorrectiveVariant::FittedTrilinear => "fitted warp maps (levels as stored), trilinear blend of 8 cells",
        }
    }

    pub fn blend(self) -> Blend {
        match self {
            CorrectiveVariant::FittedTrilinear => Blend::Trilinear,
            _ => Blend::Cell,
        }
    }
}

/// A corrective grid and the variant it is judged as.
#[derive(Clone, Copy)]
pub struct CorrectiveRow<'a> {
    pub variant: CorrectiveVariant,
    pub correctives: &'a Correctives,
}

/// One table row from a method's radiance estimates, its fetch directions (none for
/// methods without a single fetch) and its coherent/random-order costs.
fn method_row(
    set: &ValidationSet,
    name: &str,
    note: String,
    est: &[Vec3],
    dirs: Option<&[Vec3]>,
    (ns_per_lookup, ns_per_lookup_random): (f64, f64),
) -> MethodResult {
    let e = error_stats(est, &set.reference);
    MethodResult {
        name: name.into(),
        rel_rmse: e.rel_rmse,
        mae: e.mae,
        p95: e.p95,
        max: e.max,
        angular_deg: dirs.map(|d| mean_angle_deg(d, &set.oracle_dir)),
        ns_per_lookup,
        ns_per_lookup_random,
        ns_per_lookup_batched: None,
        note,
    }
}

/// Fetch directions of a per-lookup method for the whole set (parallel, deterministic).
pub fn fetch_dirs(warp: &Warp, set: &ValidationSet, method: Method) -> Vec<Vec3> {
    if method == Method::Oracle {
        return set.oracle_dir.clone();
    }
    (0..set.dirs.len()).into_par_iter().map(|k| warp.fetch_dir(method, set.position_of(k), set.dirs[k])).collect()
}

/// Radiance estimates of `reproject` (one reprojected probe per position).
pub fn reproject_estimates(warp: &Warp, set: &ValidationSet) -> Vec<Vec3> {
    let res = warp.probe.radiance.levels[0].res;
    let per_pos: Vec<Vec<Vec3>> = set
        .positions
        .par_iter()
        .enumerate()
        .map(|(k, &b)| {
            let map = reproject(&warp.probe, b, res);
            (0..set.dirs_per_position).map(|d| map.bilinear(set.dirs[k * set.dirs_per_position + d])).collect()
        })
        .collect();
    per_pos.into_iter().flatten().collect()
}

/// Evaluates `methods`; errors on the whole set, timings single-threaded.
pub fn evaluate_methods(
    warp: &Warp,
    set: &ValidationSet,
    methods: &[Method],
    timing_lookups: usize,
) -> Vec<MethodResult> {
    methods
        .iter()
        .map(|&m| {
            if m == Method::Reproject {
                let est = reproject_estimates(warp, set);
                // one per-location pass serves a location's lookups in any order: timed once
                let ns = timing::time_reproject(warp, set);
                let note = format!(
                    "per-location scatter + push-pull amortised over {} lookups per location",
                    set.dirs_per_position
                );
                return method_row(set, m.name(), note, &est, None, (ns, ns));
            }
            let dirs = fetch_dirs(warp, set, m);
            let est: Vec<Vec3> = dirs.par_iter().map(|&d| warp.probe.radiance(d)).collect();
            let note = match m {
                Method::Oracle => "bound: fetch towards the true hit traced from B (tracing cost not counted)".into(),
                Method::Box => "scene bounds as the box; query direction outside it".into(),
                Method::Kdop => "18-DOP fitted to the probe's depth samples".into(),
                _ => String::new(),
            };
            let ns = time_fetch(warp, set, timing_lookups, |b, dir, oracle| {
                if m == Method::Oracle { oracle } else { warp.fetch_vector(m, b, dir) }
            });
            let mut row = method_row(set, m.name(), note, &est, Some(&dirs), ns);
            if m == Method::Warp1 && warp.options.relax_texels == 0.0 {
                row.ns_per_lookup_batched = Some(timing::time_warp1_batched(warp, set, timing_lookups));
            }
            row
        })
        .collect()
}

/// Error and cost of a corrective grid, as one table row.
pub fn evaluate_correctives(
    warp: &Warp,
    set: &ValidationSet,
    row: CorrectiveRow,
    timing_lookups: usize,
) -> MethodResult {
    let blend = row.variant.blend();
    let fetch = |b: Vec3, dir: Vec3| row.correctives.fetch_vector(blend, warp, b, dir);
    let vectors: Vec<Vec3> =
        (0..set.dirs.len()).into_par_iter().map(|k| fetch(set.position_of(k), set.dirs[k])).collect();
    let est: Vec<Vec3> = vectors.par_iter().map(|&v| warp.probe.radiance(v)).collect();
    let dirs: Vec<Vec3> = vectors.iter().zip(&set.dirs).map(|(v, d)| v.try_normalize().unwrap_or(*d)).collect();
    let ns = time_fetch(warp, set, timing_lookups, |b, d, _| fetch(b, d));
    method_row(set, row.variant.name(), row.variant.note().into(), &est, Some(&dirs), ns)
}

/// A loaded fitted grid (`runtime::FittedGrid`) on the validation set: mirror queries
/// (roughness 0), timed through `specular` itself.
pub fn evaluate_runtime(set: &ValidationSet, grid: &FittedGrid, timing_lookups: usize) -> MethodResult {
    let est: Vec<Vec3> =
        (0..set.dirs.len()).into_par_iter().map(|k| grid.specular(set.position_of(k), set.dirs[k], 0.0)).collect();
    let dirs: Vec<Vec3> = (0..set.dirs.len())
        .map(|k| grid.fetch_vector(set.position_of(k), set.dirs[k]).try_normalize().unwrap_or(set.dirs[k]))
        .collect();
    let specular = |b, d, _| grid.specular(b, d, 0.0);
    let ns = (
        timing::time_queries(set, timing_lookups, false, specular),
        timing::time_queries(set, timing_lookups, true, specular),
    );
    let f16 =
        grid.manifest.payloads.iter().flat_map(|p| &p.layers).any(|l| l.precision == crate::runtime::Precision::F16);
    let note = format!(
        "the fitted grid loaded from disk ({}), runtime::FittedGrid::specular at roughness 0",
        if f16 { "f16 radiance" } else { "f32" }
    );
    method_row(set, "runtime", note, &est, Some(&dirs), ns)
}
