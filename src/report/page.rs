//! The run report: `report.json`, `report.md` and a self-contained `report.html` (images
//! inlined as data URIs, no scripts, no external resources) assembled from what the stages
//! left in a scene's output folder: `eval.json`, the fitted grid's `manifest.json`,
//! `residuals.json`, `bake/manifest.json`, and `sweep.json` / `stability.json` when present.
//! Computes nothing but summaries of those files.

use super::EvalReport;
use super::folder::RunFolder;
use super::plot::pareto_front;
use super::sweep::Sweep;
use crate::bakefile::manifest::BakeManifest;
use crate::files::{FileError, read_json, write_atomic, write_json};
use crate::fit::{CellFit, Level};
use crate::gridfile::GridManifest;
use base64::Engine as _;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// One eval row with its place on the error-against-cost Pareto front.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MethodRow {
    /// `method` or `method/mip rule`.
    pub name: String,
    #[serde(default)]
    pub roughness: f32,
    #[serde(default)]
    pub flip: Option<f64>,
    #[serde(default)]
    pub tm_rmse: f64,
    pub rel_rmse: f64,
    pub mae: f64,
    pub p95: f64,
    pub ns_per_lookup: f64,
    /// Through the method's batch API, where it has one.
    #[serde(default)]
    pub ns_per_lookup_batched: Option<f64>,
    pub pareto: bool,
    pub note: String,
}

/// Held-out errors of the fit's cells grouped by stored level.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LevelRow {
    pub level: Level,
    pub cells: usize,
    pub mean_err_fallback: f64,
    pub mean_err_celldepth: f64,
    pub mean_err_stored: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WorstCell {
    pub cell: u32,
    pub level: Level,
    pub err_stored: f64,
    pub err_fallback: f64,
    pub hidden_fraction: f64,
    pub reason: String,
}

/// Time and rays of one pipeline stage.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StageRow {
    pub stage: String,
    pub seconds: f64,
    pub rays: u64,
    pub rays_per_s: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LayerRow {
    pub file: String,
    pub layer: String,
    pub size: String,
    pub precision: String,
    pub raw_bytes: u64,
}

/// Everything `report.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunReport {
    pub scene: String,
    pub command: String,
    pub hidden_fraction: f64,
    pub reference_ns_per_ray: f64,
    pub validation: String,
    pub methods: Vec<MethodRow>,
    pub levels: Vec<LevelRow>,
    /// `fitted` on the validation set split by cell level (from eval.json).
    pub eval_levels: Vec<super::LevelEval>,
    pub worst_cells: Vec<WorstCell>,
    pub stages: Vec<StageRow>,
    pub layers: Vec<LayerRow>,
    pub payload_bytes: Vec<(String, u64)>,
    pub left_out: Vec<(String, String, u64)>,
    /// `sweep.json` when `warpfit sweep` wrote one into the folder.
    pub sweep: Option<Sweep>,
    /// `stability.json` when one is in the folder.
    pub stability: Option<serde_json::Value>,
    /// Images shown, by file name.
    pub images: Vec<String>,
    /// The diffuse evaluation, when eval.json has one.
    #[serde(default)]
    pub diffuse: Option<crate::eval::diffuse::DiffuseReport>,
    /// The surface-probe patches' evaluations (seed 003).
    #[serde(default)]
    pub surface: Vec<crate::eval::surface::SurfaceReport>,
    /// Where the fitted grid wins and loses, in three plain lines (`super::verdict`).
    #[serde(default)]
    pub verdict: Vec<String>,
    /// `render/render.json` when `warpfit render` drew frames into the folder: they lead
    /// the pictures.
    #[serde(default)]
    pub frames: Option<crate::render::frames::RenderReport>,
}

fn optional_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<Option<T>, FileError> {
    if path.is_file() { read_json(path).map(Some) } else { Ok(None) }
}

