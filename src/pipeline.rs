//! The stages chained as the CLI runs them: bake (or reuse a matching bake on disk), then
//! evaluate. Thin glue; each stage lives in its own module.

use crate::bake::{self, ProbeGrid, SpecularProbe};
use crate::eval::{self, CorrectiveRow, CorrectiveVariant, EvalReport, EvalSettings};
use crate::fit::{Fit, FitInputs, FitSettings};
use crate::format::{FormatError, bake_io, grid_io};
use crate::progress::Progress;
use crate::report;
use crate::runtime::{GridManifest, Precision};
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::corrective::Blend;
use crate::warp::{Warp, WarpOptions};
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

impl Baked<'_> {
    /// The warp context of this bake with `options`.
    pub fn warp(&self, options: WarpOptions) -> Warp {
        bake::warp(self.scene, self.probe, options)
    }
}

/// How a fitted grid is stored.
#[derive(Clone, Copy, Debug)]
pub struct StoreOptions {
    pub precision: Precision,
    /// Store the GGX roughness correction (left out anyway when the probe has no rough mips).
    pub roughness: bool,
}

impl Default for StoreOptions {
    fn default() -> Self {
        StoreOptions { precision: Precision::F32, roughness: true }
    }
}

/// Fits the correctives of every active cell, writes the fitted grid folder to `dir`
/// (manifest.json + EXR payloads) with the fit's diagnostics, and returns the fit and the
/// grid's manifest.
pub fn fit(
    baked: Baked,
    warp: &Warp,
    settings: &FitSettings,
    store: StoreOptions,
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<(Fit, GridManifest), FormatError> {
    let inputs = FitInputs { scene: baked.scene, tracer: baked.tracer, grid: baked.grid, warp };
    let fitted = crate::fit::fit(inputs, settings, progress);
    let roughness = (store.roughness && baked.probe.radiance.levels.len() > 1).then(crate::roughness::fit_correction);
    let manifest = grid_io::write_grid(
        dir,
        &grid_io::GridInputs {
            scene: &baked.scene.name,
            probe: baked.probe,
            grid: baked.grid,
            warp,
            fit: &fitted,
            blend: Blend::Cell,
            roughness: roughness.as_ref(),
            precision: store.precision,
        },
    )?;
    crate::fit::output::write_fit_diagnostics(dir, &fitted)?;
    crate::fit::output::write_fit_report(&dir.join("fit.md"), &fitted, command)?;
    Ok((fitted, manifest))
}

/// Where the bake of a scene's output folder lives.
pub fn bake_dir(out: &Path) -> std::path::PathBuf {
    out.join("bake")
}

/// The corrective rows of a fit, in table order.
pub fn corrective_rows(f: &Fit) -> Vec<CorrectiveRow<'_>> {
    CorrectiveVariant::ALL
        .iter()
        .map(|&variant| {
            let correctives = match variant {
                CorrectiveVariant::Celldepth => &f.celldepth,
                CorrectiveVariant::Fitted | CorrectiveVariant::FittedTrilinear => &f.correctives,
                CorrectiveVariant::FittedL2All => &f.fitted_all,
            };
            CorrectiveRow { variant, correctives }
        })
        .collect()
}

/// Evaluates `methods` (and corrective grids) on the scene's validation set and writes
/// eval.json/.md/.png and eval_views.png to `dir`.
pub fn evaluate(
    subject: eval::Subject,
    settings: &EvalSettings,
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<EvalReport, FormatError> {
    let ev = eval::evaluate(subject, settings, command, progress);
    report::write_eval(dir, &ev.report)?;
    if let Some(v) = &ev.views {
        report::plot::views(&dir.join("eval_views.png"), &v.title, &v.tiles)?;
    }
    Ok(ev.report)
}
