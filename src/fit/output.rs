//! What a fit reports besides the fitted grid (`format::grid_io`): `residuals.json` (every
//! cell's held-out errors before and after, solver iterations, evaluations, termination and
//! time), `fit.md`, `residual_slices.png` (per grid layer, how much each cell's fit improved
//! on its fallback) and `fit_convergence.png`; and the summary stored in the manifest.

use super::{CellFit, Fit};
use crate::format::{FormatError, write_atomic};
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitSummary {
    pub active_cells: usize,
    pub cells_level0: usize,
    pub cells_level2: usize,
    pub fallbacks: usize,
    pub bytes_level2: usize,
    pub fit_seconds: f64,
    pub reference_rays: u64,
    pub evaluations: u64,
    pub fallback_method: String,
    pub mean_check_err_warp1: f64,
    pub mean_check_err_fallback: f64,
    pub mean_check_err_celldepth: f64,
    pub mean_check_err_stored: f64,
}

pub fn summary(fit: &Fit) -> FitSummary {
    let n = fit.cells.len().max(1) as f64;
    let stored = |c: &CellFit| if c.level == 2 { c.check_err_fitted } else { c.check_err_fallback };
    FitSummary {
        active_cells: fit.cells.len(),
        cells_level0: fit.cells.iter().filter(|c| c.level == 0).count(),
        cells_level2: fit.cells.iter().filter(|c| c.level == 2).count(),
        fallbacks: fit.cells.iter().filter(|c| c.reason.starts_with("fallback")).count(),
        bytes_level2: fit.correctives.maps.len() * 4,
        fit_seconds: fit.seconds,
        reference_rays: fit.reference_rays,
        evaluations: fit.cells.iter().map(|c| c.evaluations).sum(),
        fallback_method: fit.correctives.fallback.name().to_string(),
        mean_check_err_warp1: fit.cells.iter().map(|c| c.check_err_warp1).sum::<f64>() / n,
        mean_check_err_fallback: fit.cells.iter().map(|c| c.check_err_fallback).sum::<f64>() / n,
        mean_check_err_celldepth: fit.cells.iter().map(|c| c.check_err_celldepth).sum::<f64>() / n,
        mean_check_err_stored: fit.cells.iter().map(stored).sum::<f64>() / n,
    }
}

/// Writes `residuals.json`, `residual_slices.png` and `fit_convergence.png` into `dir`
/// (the fitted grid itself is written by `format::grid_io`).
pub fn write_fit_diagnostics(dir: &Path, fit: &Fit) -> Result<(), FormatError> {
    write_json(&dir.join("residuals.json"), &fit.cells)?;
    write_residual_slices(&dir.join("residual_slices.png"), fit)?;
    write_convergence(&dir.join("fit_convergence.png"), fit, rayon::current_num_threads())
}

/// Pretty JSON, written atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), FormatError> {
    let bytes = serde_json::to_vec_pretty(value)
        .map_err(|e| FormatError::Json { path: path.to_path_buf(), message: e.to_string() })?;
    write_atomic(path, &bytes).map_err(|source| FormatError::Io { path: path.to_path_buf(), source })
}

/// Residual heat-map slices: one tile per grid layer (y), cells coloured by held-out error
/// after the fit relative to the fallback (green: better, grey: unchanged or level 0,
/// black: inside geometry), 8 pixels per cell; layers side by side, bottom layer left.
pub fn write_residual_slices(path: &Path, fit: &Fit) -> Result<(), FormatError> {
    let g = fit.correctives.geometry;
    let (nx, ny, nz) = (g.counts.x as usize, g.counts.y as usize, g.counts.z as usize);
    let px = 8usize;
    let gap = 4usize;
    let (w, h) = (ny * (nx * px + gap), nz * px);
    let mut rgb = vec![255u8; w * h * 3];
    let mut colour = vec![[0u8, 0, 0]; g.cell_count()];
    for c in &fit.cells {
        let ratio =
            if c.level == 2 { (c.check_err_fitted / c.check_err_fallback.max(1e-12)).clamp(0.0, 1.0) } else { 1.0 };
        // ratio 1 → grey, ratio 0 → saturated green
        let t = (1.0 - ratio) as f32;
        colour[c.cell as usize] = [(160.0 * (1.0 - t)) as u8, (160.0 + 95.0 * t) as u8, (160.0 * (1.0 - t)) as u8];
    }
    for cell in 0..g.cell_count() {
        let cc = g.cell_coords(cell);
        let (x, y, z) = (cc.x as usize, cc.y as usize, cc.z as usize);
        for dy in 0..px {
            for dx in 0..px {
                let (ix, iy) = (y * (nx * px + gap) + x * px + dx, (nz - 1 - z) * px + dy);
                let k = (iy * w + ix) * 3;
                rgb[k..k + 3].copy_from_slice(&colour[cell]);
            }
        }
    }
    crate::preview::write_png(path, w as u32, h as u32, &rgb)
}