/// Builds the report from the files of a run folder.
pub fn build(folder: &RunFolder, command: &str) -> Result<RunReport, FileError> {
    let eval: EvalReport = read_json(&folder.eval_json())?;
    let grid: GridManifest = read_json(&folder.grid_manifest())?;
    let cells: Vec<CellFit> = read_json(&folder.residuals())?;
    let bake_path = folder.bake().join(crate::bakefile::MANIFEST_FILE);
    let bake: Option<BakeManifest> = if bake_path.is_file() { Some(read_json(&bake_path)?) } else { None };
    let methods = method_rows(&eval);
    let levels = level_rows(&cells);
    let worst_cells = worst_cells(&cells);
    let stages = stage_rows(bake.as_ref(), &grid, &eval);
    let (layers, payload_bytes) = layer_rows(&grid);
    let left_out = grid.left_out.iter().map(|l| (l.what.clone(), l.reason.clone(), l.bytes_saved)).collect();
    let frames: Option<crate::render::frames::RenderReport> =
        optional_json(&crate::render::frames::folder(&folder.dir).join("render.json"))?;
    let mut images: Vec<String> =
        frames.iter().flat_map(|f| &f.frames).map(|f| format!("render/{}", f.image)).collect();
    images.retain(|f| folder.dir.join(f).is_file());
    images.extend(report_images(&folder.dir, &eval));
    Ok(RunReport {
        scene: eval.scene.clone(),
        command: command.to_string(),
        hidden_fraction: eval.hidden_fraction,
        reference_ns_per_ray: eval.reference_ns_per_ray,
        validation: format!(
            "{} positions × {} directions ({} lookups), references with {} samples, seed {:#x}",
            eval.positions,
            eval.settings.dirs_per_position,
            eval.lookups,
            eval.settings.reference_spp,
            eval.settings.seed
        ),
        methods,
        levels,
        eval_levels: eval.fitted_levels.clone(),
        worst_cells,
        stages,
        layers,
        payload_bytes,
        left_out,
        sweep: optional_json(&folder.sweep_json())?,
        stability: optional_json(&folder.stability_json())?,
        images,
        diffuse: eval.diffuse.clone(),
        surface: eval.surface.clone(),
        verdict: super::verdict(&eval),
        frames,
    })
}

/// Every method's row, marked where it lies on its bucket's Pareto front of the headline
/// tone-mapped RMSE against cost.
fn method_rows(eval: &EvalReport) -> Vec<MethodRow> {
    // the Pareto front of each roughness bucket, on the headline tone-mapped RMSE
    let mut front = vec![false; eval.methods.len()];
    for r in crate::eval::ROUGHNESS_BUCKETS {
        let at: Vec<usize> = (0..eval.methods.len()).filter(|&k| eval.methods[k].roughness == r).collect();
        let points: Vec<(String, f64, f64)> = at
            .iter()
            .map(|&k| (eval.methods[k].name.clone(), eval.methods[k].ns_per_lookup, eval.methods[k].tm_rmse))
            .collect();
        for (&k, f) in at.iter().zip(pareto_front(&points)) {
            front[k] = f;
        }
    }
    eval.methods
        .iter()
        .zip(&front)
        .map(|(m, &pareto)| MethodRow {
            name: m.label(),
            roughness: m.roughness,
            flip: m.flip,
            tm_rmse: m.tm_rmse,
            rel_rmse: m.rel_rmse,
            mae: m.mae,
            p95: m.p95,
            ns_per_lookup: m.ns_per_lookup,
            ns_per_lookup_batched: m.ns_per_lookup_batched,
            pareto,
            note: m.note.clone(),
        })
        .collect()
}

/// The fit's cells by level: how many, and their mean check errors.
fn level_rows(cells: &[CellFit]) -> Vec<LevelRow> {
    let stored = CellFit::check_err_stored;
    let mut levels = Vec::new();
    for level in Level::ALL {
        let of: Vec<&CellFit> = cells.iter().filter(|c| c.level == level).collect();
        if of.is_empty() {
            continue;
        }
        let mean = |f: &dyn Fn(&CellFit) -> f64| of.iter().map(|c| f(c)).sum::<f64>() / of.len() as f64;
        levels.push(LevelRow {
            level,
            cells: of.len(),
            mean_err_fallback: mean(&|c| c.check_err_fallback),
            mean_err_celldepth: mean(&|c| c.check_err_celldepth),
            mean_err_stored: mean(&|c| stored(c)),
        });
    }
    levels
}

