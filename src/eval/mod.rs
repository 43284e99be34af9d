//! Judging: every method against raytraced references on a held-out validation set.
//!
//! - `validation`: the held-out queries (own sampler domain, never fitted on) with references
//!   and oracle directions from `trace::truth`;
//! - `methods`: one row per way to fetch probe A (seed method, oracle, corrective grid,
//!   loaded fitted grid) and way to pick a rough lookup's mip (`warp::glossy::MipRule`);
//! - `metrics`: error statistics (relative and tone-mapped), and the fitted grid's error
//!   split by cell level;
//! - `renders`, `flip`: rendered views (a camera on glossy surfaces, spheres of directions)
//!   judged by ꟻLIP against lobe references with many samples;
//! - `timing`: the one timing harness (single-threaded warm loops);
//! - `options`: the warp1 option sweep (depth mip, UV relaxation);
//! - `views`: what a reflection sees from one validation position, per method.
//!
//! Every row is judged on roughness buckets [`ROUGHNESS_BUCKETS`]: the mirror set and, per
//! rough bucket, the same rays with GGX lobe references (`trace::truth::lobe_reference`, the
//! lobe the probe's mips are prefiltered with). References are traced with the same radiance
//! model as the probe, so the only difference between a row and its reference is the lookup
//! (plus the reference's own noise, reported per bucket as its standard error). Evaluation
//! writes no files: the report does.

pub mod bound;
pub mod diffuse;
pub mod engine;
pub mod methods;
pub mod metrics;
pub mod options;
pub mod renders;
pub mod surface;
pub mod timing;
pub mod validation;
pub mod views;

pub use methods::{CorrectiveRow, CorrectiveVariant, MethodResult, RowId, RowKind};
pub use metrics::{ErrorStats, LevelEval, error_stats};
pub use options::Warp1OptionRow;
pub use renders::RenderSettings;
pub use validation::{DOMAIN_EVAL, ValidationSet, validation_set};
pub use views::Views;

use crate::bake::Baked;
use crate::perceptual;
use crate::progress::Progress;
use crate::roughness::RoughnessCorrection;
use crate::runtime::FittedGrid;
use crate::trace::Renderer;
use crate::warp::glossy::Glossy;
use crate::warp::glossy::MipRule;
use crate::warp::{Method, Warp, WarpOptions};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Size and seed of the validation set.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EvalSettings {
    pub positions: u32,
    pub dirs_per_position: u32,
    pub reference_spp: u32,
    pub seed: u64,
    pub options: WarpOptions,
    /// Lookups per timing loop (single-threaded, warm); rough buckets time a quarter.
    pub timing_lookups: u32,
    /// Rough buckets: the mirror set's first `rough_positions` positions × `rough_dirs`
    /// directions, with lobe references of `rough_reference_spp` samples (0 positions: no
    /// rough buckets).
    #[serde(default)]
    pub rough_positions: u32,
    #[serde(default)]
    pub rough_dirs: u32,
    #[serde(default)]
    pub rough_reference_spp: u32,
    /// A rough bucket whose references' noise is above a quarter of the difference its
    /// claim reports is traced again with twice the samples, while that stays at or below
    /// this many (`rough_reference_spp` or less: never).
    #[serde(default)]
    pub rough_reference_spp_max: u32,
    /// The rendered views judged by ꟻLIP (`None`: not rendered).
    #[serde(default)]
    pub renders: Option<RenderSettings>,
    /// Diffuse: held-out surface points and samples per irradiance reference (0 points: no
    /// diffuse evaluation).
    #[serde(default)]
    pub diffuse_points: u32,
    #[serde(default)]
    pub diffuse_spp: u32,
    /// Surface probes (seed 003): held-out points per patch and reflection directions per
    /// point (0: not judged). References use `reference_spp` and `rough_reference_spp`.
    #[serde(default)]
    pub surface_points: u32,
    #[serde(default)]
    pub surface_dirs: u32,
    /// The mirror set's first `quiet_positions` positions (every direction) traced again
    /// with `quiet_spp` samples from streams of their own, to measure how much of the
    /// mirror bucket's errors is its 16-sample references' own noise
    /// ([`bound::NoiseCeiling`]; 0: not measured).
    #[serde(default)]
    pub quiet_positions: u32,
    #[serde(default)]
    pub quiet_spp: u32,
}

/// The roughness buckets every row is judged on (perceptual roughness; α = r²).
pub const ROUGHNESS_BUCKETS: [f32; 6] = [0.0, 0.125, 0.25, 0.5, 0.75, 1.0];

/// Whether a row (by name or label) is the runtime's own, in any read tier, renormalized or
/// not: the subject of the comparisons, never "the best other row".
#[must_use]
pub fn is_runtime(name: &str) -> bool {
    RowId::parse(name).is_some_and(RowId::is_runtime)
}

/// Whether a row (by name or label) is a bound rather than a method (`oracle`, `best-fetch`,
/// `best-aim`, `in-sample`, …): never on the Pareto front, never "the best other row".
#[must_use]
pub fn is_bound(name: &str) -> bool {
    RowId::parse(name).is_some_and(RowId::is_bound)
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
            rough_positions: 128,
            rough_dirs: 64,
            rough_reference_spp: 512,
            rough_reference_spp_max: 2048,
            renders: Some(RenderSettings::standard()),
            diffuse_points: 1024,
            diffuse_spp: 1024,
            surface_points: 256,
            surface_dirs: 32,
            quiet_positions: 16,
            quiet_spp: 256,
        }
    }

    /// A small set for tests: seconds, not minutes.
    pub const fn quick() -> Self {
        EvalSettings {
            positions: 16,
            dirs_per_position: 32,
            reference_spp: 1,
            timing_lookups: 512,
            rough_positions: 8,
            rough_dirs: 16,
            rough_reference_spp: 8,
            rough_reference_spp_max: 32,
            renders: Some(RenderSettings::quick()),
            diffuse_points: 32,
            diffuse_spp: 16,
            surface_points: 16,
            surface_dirs: 8,
            quiet_positions: 4,
            quiet_spp: 32,
            ..Self::standard()
        }
    }
}

impl Default for EvalSettings {
    fn default() -> Self {
        Self::standard()
    }
}

