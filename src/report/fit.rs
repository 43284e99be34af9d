//! A fit's diagnostics files: `residuals.json` (every cell's held-out errors before and
//! after, solver iterations, evaluations, termination and time), `fit.md`,
//! `residual_slices.png` (per grid layer, how much each cell's fit improved on its fallback)
//! and `fit_convergence.png`.

use super::folder::RunFolder;
use crate::files::{FileError, write_atomic, write_json};
use crate::fit::summary::{convergence, summary};
use crate::fit::{CellFit, Fit, Level};
use std::path::Path;

/// Writes `residuals.json`, `fit.md`, `residual_slices.png` and `fit_convergence.png`
/// (the fitted grid itself is written by `gridfile::write`).
pub fn write_fit_diagnostics(folder: &RunFolder, fit: &Fit, command: &str) -> Result<(), FileError> {
    write_json(&folder.residuals(), &fit.cells)?;
    write_fit_report(&folder.fit_md(), fit, command)?;
    write_residual_slices(&folder.residual_slices(), fit)?;
    write_convergence(&folder.fit_convergence(), fit, rayon::current_num_threads())
}

/// Residual heat-map slices: one panel per grid layer (y), each cell coloured by how much
/// its stored map lowers the held-out error of the fallback (`1 − fitted / fallback`), grey
/// where the cell keeps the fallback, black inside geometry; cell axes and a colour bar.
pub fn write_residual_slices(path: &Path, fit: &Fit) -> Result<(), FileError> {
    let g = fit.correctives.geometry;
    let (nx, ny, nz) = (g.counts.x as usize, g.counts.y as usize, g.counts.z as usize);
    let mut value = vec![None; g.cell_count()];
    let mut fallback = vec![false; g.cell_count()];
    for c in &fit.cells {
        let k = c.cell as usize;
        if c.level == Level::Map {
            value[k] = Some((1.0 - c.check_err_fitted / c.check_err_fallback.max(1e-12)).clamp(0.0, 1.0));
        } else {
            value[k] = Some(0.0);
            fallback[k] = true;
        }
    }
    let slices: Vec<crate::report::plot::Slice> = (0..ny)
        .map(|y| {
            let cells: Vec<usize> = (0..nz).flat_map(|z| (0..nx).map(move |x| x + nx * (y + ny * z))).collect();
            let (lo, hi) = (g.min.y + g.cell_size().y * y as f32, g.min.y + g.cell_size().y * (y + 1) as f32);
            crate::report::plot::Slice {
                title: format!("layer y = {y} (height {lo:.2} – {hi:.2})"),
                nx,
                nz,
                values: cells.iter().map(|&k| value[k]).collect(),
                fallback: cells.iter().map(|&k| fallback[k]).collect(),
            }
        })
        .collect();
    crate::report::plot::heatmap_slices(
        path,
        "held-out error removed by each cell's stored shift map, per grid layer",
        "share of the fallback's held-out error the stored map removes",
        &slices,
    )
}

/// `fit.md`: what was stored where and what it bought, the histogram of per-cell
/// improvement, and the worst cells with what explains them.
pub fn write_fit_report(path: &Path, fit: &Fit, command: &str) -> Result<(), FileError> {
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
    let t = &s.times;
    let _ = writeln!(
        md,
        "Time: cells {:.1} s (CPU {:.1} s, {:.1} s of it tracing references), surface points {:.1} s, their references {:.1} s, roughness correction {:.1} s, diffuse fit {:.1} s{}.\n",
        t.cells,
        t.cells_cpu,
        t.cells_tracing_cpu,
        t.surface_points,
        t.irradiance_references,
        t.roughness,
        t.irradiance_fit,
        t.counted()
    );
    diffuse_bias_table(&mut md, &s);
    levels_table(&mut md, fit, &s);
    if s.cells_more_checked > 0 {
        let _ = writeln!(
            md,
            "Selection: {} cells could not tell their maps from the proxy on their first {} check positions (the per-position difference within {} standard errors of 0) and were judged on {} more.\n",
            s.cells_more_checked,
            fit.settings.check_positions,
            crate::fit::selection::DECIDED_AT,
            fit.settings.extra_check_positions
        );
    }
    if let Some(l) = &s.level1 {
        level1_paragraph(&mut md, l);
    }
    if let Some(r) = &s.resolutions {
        resolutions_table(&mut md, r);
    }
    let _ = writeln!(
        md,
        "Mean held-out relative error per active cell: warp1 {:.4}, the proxy alone {:.4}, celldepth {:.4}, stored model {:.4}.\n",
        s.mean_check_err_warp1, s.mean_check_err_fallback, s.mean_check_err_celldepth, s.mean_check_err_stored
    );
    ratio_histogram(&mut md, fit);
    worst_cells_table(&mut md, fit);
    roughness_rows(&mut md, fit);
    let _ = writeln!(md, "\n## Convergence\n\n| fit time (s) | mean training objective |\n|---:|---:|");
    for (t, c) in convergence(fit, rayon::current_num_threads()) {
        let _ = writeln!(md, "| {t:.2} | {c:.4} |");
    }
    let _ = writeln!(md, "\n![convergence](fit_convergence.png)");
    let _ = writeln!(
        md,
        "\n![residual slices](residual_slices.png)\n\nOne panel per grid layer (bottom layer first), cell x to the right, cell z up; green: the share of the fallback's held-out error the cell's stored map removes (colour bar), grey: the cell keeps the fallback, black: inside geometry (not fitted)."
    );
    write_atomic(path, md.as_bytes())
}