/// The ten cells with the largest stored check error, and why they are what they are.
fn worst_cells(cells: &[CellFit]) -> Vec<WorstCell> {
    let stored = CellFit::check_err_stored;
    let mut worst: Vec<&CellFit> = cells.iter().collect();
    worst.sort_by(|a, b| stored(b).total_cmp(&stored(a)).then(a.cell.cmp(&b.cell)));
    worst
        .iter()
        .take(10)
        .map(|c| WorstCell {
            cell: c.cell,
            level: c.level,
            err_stored: stored(c),
            err_fallback: c.check_err_fallback,
            hidden_fraction: c.hidden_fraction,
            reason: c.selection.to_string(),
        })
        .collect()
}

/// Each stage's time, rays and rays per second: the bake's (when its manifest is there),
/// the fit's and the evaluation's.
fn stage_rows(bake: Option<&BakeManifest>, grid: &GridManifest, eval: &EvalReport) -> Vec<StageRow> {
    let mut stages = Vec::new();
    if let Some(b) = bake {
        let s = &b.stats;
        let rate = |rays: u64, sec: f64| if sec > 0.0 { rays as f64 / sec } else { 0.0 };
        stages.push(StageRow { stage: "bake: BVH build".into(), seconds: s.bvh_build_s, rays: 0, rays_per_s: 0.0 });
        stages.push(StageRow {
            stage: "bake: specular probe".into(),
            seconds: s.probe_s,
            rays: s.probe_rays,
            rays_per_s: rate(s.probe_rays, s.probe_s),
        });
        stages.push(StageRow {
            stage: "bake: probe grid".into(),
            seconds: s.grid_s,
            rays: s.grid_rays,
            rays_per_s: rate(s.grid_rays, s.grid_s),
        });
    }
    let fit_s = grid.residuals.get("fit_seconds").and_then(|v| v.as_f64()).unwrap_or(0.0);
    let fit_rays = grid.residuals.get("reference_rays").and_then(|v| v.as_u64()).unwrap_or(0);
    stages.push(StageRow {
        stage: "fit (references + solver)".into(),
        seconds: fit_s,
        rays: fit_rays,
        rays_per_s: if fit_s > 0.0 { fit_rays as f64 / fit_s } else { 0.0 },
    });
    stages.push(StageRow {
        stage: "eval (references, methods, timings)".into(),
        seconds: eval.seconds,
        rays: eval.reference_rays,
        rays_per_s: if eval.seconds > 0.0 { eval.reference_rays as f64 / eval.seconds } else { 0.0 },
    });

    stages
}

/// Each stored layer's size and precision, and each payload's bytes.
fn layer_rows(grid: &GridManifest) -> (Vec<LayerRow>, Vec<(String, u64)>) {
    let mut layers = Vec::new();
    let mut payload_bytes = Vec::new();
    for p in &grid.payloads {
        payload_bytes.push((p.file.clone(), p.bytes));
        for l in &p.layers {
            let per = if l.precision == crate::runtime::Precision::F16 { 2 } else { 4 };
            layers.push(LayerRow {
                file: p.file.clone(),
                layer: l.name.clone(),
                size: format!("{}×{}", l.width, l.height),
                precision: format!("{:?}", l.precision).to_lowercase(),
                raw_bytes: l.width as u64 * l.height as u64 * l.channels.len() as u64 * per,
            });
        }
    }
    (layers, payload_bytes)
}

/// The figures of the run that exist in its folder, in the report's order.
/// The figures in the order a reader wants them: the frames (every camera per roughness),
/// the error-against-cost pictures, then the surface patches and the diagnostics.
fn report_images(dir: &Path, eval: &EvalReport) -> Vec<String> {
    let mut images: Vec<String> = crate::eval::ROUGHNESS_BUCKETS.iter().map(|&r| format!("flip_r{r:.3}.png")).collect();
    images.push("flip_diffuse.png".into());
    images.extend(["eval_error_vs_cost.png", "eval_rough.png"].iter().map(|f| f.to_string()));
    for sr in &eval.surface {
        images.push(format!("surface_atlas{}.png", sr.index));
        images.extend(crate::eval::ROUGHNESS_BUCKETS.iter().map(|&r| format!("flip_surface{}_r{r:.3}.png", sr.index)));
    }
    images.extend(
        ["eval_views.png", "fit_convergence.png", "residual_slices.png", "sweep.png", "sweep_convergence.png"]
            .iter()
            .map(|f| f.to_string()),
    );
    images.into_iter().filter(|f| dir.join(f).is_file()).collect()
}

