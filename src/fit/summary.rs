//! What a fit says about itself: the summary of its held-out errors (stored in the grid's
//! manifest, printed by the CLI) and its convergence. The report writes the diagnostics
//! files from these.

use super::{CellFit, Fit, Level};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitSummary {
    pub active_cells: usize,
    pub cells_level0: usize,
    pub cells_level2: usize,
    /// Cells whose fitted map lost to the fallback on held-out queries (kept the fallback).
    pub kept_fallback: usize,
    /// Cells whose first check positions could not tell their maps from the fallback, so
    /// that more decided (`FitSettings::extra_check_positions`).
    #[serde(default)]
    pub cells_more_checked: usize,
    pub bytes_level2: usize,
    /// Stored cells keep a rough map beside their map (`bytes_level2` counts both).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub rough_maps: bool,
    pub fit_seconds: f64,
    pub reference_rays: u64,
    pub evaluations: u64,
    pub fallback_method: String,
    /// How the proxy was chosen (and, measured, the box's and the k-DOP's errors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proxy: Option<super::proxy::ProxyOutcome>,
    pub mean_check_err_warp1: f64,
    pub mean_check_err_fallback: f64,
    pub mean_check_err_celldepth: f64,
    pub mean_check_err_stored: f64,
    /// Diffuse correctives: cells fitted, cells storing a map, and the fitted cells' mean
    /// tone-mapped RMSE on their check points without and with what they store.
    pub diffuse_cells_fitted: usize,
    pub diffuse_cells_stored: usize,
    pub diffuse_check_before: f64,
    pub diffuse_check_after: f64,
    /// Each candidate surface bias of the diffuse blend: the blend's and the corrected
    /// field's tone-mapped RMSE (the stored bias is the smallest within 1% of the lowest
    /// corrected check error).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub diffuse_bias_trials: Vec<super::irradiance::BiasTrial>,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub diffuse_surface_bias: f32,
    /// Where the fit's time went.
    #[serde(default)]
    pub times: super::FitTimes,
    /// The level-1 comparison, when the fit measured it (`FitSettings::level1`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level1: Option<Level1Summary>,
    /// The resolution study, when the fit measured it (`FitSettings::resolution_study`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolutions: Option<ResolutionSummary>,
}

/// What per-cell map resolution would give, by two-fold cross-validation over each cell's
/// check positions ([`super::ResolutionStudy`]): a selection chooses on one half and is judged
/// on the other, both ways round, and errors and bytes are the two folds' means.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ResolutionSummary {
    pub cells: usize,
    /// The fit's own resolution.
    pub map_res: u32,
    /// One row per way of storing maps: the fallback everywhere, a map of each studied
    /// resolution everywhere, the stored selection's rule at the fit's resolution, and the
    /// per-cell choice over every resolution, and over those up to the fit's, at each
    /// tolerance of [`STUDY_TOLERANCES`].
    pub rows: Vec<ResolutionRow>,
}

/// One way of storing maps in the resolution study.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ResolutionRow {
    pub name: String,
    /// Mean held-out relative error per cell, on the half that did not choose.
    pub mean_err: f64,
    /// Bytes of the maps stored (f32), and cells storing a map of each studied resolution
    /// (the folds' means).
    pub bytes: f64,
    pub cells_per_res: Vec<f64>,
}

/// Tolerances of the per-cell resolution choice: a cell stores the cheapest model (nothing,
/// then the smallest map) whose error on the choosing half is within this fraction of the
/// best there.
pub const STUDY_TOLERANCES: [f64; 2] = [0.0, 0.02];

