//! The stages chained as the CLI runs them: bake (or reuse a matching bake on disk), then
//! evaluate. Thin glue; each stage lives in its own module.

use crate::bake::{self, ProbeGrid, SpecularProbe};
use crate::eval::{self, EvalSettings, MethodContext};
use crate::fit::{Blend, Correctives, Fit, FitSettings};
use crate::format::{FormatError, bake_io};
use crate::progress::Progress;
use crate::report::{self, EvalReport, SweepRow};
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer};
use crate::warp::{Method, WarpOptions};
use std::path::Path;

/// The bake in `dir` if it was made from exactly these scene settings, else a fresh bake
/// written to `dir`. Returns the probe, the grid and whether it baked.
pub fn load_or_bake(
    scene: &Scene,
    tracer: &Tracer,
    dir: &Path,
    progress: &Progress,
) -> Result<(SpecularProbe, ProbeGrid, bool), FormatError> {
    if dir.join(bake_io::MANIFEST_FILE).is_file() {
        match bake_io::read_bake(dir) {
            Ok((m, probe, grid))
                if serde_json::to_value(&m.settings).ok() == serde_json::to_value(&scene.config).ok() =>
            {
                tracing::info!("reusing bake in {}", dir.display());
                return Ok((probe, grid, false));
            }
            Ok(_) => tracing::info!("bake in {} was made with other settings; baking again", dir.display()),
            Err(e) => tracing::warn!("ignoring unreadable bake: {e}"),
        }
    }
    let baked = bake::bake(scene, tracer, progress);
    bake_io::write_bake(dir, scene, &baked)?;
    Ok((baked.probe, baked.grid, true))
}

/// A scene with its tracer and bake: what every stage after the bake reads.
#[derive(Clone, Copy)]
pub struct Baked<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a Tracer,
    pub probe: &'a SpecularProbe,
    pub grid: &'a ProbeGrid,
}

/// A corrective grid to evaluate beside the warp methods.
pub struct CorrectiveRow<'a> {
    pub name: &'a str,
    pub note: &'a str,
    pub correctives: &'a Correctives,
    pub blend: Blend,
}

/// Fits the correctives of every active cell and writes the provisional fit files.
pub fn fit(
    baked: Baked,
    settings: &FitSettings,
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<Fit, FormatError> {
    let ctx = MethodContext::new(baked.scene, baked.probe);
    let fitted = crate::fit::fit(baked.scene, baked.tracer, baked.probe, baked.grid, &ctx.proxies, settings, progress);
    crate::fit::output::write_fit(dir, &fitted)?;
    crate::fit::output::write_fit_report(&dir.join("fit.md"), &fitted, command)?;
    Ok(fitted)
}

/// Evaluates `methods` (and corrective grids) on the scene's validation set and writes
/// eval.json/.md/.png to `dir`.
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    baked: Baked,
    settings: &EvalSettings,
    methods: &[Method],
    corrective_rows: &[CorrectiveRow],
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<EvalReport, FormatError> {
    let Baked { scene, tracer, probe, grid } = baked;
    let bar = progress.bar(3, "eval");
    bar.set_message("eval: references");
    let set = eval::validation_set(scene, tracer, grid, probe.position, settings);
    bar.inc(1);
    bar.set_message("eval: methods");
    let ctx = MethodContext::new(scene, probe);
    let lookups = settings.timing_lookups as usize;
    let mut rows = eval::evaluate_methods(&ctx, &set, methods, &settings.options, lookups);
    for r in corrective_rows {
        rows.push(eval::evaluate_correctives(
            &ctx,
            &set,
            r.name,
            r.note,
            r.correctives,
            r.blend,
            &settings.options,
            lookups,
        ));
    }
    bar.inc(1);
    bar.set_message("eval: warp1 sweep");
    let mut sweep = Vec::new();
    let max_lod = (probe.depth.levels.len() - 1).min(4);
    for lod in 0..=max_lod {
        for relax in [0.0f32, 1.0, 2.0] {
            let opts = WarpOptions { depth_lod: lod as f32, relax_texels: relax, ..settings.options };
            let dirs = eval::fetch_dirs(&ctx, &set, Method::Warp1, &opts);
            let est: Vec<glam::Vec3> = dirs.iter().map(|&d| ctx.probe.radiance(d)).collect();
            sweep.push(SweepRow {
                depth_lod: lod as f32,
                relax_texels: relax,
                rel_rmse: eval::error_stats(&est, &set.reference).0,
            });
        }
    }
    bar.inc(1);
    bar.finish_and_clear();
    let renderer = Renderer::new(scene, tracer);
    let report = EvalReport {
        scene: scene.name.clone(),
        positions: set.positions.len(),
        lookups: set.dirs.len(),
        hidden_fraction: set.hidden.iter().filter(|h| **h).count() as f64 / set.hidden.len().max(1) as f64,
        reference_ns_per_ray: eval::time_reference(&renderer, &set, 4096),
        methods: rows,
        warp1_sweep: sweep,
        settings: settings.clone(),
        command: command.to_string(),
    };
    report::write_eval(dir, &report)?;
    Ok(report)
}