/// Whether figure `file` is shown before the tables (the frames and the error-against-cost
/// pictures) or after them (the diagnostics).
fn leading(file: &str) -> bool {
    file.starts_with("render/")
        || file.starts_with("flip_")
        || file.starts_with("eval_error")
        || file == "eval_rough.png"
}

/// The report as Markdown: the verdict, the frames and error-against-cost pictures, the
/// tables, then the diagnostic figures; images referenced by file name.
pub fn markdown(r: &RunReport) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# warpfit report: {}\n\nProduced by `{}`.\n", r.scene, r.command);
    if !r.verdict.is_empty() {
        let _ = writeln!(md, "## Verdict\n");
        for line in &r.verdict {
            let _ = writeln!(md, "- {line}");
        }
        md.push('\n');
    }
    let figures = |md: &mut String, lead: bool| {
        for img in r.images.iter().filter(|f| leading(f) == lead) {
            let _ = writeln!(md, "![{img}]({img})\n\n*{}*\n", caption(r, img));
        }
    };
    let _ = writeln!(md, "## Pictures\n");
    figures(&mut md, true);
    let _ = writeln!(
        md,
        "Validation: {}; hidden fraction {:.1}%; a reference ray costs {:.0} ns.\n",
        r.validation,
        100.0 * r.hidden_fraction,
        r.reference_ns_per_ray
    );
    for (title, rows) in sections(r) {
        let _ = writeln!(md, "## {title}\n");
        md += &md_table(&rows);
        md.push('\n');
    }
    let _ = writeln!(md, "## Diagnostics\n");
    figures(&mut md, false);
    md
}

fn md_table(rows: &[Vec<String>]) -> String {
    let mut s = String::new();
    for (k, row) in rows.iter().enumerate() {
        let _ = writeln!(s, "| {} |", row.join(" | "));
        if k == 0 {
            let _ = writeln!(s, "|{}", "---|".repeat(row.len()));
        }
    }
    s
}

/// The headers of [`super::error_cells`]'s columns, ꟻLIP named by what it was measured on.
fn error_headers(flip: &str) -> impl Iterator<Item = String> + '_ {
    std::iter::once(flip.to_string())
        .chain(["tone-mapped RMSE", "rel RMSE", "MAE", "p95", "ns/lookup"].into_iter().map(String::from))
}

/// A table's header row.
fn header(cells: &[&str]) -> Vec<String> {
    cells.iter().map(|s| s.to_string()).collect()
}

/// Titled tables (first row = header), shared by the Markdown and HTML renderings.
fn sections(r: &RunReport) -> Vec<(String, Vec<Vec<String>>)> {
    let mut out = vec![methods_section(r)];
    out.extend(r.diffuse.as_ref().map(diffuse_section));
    out.extend(r.surface.iter().map(surface_section));
    if !r.eval_levels.is_empty() {
        out.push(eval_levels_section(r));
    }
    out.extend([fit_levels_section(r), worst_section(r), stages_section(r), bytes_section(r), left_out_section(r)]);
    out.extend(r.sweep.as_ref().map(sweep_section));
    if let Some(cases) = r.stability.as_ref().and_then(|s| s.get("cases")).and_then(|v| v.as_array()) {
        out.push(stability_section(cases));
    }
    out
}

/// Every method on held-out positions and directions, per roughness.
fn methods_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&[
        "roughness",
        "method",
        "ꟻLIP",
        "tone-mapped RMSE",
        "rel RMSE",
        "MAE",
        "p95",
        "ns/lookup",
        "ns/lookup (batch API)",
        "Pareto front (tm RMSE)",
        "note",
    ])];
    for m in &r.methods {
        let mut cells = vec![format!("{}", m.roughness), m.name.clone()];
        cells.extend(super::error_cells(m.flip, [m.tm_rmse, m.rel_rmse, m.mae, m.p95], m.ns_per_lookup));
        cells.extend([
            m.ns_per_lookup_batched.map_or("–".into(), |ns| format!("{ns:.1}")),
            if m.pareto { "yes".into() } else { String::new() },
            m.note.clone(),
        ]);
        t.push(cells);
    }
    ("Every method on held-out positions and directions, per roughness".to_string(), t)
}