/// Wall-clock seconds of an evaluation's stages (`EvalReport::times`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EvalTimes {
    /// The mirror validation set and its 16-sample references.
    pub mirror_references: f64,
    /// The rough buckets' validation sets and their lobe references.
    pub rough_references: f64,
    /// The rendered views and their references (every bucket).
    pub view_references: f64,
    /// Probe A's emitted chain (what the rows' linear error with the emitters apart takes
    /// out of their lookups).
    #[serde(default)]
    pub emitted: f64,
    /// Every row's lookups, errors and timing loops, reprojection, the two bounds, the
    /// fitted levels' errors and the `warp1` options sweep.
    pub rows: f64,
    /// Every row's views rendered and judged by ꟻLIP.
    pub flip: f64,
    /// The bucket summaries with the quiet references' noise ceiling.
    pub summaries: f64,
    /// The diffuse table (its references and views) and the surface probes.
    pub diffuse_and_surfaces: f64,
    /// The `in-sample` bound's maps refitted on the mirror validation set (when the fit
    /// kept its maps).
    #[serde(default)]
    pub in_sample: f64,
    /// Sets of references traced by this run, and read back from an earlier run's
    /// (`crate::trace::store::ReferenceStore`; both 0 without a store).
    #[serde(default)]
    pub reference_sets_traced: u64,
    #[serde(default)]
    pub reference_sets_reused: u64,
}

/// Everything `eval.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EvalReport {
    pub scene: String,
    pub positions: usize,
    pub lookups: usize,
    /// Fraction of validation lookups whose true hit is hidden from probe A.
    pub hidden_fraction: f64,
    /// With several probes: the share of the queries whose true hit no probe sees, and how
    /// many probes there are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hidden_fraction_all: Option<(f64, usize)>,
    /// Cost of tracing one reference ray (one radiance sample), single-threaded.
    pub reference_ns_per_ray: f64,
    /// Every row on every roughness bucket (`roughness`, `mip_rule` say which).
    pub methods: Vec<MethodResult>,
    /// Per roughness bucket: size, the references' own noise against the differences the
    /// table reports.
    #[serde(default)]
    pub buckets: Vec<BucketSummary>,
    /// Exposure of the tone mapping behind `tm_rmse` and ꟻLIP (the key of probe A's mirror
    /// image).
    #[serde(default)]
    pub exposure: f32,
    pub warp1_sweep: Vec<Warp1OptionRow>,
    pub settings: EvalSettings,
    pub command: String,
    /// `fitted` split by the level of the cell containing each validation position.
    #[serde(default)]
    pub fitted_levels: Vec<LevelEval>,
    /// Diffuse lighting: irradiance at held-out surface points, per method.
    #[serde(default)]
    pub diffuse: Option<diffuse::DiffuseReport>,
    /// Surface probes (seed 003): one report per `[[surface_probes]]` patch of the scene.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub surface: Vec<surface::SurfaceReport>,
    /// Wall time of the evaluation (references, methods, timings) and its traced rays.
    #[serde(default)]
    pub seconds: f64,
    /// Where `seconds` went.
    #[serde(default)]
    pub times: EvalTimes,
    #[serde(default)]
    pub reference_rays: u64,
}

/// One roughness bucket of the evaluation.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BucketSummary {
    pub roughness: f32,
    pub lookups: usize,
    pub reference_spp: u32,
    /// RMS standard error of a single reference's luminance over the mean reference.
    pub query_se_rel: f64,
    /// Share of the bucket's queries that are emitter queries (`metrics::EMITTER_QUERY`),
    /// left out of `rel_rmse_no_emitters`.
    #[serde(default)]
    pub emitter_queries: f64,
    /// The comparison the bucket's claim rests on: `claim.0` (the fitted grid through the
    /// runtime, or the best seed-method row without one) against `claim.1`, the best row of
    /// a seed method (by tone-mapped RMSE); both among the rows reading probe A at most
    /// twice as often as warp1 per lookup ([`Method::probe_reads`]: a count, so the claim,
    /// and whether the references are traced again for it, is the same on every run).
    pub claim: (String, String),
    /// Their difference, in rel RMSE and in tone-mapped RMSE (positive: `claim.0` better).
    pub difference_rel: f64,
    pub difference_tm: f64,
    /// The standard error the references' own noise puts on that difference
    /// (`metrics::difference_se`).
    pub reference_se_rel: f64,
    pub reference_se_tm: f64,
    /// The references are quiet enough: standard error ≤ 1/4 of the difference.
    pub reference_ok: bool,
    /// Rendered-view pixels behind each row's ꟻLIP, and their references' samples.
    pub view_pixels: usize,
    pub view_reference_spp: u32,
    /// ꟻLIP between the two halves of each view's reference samples: how much of a row's
    /// ꟻLIP is the references' own noise (an upper bound: each half has half the samples).
    pub view_noise_flip: f64,
    /// The ꟻLIP claim: `claim.0` against the seed method within the claim's read budget
    /// with the lowest mean ꟻLIP (its label), their difference (positive: `claim.0` lower) and that
    /// difference's standard error over 8×8-pixel tiles of the views (paired: the same
    /// pixels and references). It measures how the views' pixels scatter, not how other
    /// viewpoints would score. Absent without views or in files written before it.
    #[serde(default)]
    pub flip_claim: Option<FlipClaim>,
    /// The champion against each of its rivals over all the views' tiles: the ꟻLIP
    /// challenger (as `flip_claim`), the runtime reading its probes alone, and with several
    /// probes the engines' blend of them (empty without views and in older files).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flip_against: Vec<FlipClaim>,
    /// How much of the bucket's errors is its references' own noise, measured against
    /// quieter references of some of its queries (the mirror bucket; absent elsewhere and
    /// in files written before it).
    #[serde(default)]
    pub noise_ceiling: Option<bound::NoiseCeiling>,
    /// The views behind the ꟻLIP columns, in the order of every row's `flip_views`, each
    /// with the claim's champion against its rivals on that view alone (empty without
    /// views and in files written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub views: Vec<ViewSummary>,
    /// The references' own seam ratio (`perceptual::SeamSums::ratio` of one half of their
    /// samples against the other), beside each row's `seam`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seam_reference: Option<f64>,
}

/// One rendered view of a bucket (see [`BucketSummary::views`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ViewSummary {
    pub name: String,
    /// A camera on the level's surfaces (else a sphere of directions).
    pub camera: bool,
    /// Share of its pixels that see geometry (a sphere of directions: 1).
    pub coverage: f64,
    pub pixels: usize,
    /// ꟻLIP between the two halves of its reference's samples.
    pub noise_flip: f64,
    /// The champion (`BucketSummary::claim.0`) against each rival on this view: the ꟻLIP
    /// challenger, and the runtime reading its probes alone where the runtime blends.
    pub against: Vec<FlipClaim>,
}

/// See [`BucketSummary::flip_claim`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FlipClaim {
    pub challenger: String,
    pub difference: f64,
    pub se: f64,
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
    /// The correction the `Corrected` mip rule applies (the fitted grid's).
    pub correction: Option<&'a RoughnessCorrection>,
    /// The mirror validation set ([`validation_set`] with the same settings and
    /// references), made by the caller, who may judge more on it (the in-sample bound).
    pub mirror: &'a ValidationSet,
}