fn resolution_summary(fit: &Fit) -> Option<ResolutionSummary> {
    use super::STUDY_RESOLUTIONS as RES;
    let cells: Vec<&super::ResolutionStudy> = fit.cells.iter().filter_map(|c| c.resolutions.as_deref()).collect();
    if cells.is_empty() {
        return None;
    }
    let n = cells.len() as f64;
    let bytes_of = |k: usize| if k == 0 { 0 } else { RES[k - 1] as usize * RES[k - 1] as usize * 4 };
    // a rule picks a candidate (0 = fallback, k = RES[k - 1]) from the choosing half's errors
    let row = |name: String, pick: &dyn Fn(&[f64]) -> usize| {
        let (mut err, mut bytes, mut per_res) = (0.0, 0.0, vec![0.0; RES.len()]);
        for c in &cells {
            for fold in 0..2 {
                let k = pick(&c.errors[fold]);
                err += c.errors[1 - fold][k] / 2.0;
                bytes += bytes_of(k) as f64 / 2.0;
                if k > 0 {
                    per_res[k - 1] += 0.5;
                }
            }
        }
        ResolutionRow { name, mean_err: err / n, bytes, cells_per_res: per_res }
    };
    // the cheapest of `candidates` within `tol` of their best
    let cheapest = |e: &[f64], candidates: &[usize], tol: f64| -> usize {
        let best = candidates.iter().map(|&k| e[k]).fold(f64::INFINITY, f64::min);
        candidates.iter().copied().find(|&k| e[k] <= best * (1.0 + tol)).unwrap_or(0)
    };
    let own = RES.iter().position(|&r| r == fit.settings.map_res).map(|i| i + 1);
    let all: Vec<usize> = (0..=RES.len()).collect();
    let mut rows = vec![row("the proxy alone".into(), &|_| 0)];
    for k in 1..=RES.len() {
        rows.push(row(format!("a {0}×{0} map everywhere", RES[k - 1]), &|_| k));
    }
    if let Some(own) = own {
        let margin = fit.settings.selection_margin;
        rows.push(row(format!("stored rule at {0}×{0} (a map where it beats the proxy)", RES[own - 1]), &|e| {
            if e[own] < margin.min(1.0) * e[0] { own } else { 0 }
        }));
    }
    // every resolution, and those up to the fit's own (a choice that never grows a map)
    let up_to_own: Vec<usize> = (0..=RES.len()).filter(|&k| k == 0 || RES[k - 1] <= fit.settings.map_res).collect();
    for tol in STUDY_TOLERANCES {
        rows.push(row(format!("per-cell resolution, the cheapest within {:.0}% of the best", 100.0 * tol), &|e| {
            cheapest(e, &all, tol)
        }));
        let name = format!(
            "per-cell resolution up to {0}×{0}, the cheapest within {1:.0}% of the best",
            fit.settings.map_res,
            100.0 * tol
        );
        rows.push(row(name, &|e| cheapest(e, &up_to_own, tol)));
    }
    Some(ResolutionSummary { cells: cells.len(), map_res: fit.settings.map_res, rows })
}

/// Level 1 against the fallback and the fitted map on the cells' check queries, and what a
/// selection over all three would store: per cell the cheapest of {fallback: 0 bytes, level
/// 1: 20 bytes, map: 4·N² bytes} within the selection margin (`FitSettings::selection_margin`; with 1, the default, the best) of the best of them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Level1Summary {
    pub cells: usize,
    pub mean_check_err_level1: f64,
    /// The fitted map in every cell (before selection).
    pub mean_check_err_map: f64,
    /// Cells where level 1 beats the fallback by the selection margin.
    pub beats_fallback: usize,
    /// Cells where level 1 is within the margin of the map.
    pub within_margin_of_map: usize,
    /// Cells where level 1 has the lowest error of the three.
    pub best_of_three: usize,
    /// The three-way selection: cells per level (0, 1, 2), its mean check error and bytes,
    /// against the stored (two-way) selection's.
    pub chosen: [usize; 3],
    pub mean_check_err_chosen: f64,
    pub bytes_chosen: usize,
    pub mean_check_err_stored: f64,
    pub bytes_stored: usize,
    /// Objective evaluations and cell CPU seconds level 1 took (a quarter of the training
    /// queries each).
    pub evaluations: u64,
}

/// Bytes of a level-1 corrective: offset (3), depth mip and relaxation, f32.
pub const LEVEL1_BYTES: usize = 20;

fn level1_summary(fit: &Fit) -> Option<Level1Summary> {
    let cells: Vec<(&CellFit, &super::Level1Fit)> =
        fit.cells.iter().filter_map(|c| c.level1.as_deref().map(|l| (c, l))).collect();
    if cells.is_empty() {
        return None;
    }
    let n = cells.len() as f64;
    let maps_per_cell = if fit.correctives.has_rough_maps() { 2 } else { 1 };
    let map_bytes = (fit.settings.map_res * fit.settings.map_res) as usize * 4 * maps_per_cell;
    let margin = fit.settings.selection_margin;
    let (mut chosen, mut err, mut bytes) = ([0usize; 3], 0.0, 0usize);
    for (c, l) in &cells {
        let errs = [c.check_err_fallback, l.check_err, c.check_err_fitted];
        let best = errs.iter().copied().fold(f64::INFINITY, f64::min);
        // cheapest first; a stored model must also beat the fallback by the margin
        let pick = (0..3).find(|&k| errs[k] * margin <= best && (k == 0 || errs[k] < margin * errs[0])).unwrap_or(0);
        chosen[pick] += 1;
        err += errs[pick];
        bytes += [0, LEVEL1_BYTES, map_bytes][pick];
    }
    Some(Level1Summary {
        cells: cells.len(),
        mean_check_err_level1: cells.iter().map(|(_, l)| l.check_err).sum::<f64>() / n,
        mean_check_err_map: cells.iter().map(|(c, _)| c.check_err_fitted).sum::<f64>() / n,
        beats_fallback: cells.iter().filter(|(c, l)| l.check_err < margin * c.check_err_fallback).count(),
        within_margin_of_map: cells.iter().filter(|(c, l)| l.check_err * margin <= c.check_err_fitted).count(),
        best_of_three: cells
            .iter()
            .filter(|(c, l)| l.check_err < c.check_err_fitted && l.check_err < c.check_err_fallback)
            .count(),
        chosen,
        mean_check_err_chosen: err / n,
        bytes_chosen: bytes,
        mean_check_err_stored: cells.iter().map(|(c, _)| c.check_err_stored()).sum::<f64>() / n,
        bytes_stored: cells.iter().filter(|(c, _)| c.level == Level::Map).count() * map_bytes,
        evaluations: cells.iter().map(|(_, l)| l.evaluations).sum(),
    })
}