/// The diffuse table.
fn diffuse_section(d: &crate::eval::diffuse::DiffuseReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![
        std::iter::once("method".to_string()).chain(error_headers("ꟻLIP (diffuse-shaded cameras)")).collect::<Vec<_>>(),
    ];
    for row in &d.rows {
        let mut cells = vec![row.name.clone()];
        cells.extend(super::error_cells(row.flip, [row.tm_rmse, row.rel_rmse, row.mae, row.p95], row.ns_per_lookup));
        t.push(cells);
    }
    (
        format!(
            "Diffuse: irradiance at {} held-out surface points ({}-sample references, single-reference SE {:.3} relative)",
            d.points, d.reference_spp, d.reference_se_rel
        ),
        t,
    )
}

/// One surface-probe patch's table.
fn surface_section(sr: &crate::eval::surface::SurfaceReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![
        ["roughness", "method"]
            .iter()
            .map(|s| s.to_string())
            .chain(error_headers("ꟻLIP (patch camera)"))
            .collect::<Vec<_>>(),
    ];
    for row in &sr.rows {
        let mut cells = vec![format!("{}", row.roughness), row.name.clone()];
        cells.extend(super::error_cells(row.flip, [row.tm_rmse, row.rel_rmse, row.mae, row.p95], row.ns_per_lookup));
        t.push(cells);
    }
    (
        format!(
            "Surface probes {} (seed 003): {}×{} probes of {}² texels ({:.1} MB), {} held-out points × {} reflection directions",
            sr.index,
            sr.counts[0],
            sr.counts[1],
            sr.resolution,
            sr.bytes as f64 / 1e6,
            sr.points,
            sr.dirs_per_point
        ),
        t,
    )
}

/// The fitted grid per cell level, on the validation set.
fn eval_levels_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&[
        "cell level",
        "validation lookups",
        "fitted tone-mapped / rel RMSE",
        "fallback tone-mapped / rel RMSE (same lookups)",
    ])];
    for l in &r.eval_levels {
        t.push(vec![
            l.level.to_string(),
            l.lookups.to_string(),
            format!("{:.4} / {:.4}", l.fitted_tm_rmse, l.fitted_rel_rmse),
            format!("{:.4} / {:.4} ({})", l.fallback_tm_rmse, l.fallback_rel_rmse, l.fallback),
        ]);
    }
    ("Fitted per level, on the validation set".to_string(), t)
}

/// The fitted grid per cell level, on the fit's own check set.
fn fit_levels_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&["level", "cells", "fallback", "celldepth", "stored model"])];
    for l in &r.levels {
        t.push(vec![
            match l.level {
                Level::Fallback => "0 (fallback, nothing stored)".into(),
                Level::Map => "2 (fitted shift map)".into(),
            },
            l.cells.to_string(),
            format!("{:.4}", l.mean_err_fallback),
            format!("{:.4}", l.mean_err_celldepth),
            format!("{:.4}", l.mean_err_stored),
        ]);
    }
    ("Fitted per level, on the fit's own held-out check set (mean relative error per cell)".to_string(), t)
}

/// The worst cells and why.
fn worst_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&["cell", "level", "stored error", "fallback error", "hidden", "why"])];
    for c in &r.worst_cells {
        t.push(vec![
            c.cell.to_string(),
            c.level.to_string(),
            format!("{:.3}", c.err_stored),
            format!("{:.3}", c.err_fallback),
            format!("{:.0}%", 100.0 * c.hidden_fraction),
            c.reason.clone(),
        ]);
    }
    ("Worst cells".to_string(), t)
}

/// Each stage's time and rays.
fn stages_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&["stage", "seconds", "rays", "rays/s"])];
    for s in &r.stages {
        t.push(vec![
            s.stage.clone(),
            format!("{:.3}", s.seconds),
            s.rays.to_string(),
            if s.rays > 0 { format!("{:.2} M", s.rays_per_s / 1e6) } else { "–".into() },
        ]);
    }
    ("Stages".to_string(), t)
}

