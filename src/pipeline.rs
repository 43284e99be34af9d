//! The stages chained as the CLI runs them: bake (or reuse a matching bake on disk), then
//! evaluate. Thin glue; each stage lives in its own module.

use crate::bake::{self, ProbeGrid, SpecularProbe};
use crate::eval::{self, EvalSettings, MethodContext};
use crate::fit::{Blend, Correctives, Fit, FitSettings};
use crate::format::{FormatError, bake_io, grid_io};
use crate::progress::Progress;
use crate::report::{self, EvalReport, SweepRow};
use crate::runtime::{FittedGrid, GridManifest, Precision};
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
    settings: &FitSettings,
    store: StoreOptions,
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<(Fit, GridManifest), FormatError> {
    let ctx = MethodContext::new(baked.scene, baked.probe);
    let fitted = crate::fit::fit(baked.scene, baked.tracer, baked.probe, baked.grid, &ctx.proxies, settings, progress);
    let roughness = (store.roughness && baked.probe.radiance.levels.len() > 1).then(crate::roughness::fit_correction);
    let manifest = grid_io::write_grid(
        dir,
        &grid_io::GridInputs {
            scene: &baked.scene.name,
            probe: baked.probe,
            grid: baked.grid,
            proxies: &ctx.proxies,
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

/// Evaluates `methods` (and corrective grids) on the scene's validation set and writes
/// eval.json/.md/.png to `dir`.
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    baked: Baked,
    settings: &EvalSettings,
    methods: &[Method],
    corrective_rows: &[CorrectiveRow],
    runtime: Option<&FittedGrid>,
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<EvalReport, FormatError> {
    let Baked { scene, tracer, probe, grid } = baked;
    let t0 = std::time::Instant::now();
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
    let fitted_levels = corrective_rows
        .iter()
        .find(|r| r.name == "fitted")
        .map(|r| level_errors(&ctx, &set, r.correctives, &settings.options))
        .unwrap_or_default();
    if let Some(g) = runtime {
        let precision = g.manifest.payloads.iter().flat_map(|p| &p.layers).any(|l| l.precision == Precision::F16);
        let note = if precision {
            "the fitted grid loaded from disk (f16 radiance), runtime::FittedGrid::specular at roughness 0"
        } else {
            "the fitted grid loaded from disk (f32), runtime::FittedGrid::specular at roughness 0"
        };
        rows.push(eval::evaluate_runtime(&set, "runtime", note, g, lookups));
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
        fitted_levels,
        seconds: t0.elapsed().as_secs_f64(),
        reference_rays: set.reference_rays,
    };
    report::write_eval(dir, &report)?;
    write_views(baked, &ctx, &set, settings, corrective_rows, &dir.join("eval_views.png"))?;
    Ok(report)
}

/// `fitted` on the validation lookups split by the level of their position's cell.
fn level_errors(
    ctx: &MethodContext,
    set: &eval::ValidationSet,
    c: &Correctives,
    opts: &WarpOptions,
) -> Vec<report::LevelEval> {
    let mut out = Vec::new();
    for level in [0u8, 2] {
        let (mut fit_est, mut fb_est, mut refs) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..set.dirs.len() {
            let b = set.position_of(k);
            let cell = c.geometry.cell_index(c.geometry.cell_of(b));
            let l = if c.slot[cell] == u32::MAX { 0 } else { 2 };
            if l != level {
                continue;
            }
            let d = set.dirs[k];
            fit_est.push(ctx.probe.radiance(c.fetch_vector(Blend::Cell, &ctx.probe, &ctx.proxies, opts, b, d)));
            fb_est.push(crate::warp::lookup(c.fallback, &ctx.probe, &ctx.proxies, opts, b, d));
            refs.push(set.reference[k]);
        }
        if !refs.is_empty() {
            out.push(report::LevelEval {
                level,
                lookups: refs.len(),
                fitted_rel_rmse: eval::error_stats(&fit_est, &refs).0,
                fallback: c.fallback.name().to_string(),
                fallback_rel_rmse: eval::error_stats(&fb_est, &refs).0,
            });
        }
    }
    out
}

/// `eval_views.png`: what a reflection sees from an open validation position, as
/// octahedral maps: the raytraced reference, then the probe warped by each method.
fn write_views(
    baked: Baked,
    ctx: &MethodContext,
    set: &eval::ValidationSet,
    settings: &EvalSettings,
    corrective_rows: &[CorrectiveRow],
    path: &Path,
) -> Result<(), FormatError> {
    use crate::octa::{self, OctMap};
    // The most open of the first 32 validation positions (largest nearest-hit distance over
    // 64 directions): a view hugging a column shows mostly that column.
    let openness = |b: glam::Vec3| {
        (0..64u32)
            .map(|k| crate::sampling::uniform_sphere(crate::sampling::Sampler::new(5, 0, k).next_2d()))
            .map(|d| baked.tracer.closest_hit(b, d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t))
            .fold(f32::INFINITY, f32::min)
    };
    let Some(&b) = set.positions.iter().take(32).max_by(|p, q| openness(**p).total_cmp(&openness(**q))) else {
        return Ok(());
    };
    let res = 128u32;
    let dirs: Vec<glam::Vec3> = (0..res * res).map(|t| octa::texel_dir(res, t % res, t / res)).collect();
    let renderer = crate::trace::Renderer::new(baked.scene, baked.tracer);
    let origins = vec![b; dirs.len()];
    let (reference, _) =
        crate::trace::trace_batch(&renderer, &origins, &dirs, settings.seed, 0x7E5, settings.reference_spp);
    let mut tiles = vec![("reference".to_string(), OctMap::new(res, reference.iter().map(|r| r.radiance).collect()))];
    for m in [Method::None, Method::Box, Method::Warp1, Method::Raymarch] {
        let map = OctMap::new(
            res,
            dirs.iter().map(|&d| crate::warp::lookup(m, &ctx.probe, &ctx.proxies, &settings.options, b, d)).collect(),
        );
        tiles.push((m.name().to_string(), map));
    }
    for r in corrective_rows.iter().filter(|r| r.name == "fitted") {
        let map = OctMap::new(
            res,
            dirs.iter()
                .map(|&d| {
                    ctx.probe.radiance(r.correctives.fetch_vector(
                        r.blend,
                        &ctx.probe,
                        &ctx.proxies,
                        &settings.options,
                        b,
                        d,
                    ))
                })
                .collect(),
        );
        tiles.push((r.name.to_string(), map));
    }
    let oracle = OctMap::new(
        res,
        dirs.iter()
            .map(|&d| ctx.probe.radiance(eval::oracle(baked.scene, baked.tracer, baked.probe.position, b, d).0))
            .collect(),
    );
    tiles.push(("oracle".to_string(), oracle));
    let title = format!(
        "{}: seen from validation position ({:.2}, {:.2}, {:.2}); octahedral maps, +Z at the centre",
        baked.scene.name, b.x, b.y, b.z
    );
    crate::report::plot::views(path, &title, &tiles)
}
