//! Error against fit effort: one knob at a time around the given settings (probe
//! resolution, training directions per position, solver iterations, solver), each a real
//! bake + fit + write + load, judged by the runtime sampler on one held-out validation set
//! shared by every row. Writes `sweep.json`, `sweep.png` (held-out error against fit time,
//! a line per knob) and `sweep_convergence.png` (training objective against time per solver).

use crate::eval::{self, EvalSettings};
use crate::fit::{FitSettings, Solver};
use crate::format::FormatError;
use crate::pipeline::{self, Baked, StoreOptions};
use crate::progress::Progress;
use crate::runtime::FittedGrid;
use crate::scene::Scene;
use crate::trace::Tracer;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One fit of the sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SweepRow {
    pub knob: String,
    pub value: String,
    pub fit_seconds: f64,
    /// Runtime `specular` at roughness 0 on the shared validation set: rel RMSE.
    pub rel_rmse: f64,
    pub stored_cells: usize,
    pub payload_bytes: u64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Sweep {
    pub scene: String,
    pub command: String,
    pub validation: String,
    pub rows: Vec<SweepRow>,
    /// Per solver: (fit time s, mean training objective) after each stage.
    pub convergence: Vec<(String, Vec<(f64, f64)>)>,
}

/// Runs the sweep for `scene` into `dir` (each fit written to `dir/sweep/<knob>-<value>`,
/// loaded, measured, then removed).
pub fn run(
    scene: &Scene,
    base: &FitSettings,
    eval_settings: &EvalSettings,
    dir: &Path,
    command: &str,
    progress: &Progress,
) -> Result<Sweep, FormatError> {
    let base_res = scene.config.probe.resolution;
    let mut configs: Vec<(String, String, u32, FitSettings)> = Vec::new();
    for res in [base_res / 4, base_res / 2, base_res] {
        if res >= 16 {
            configs.push(("probe resolution".into(), res.to_string(), res, base.clone()));
        }
    }
    for d in [32u32, 64, 128] {
        configs.push((
            "training directions".into(),
            d.to_string(),
            base_res,
            FitSettings { train_dirs: d, ..base.clone() },
        ));
    }
    for it in [1u32, 2, 3] {
        configs.push(("iterations".into(), it.to_string(), base_res, FitSettings { iterations: it, ..base.clone() }));
    }
    for s in [Solver::Brent, Solver::Lbfgs, Solver::NelderMead] {
        configs.push((
            "solver".into(),
            format!("{s:?}").to_lowercase(),
            base_res,
            FitSettings { solver: s, ..base.clone() },
        ));
    }

    let tracer = Tracer::new(scene);
    let mut bakes: Vec<(u32, crate::bake::Bake)> = Vec::new();
    let mut rows = Vec::new();
    let mut convergence = Vec::new();
    let mut set = None;
    let bar = progress.bar(configs.len() as u64, "sweep");
    for (knob, value, res, settings) in configs {
        bar.set_message(format!("sweep: {knob} {value}"));
        if !bakes.iter().any(|(r, _)| *r == res) {
            let mut s = scene.clone();
            s.config.probe.resolution = res;
            bakes.push((res, crate::bake::bake(&s, &tracer, &Progress::quiet())));
        }
        let bake = &bakes.iter().find(|(r, _)| *r == res).expect("baked above").1;
        let baked = Baked { scene, tracer: &tracer, probe: &bake.probe, grid: &bake.grid };
        // the validation set depends on the grid and the probe position only: one for all rows
        let set = set.get_or_insert_with(|| {
            eval::validation_set(scene, &tracer, &bake.grid, bake.probe.position, eval_settings)
        });
        let out = dir.join("sweep").join(format!("{}-{value}", knob.replace(' ', "-")));
        let warp = baked.warp(eval_settings.options);
        let (fit, manifest) =
            pipeline::fit(baked, &warp, &settings, StoreOptions::default(), &out, command, &Progress::quiet())?;
        let grid = FittedGrid::load(&out).map_err(|e| FormatError::Invalid {
            path: out.clone(),
            field: "fitted grid".into(),
            message: e.to_string(),
        })?;
        let est: Vec<glam::Vec3> =
            (0..set.dirs.len()).map(|k| grid.specular(set.position_of(k), set.dirs[k], 0.0)).collect();
        rows.push(SweepRow {
            knob: knob.clone(),
            value: value.clone(),
            fit_seconds: fit.seconds,
            rel_rmse: eval::error_stats(&est, &set.reference).rel_rmse,
            stored_cells: fit.correctives.stored_cells(),
            payload_bytes: manifest.payloads.iter().map(|p| p.bytes).sum(),
        });
        // each row's grid was needed only to be measured through the runtime sampler
        let _ = std::fs::remove_dir_all(&out);
        if knob == "solver" {
            convergence.push((value, crate::fit::output::convergence(&fit, rayon::current_num_threads())));
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let _ = std::fs::remove_dir(dir.join("sweep"));
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
    crate::fit::output::write_json(&dir.join("sweep.json"), &sweep)?;
    plot(dir, &sweep)?;
    Ok(sweep)
}

/// Renders `sweep.png` and `sweep_convergence.png` from a sweep.
pub fn plot(dir: &Path, sw: &Sweep) -> Result<(), FormatError> {
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    // one line per knob, through its values in sweep order (named in the legend)
    let mut knobs: Vec<&str> = Vec::new();
    for r in &sw.rows {
        if !knobs.contains(&r.knob.as_str()) {
            knobs.push(&r.knob);
        }
    }
    for k in knobs {
        let rows: Vec<&SweepRow> = sw.rows.iter().filter(|r| r.knob == k).collect();
        let values: Vec<&str> = rows.iter().map(|r| r.value.as_str()).collect();
        series
            .push((format!("{k}: {}", values.join(" → ")), rows.iter().map(|r| (r.fit_seconds, r.rel_rmse)).collect()));
    }
    crate::report::plot::line_plot(
        &dir.join("sweep.png"),
        &format!("{}: held-out error against fit time, one knob at a time", sw.scene),
        "fit time (s)",
        "runtime rel RMSE (held out)",
        &series,
    )?;
    crate::report::plot::line_plot(
        &dir.join("sweep_convergence.png"),
        &format!("{}: fit convergence per solver", sw.scene),
        "fit time on this machine (s, references excluded)",
        "mean training objective per cell",
        &sw.convergence,
    )?;
    Ok(())
}