/// The diffuse surface bias's trials (none when the fit tried none).
fn diffuse_bias_table(md: &mut String, s: &crate::fit::summary::FitSummary) {
    use std::fmt::Write as _;
    if s.diffuse_bias_trials.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "Diffuse surface bias (the blend's point moved along its normal, in smallest cell extents; tone-mapped RMSE of the blend alone and of the field corrected by the maps fitted at that bias; the smallest bias within 1% of the lowest corrected check error is stored: {}):\n\n| bias | blend, check points | corrected, training | corrected, check |\n|---:|---:|---:|---:|",
        s.diffuse_surface_bias
    );
    for t in &s.diffuse_bias_trials {
        let _ = writeln!(md, "| {} | {:.4} | {:.4} | {:.4} |", t.bias, t.blend_check_rmse, t.train_rmse, t.check_rmse);
    }
    let _ = writeln!(md);
}

/// The cells per level, their bytes and what each level means.
fn levels_table(md: &mut String, fit: &Fit, s: &crate::fit::summary::FitSummary) {
    use std::fmt::Write as _;
    let _ = writeln!(md, "| level | cells | bytes | meaning |\n|---|---:|---:|---|");
    let how = match s.proxy.and_then(|p| p.measured) {
        Some([b, k, w]) => format!(
            "measured on held-out queries: box {b:.4}, kdop {k:.4}, warp1 {w:.4}; the cheapest within {:.0}% of the best",
            100.0 * (1.0 / crate::fit::proxy::MARGIN - 1.0)
        ),
        None => "set".into(),
    };
    let _ = writeln!(md, "| 0 | {} | 0 | the grid's proxy `{}` alone ({how}) |", s.cells_level0, s.fallback_method);
    let _ = writeln!(
        md,
        "| 2 | {} | {} | {}×{} shift map of the proxy{}, f32 scene units |",
        s.cells_level2,
        s.bytes_level2,
        fit.settings.map_res,
        fit.settings.map_res,
        if s.rough_maps { " and one for rough lookups" } else { "" }
    );
    let _ = writeln!(
        md,
        "| left out | {} | 0 | inside geometry |\n",
        fit.correctives.geometry.cell_count() - s.active_cells
    );
}

/// Level 1, measured and not stored.
fn level1_paragraph(md: &mut String, l: &crate::fit::summary::Level1Summary) {
    use std::fmt::Write as _;
    let _ = writeln!(
        md,
        "Level 1 (one origin offset, depth mip and relaxation per cell, fitted with Nelder-Mead on a quarter of each cell's training queries; measured, not stored), on {} cells' check queries: mean relative error {:.4} against the fitted map's {:.4} in every cell. It beats the fallback by the selection margin in {} cells, is within the margin of the map in {} and the best of the three in {}. A selection over all three (the cheapest within the selection margin of the best, a stored model beating the proxy alone by it) would keep {} / {} / {} cells at levels 0 / 1 / 2: mean error {:.4} in {} bytes, against the stored selection's {:.4} in {} bytes. Level 1 took {} objective evaluations.\n",
        l.cells,
        l.mean_check_err_level1,
        l.mean_check_err_map,
        l.beats_fallback,
        l.within_margin_of_map,
        l.best_of_three,
        l.chosen[0],
        l.chosen[1],
        l.chosen[2],
        l.mean_check_err_chosen,
        l.bytes_chosen,
        l.mean_check_err_stored,
        l.bytes_stored,
        l.evaluations
    );
}