/// A figure of one roughness bucket's camera view: the reference, then a few rows' images
/// with their ꟻLIP maps and means.
pub struct FlipFigure {
    pub roughness: f32,
    /// Diffuse shading (irradiance / π, albedo 1) instead of glossy reflection.
    pub diffuse: bool,
    /// The camera across surface-probe patch k (`eval::surface`), not a scene camera.
    pub surface: Option<usize>,
    /// The view's name: a figure of several cameras stacks one figure per camera.
    pub view: String,
    pub width: u32,
    pub height: u32,
    pub reference: Vec<Vec3>,
    /// (row label, image, ꟻLIP map, mean ꟻLIP of the image)
    pub tiles: Vec<(String, Vec<Vec3>, Vec<f32>, f64)>,
}

/// An evaluation: the report (eval.json), the view tiles (eval_views.png) and the ꟻLIP
/// figures.
pub struct Evaluation {
    pub report: EvalReport,
    /// Each surface-probe patch's atlas, as baked for the evaluation.
    pub surface_atlases: Vec<crate::warp::surface::SurfaceAtlas>,
    pub views: Option<Views>,
    pub flip_figures: Vec<FlipFigure>,
}

/// Evaluates the subject on its scene's validation set, every row on every roughness
/// bucket. `subject.warp` must carry `settings.options`.
pub fn evaluate(subject: Subject, settings: &EvalSettings, command: &str, progress: &Progress) -> Evaluation {
    let Subject { baked, warp, methods, corrective_rows, runtime, correction, mirror } = subject;
    let Baked { scene, tracer, grid, references, .. } = baked;
    let t0 = std::time::Instant::now();
    let shading = Glossy { warp, correction };
    let exposure = warp.probe.key_exposure();
    // the dense grid's irradiance (the written grid's when there is one, else the bake's)
    // and probe A's own, for the diffuse rows and the renormalized specular rows
    let mut from_bake = None;
    let irradiance = judged_irradiance(runtime, grid, &mut from_bake);
    let probe_a = diffuse::probe_irradiance(&warp.probe.radiance);
    let renorm = methods::Renorm { grid: irradiance, probe_a: &probe_a };
    // several probes: the engines' blend of them, the anchor the runtime is judged against
    let engine = (warp.probe_count() > 1).then(|| engine::EngineBlend::of(warp));
    let rough = settings.rough_positions > 0 && settings.rough_dirs > 0;
    let buckets: Vec<f32> = ROUGHNESS_BUCKETS.iter().copied().filter(|&r| r == 0.0 || rough).collect();
    let bar = progress.bar(2 + 3 * buckets.len() as u64, "eval");
    bar.set_message("eval: references");
    let mut times = EvalTimes::default();
    let mut laps = Laps(std::time::Instant::now());
    let mut reference_rays = mirror.rays;
    bar.inc(1);
    let views = settings
        .renders
        .map(|r| renders::views(scene, tracer, &mirror.positions, &warp.probe_positions(), &r))
        .unwrap_or_default();
    let seam_pairs = renders::seam_pairs(&views, &grid.geometry);
    laps.lap(&mut times.view_references);
    // probe A's emitted part, read by every row as it reads probe A (the linear error with
    // the emitters apart): a warp context and a loaded grid with that chain as radiance
    let (emitted, rays) = emitted_twins(baked, warp, runtime, progress);
    reference_rays += rays;
    let emitters = emitted
        .as_ref()
        .map(|(w, g)| methods::Emitters { shading: Glossy { warp: w, correction }, runtime: g.as_ref() });
    let emitters = emitters.as_ref();
    laps.lap(&mut times.emitted);
    let lookups = settings.timing_lookups as usize;
    let mut rows_out = Vec::new();
    let mut summaries = Vec::new();
    let mut flip_figures = Vec::new();
    for (bucket, &r) in buckets.iter().enumerate() {
        bar.set_message(format!("eval: r {r} references"));
        // the rough bucket's queries, traced with `spp`-sample references
        let size = (settings.rough_positions as usize, settings.rough_dirs as usize);
        let trace_rough = |spp: u32| {
            validation::rough_set((scene, tracer, references), mirror, (r, bucket as u64), size, spp, settings.seed)
        };
        let set = if r == 0.0 {
            None
        } else {
            let s = trace_rough(settings.rough_reference_spp);
            reference_rays += s.rays;
            Some(s)
        };
        laps.lap(&mut times.rough_references);
        let set = set.as_ref().unwrap_or(mirror);
        let view_refs = view_references((baked, references), &views, (r, bucket), settings, exposure);
        laps.lap(&mut times.view_references);
        bar.inc(1);
        bar.set_message(format!("eval: r {r} rows"));
        let rules: &[MipRule] = if r == 0.0 { &[MipRule::Plain] } else { &MipRule::ALL };
        let rows = methods::rows(methods, corrective_rows, runtime, (rules, engine.as_ref()), Some(&renorm));
        let emitted_warp = emitted.as_ref().map(|e| &e.0);
        let timing = if r == 0.0 { lookups } else { (lookups / 4).max(1) };
        let mut results = score_rows(&rows, (shading, emitters), set, (exposure, timing));
        if r == 0.0 && methods.contains(&Method::Reproject) {
            // reproject has no rough variant: no reprojected prefiltered chain is built
            insert_reprojections(&mut results, (warp, emitted_warp), set, exposure);
        }
        insert_bounds(&mut results, warp, set, exposure);
        laps.lap(&mut times.rows);
        bar.inc(1);
        bar.set_message(format!("eval: r {r} ꟻLIP"));
        let mut row_tiles = Vec::new();
        if !view_refs.is_empty() {
            row_tiles = set_flips(&mut results, &rows, shading, (&view_refs, &seam_pairs), exposure);
            flip_figures.extend(flip_figures_of(&rows, &results, shading, &view_refs, exposure));
        }
        laps.lap(&mut times.flip);
        bar.inc(1);
        let mut spp = if r == 0.0 { settings.reference_spp } else { settings.rough_reference_spp };
        let views = (&view_refs[..], &row_tiles[..], &seam_pairs[..]);
        let mut summary = bucket_summary(set, r, spp, (&rows, &results), shading, exposure, views);
        // A rough bucket whose references are too noisy for the difference its claim
        // reports is traced again with twice the samples (the same as asking for that many)
        // and its errors measured again; the lookups, their costs and ꟻLIP stand.
        let mut refined: Option<ValidationSet> = None;
        while r > 0.0 && !summary.reference_ok && spp.saturating_mul(2) <= settings.rough_reference_spp_max {
            spp *= 2;
            bar.set_message(format!("eval: r {r} references, {spp} samples"));
            let traced = refined.insert(trace_rough(spp));
            reference_rays += traced.rays;
            laps.lap(&mut times.rough_references);
            rescore(&mut results, &rows, (shading, emitters), traced, exposure);
            summary = bucket_summary(traced, r, spp, (&rows, &results), shading, exposure, views);
            laps.lap(&mut times.rows);
        }
        if r == 0.0 {
            bar.set_message("eval: quiet references");
            let set = refined.as_ref().unwrap_or(set);
            let (ceiling, rays) =
                quiet_ceiling((baked, references), set, (&rows, &summary.claim.0), shading, settings, exposure);
            (summary.noise_ceiling, reference_rays) = (ceiling, reference_rays + rays);
        }
        summaries.push(summary);
        rows_out.extend(results);
        laps.lap(&mut times.summaries);
    }
    let fitted_levels = fitted_level_errors(corrective_rows, warp, mirror, exposure);
    bar.set_message("eval: warp1 options");
    let warp1_sweep = options::warp1_options(warp, mirror, exposure);
    laps.lap(&mut times.rows);
    bar.inc(1);
    bar.set_message("eval: diffuse");
    let (diffuse, rays, figures) =
        diffuse_table(baked, irradiance, &probe_a, runtime.is_some(), (&views, exposure), settings);
    reference_rays += rays;
    flip_figures.extend(figures);
    bar.set_message("eval: surface probes");
    let (surface, surface_atlases, rays, figures) =
        surface_probes(baked, (shading, runtime, methods), settings, exposure, progress);
    reference_rays += rays;
    flip_figures.extend(figures);
    laps.lap(&mut times.diffuse_and_surfaces);
    bar.finish_and_clear();
    let renderer = Renderer::new(scene, tracer);
    let report = EvalReport {
        scene: scene.name.clone(),
        positions: mirror.positions.len(),
        lookups: mirror.dirs.len(),
        hidden_fraction: mirror.hidden_fraction(),
        hidden_fraction_all: (warp.probe_count() > 1).then(|| (mirror.hidden_fraction_all(), warp.probe_count())),
        reference_ns_per_ray: timing::time_reference(&renderer, mirror, 4096),
        methods: rows_out,
        buckets: summaries,
        exposure,
        warp1_sweep,
        settings: settings.clone(),
        command: command.to_string(),
        fitted_levels,
        diffuse,
        surface,
        seconds: t0.elapsed().as_secs_f64(),
        times,
        reference_rays,
    };
    let views = views::views(scene, tracer, warp, mirror, settings.reference_spp, settings.seed, corrective_rows);
    Evaluation { report, surface_atlases, views, flip_figures }
}