/// The bytes of each stored layer and payload.
fn bytes_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&["file", "layer", "size", "precision", "raw bytes"])];
    for l in &r.layers {
        t.push(vec![l.file.clone(), l.layer.clone(), l.size.clone(), l.precision.clone(), l.raw_bytes.to_string()]);
    }
    for (f, b) in &r.payload_bytes {
        t.push(vec![f.clone(), "(file on disk, compressed)".into(), String::new(), String::new(), b.to_string()]);
    }
    ("Bytes of each stored layer".to_string(), t)
}

/// What the scene does not need, and the bytes that saves.
fn left_out_section(r: &RunReport) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&["left out", "why", "bytes saved"])];
    for (w, why, b) in &r.left_out {
        t.push(vec![w.clone(), why.clone(), b.to_string()]);
    }
    ("What this scene does not need".to_string(), t)
}

/// The sweep's rows.
fn sweep_section(sweep: &Sweep) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&[
        "knob",
        "value",
        "fit seconds",
        "ꟻLIP r 0",
        "± 2 SE (vs given)",
        "ꟻLIP r 0.5",
        "tone-mapped RMSE",
        "rel RMSE (held out)",
    ])];
    for row in &sweep.rows {
        t.push(vec![
            row.knob.name().to_string(),
            row.value.clone(),
            format!("{:.1}", row.fit_seconds),
            format!("{:.4}", row.flip_r0),
            row.flip_r0_se.map_or("–".to_string(), |se| format!("{:.4}", 2.0 * se)),
            format!("{:.4}", row.flip_r05),
            format!("{:.4}", row.tm_rmse),
            format!("{:.4}", row.rel_rmse),
        ]);
    }
    ("Error against fit effort (warpfit sweep)".to_string(), t)
}

