//! Error against fit effort: one knob at a time around the given settings (probe
//! resolution, training directions per position, solver iterations, solver), each a real
//! bake + fit + write + load, judged by the runtime sampler on one held-out validation set
//! and one set of rendered views (ꟻLIP at roughness 0 and 0.5) shared by every row. Writes `sweep.json`, `sweep.png` and `sweep_convergence.png`.

use super::run::{self, Output, StoreOptions};
use crate::eval::methods::{Fetch, Row};
use crate::eval::{self, EvalSettings, RenderSettings, renders};
use crate::files::{FileError, write_json};
use crate::fit::MapSets;
use crate::fit::{FitSettings, Solver};
use crate::perceptual;
use crate::progress::Progress;
use crate::report::folder::RunFolder;
use crate::report::sweep::{Knob, Sweep, SweepRow};
use crate::runtime::FittedGrid;
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::glossy::Glossy;

/// Roughness of the rendered views every row is judged on by ꟻLIP.
const FLIP_ROUGHNESS: [f32; 2] = [0.0, 0.5];

/// One configuration of the sweep: the knob turned, its value, the probe resolution and the
/// fit settings.
struct Config {
    knob: Knob,
    value: String,
    probe_resolution: u32,
    settings: FitSettings,
    /// The row at the given settings (the one its knob's other rows are compared with).
    given: bool,
}

/// The configurations around `base`: each knob at three values, the rest unchanged.
fn configs(base_res: u32, base: &FitSettings) -> Vec<Config> {
    let at = |knob, value: String, probe_resolution, settings, given| Config {
        knob,
        value,
        probe_resolution,
        settings,
        given,
    };
    let mut out = Vec::new();
    for res in [base_res / 4, base_res / 2, base_res].into_iter().filter(|&r| r >= 16) {
        out.push(at(Knob::ProbeResolution, res.to_string(), res, base.clone(), res == base_res));
    }
    for d in [32u32, 64, 128] {
        let settings = FitSettings { train_dirs: d, ..base.clone() };
        out.push(at(Knob::TrainingDirections, d.to_string(), base_res, settings, d == base.train_dirs));
    }
    for it in [1u32, 2, 3] {
        let settings = FitSettings { iterations: it, ..base.clone() };
        out.push(at(Knob::Iterations, it.to_string(), base_res, settings, it == base.iterations));
    }
    for s in [Solver::Brent, Solver::Lbfgs, Solver::NelderMead] {
        let value = format!("{s:?}").to_lowercase();
        out.push(at(Knob::Solver, value, base_res, FitSettings { solver: s, ..base.clone() }, s == base.solver));
    }
    out
}