/// The stored fitted grid's errors by level on the mirror set (`metrics::level_errors`), when
/// the evaluation judges one.
fn fitted_level_errors(
    rows: &[CorrectiveRow],
    warp: &Warp,
    mirror: &ValidationSet,
    exposure: f32,
) -> Vec<metrics::LevelEval> {
    rows.iter()
        .find(|r| r.variant == CorrectiveVariant::Fitted)
        .map(|r| metrics::level_errors(warp, mirror, r.correctives, exposure))
        .unwrap_or_default()
}

/// Probe A's emitted part as every row reads it (the linear error with the emitters apart):
/// a warp context with that chain as radiance and, for a loaded grid whose probe has the
/// bake's mips, its twin with that chain (and, when it blends irradiance into rough lookups,
/// the stored cells' emitted irradiance); `None` in a scene without emitters. Returns the
/// reference rays it traced.
#[allow(clippy::type_complexity)]
fn emitted_twins(
    baked: Baked,
    warp: &Warp,
    runtime: Option<&FittedGrid>,
    progress: &Progress,
) -> (Option<(Warp, Option<FittedGrid>)>, u64) {
    let Baked { scene, tracer, grid, .. } = baked;
    let mut reference_rays = 0;
    let twins = {
        let renderer = Renderer::new(scene, tracer);
        renderer.has_emitters().then(|| {
            let probe = crate::bake::probe::ProbeSettings {
                position: warp.probe.position,
                ..crate::bake::probe_settings(scene)
            };
            let (chain, rays) = crate::bake::probe::emitted_mips(&renderer, &probe, progress);
            reference_rays += rays;
            // the other probes' emitted parts, each read where the rows read that probe
            let others: std::sync::Arc<[crate::warp::WarpProbe]> = warp
                .others
                .iter()
                .map(|p| {
                    let s = crate::bake::probe::ProbeSettings { position: p.position, ..probe };
                    let (c, rays) = crate::bake::probe::emitted_mips(&renderer, &s, progress);
                    reference_rays += rays;
                    let mut p = p.clone();
                    p.radiance = c;
                    p
                })
                .collect::<Vec<_>>()
                .into();
            // (a grid whose probe has other mips than the bake's has no twin: its rows report none)
            let sizes = |m: &crate::octa::OctMips<Vec3>| m.levels.iter().map(|l| l.res).collect::<Vec<_>>();
            let grid = runtime.filter(|g| sizes(&g.warp().probe.radiance) == sizes(&chain)).map(|g| {
                // a grid that blends the cells' irradiance into rough lookups: that
                // irradiance's emitted part too, for the cells the grid stores
                let blends = g.roughness().is_some_and(|c| !c.irradiance_nodes().is_empty());
                let others = others.clone();
                g.clone().with_radiance(chain.clone()).with_lookup(|w, _, _| w.others = others).with_irradiance(|ir| {
                    let i2 = (ir.resolution * ir.resolution) as usize;
                    if !(blends && i2 == (grid.irradiance_resolution * grid.irradiance_resolution) as usize) {
                        return false;
                    }
                    let (emitted, rays) =
                        crate::bake::grid::emitted_irradiance(&renderer, &crate::bake::grid_settings(scene), grid);
                    reference_rays += rays;
                    for (cell, &slot) in ir.slot.iter().enumerate() {
                        if slot != crate::warp::corrective::NO_MAP {
                            let (to, from) = (slot as usize * i2, cell * i2);
                            ir.irradiance[to..to + i2].copy_from_slice(&emitted[from..from + i2]);
                        }
                    }
                    true
                })
            });
            let mut w = warp.clone();
            w.probe.radiance = chain;
            w.others = others;
            (w, grid)
        })
    };
    (twins, reference_rays)
}