/// The stability suite's cases.
fn stability_section(cases: &[serde_json::Value]) -> (String, Vec<Vec<String>>) {
    let mut t = vec![header(&["case", "expectation", "measured", "result"])];
    for c in cases {
        let f = |k: &str| c.get(k).and_then(|v| v.as_str()).unwrap_or_default().to_string();
        let pass = c.get("pass").and_then(|v| v.as_bool()).unwrap_or(false);
        t.push(vec![f("case"), f("expectation"), f("measured"), if pass { "pass" } else { "FAIL" }.into()]);
    }
    ("Stability suite".to_string(), t)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The report as one HTML file with every image inlined.
pub fn html(r: &RunReport, dir: &Path) -> Result<String, FileError> {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>warpfit report: {}</title>\n<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}table{{border-collapse:collapse;margin:0 0 1.5em;font-size:13px}}td,th{{border:1px solid #ccc;padding:3px 7px;text-align:left}}th{{background:#eee}}tr.front td:first-child{{font-weight:bold;color:#b22}}img{{max-width:100%;border:1px solid #ddd;margin:0.5em 0}}code{{background:#f4f4f4;padding:1px 4px}}</style></head><body>\n",
        escape(&r.scene)
    );
    let _ = writeln!(h, "<h1>warpfit report: {}</h1>", escape(&r.scene));
    let _ = writeln!(h, "<p>Produced by <code>{}</code>.</p>", escape(&r.command));
    if !r.verdict.is_empty() {
        h += "<h2>Verdict</h2>\n<ul>\n";
        for line in &r.verdict {
            let _ = writeln!(h, "<li>{}</li>", escape(line));
        }
        h += "</ul>\n";
    }
    h += "<h2>Pictures</h2>\n";
    figures_html(&mut h, r, dir, true)?;
    let _ = writeln!(
        h,
        "<p>Validation: {}; hidden fraction {:.1}%; a reference ray costs {:.0} ns.</p>",
        escape(&r.validation),
        100.0 * r.hidden_fraction,
        r.reference_ns_per_ray
    );
    for (k, (title, rows)) in sections(r).iter().enumerate() {
        let _ = writeln!(h, "<h2>{}</h2>\n<table>", escape(title));
        for (i, row) in rows.iter().enumerate() {
            let front = k == 0 && i > 0 && r.methods.get(i - 1).is_some_and(|m| m.pareto);
            let _ = write!(h, "<tr{}>", if front { " class=\"front\"" } else { "" });
            let tag = if i == 0 { "th" } else { "td" };
            for cell in row {
                let _ = write!(h, "<{tag}>{}</{tag}>", escape(cell));
            }
            h += "</tr>\n";
        }
        h += "</table>\n";
    }
    h += "<h2>Diagnostics</h2>\n";
    figures_html(&mut h, r, dir, false)?;
    h += "</body></html>\n";
    Ok(h)
}

/// The figures that lead (`lead`) or follow the tables, inlined.
fn figures_html(h: &mut String, r: &RunReport, dir: &Path, lead: bool) -> Result<(), FileError> {
    for img in r.images.iter().filter(|f| leading(f) == lead) {
        let path = dir.join(img);
        let bytes = std::fs::read(&path).map_err(FileError::io(&path))?;
        let b64 = base64::engine::general_purpose::STANDARD.encode(&bytes);
        let _ = writeln!(
            h,
            "<figure><img alt=\"{0}\" src=\"data:image/png;base64,{b64}\"><figcaption><b>{0}</b>: {1}</figcaption></figure>",
            escape(img),
            escape(&caption(r, img))
        );
    }
    Ok(())
}

/// What to look for in figure `file`.
fn caption(r: &RunReport, file: &str) -> String {
    let frame = file.strip_prefix("render/").and_then(|f| r.frames.as_ref()?.frames.iter().find(|x| x.image == f));
    if let Some(f) = frame {
        let what = f
            .roughness
            .map_or("every surface diffuse".to_string(), |x| format!("every surface a reflector of roughness {x}"));
        let beside = f.flip.box_projection.map_or(format!("the CPU sampler's frame (ꟻLIP {:.3})", f.flip.cpu), |b| {
            format!("box projection (ꟻLIP {b:.3})")
        });
        return format!(
            "camera {}, {what}, drawn as an engine draws it (rasterised, shaded by the exported shader): the traced reference | the shader's frame (ꟻLIP {:.3}) | {beside} | the shader's ꟻLIP map. The reference's own noise is ꟻLIP {:.3}; render/render.md has every figure.",
            f.camera, f.flip.shader, f.flip.reference_noise
        );
    }
    static_caption(file).to_string()
}

fn static_caption(file: &str) -> &'static str {
    match file {
        "eval_error_vs_cost.png" => {
            "every method's held-out tone-mapped error against its cost per lookup, mirror lookups; the red line is the Pareto front. Look for the fitted grid (fitted = runtime) below and left of the seed methods, and for how far it sits from the oracle bound."
        }
        "eval_rough.png" => {
            "mean ꟻLIP of the rendered views against cost, one panel per roughness; green is the runtime. Look for the runtime at the bottom of each panel among methods of similar cost."
        }
        "eval_views.png" => {
            "what probe A shows from one validation position through each method, beside the traced reference: look for misplaced geometry near edges and through openings."
        }
        "fit_convergence.png" => {
            "the fit's training objective against time per solver stage: a curve still falling at its end says more iterations would pay."
        }
        "residual_slices.png" => {
            "per grid layer, how much of the fallback's held-out error each cell's stored map removes; grey cells keep the fallback, black ones are inside geometry. Clusters of grey near walls or openings are where single fetches from A cannot do better."
        }
        "sweep.png" => {
            "what a player sees (ꟻLIP at roughness 0.5) against fit time, one knob at a time: flat lines mean the knob is not worth its time."
        }
        "sweep_convergence.png" => "training objective against time for each solver of the sweep.",
        f if f.starts_with("flip_r") => {
            "every camera at this roughness, one band each: the traced reference, the runtime and the best other methods, each above its ꟻLIP error map (black: no visible difference, yellow: large). Look for seams between cells and misplaced reflections."
        }
        _ => "",
    }
}

/// Builds the report from a run folder and writes report.json, report.md and report.html
/// there.
pub fn write_report(folder: &RunFolder, command: &str) -> Result<RunReport, FileError> {
    // figures of a sweep are rendered from its data, so a report always shows the current style
    if folder.sweep_json().is_file() {
        let sw: Sweep = read_json(&folder.sweep_json())?;
        super::sweep::plot(folder, &sw)?;
    }
    let r = build(folder, command)?;
    write_json(&folder.report_json(), &r)?;
    write_atomic(&folder.report_md(), markdown(&r).as_bytes())?;
    write_atomic(&folder.report_html(), html(&r, &folder.dir)?.as_bytes())?;
    Ok(r)
}
