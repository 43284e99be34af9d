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
    pub bytes_level2: usize,
    pub fit_seconds: f64,
    pub reference_rays: u64,
    pub evaluations: u64,
    pub fallback_method: String,
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
    /// Where the fit's time went.
    #[serde(default)]
    pub times: super::FitTimes,
}

pub fn summary(fit: &Fit) -> FitSummary {
    let n = fit.cells.len().max(1) as f64;
    let ir = &fit.irradiance.cells;
    FitSummary {
        active_cells: fit.cells.len(),
        cells_level0: fit.cells.iter().filter(|c| c.level == Level::Fallback).count(),
        cells_level2: fit.cells.iter().filter(|c| c.level == Level::Map).count(),
        kept_fallback: fit.cells.iter().filter(|c| c.selection == super::Selection::KeptFallback).count(),
        bytes_level2: fit.correctives.maps.len() * 4,
        fit_seconds: fit.seconds,
        reference_rays: fit.reference_rays,
        evaluations: fit.cells.iter().map(|c| c.evaluations).sum(),
        fallback_method: fit.correctives.fallback.name().to_string(),
        mean_check_err_warp1: fit.cells.iter().map(|c| c.check_err_warp1).sum::<f64>() / n,
        mean_check_err_fallback: fit.cells.iter().map(|c| c.check_err_fallback).sum::<f64>() / n,
        mean_check_err_celldepth: fit.cells.iter().map(|c| c.check_err_celldepth).sum::<f64>() / n,
        mean_check_err_stored: fit.cells.iter().map(CellFit::check_err_stored).sum::<f64>() / n,
        diffuse_cells_fitted: ir.len(),
        diffuse_cells_stored: ir.iter().filter(|c| c.stored).count(),
        diffuse_check_before: ir.iter().map(|c| c.check_before).sum::<f64>() / ir.len().max(1) as f64,
        diffuse_check_after: ir.iter().map(|c| if c.stored { c.check_after } else { c.check_before }).sum::<f64>()
            / ir.len().max(1) as f64,
        times: fit.times,
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