/// The diffuse table at held-out surface points (`diffuse`): the grid through each step
/// of DDGI's blend, the runtime's corrected answer when there is a loaded grid, probe A
/// alone and seed 004's voxel GI; with the reference rays it traced and its ꟻLIP figures.
fn diffuse_table(
    baked: Baked,
    irradiance: &crate::runtime::IrradianceGrid,
    probe_a: &crate::octa::OctMap<Vec3>,
    with_runtime: bool,
    (views, exposure): (&[crate::perceptual::View], f32),
    settings: &EvalSettings,
) -> (Option<diffuse::DiffuseReport>, u64, Vec<FlipFigure>) {
    let Baked { scene, tracer, grid, .. } = baked;
    let (mut reference_rays, mut flip_figures) = (0, Vec::new());
    let diffuse = (settings.diffuse_points > 0)
        .then(|| -> Option<diffuse::DiffuseReport> {
            let set = diffuse::diffuse_set(
                (scene, tracer, baked.references),
                irradiance,
                settings.diffuse_points,
                settings.diffuse_spp,
                settings.seed,
            );
            reference_rays += set.rays;
            if set.points.is_empty() {
                return None; // no triangles inside the grid (spheres have no surface points)
            }
            let voxels = diffuse::VoxelGi::build(scene, tracer, grid.geometry, settings.seed);
            let mut methods: Vec<diffuse::DiffuseMethod> = crate::runtime::IrradianceBlend::ALL
                .iter()
                .map(|&b| diffuse::DiffuseMethod::Grid(irradiance, b))
                .collect();
            if with_runtime {
                methods.push(diffuse::DiffuseMethod::Runtime(irradiance));
            }
            methods.push(diffuse::DiffuseMethod::ProbeA(probe_a));
            methods.push(diffuse::DiffuseMethod::Voxel(&voxels));
            let view_spp = settings.renders.map_or(0, |r| r.reference_spp);
            let (mut r, figure) = diffuse::evaluate(
                (scene, tracer, baked.references),
                &set,
                &methods,
                views,
                (view_spp, settings.seed, exposure),
            );
            r.reference_spp = settings.diffuse_spp;
            flip_figures.extend(figure);
            Some(r)
        })
        .flatten();
    (diffuse, reference_rays, flip_figures)
}

/// Each `[[surface_probes]]` patch's atlas, baked for the evaluation and judged on the
/// patch against probe A's seed methods and the runtime (`surface`); with the reference
/// rays it traced and its ꟻLIP figures.
#[allow(clippy::type_complexity)]
fn surface_probes(
    baked: Baked,
    (shading, runtime, methods): (Glossy, Option<&FittedGrid>, &[Method]),
    settings: &EvalSettings,
    exposure: f32,
    progress: &Progress,
) -> (Vec<surface::SurfaceReport>, Vec<crate::warp::surface::SurfaceAtlas>, u64, Vec<FlipFigure>) {
    let Baked { scene, tracer, grid, .. } = baked;
    let (mut reference_rays, mut flip_figures) = (0, Vec::new());
    let (mut surface, mut surface_atlases) = (Vec::new(), Vec::new());
    if settings.surface_points > 0 && settings.surface_dirs > 0 {
        let renderer = Renderer::new(scene, tracer);
        for (index, spec) in scene.surface_probes().iter().enumerate() {
            let t = std::time::Instant::now();
            let (atlas, rays) =
                crate::bake::surface::bake_surface_atlas(&renderer, spec, index as u64, scene.config.seed, progress);
            let bake = (t.elapsed().as_secs_f64(), rays);
            reference_rays += rays;
            let mut rows = vec![surface::SurfaceMethod::Atlas(&atlas), surface::SurfaceMethod::AtlasWarped(&atlas)];
            let probe_rows = methods::rows(
                &methods
                    .iter()
                    .copied()
                    .filter(|m| matches!(m, Method::None | Method::Box | Method::Kdop | Method::Warp1))
                    .collect::<Vec<_>>(),
                &[],
                runtime,
                (&[MipRule::Plain], None),
                None,
            );
            rows.extend(probe_rows.into_iter().map(surface::SurfaceMethod::Volume));
            let subject = surface::SurfaceSubject { atlas: &atlas, index, bake, methods: &rows };
            // the grid's bounds grown by a cell: a floor lies just outside a grid that
            // starts above it, and the grid answers there from its outer cells
            let cell = grid.geometry.cell_size();
            let bounds = (grid.geometry.min - cell, grid.geometry.max + cell);
            let (report, figures) = surface::evaluate(scene, tracer, &subject, shading, (settings, bounds, exposure));
            surface.push(report);
            flip_figures.extend(figures);
            surface_atlases.push(atlas);
        }
    }
    (surface, surface_atlases, reference_rays, flip_figures)
}

/// Every row of a bucket scored on its queries (`timing` lookups timed per row).
fn score_rows(
    rows: &[methods::Row],
    shading: (Glossy, Option<&methods::Emitters>),
    set: &ValidationSet,
    (exposure, timing): (f32, usize),
) -> Vec<MethodResult> {
    rows.iter().map(|row| methods::evaluate_row(row, shading, set, exposure, timing)).collect()
}

/// The two reprojections (push-pull and seed 002's median dilation) before the oracle.
fn insert_reprojections(
    results: &mut Vec<MethodResult>,
    warps: (&Warp, Option<&Warp>),
    set: &ValidationSet,
    exposure: f32,
) {
    use crate::warp::reproject::HoleFill;
    let at = results.iter().position(|m| m.is(RowId::method(Method::Oracle))).unwrap_or(results.len());
    results.insert(at, methods::evaluate_reproject(warps, set, exposure, HoleFill::MedianDilate));
    results.insert(at, methods::evaluate_reproject(warps, set, exposure, HoleFill::PushPull));
}

/// The single-fetch bounds `best-fetch` and `best-aim` after the oracle, and every row's
/// share of the gap to them.
fn insert_bounds(results: &mut Vec<MethodResult>, warp: &Warp, set: &ValidationSet, exposure: f32) {
    let at = results.iter().position(|m| m.is(RowId::method(Method::Oracle))).map_or(results.len(), |k| k + 1);
    results.insert(at, bound::best_fetch_row(warp, set, exposure));
    results.insert(at + 1, bound::best_aim_row(warp, set, exposure));
    bound::set_gap_closed(results);
}

/// Bucket `bucket`'s (roughness `r`) reference views of every camera, from streams of
/// their own (none without rendered views).
fn view_references(
    (baked, references): (Baked, Option<&crate::trace::store::ReferenceStore>),
    views: &[crate::perceptual::View],
    (r, bucket): (f32, usize),
    settings: &EvalSettings,
    exposure: f32,
) -> Vec<renders::ViewReference> {
    let Some(rs) = settings.renders else { return Vec::new() };
    views
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let tag = (bucket * 16 + k) as u64;
            renders::reference(
                (baked.scene, baked.tracer, references),
                v,
                r,
                rs.reference_spp,
                (settings.seed, tag, exposure),
            )
        })
        .collect()
}