/// Runs the sweep for `scene` into `folder` (each fit written to `<folder>/sweep/<knob>-<value>`,
/// loaded, measured, then removed).
pub fn sweep(
    scene: &Scene,
    base: &FitSettings,
    eval_settings: &EvalSettings,
    folder: &RunFolder,
    command: &str,
    progress: &Progress,
) -> Result<Sweep, FileError> {
    let configs = configs(scene.config.probe.resolution, base);
    let tracer = Tracer::new(scene);
    let mut bakes: Vec<(u32, crate::bake::Bake)> = Vec::new();
    let mut rows = Vec::new();
    // per row: its knob, whether it is at the given settings, and its r = 0 ꟻLIP tiles
    let mut tiles: Vec<(Knob, bool, Vec<perceptual::Tile>)> = Vec::new();
    let mut convergence = Vec::new();
    let mut set = None;
    // rendered views and their references (r = 0 and 0.5), shared by every row, and the
    // exposure every row is judged at (the base bake's)
    let mut views: Option<(f32, Vec<Vec<renders::ViewReference>>)> = None;
    let bar = progress.bar(configs.len() as u64, "sweep");
    for c in configs {
        bar.set_message(format!("sweep: {} {}", c.knob.name(), c.value));
        if !bakes.iter().any(|(r, _)| *r == c.probe_resolution) {
            let mut s = scene.clone();
            s.config.probe.resolution = c.probe_resolution;
            bakes.push((c.probe_resolution, crate::bake::bake(&s, &tracer, &Progress::quiet())));
        }
        let bake = &bakes.iter().find(|(r, _)| *r == c.probe_resolution).expect("baked above").1;
        let baked = bake.baked(scene, &tracer);
        // the validation set depends on the grid and the probe position only: one for all rows
        let set = set.get_or_insert_with(|| {
            eval::validation_set(scene, &tracer, &bake.grid, &bake.positions(), eval_settings, None)
        });
        let (exposure, view_refs) = views.get_or_insert_with(|| {
            let exposure = bake.probe.warp_probe().key_exposure();
            let rs = eval_settings.renders.unwrap_or(RenderSettings::standard());
            let vs = renders::views(scene, &tracer, &set.positions, &bake.positions(), &rs);
            let refs = FLIP_ROUGHNESS
                .iter()
                .enumerate()
                .map(|(b, &r)| {
                    vs.iter()
                        .enumerate()
                        .map(|(k, v)| {
                            let tag = 0x5EE9_0000 + (b * 16 + k) as u64;
                            renders::reference(
                                (scene, &tracer, None),
                                v,
                                r,
                                rs.reference_spp,
                                (eval_settings.seed, tag, exposure),
                            )
                        })
                        .collect()
                })
                .collect();
            (exposure, refs)
        });
        let exposure = *exposure;
        let row_folder =
            RunFolder::new(folder.dir.join("sweep").join(format!("{}-{}", c.knob.name().replace(' ', "-"), c.value)));
        let warp = baked.warp(eval_settings.options);
        let out = Output { folder: &row_folder, command, progress: &Progress::quiet() };
        let (fit, manifest) = run::fit(baked, &warp, &c.settings, StoreOptions::default(), MapSets::Stored, out)?;
        let grid = FittedGrid::load(&row_folder.dir)?;
        let est: Vec<glam::Vec3> =
            (0..set.dirs.len()).map(|k| grid.specular(set.position_of(k), set.dirs[k], 0.0)).collect();
        let stats = eval::error_stats(&est, &set.reference, exposure);
        let row = Row { fetch: Fetch::Runtime(&grid, grid.read()), rule: None, renorm: None };
        let shading = Glossy { warp: &warp, correction: grid.roughness() };
        // r = 0 as tiles (its mean, and its difference from the given row's), r = 0.5 as a mean
        let tiles_r0 =
            perceptual::flip_tiles(&view_refs[0], exposure, 8, |r, b, dir, o| row.estimate(shading, b, dir, o, r));
        let flip_r0 = perceptual::weighted_mean(&tiles_r0);
        tiles.push((c.knob, c.given, tiles_r0));
        rows.push(SweepRow {
            knob: c.knob,
            value: c.value.clone(),
            fit_seconds: fit.seconds,
            rel_rmse: stats.rel_rmse,
            tm_rmse: stats.tm_rmse,
            flip_r0,
            flip_r05: renders::mean_flip(&row, shading, &view_refs[1], exposure),
            flip_r0_se: None,
            stored_cells: fit.correctives.stored_cells(),
            payload_bytes: manifest.payloads.iter().map(|p| p.bytes).sum(),
        });
        // each row's grid was needed only to be measured through the runtime sampler
        let _ = std::fs::remove_dir_all(&row_folder.dir);
        if c.knob == Knob::Solver {
            convergence.push((c.value, crate::fit::summary::convergence(&fit, rayon::current_num_threads())));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    for (row, (knob, given, t)) in rows.iter_mut().zip(&tiles) {
        let base = tiles.iter().find(|(k, g, _)| k == knob && *g).map(|x| &x.2);
        row.flip_r0_se = base.filter(|_| !given).map(|b| perceptual::paired_standard_error(t, b));
    }
    let _ = std::fs::remove_dir(folder.dir.join("sweep"));
    let set = set.expect("at least one row");
    let sweep = Sweep {
        scene: scene.name.clone(),
        command: command.to_string(),
        validation: format!(
            "{} positions × {} directions, references with {} samples, seed {:#x}",
            set.positions.len(),
            set.dirs_per_position,
            eval_settings.reference_spp,
            eval_settings.seed
        ),
        rows,
        convergence,
    };
    write_json(&folder.sweep_json(), &sweep)?;
    crate::report::sweep::plot(folder, &sweep)?;
    Ok(sweep)
}
