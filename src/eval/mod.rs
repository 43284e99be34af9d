//! Judging: every method against raytraced references on a held-out validation set.
//!
//! - `validation`: the held-out queries (own sampler domain, never fitted on) with references
//!   and oracle directions from `trace::truth`;
//! - `methods`: one row per seed method, corrective grid and loaded fitted grid;
//! - `metrics`: error statistics, and the fitted grid's error split by cell level;
//! - `timing`: the one timing harness (single-threaded warm loops);
//! - `options`: the warp1 option sweep (depth mip, UV relaxation);
//! - `views`: what a reflection sees from one validation position, per method.
//!
//! References are traced with the same radiance model as the probe, so the only difference
//! between a method and its reference is the warp (plus sampling noise, which the `oracle`
//! row bounds from below). Evaluation writes no files: the report does.

pub mod methods;
pub mod metrics;
pub mod options;
pub mod timing;
pub mod validation;
pub mod views;

pub use methods::{CorrectiveRow, CorrectiveVariant, MethodResult};
pub use metrics::{ErrorStats, LevelEval, error_stats};
pub use options::Warp1OptionRow;
pub use validation::{DOMAIN_EVAL, ValidationSet, validation_set};
pub use views::Views;

use crate::bake::Baked;
use crate::progress::Progress;
use crate::runtime::FittedGrid;
use crate::trace::Renderer;
use crate::warp::{Method, Warp, WarpOptions};
use serde::{Deserialize, Serialize};

/// Size and seed of the validation set.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EvalSettings {
    pub positions: u32,
    pub dirs_per_position: u32,
    pub reference_spp: u32,
    pub seed: u64,
    pub options: WarpOptions,
    /// Lookups per timing loop (single-threaded, warm).
    pub timing_lookups: u32,
}

impl EvalSettings {
    /// The default validation set: 256 positions × 256 directions, 16-sample references.
    pub const fn standard() -> Self {
        EvalSettings {
            positions: 256,
            dirs_per_position: 256,
            reference_spp: 16,
            seed: 0xE7A1,
            options: WarpOptions::standard(),
            timing_lookups: 32_768,
        }
    }

    /// A small set for tests: seconds, not minutes.
    pub const fn quick() -> Self {
        EvalSettings { positions: 16, dirs_per_position: 32, reference_spp: 1, timing_lookups: 512, ..Self::standard() }
    }
}

impl Default for EvalSettings {
    fn default() -> Self {
        Self::standard()
    }
}

/// Everything `eval.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EvalReport {
    pub scene: String,
    pub positions: usize,
    pub lookups: usize,
    /// Fraction of validation lookups whose true hit is hidden from probe A.
    pub hidden_fraction: f64,
    /// Cost of tracing one reference ray (one radiance sample), single-threaded.
    pub reference_ns_per_ray: f64,
    pub methods: Vec<MethodResult>,
    pub warp1_sweep: Vec<Warp1OptionRow>,
    pub settings: EvalSettings,
    pub command: String,
    /// `fitted` split by the level of the cell containing each validation position.
    #[serde(default)]
    pub fitted_levels: Vec<LevelEval>,
    /// Wall time of the evaluation (references, methods, timings) and its traced rays.
    #[serde(default)]
    pub seconds: f64,
    #[serde(default)]
    pub reference_rays: u64,
}

/// What an evaluation judges: a scene with its tracer and bake, the warp context, the seed
/// methods, corrective grids and (optionally) a fitted grid loaded from disk.
#[derive(Clone, Copy)]
pub struct Subject<'a> {
    pub baked: Baked<'a>,
    pub warp: &'a Warp,
    pub methods: &'a [Method],
    pub corrective_rows: &'a [CorrectiveRow<'a>],
    pub runtime: Option<&'a FittedGrid>,
}

/// An evaluation: the report (eval.json) and the view tiles (eval_views.png).
pub struct Evaluation {
    pub report: EvalReport,
    pub views: Option<Views>,
}

/// Evaluates the subject on its scene's validation set. `subject.warp` must carry
/// `settings.options`.
pub fn evaluate(subject: Subject, settings: &EvalSettings, command: &str, progress: &Progress) -> Evaluation {
    let Subject { baked, warp, methods, corrective_rows, runtime } = subject;
    let Baked { scene, tracer, grid, .. } = baked;
    let t0 = std::time::Instant::now();
    let bar = progress.bar(3, "eval");
    bar.set_message("eval: references");
    let set = validation_set(scene, tracer, grid, warp.probe.position, settings);
    bar.inc(1);
    bar.set_message("eval: methods");
    let lookups = settings.timing_lookups as usize;
    let mut rows = methods::evaluate_methods(warp, &set, methods, lookups);
    for &r in corrective_rows {
        rows.push(methods::evaluate_correctives(warp, &set, r, lookups));
    }
    let fitted_levels = corrective_rows
        .iter()
        .find(|r| r.variant == CorrectiveVariant::Fitted)
        .map(|r| metrics::level_errors(warp, &set, r.correctives))
        .unwrap_or_default();
    if let Some(g) = runtime {
        rows.push(methods::evaluate_runtime(&set, g, lookups));
    }
    bar.inc(1);
    bar.set_message("eval: warp1 options");
    let warp1_sweep = options::warp1_options(warp, &set);
    bar.inc(1);
    bar.finish_and_clear();
    let renderer = Renderer::new(scene, tracer);
    let report = EvalReport {
        scene: scene.name.clone(),
        positions: set.positions.len(),
        lookups: set.dirs.len(),
        hidden_fraction: set.hidden_fraction(),
        reference_ns_per_ray: timing::time_reference(&renderer, &set, 4096),
        methods: rows,
        warp1_sweep,
        settings: settings.clone(),
        command: command.to_string(),
        fitted_levels,
        seconds: t0.elapsed().as_secs_f64(),
        reference_rays: set.rays,
    };
    let views = views::views(scene, tracer, warp, &set, settings.reference_spp, settings.seed, corrective_rows);
    Evaluation { report, views }
}