/// Each row's ꟻLIP (per view and their mean) and seams over the views, into its result;
/// returns each row's per-view tiles (as `rows`), what the bucket's claims compare.
fn set_flips(
    results: &mut [MethodResult],
    rows: &[methods::Row],
    shading: Glossy,
    (view_refs, pairs): (&[renders::ViewReference], &[perceptual::SeamPairs]),
    exposure: f32,
) -> Vec<Vec<Vec<perceptual::Tile>>> {
    let judged: Vec<perceptual::Judged> =
        rows.par_iter().map(|row| renders::judge(row, shading, view_refs, pairs, exposure)).collect();
    rows.iter()
        .zip(judged)
        .map(|(row, j)| {
            if let Some(m) = results.iter_mut().find(|m| row.made(m)) {
                m.flip = Some(perceptual::pixel_weighted(view_refs, &j.flips));
                m.flip_views = j.flips;
                m.seam = j.seams.ratio();
            }
            j.tiles
        })
        .collect()
}

/// The seconds between the evaluation's stages.
struct Laps(std::time::Instant);

impl Laps {
    /// The seconds since the last lap, added to `field`.
    fn lap(&mut self, field: &mut f64) {
        *field += self.0.elapsed().as_secs_f64();
        self.0 = std::time::Instant::now();
    }
}

/// The dense grid's irradiance the diffuse and renormalized rows read: the loaded grid's
/// when there is one, else the bake's (built into `from_bake`).
fn judged_irradiance<'a>(
    runtime: Option<&'a FittedGrid>,
    grid: &crate::bake::ProbeGrid,
    from_bake: &'a mut Option<crate::runtime::IrradianceGrid>,
) -> &'a crate::runtime::IrradianceGrid {
    match runtime {
        Some(g) => g.irradiance_grid(),
        None => from_bake.insert(crate::runtime::IrradianceGrid::from_cells(
            grid.geometry,
            (grid.irradiance_resolution, grid.depth_resolution),
            (&grid.irradiance, &grid.depth_mean, &grid.depth_mean_sq, &grid.probe_offset),
            |c| !grid.inside[c],
        )),
    }
}

/// The mirror bucket's noise ceiling (`bound::NoiseCeiling`): some of its queries traced
/// again with quiet references from streams of their own; with the rays traced (none when
/// the settings ask for no quiet references).
fn quiet_ceiling(
    (baked, references): (Baked, Option<&crate::trace::store::ReferenceStore>),
    set: &ValidationSet,
    (rows, champion): (&[methods::Row], &str),
    shading: Glossy,
    settings: &EvalSettings,
    exposure: f32,
) -> (Option<bound::NoiseCeiling>, u64) {
    if settings.quiet_positions == 0 || settings.quiet_spp == 0 {
        return (None, 0);
    }
    let positions = settings.quiet_positions as usize;
    let quiet = validation::quiet_references(
        baked.scene,
        baked.tracer,
        set,
        positions,
        settings.quiet_spp,
        settings.seed,
        references,
    );
    let ceiling = noise_ceiling(set, (&quiet, settings.quiet_spp), (rows, champion), shading, exposure);
    (ceiling, quiet.rays)
}

/// The rows a bucket's claims compare (see [`BucketSummary::claim`]).
struct Rivals<'r> {
    champion: Option<&'r MethodResult>,
    /// The seed method with the lowest tone-mapped RMSE.
    challenger: Option<&'r MethodResult>,
    /// The seed method with the lowest ꟻLIP, other than the champion.
    flip_challenger: Option<&'r MethodResult>,
}

/// The rows of a bucket's claims among `results`: the runtime (or, without one, the best
/// row other than the challenger), against the best seed methods, all within the budget of
/// twice warp1's reads of probe A per lookup. The budget counts reads, never measured
/// times: a row near 2× warp1's time moved in and out between runs (warp2-new's corrected
/// rule measured 1.44–2.37× across five evaluations), and with the claim whether the
/// bucket's references were traced again, so every error of the bucket.
fn rivals<'r>(results: &'r [MethodResult], options: &crate::warp::WarpOptions) -> Rivals<'r> {
    let budget = Method::Warp1.probe_reads(options).map_or(0, |r| 2 * r);
    let cheap = |m: &&MethodResult| claim_reads(&m.name, options).is_some_and(|r| r <= budget);
    let seed_method = |m: &&MethodResult| Method::parse(&m.name).is_some();
    let by_tm = |a: &&MethodResult, b: &&MethodResult| a.tm_rmse.total_cmp(&b.tm_rmse);
    let challenger = results.iter().filter(cheap).filter(seed_method).min_by(by_tm);
    let champion = results.iter().find(|m| m.is(RowId::RUNTIME)).or_else(|| {
        results
            .iter()
            .filter(cheap)
            .filter(|m| Some(m.name.as_str()) != challenger.map(|c| c.name.as_str()))
            .min_by(by_tm)
    });
    let by_flip = |m: &&MethodResult| m.flip.unwrap_or(f64::INFINITY);
    let flip_challenger = results
        .iter()
        .filter(cheap)
        .filter(seed_method)
        .filter(|m| m.flip.is_some() && Some(m.label()) != champion.map(|c| c.label()))
        .min_by(|a, b| by_flip(a).total_cmp(&by_flip(b)));
    Rivals { champion, challenger, flip_challenger }
}

/// Reads of probe A a lookup of the row named `name` makes, as the claims count them
/// ([`Method::probe_reads`]; a renormalized row reads as its method): `None` for the bounds
/// and for rows that are not a seed method.
fn claim_reads(name: &str, options: &crate::warp::WarpOptions) -> Option<u32> {
    Method::parse(name.strip_suffix("+renorm").unwrap_or(name))?.probe_reads(options)
}

/// The bucket's summary: the claim's comparison, its difference, and the standard error
/// the references' noise puts on it.
/// A bucket's rendered views, each row's per-view ꟻLIP tiles (as the bucket's rows) and
/// the views' seam pairs.
type BucketViews<'a> = (&'a [renders::ViewReference], &'a [Vec<Vec<perceptual::Tile>>], &'a [perceptual::SeamPairs]);