/// Per-cell map resolution, measured and not stored.
fn resolutions_table(md: &mut String, r: &crate::fit::summary::ResolutionSummary) {
    use std::fmt::Write as _;
    let _ = writeln!(
        md,
        "Map resolution, per cell (measured, not stored): each of {} cells' maps fitted at {} texels a side as the {}×{} map is, judged with two-fold cross-validation over the cell's check positions (one half chooses, the other judges, both ways round; errors and bytes are the two folds' means):\n",
        r.cells,
        crate::fit::STUDY_RESOLUTIONS.map(|x| x.to_string()).join(", "),
        r.map_res,
        r.map_res
    );
    let heads: Vec<String> = crate::fit::STUDY_RESOLUTIONS.iter().map(|x| format!("cells {x}²")).collect();
    let _ = writeln!(md, "| maps | mean held-out relative error | bytes (f32) | {} |", heads.join(" | "));
    let _ = writeln!(md, "|---|---:|---:|{}", "---:|".repeat(heads.len()));
    for row in &r.rows {
        let counts: Vec<String> = row.cells_per_res.iter().map(|c| format!("{c:.1}")).collect();
        let _ = writeln!(md, "| {} | {:.4} | {:.0} | {} |", row.name, row.mean_err, row.bytes, counts.join(" | "));
    }
    let _ = writeln!(md);
}

/// The histogram of stored error over the proxy's error, level-2 cells.
fn ratio_histogram(md: &mut String, fit: &Fit) {
    use std::fmt::Write as _;
    let _ =
        writeln!(md, "## Stored error / the proxy's error per cell (level-2 cells)\n\n| ratio | cells |\n|---|---:|");
    let mut buckets = [0usize; 10];
    for c in fit.cells.iter().filter(|c| c.level == Level::Map) {
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
}

/// The twelve worst cells after the fit, and what explains them.
fn worst_cells_table(md: &mut String, fit: &Fit) {
    use std::fmt::Write as _;
    let _ = writeln!(
        md,
        "\n## Worst cells after the fit\n\n| cell | level | stored error | fallback | celldepth | hidden from A | start | why |\n|---:|---:|---:|---:|---:|---:|---|---|"
    );
    let stored_err = CellFit::check_err_stored;
    let mut worst: Vec<&CellFit> = fit.cells.iter().collect();
    worst.sort_by(|a, b| stored_err(b).total_cmp(&stored_err(a)));
    for c in worst.iter().take(12) {
        let why = if c.hidden_fraction > 0.3 {
            format!("{:.0}% of its queries hit points probe A cannot see; {}", 100.0 * c.hidden_fraction, c.selection)
        } else {
            c.selection.to_string()
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
            format!("{:?}", c.start).to_lowercase(),
            why
        );
    }
}

/// `fit_convergence.png`.
pub fn write_convergence(path: &Path, fit: &Fit, threads: usize) -> Result<(), FileError> {
    let series = vec![(format!("{:?}", fit.settings.solver), convergence(fit, threads))];
    crate::report::plot::line_plot(
        path,
        "Fit convergence: mean training objective per cell",
        "fit time on this machine (s, references excluded)",
        "training objective",
        &series,
    )
}

/// The scene's roughness correction, row by row: the rule each row holds and every
/// candidate's views and held-out lookups.
fn roughness_rows(md: &mut String, fit: &Fit) {
    use crate::roughness::RowRule;
    use std::fmt::Write as _;
    let Some(cmp) = fit.roughness.as_ref().and_then(|r| r.heldout_scene.as_ref()) else { return };
    if cmp.rows.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n## Roughness correction, per row\n\nEach row holds the rule with the lowest mean ꟻLIP on views rendered from held-out positions, the scene fit unless another is lower by more than twice the paired standard error (±). Held-out lookups' tone-mapped RMSE beside it.\n\n| r | holds | ꟻLIP: scene fit / lobes / Frostbite / plain | tone-mapped RMSE: scene fit / lobes / Frostbite / plain |\n|---:|---|---|---|"
    );
    let name = |r: RowRule| match r {
        RowRule::SceneFit => "scene fit",
        RowRule::Lobes => "lobes",
        RowRule::Engine => "Frostbite",
        RowRule::Plain => "plain r",
    };
    for row in &cmp.rows {
        let flip: Vec<String> = RowRule::ALL
            .iter()
            .map(|&r| match r {
                RowRule::SceneFit => format!("{:.4}", row.flip.get(r)),
                _ => format!("{:.4} ± {:.4}", row.flip.get(r), 2.0 * row.flip_se.get(r)),
            })
            .collect();
        let tm: Vec<String> = RowRule::ALL.iter().map(|&r| format!("{:.4}", row.tm_rmse.get(r))).collect();
        let _ =
            writeln!(md, "| {} | {} | {} | {} |", row.roughness, name(row.chosen), flip.join(" / "), tm.join(" / "));
    }
}