pub fn summary(fit: &Fit) -> FitSummary {
    let n = fit.cells.len().max(1) as f64;
    let ir = &fit.irradiance.cells;
    FitSummary {
        active_cells: fit.cells.len(),
        cells_level0: fit.cells.iter().filter(|c| c.level == Level::Fallback).count(),
        cells_level2: fit.cells.iter().filter(|c| c.level == Level::Map).count(),
        kept_fallback: fit.cells.iter().filter(|c| c.selection == super::Selection::KeptFallback).count(),
        cells_more_checked: fit.cells.iter().filter(|c| c.check_positions > fit.settings.check_positions).count(),
        bytes_level2: (fit.correctives.maps.len() + fit.correctives.rough_maps.len()) * 4,
        rough_maps: fit.correctives.has_rough_maps(),
        fit_seconds: fit.seconds,
        reference_rays: fit.reference_rays,
        evaluations: fit.cells.iter().map(|c| c.evaluations + c.rough_map.as_ref().map_or(0, |r| r.evaluations)).sum(),
        fallback_method: fit.correctives.fallback.name().to_string(),
        proxy: Some(fit.proxy),
        mean_check_err_warp1: fit.cells.iter().map(|c| c.check_err_warp1).sum::<f64>() / n,
        mean_check_err_fallback: fit.cells.iter().map(|c| c.check_err_fallback).sum::<f64>() / n,
        mean_check_err_celldepth: fit.cells.iter().map(|c| c.check_err_celldepth).sum::<f64>() / n,
        mean_check_err_stored: fit.cells.iter().map(CellFit::check_err_stored).sum::<f64>() / n,
        diffuse_cells_fitted: ir.len(),
        diffuse_cells_stored: ir.iter().filter(|c| c.stored).count(),
        diffuse_check_before: ir.iter().map(|c| c.check_before).sum::<f64>() / ir.len().max(1) as f64,
        diffuse_check_after: ir.iter().map(|c| if c.stored { c.check_after } else { c.check_before }).sum::<f64>()
            / ir.len().max(1) as f64,
        diffuse_bias_trials: fit.irradiance.bias_trials.clone(),
        diffuse_surface_bias: fit.irradiance.correction.surface_bias,
        times: fit.times,
        level1: level1_summary(fit),
        resolutions: resolution_summary(fit),
    }
}

impl CellFit {
    /// Held-out error of what the cell stores: its map at level 2, the fallback at level 0.
    pub fn check_err_stored(&self) -> f64 {
        match self.level {
            Level::Map => self.check_err_fitted,
            Level::Fallback => self.check_err_fallback,
        }
    }
}

/// Convergence of the fit: the mean training objective over active cells after each stage
/// (start, each Brent sweep or the whole solve, relaxation) against the wall-clock time the
/// whole grid takes to reach that stage (mean per-cell time × cells / threads).
pub fn convergence(fit: &Fit, threads: usize) -> Vec<(f64, f64)> {
    let stages = fit.cells.iter().map(|c| c.curve.len()).max().unwrap_or(0);
    let n = fit.cells.len().max(1) as f64;
    (0..stages)
        .map(|k| {
            let (mut t, mut cost) = (0.0, 0.0);
            for c in &fit.cells {
                let p = c.curve.get(k).or(c.curve.last()).copied().unwrap_or((0.0, 0.0));
                t += p.0;
                cost += p.1;
            }
            (t / threads.max(1) as f64, cost / n)
        })
        .collect()
}

/// Whether `x` is 0: fields added with a default of 0 are left out, so summaries written
/// before them keep their form (and the manifest holding them its checksum).
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_zero(x: &f32) -> bool {
    *x == 0.0
}