fn bucket_summary(
    set: &ValidationSet,
    r: f32,
    spp: u32,
    (rows, results): (&[methods::Row], &[MethodResult]),
    shading: Glossy,
    exposure: f32,
    (views, row_tiles, pairs): BucketViews,
) -> BucketSummary {
    let n = set.reference.len().max(1) as f64;
    let mean_ref = set.reference.iter().map(|c| crate::tonemap::luminance(*c) as f64).sum::<f64>() / n;
    let se2: f64 = set.reference_se.iter().map(|&e| (e as f64).powi(2)).sum::<f64>() / n;
    let options = &shading.warp.options;
    let Rivals { champion, challenger, flip_challenger } = rivals(results, options);
    let row_of = |m: &MethodResult| rows.iter().find(|row| row.made(m));
    let (mut claim, mut diff, mut se) = ((String::new(), String::new()), (0.0, 0.0), (0.0, 0.0));
    if let (Some(a), Some(b)) = (champion, challenger) {
        claim = (a.label(), b.label());
        diff = (b.rel_rmse - a.rel_rmse, b.tm_rmse - a.tm_rmse);
        if let (Some(ra), Some(rb)) = (row_of(a), row_of(b)) {
            let (ea, eb) = (methods::estimates(ra, shading, set), methods::estimates(rb, shading, set));
            se = metrics::difference_se(&ea, &eb, &set.reference, &set.reference_se, exposure);
        }
    }
    // the champion's rivals on the views: the ꟻLIP challenger, and the runtime reading
    // its probes alone (what the runtime's irradiance blend must not make worse)
    let mut flip_rivals: Vec<&MethodResult> = flip_challenger.into_iter().collect();
    let probe_only = results.iter().find(|m| m.is(RowId::RUNTIME_PROBE_ONLY));
    if champion.is_some_and(|c| c.is(RowId::RUNTIME)) && r > 0.0 {
        flip_rivals.extend(probe_only);
    }
    // several probes: the engines' blend of them (its best mip rule), what a level lit by
    // several probes is shaded with today
    let engine = results
        .iter()
        .filter(|m| m.is(RowId::of(methods::RowKind::EngineBlend)) && m.flip.is_some())
        .min_by(|a, b| a.flip.unwrap_or(f64::INFINITY).total_cmp(&b.flip.unwrap_or(f64::INFINITY)));
    if champion.is_some_and(|c| c.is(RowId::RUNTIME)) {
        flip_rivals.extend(engine);
    }
    // each row's per-view tiles, as `set_flips` measured them
    let tiles = |m: &MethodResult| rows.iter().position(|row| row.made(m)).and_then(|k| row_tiles.get(k));
    let champion_tiles = champion.and_then(tiles).filter(|_| !views.is_empty());
    let rival_tiles: Vec<(String, &Vec<Vec<perceptual::Tile>>)> = match champion_tiles {
        Some(_) => flip_rivals.iter().filter_map(|m| Some((m.label(), tiles(m)?))).collect(),
        None => Vec::new(),
    };
    let challenger_tiles = flip_challenger.and_then(|c| rival_tiles.iter().find(|(label, _)| *label == c.label()));
    let flip_claim =
        champion_tiles.zip(challenger_tiles).map(|(a, (label, b))| claim_of(label.clone(), &a.concat(), &b.concat()));
    let flip_against = match champion_tiles {
        Some(a) => rival_tiles.iter().map(|(label, b)| claim_of(label.clone(), &a.concat(), &b.concat())).collect(),
        None => Vec::new(),
    };
    let view_summaries = views
        .iter()
        .enumerate()
        .map(|(k, v)| ViewSummary {
            name: v.view.name.clone(),
            camera: v.view.camera,
            coverage: v.view.coverage(),
            pixels: v.reference.len(),
            noise_flip: v.noise_flip,
            against: match champion_tiles {
                Some(a) => rival_tiles.iter().map(|(label, b)| claim_of(label.clone(), &a[k], &b[k])).collect(),
                None => Vec::new(),
            },
        })
        .collect();
    let (mut noise, mut pixels) = (0.0, 0usize);
    for v in views {
        noise += v.noise_flip * v.reference.len() as f64;
        pixels += v.reference.len();
    }
    BucketSummary {
        roughness: r,
        lookups: set.dirs.len(),
        reference_spp: spp,
        query_se_rel: se2.sqrt() / mean_ref.max(1e-30),
        emitter_queries: (0..set.dirs.len()).filter(|&k| set.emitter_share(k) >= metrics::EMITTER_QUERY).count() as f64
            / n,
        claim,
        difference_rel: diff.0,
        difference_tm: diff.1,
        reference_se_rel: se.0,
        reference_se_tm: se.1,
        // (one sample per reference says nothing of its noise: its standard error reads 0)
        reference_ok: spp >= 2 && se.0 <= diff.0.abs() / 4.0 && se.1 <= diff.1.abs() / 4.0,
        view_pixels: pixels,
        view_reference_spp: views.first().map_or(0, |v| v.spp),
        view_noise_flip: noise / pixels.max(1) as f64,
        flip_claim,
        flip_against,
        noise_ceiling: None,
        views: view_summaries,
        seam_reference: perceptual::SeamSums::of_references(views, pairs, exposure).ratio(),
    }
}

/// Every result of a bucket measured again against `set`, the same queries traced anew:
/// rows through [`methods::rescore_row`], the two bounds searched again against the new
/// references, the gap each row closes recomputed.
fn rescore(
    results: &mut [MethodResult],
    rows: &[methods::Row],
    (shading, emitters): (Glossy, Option<&methods::Emitters>),
    set: &ValidationSet,
    exposure: f32,
) {
    for m in results.iter_mut() {
        if m.is(RowId::BEST_FETCH) {
            *m = bound::best_fetch_row(shading.warp, set, exposure);
        } else if m.is(RowId::BEST_AIM) {
            *m = bound::best_aim_row(shading.warp, set, exposure);
        } else if let Some(row) = rows.iter().find(|row| row.made(m)) {
            *m = methods::rescore_row(row, (shading, emitters), set, exposure, m);
        }
    }
    bound::set_gap_closed(results);
}

/// The bucket's [`bound::NoiseCeiling`] on the queries `quiet` traced again: `none`, the
/// claim's champion (`label`, when it is a row) and the oracle estimated as their rows
/// answer.
fn noise_ceiling(
    set: &ValidationSet,
    quiet: (&crate::trace::truth::TracedQueries, u32),
    (rows, champion): (&[methods::Row], &str),
    shading: Glossy,
    exposure: f32,
) -> Option<bound::NoiseCeiling> {
    // (the mirror bucket has one mip rule: a row is found by its id alone)
    let row = |id: Option<RowId>| rows.iter().find(|row| Some(row.id()) == id);
    let n = quiet.0.dirs.len();
    let on_quiet = |row: &methods::Row| methods::estimates_of_first(row, shading, set, n);
    let none = on_quiet(row(Some(RowId::method(Method::None)))?);
    let champion = row(RowId::parse(champion)).map(|r| (r.name(), on_quiet(r)));
    let oracle = row(Some(RowId::method(Method::Oracle))).map(on_quiet);
    bound::noise_ceiling(shading.warp, set, quiet, &none, champion, oracle, exposure)
}

