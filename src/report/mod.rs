//! Everything a run leaves for people and tools to read, written from what the stages
//! computed: the evaluation (`eval.json`, `eval.md`, the error-against-cost plot and the
//! view tiles), the fit's diagnostics (`fit`), the roughness correction (`roughness`), the
//! sweep's record and figures (`sweep`), and the run report (`page`: report.json/.md/.html).
//! `folder::RunFolder` names the files. Computes nothing but summaries of its inputs.

pub mod fit;
pub mod folder;
pub mod page;
pub mod plot;
pub mod roughness;
pub mod sweep;

use crate::eval::Evaluation;
pub use crate::eval::{EvalReport, LevelEval};
use crate::files::{FileError, write_atomic, write_json};
use folder::RunFolder;
use std::fmt::Write as _;

/// Markdown table of the methods, sorted as given.
pub fn methods_table(r: &EvalReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| method | rel RMSE | MAE | p95 | max | angular ° | ns/lookup | ns/lookup (random order) | ns/lookup (batch API) | × cheaper than a reference ray | note |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for m in &r.methods {
        let ang = m.angular_deg.map_or("–".to_string(), |a| format!("{a:.2}"));
        let cheaper = if m.name == "oracle" {
            "–".to_string()
        } else {
            format!("{:.0}", r.reference_ns_per_ray / m.ns_per_lookup.max(1e-9))
        };
        let batched = m.ns_per_lookup_batched.map_or("–".to_string(), |ns| format!("{ns:.1}"));
        let _ = writeln!(
            s,
            "| {} | {:.4} | {:.4} | {:.4} | {:.3} | {} | {:.1} | {:.1} | {} | {} | {} |",
            m.name,
            m.rel_rmse,
            m.mae,
            m.p95,
            m.max,
            ang,
            m.ns_per_lookup,
            m.ns_per_lookup_random,
            batched,
            cheaper,
            m.note
        );
    }
    s
}

/// Writes eval.json, eval.md, eval_error_vs_cost.png and eval_views.png into `folder`.
pub fn write_evaluation(folder: &RunFolder, ev: &Evaluation) -> Result<(), FileError> {
    write_eval(folder, &ev.report)?;
    match &ev.views {
        Some(v) => plot::views(&folder.eval_views(), &v.title, &v.tiles),
        None => Ok(()),
    }
}

/// Writes eval.json, eval.md and eval_error_vs_cost.png into `folder`.
pub fn write_eval(folder: &RunFolder, r: &EvalReport) -> Result<(), FileError> {
    std::fs::create_dir_all(&folder.dir).map_err(FileError::io(&folder.dir))?;
    write_json(&folder.eval_json(), r)?;

    let mut md = String::new();
    let _ = writeln!(md, "# Warp evaluation: {}\n", r.scene);
    let _ = writeln!(md, "Produced by `{}`.\n", r.command);
    let _ = writeln!(
        md,
        "Validation set: {} positions uniformly random inside grid cells that are not inside geometry, {} uniformly random directions each ({} lookups), references traced with {} samples. Seed {:#x}, independent of any fitting data.\n",
        r.positions, r.settings.dirs_per_position, r.lookups, r.settings.reference_spp, r.settings.seed
    );
    let _ = writeln!(
        md,
        "Hidden fraction (true hit not visible from probe A; no single fetch of A can fix these): **{:.1}%**.\n",
        100.0 * r.hidden_fraction
    );
    let _ = writeln!(
        md,
        "A reference ray (one radiance sample, with shadow and bounce rays) costs {:.0} ns single-threaded.\n",
        r.reference_ns_per_ray
    );
    md += &methods_table(r);
    if !r.fitted_levels.is_empty() {
        let _ = writeln!(
            md,
            "\n`fitted` by the level of the cell containing the query position (rel RMSE over each subset):\n"
        );
        let _ = writeln!(md, "| level | lookups | fitted | fallback on the same lookups |\n|---|---:|---:|---:|");
        for l in &r.fitted_levels {
            let _ = writeln!(
                md,
                "| {} | {} | {:.4} | {:.4} ({}) |",
                l.level, l.lookups, l.fitted_rel_rmse, l.fallback_rel_rmse, l.fallback
            );
        }
    }
    let _ = writeln!(
        md,
        "\nrel RMSE = RMSE of linear RGB radiance / mean reference radiance; MAE, p95, max: per-lookup mean absolute RGB error. Angular error: fetch direction against the oracle's. Costs: single-threaded warm loop, fetch + bilinear radiance lookup; queries issued per position in Morton order of their octahedral uv (coherent, as neighbouring pixels query a probe), and in random order (cache-hostile).\n"
    );
    let _ = writeln!(md, "## warp1 options (depth mip the warp reads, UV relaxation)\n");
    let _ = writeln!(md, "| depth mip | relax (texels) | rel RMSE |\n|---:|---:|---:|");
    for row in &r.warp1_sweep {
        let _ = writeln!(md, "| {} | {} | {:.4} |", row.depth_lod, row.relax_texels, row.rel_rmse);
    }
    let _ = writeln!(md, "\n![error against cost](eval_error_vs_cost.png)");
    write_atomic(&folder.eval_md(), md.as_bytes())?;

    let points: Vec<(String, f64, f64)> =
        r.methods.iter().map(|m| (m.name.clone(), m.ns_per_lookup, m.rel_rmse)).collect();
    plot::error_vs_cost(&folder.eval_plot(), &format!("{}: error against cost", r.scene), &points)
}