/// `fit.md`: what was stored where and what it bought, the histogram of per-cell
/// improvement, and the worst cells with what explains them.
pub fn write_fit_report(path: &Path, fit: &Fit, command: &str) -> Result<(), FormatError> {
    use std::fmt::Write as _;
    let s = summary(fit);
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Fit report\n\nProduced by `{command}`. The fitted grid is `manifest.json` beside this file (`warpfit inspect` summarises it).\n"
    );
    let _ = writeln!(
        md,
        "Solver {:?}, {} s, {} reference rays, {} objective evaluations.\n",
        fit.settings.solver, s.fit_seconds as f32, s.reference_rays, s.evaluations
    );
    let _ = writeln!(md, "| level | cells | bytes | meaning |\n|---|---:|---:|---|");
    let _ = writeln!(
        md,
        "| 0 | {} | 0 | grid fallback `{}` (chosen by held-out error) |",
        s.cells_level0, s.fallback_method
    );
    let _ = writeln!(
        md,
        "| 2 | {} | {} | {}×{} warp map, f32 inverse distance |",
        s.cells_level2, s.bytes_level2, fit.settings.map_res, fit.settings.map_res
    );
    let _ = writeln!(
        md,
        "| left out | {} | 0 | inside geometry |\n",
        fit.correctives.geometry.cell_count() - s.active_cells
    );
    let _ = writeln!(
        md,
        "Mean held-out relative error per active cell: warp1 {:.4}, fallback {:.4}, celldepth {:.4}, stored model {:.4}.\n",
        s.mean_check_err_warp1, s.mean_check_err_fallback, s.mean_check_err_celldepth, s.mean_check_err_stored
    );
    let _ = writeln!(md, "## Stored error / fallback error per cell (level-2 cells)\n\n| ratio | cells |\n|---|---:|");
    let mut buckets = [0usize; 10];
    for c in fit.cells.iter().filter(|c| c.level == 2) {
        let r = (c.check_err_fitted / c.check_err_fallback.max(1e-12)).clamp(0.0, 0.999);
        buckets[(r * 10.0) as usize] += 1;
    }
    for (k, n) in buckets.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {:.1}–{:.1} | {} {} |",
            k as f32 / 10.0,
            (k + 1) as f32 / 10.0,
            n,
            "█".repeat((*n).div_ceil(20))
        );
    }
    let _ = writeln!(
        md,
        "\n## Worst cells after the fit\n\n| cell | level | stored error | fallback | celldepth | hidden from A | start | why |\n|---:|---:|---:|---:|---:|---:|---|---|"
    );
    let stored_err = |c: &CellFit| if c.level == 2 { c.check_err_fitted } else { c.check_err_fallback };
    let mut worst: Vec<&CellFit> = fit.cells.iter().collect();
    worst.sort_by(|a, b| stored_err(b).total_cmp(&stored_err(a)));
    for c in worst.iter().take(12) {
        let why = if c.hidden_fraction > 0.3 {
            format!("{:.0}% of its queries hit points probe A cannot see; {}", 100.0 * c.hidden_fraction, c.reason)
        } else {
            c.reason.clone()
        };
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.0}% | {} | {} |",
            c.cell,
            c.level,
            stored_err(c),
            c.check_err_fallback,
            c.check_err_celldepth,
            100.0 * c.hidden_fraction,
            c.start,
            why
        );
    }
    let _ = writeln!(md, "\n## Convergence\n\n| fit time (s) | mean training objective |\n|---:|---:|");
    for (t, c) in convergence(fit, rayon::current_num_threads()) {
        let _ = writeln!(md, "| {t:.2} | {c:.4} |");
    }
    let _ = writeln!(md, "\n![convergence](fit_convergence.png)");
    let _ = writeln!(
        md,
        "\n![residual slices](residual_slices.png)\n\nSlices: one tile per grid layer (bottom layer left), x to the right, z up; green = the stored map improves on the fallback (saturated: error → 0), grey = fallback, black = inside geometry."
    );
    write_atomic(path, md.as_bytes()).map_err(|source| FormatError::Io { path: path.to_path_buf(), source })
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

/// `fit_convergence.png`.
pub fn write_convergence(path: &Path, fit: &Fit, threads: usize) -> Result<(), FormatError> {
    let series = vec![(format!("{:?}", fit.settings.solver), convergence(fit, threads))];
    crate::report::plot::line_plot(
        path,
        "Fit convergence: mean training objective per cell",
        "fit time on this machine (s, references excluded)",
        "training objective",
        &series,
    )
}