/// The ꟻLIP claim of the champion against a rival (its label), from the same tiles of
/// their ꟻLIP maps (8×8 pixels of the same views): the difference of their pixel-weighted
/// means and its paired standard error over the tiles.
fn claim_of(rival: String, champion: &[perceptual::Tile], tiles: &[perceptual::Tile]) -> FlipClaim {
    FlipClaim {
        challenger: rival,
        difference: perceptual::weighted_mean(tiles) - perceptual::weighted_mean(champion),
        se: perceptual::paired_standard_error(tiles, champion),
    }
}

/// The camera views' figures for a bucket, one per camera: the runtime (both read tiers),
/// the best other row costing ≤ 2× warp1 by ꟻLIP, warp1 and box (plain mips), each with
/// its ꟻLIP map.
fn flip_figures_of(
    rows: &[methods::Row],
    results: &[MethodResult],
    shading: Glossy,
    views: &[renders::ViewReference],
    exposure: f32,
) -> Vec<FlipFigure> {
    let Some(budget) = results.iter().find(|m| m.is(RowId::method(Method::Warp1))).map(|m| 2.0 * m.ns_per_lookup)
    else {
        return Vec::new();
    };
    let best_other = results
        .iter()
        .filter(|m| m.ns_per_lookup <= budget && !is_runtime(&m.name) && !is_bound(&m.name))
        .filter(|m| m.flip.is_some())
        .min_by(|a, b| a.flip.unwrap_or(1.0).total_cmp(&b.flip.unwrap_or(1.0)));
    let plain = |m: &MethodResult| m.mip_rule.is_none() || m.mip_rule == Some(MipRule::Plain);
    let mut wanted: Vec<&MethodResult> =
        results.iter().filter(|m| m.is(RowId::RUNTIME) || m.is(RowId::RUNTIME_PROBE_ONLY)).collect();
    wanted.extend(best_other);
    for m in [Method::Warp1, Method::Box] {
        wanted.extend(results.iter().find(|r| r.is(RowId::method(m)) && plain(r)));
    }
    let mut seen = std::collections::HashSet::new();
    wanted.retain(|m| seen.insert(m.label()));
    let figure = |view: &renders::ViewReference| {
        let mut tiles = Vec::new();
        for m in &wanted {
            let Some(row) = rows.iter().find(|row| row.made(m)) else { continue };
            let image = renders::render(row, shading, view);
            let map = renders::flip_map(view, &image, exposure);
            let mean = crate::perceptual::flip::mean(&map);
            tiles.push((m.label(), image, map, mean));
        }
        FlipFigure {
            roughness: view.roughness,
            diffuse: false,
            surface: None,
            view: view.view.name.clone(),
            width: view.view.width,
            height: view.view.height,
            reference: view.reference.clone(),
            tiles,
        }
    };
    views.iter().filter(|v| v.view.camera).map(figure).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::WarpOptions;

    fn row(name: &str, tm_rmse: f64, flip: f64, ns: f64) -> MethodResult {
        MethodResult {
            name: name.into(),
            roughness: 0.5,
            mip_rule: Some(MipRule::Corrected),
            rel_rmse: tm_rmse * 10.0,
            rel_rmse_emitters_apart: None,
            tm_rmse,
            mae: 0.0,
            p95: 0.0,
            max: 0.0,
            flip: Some(flip),
            flip_views: Vec::new(),
            seam: None,
            angular_deg: None,
            ns_per_lookup: ns,
            ns_per_lookup_random: ns,
            ns_per_lookup_batched: None,
            gap_closed: None,
            note: String::new(),
        }
    }

    /// A bucket's claims compare the same rows whatever the lookups' measured times: the
    /// budget counts reads of probe A (a two-step warp is a rival even where it measured
    /// well over twice warp1's time; a search never is, even where it measured cheap).
    #[test]
    fn the_claims_rivals_do_not_follow_measured_times() {
        let options = WarpOptions::default();
        let results = |ns: [f64; 6]| {
            vec![
                row("runtime", 0.10, 0.20, ns[0]),
                row("box", 0.16, 0.31, ns[1]),
                row("warp1", 0.15, 0.30, ns[2]),
                row("warp2-new", 0.14, 0.29, ns[3]),
                row("secant", 0.12, 0.25, ns[4]),
                row("oracle", 0.11, 0.22, ns[5]),
            ]
        };
        let names = |r: &Rivals| [r.champion, r.challenger, r.flip_challenger].map(|m| m.map(MethodResult::label));
        let want = [Some("runtime/corrected"), Some("warp2-new/corrected"), Some("warp2-new/corrected")]
            .map(|s| s.map(String::from));
        for ns in [
            [90.0, 30.0, 50.0, 95.0, 140.0, 20.0],
            [90.0, 30.0, 50.0, 260.0, 140.0, 20.0],
            [90.0, 30.0, 50.0, 95.0, 40.0, 20.0],
        ] {
            assert_eq!(names(&rivals(&results(ns), &options)), want, "times {ns:?}");
        }
        // without the runtime, the best rival other than the challenger stands in for it
        let no_runtime: Vec<MethodResult> = results([90.0, 30.0, 50.0, 95.0, 140.0, 20.0]).split_off(1);
        let r = rivals(&no_runtime, &options);
        assert_eq!(r.champion.map(MethodResult::label).as_deref(), Some("warp1/corrected"));
        assert_eq!(r.challenger.map(MethodResult::label).as_deref(), Some("warp2-new/corrected"));
        assert_eq!(claim_reads("box+renorm", &options), Some(1));
        assert_eq!(claim_reads("oracle", &options), None);
        assert_eq!(claim_reads("runtime", &options), None);
    }

    #[test]
    fn every_row_id_reads_back_from_its_name_and_its_labels() {
        let kinds = RowKind::all();
        let mut names = std::collections::HashSet::new();
        for kind in kinds {
            for renorm in [false, true] {
                let id = RowId { kind, renorm };
                assert_eq!(RowId::parse(&id.name()), Some(id), "{}", id.name());
                assert_eq!(RowId::parse(&format!("{}/engine", id.name())), Some(id), "a label carries its mip rule");
                assert!(names.insert(id.name()), "two rows named {}", id.name());
            }
        }
        assert_eq!(RowId::parse("runtime"), Some(RowId::RUNTIME));
        assert_eq!(RowId::parse("reproject"), Some(RowId::method(Method::Reproject)));
        assert_eq!(RowId::parse("no-such-row"), None);
        assert!(is_runtime("runtime-probe-only") && is_runtime("runtime+renorm") && !is_runtime("box"));
        assert!(is_bound("oracle/plain") && is_bound("best-aim") && is_bound("in-sample") && !is_bound("fitted"));
    }
}
