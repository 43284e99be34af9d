//! The distance-ratio roughness correction fitted to the scene (seed 002: "look at rendered
//! results, compare to ground truth obtained by sampling, then fit"): a table α'(α, k) with,
//! per roughness, `α' = c0 · α · k^−e`, one exponent for k > 1 and one for k < 1, fitted by
//! Nelder-Mead against this scene's own GGX references through the fitted grid's lookups
//! (its correctives' fetch, then the mip the candidate picks). c0 stays the lobes' (≈ 1):
//! at equal distances (k = 1) the surface's lobe is the probe's, whatever the scene. Fitting
//! c0 too lowered the tone-mapped RMSE on torture a little further by reading sharper mips
//! everywhere, but those mips carry the probe's sampling noise and the rendered views'
//! ꟻLIP got worse (0.375 → 0.418 at r = 0.5), so the scale is not the scene's to choose.
//! Two exponents because the evidence is one-sided: Frostbite's rule, which never blurs
//! beyond r where the surface is farther from the hit (k < 1), beat the lobes' power law at
//! low roughness.
//!
//! Each row of the stored table (one per roughness of [`ROUGH_MIX`]) then holds the rule,
//! of the scene fit's exponents, the analytic-lobe correction, Frostbite's rule and plain
//! r, whose views look best on held-out positions: mean ꟻLIP of a camera and a sphere of
//! directions rendered from them against their traced references. Tone-mapped RMSE fitted
//! the exponents, and it rewards blur (blur hedges a misplaced fetch); which mip a viewer
//! should see is exactly that trade, so ꟻLIP judges it. The held-out lookups' tone-mapped
//! RMSE of every candidate, per row and overall, is recorded beside it (the manifest's
//! `roughness.heldout_scene`).
//!
//! Last, the rough lookups' irradiance blend (`RoughnessFit::irradiance_weight`): the
//! runtime mixes the grid's irradiance over π (the band-2 harmonics of the cells around
//! the point, read smoothly: `runtime::IrradianceSh::read`) into a rough lookup, since at
//! α = 1 the lobe is the clamped cosine and the reference is that irradiance itself. Per
//! row, the weight with the lowest training tone-mapped RMSE through the row's chosen
//! mips, or its half or quarter, the largest whose views' mean ꟻLIP is no worse than
//! without and no view's worse beyond 2 standard errors of its 8×8-pixel tiles; the grid
//! keeps the weights only if the held-out tone-mapped RMSE falls.

use super::{DOMAIN_FIT, FitSettings, ROUGH_MIX};
use crate::bake::Baked;
use crate::octa;
use crate::perceptual::{self, RenderSettings, ViewReference};
use crate::roughness::{
    PerRule, Representation, RoughnessCorrection, RoughnessFit, RowChoice, RowRule, SceneComparison, Source,
};
use crate::runtime::IrradianceSh;
use crate::sampling::{Sampler, hash_pair};
use crate::tonemap::reinhard;
use crate::trace::Renderer;
use crate::trace::store;
use crate::trace::truth::{self, QueryStreams, TracedQueries};
use crate::warp::Warp;
use crate::warp::corrective::{Blend, Correctives};
use crate::warp::glossy::engine_roughness;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Positions the scene's rough queries are drawn at (uniform over active cells), the
/// directions per position and the samples per reference.
const POSITIONS: u32 = 512;
const DIRS: usize = 16;
const SPP: u32 = 16;

/// The views each row's rule is chosen on: one camera and one sphere of directions from the
/// most open held-out positions, references of 64 lobe samples (a sixth of the
/// evaluation's pixels at a quarter of its samples: about 0.4 s of a torture fit).
const VIEWS: RenderSettings = RenderSettings {
    camera: (64, 40),
    cameras: 3,
    fov_deg: 75.0,
    sphere_res: 32,
    spheres: 1,
    reference_spp: 64,
    probe_cameras: 0,
};

/// A rough query with what every candidate shares: the fetch's octahedral coordinate and the
/// distance ratio there.
#[derive(Clone, Copy)]
struct Query {
    uv: Vec2,
    /// The probe the fetch reads (`Warp::probe_at`).
    probe: u8,
    k: f32,
    r: f32,
    reference: Vec3,
    /// The containing cell's irradiance for the query's direction (`None`: no stored
    /// cell), what the runtime blends in.
    irradiance: Option<Vec3>,
}

struct Streams {
    seed: u64,
    first: usize,
    /// The surface the position lies on.
    normal: Option<Vec3>,
}

impl QueryStreams for Streams {
    fn direction(&self, p: usize, d: usize) -> Sampler {
        Sampler::new(self.seed, hash_pair(hash_pair(DOMAIN_FIT, 0x5C), (self.first + p) as u64), d as u32)
    }
    fn reference(&self, p: usize, d: usize, k: u32) -> Sampler {
        let ray = ((self.first + p) * DIRS + d) as u64;
        Sampler::new(self.seed, hash_pair(hash_pair(DOMAIN_FIT, 0x5D), ray), k)
    }
    fn roughness(&self, p: usize, d: usize) -> f32 {
        ROUGH_MIX[(self.first + p + d) % ROUGH_MIX.len()]
    }
    fn hemisphere(&self, _p: usize) -> Option<Vec3> {
        self.normal
    }
}

/// The scene's rough queries, split by position.
struct Queries {
    train: Vec<Query>,
    held: Vec<Query>,
    /// The held-out queries' positions.
    held_positions: Vec<Vec3>,
}

/// Rough queries over the active cells with the cells' own mix (`surface_fraction` of the
/// positions on surfaces, reflecting over their hemisphere; the rest in the volume), traced,
/// and prepared through `correctives`, split by position into training and held-out halves.
fn queries(
    baked: Baked,
    warp: &Warp,
    correctives: &Correctives,
    irradiance: &IrradianceSh,
    s: &FitSettings,
) -> Queries {
    let Baked { scene, tracer, grid, .. } = baked;
    let (g, seed) = (grid.geometry, s.seed);
    let active: Vec<usize> = (0..g.cell_count()).filter(|&c| !grid.inside[c]).collect();
    if active.is_empty() {
        return Queries { train: Vec::new(), held: Vec::new(), held_positions: Vec::new() };
    }
    let renderer = Renderer::new(scene, tracer);
    let positions: Vec<(Vec3, Option<Vec3>)> = (0..POSITIONS)
        .into_par_iter()
        .map(|p| {
            let mut r = Sampler::new(seed, hash_pair(DOMAIN_FIT, 0x5B), p);
            let cell = active[((r.next_1d() * active.len() as f32) as usize).min(active.len() - 1)];
            let u = Vec3::new(r.next_1d(), r.next_1d(), r.next_1d());
            if r.next_1d() < s.surface_fraction {
                let stream = (seed, hash_pair(hash_pair(DOMAIN_FIT, 0x5E), p as u64));
                if let Some(&(b, n)) = super::cell_surface_points(&renderer, &g, cell, 1, stream).first() {
                    return (b, Some(n));
                }
            }
            (g.min + (g.cell_coords(cell).as_vec3() + u) * g.cell_size(), None)
        })
        .collect();
    let trace = || {
        let parts: Vec<TracedQueries> = positions
            .par_iter()
            .enumerate()
            .map(|(p, &(b, normal))| {
                truth::trace_queries(
                    &renderer,
                    std::slice::from_ref(&b),
                    DIRS,
                    SPP,
                    &Streams { seed, first: p, normal },
                )
            })
            .collect();
        TracedQueries::concat(parts)
    };
    let q = match baked.references {
        Some(store) => {
            let (b, n): (Vec<Vec3>, Vec<Vec3>) = positions.iter().map(|&(b, n)| (b, n.unwrap_or(Vec3::ZERO))).unzip();
            let key = store.key("roughness").vec3s(&b).vec3s(&n).words([DIRS as u64, u64::from(SPP), seed]);
            let codec = (store::queries_to_words, store::queries_from_words);
            store.cached("roughness", key, codec, trace)
        }
        None => trace(),
    };
    let prepared: Vec<(usize, Query)> = (0..q.dirs.len())
        .into_par_iter()
        .map(|k| {
            let (b, dir) = (q.position_of(k), q.dirs[k]);
            let (uv, k_ratio, probe) = fetch(warp, correctives, b, dir, q.roughness[k]);
            let irradiance = irradiance.read(b, dir);
            (k / DIRS, Query { uv, probe, k: k_ratio, r: q.roughness[k], reference: q.reference[k], irradiance })
        })
        .collect();
    let (train, held): (Vec<_>, Vec<_>) = prepared.into_iter().partition(|(p, _)| p % 2 == 0);
    Queries {
        train: train.into_iter().map(|x| x.1).collect(),
        held: held.into_iter().map(|x| x.1).collect(),
        held_positions: positions.iter().skip(1).step_by(2).map(|p| p.0).collect(),
    }
}

/// The fitted grid's fetch for query (b, dir) of roughness `r`: the octahedral coordinate
/// it reads, the distance ratio there and the probe it reads.
fn fetch(warp: &Warp, correctives: &Correctives, b: Vec3, dir: Vec3, r: f32) -> (Vec2, f32, u8) {
    let aim = correctives.fetch(Blend::Cell, warp, b, dir, r);
    let uv = octa::encode(aim.v);
    (uv, aim.ratio(warp, b, uv), aim.probe)
}

/// What the fetch reads: probe `probe`'s radiance at `uv`, the mip of roughness `rough`.
fn read(warp: &Warp, (uv, probe): (Vec2, u8), rough: f32) -> Vec3 {
    let p = warp.probe_at(probe.into());
    p.radiance.sample_lod_uv(uv, p.lod_of_roughness(rough))
}

/// Tone-mapped RMSE of `queries` when each reads the mip of the roughness `rough(q)` gives.
fn tm_rmse(warp: &Warp, queries: &[Query], exposure: f32, rough: impl Fn(&Query) -> f32 + Sync) -> f64 {
    tm_rmse_blended(warp, queries, exposure, rough, |_| 0.0)
}

/// [`tm_rmse`] with each lookup blended with its cell's irradiance by weight `weight(q)`
/// as the runtime blends (`runtime::mix_irradiance`).
fn tm_rmse_blended(
    warp: &Warp,
    queries: &[Query],
    exposure: f32,
    rough: impl Fn(&Query) -> f32 + Sync,
    weight: impl Fn(&Query) -> f32 + Sync,
) -> f64 {
    let per_query: Vec<f64> = queries
        .par_iter()
        .map(|q| {
            let spec = read(warp, (q.uv, q.probe), rough(q));
            let w = weight(q);
            let est = match q.irradiance {
                Some(e) if w > 0.0 => crate::runtime::mix_irradiance(spec, e, w),
                _ => spec,
            };
            let d = reinhard(est, exposure) - reinhard(q.reference, exposure);
            (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2)
        })
        .collect();
    // summed in query order: a parallel sum's order (and rounding) would depend on threads
    let sq: f64 = per_query.iter().sum();
    (sq / (3.0 * queries.len().max(1) as f64)).sqrt()
}

/// The candidate rules of the scene table's rows.
struct Rules<'a> {
    lobe_fit: &'a RoughnessCorrection,
    c0: f64,
    /// The scene fit's exponents (e⁺, e⁻) per roughness of [`ROUGH_MIX`].
    exponents: &'a [(f64, f64)],
}

impl Rules<'_> {
    /// Perceptual roughness of the mip `rule` reads for a lookup of roughness `r` at
    /// distance ratio `k`, in row `row` (the row's roughness is `r` itself).
    fn roughness(&self, rule: RowRule, row: usize, r: f32, k: f32) -> f32 {
        match rule {
            RowRule::SceneFit => exponent_roughness(r, k, self.c0, self.exponents[row]),
            RowRule::Lobes => self.lobe_fit.corrected_roughness(r, k),
            RowRule::Engine => engine_roughness(r, k),
            RowRule::Plain => r,
        }
    }

    /// α' of `rule` for surface α = r² at ratio `k` (a table entry), in [1e-3, 1].
    fn alpha(&self, rule: RowRule, row: usize, r: f32, k: f32) -> f32 {
        let alpha = r * r;
        let a = match rule {
            RowRule::SceneFit => exponent_alpha(r, k, self.c0, self.exponents[row]) as f32,
            RowRule::Lobes => self.lobe_fit.corrected_alpha(alpha, k),
            RowRule::Engine => engine_roughness(r, k).powi(2),
            RowRule::Plain => alpha,
        };
        if a.is_finite() { a.clamp(1e-3, 1.0) } else { alpha.clamp(1e-3, 1.0) }
    }
}

/// The scene's table: a row per roughness of [`ROUGH_MIX`] holding its chosen rule on the
/// lobe table's k axis (the scene fit's is `α' = c0 · α · k^−e` with one exponent `e⁺` where
/// the surface is nearer the hit than the probe (k > 1: sharper) and another `e⁻` where it
/// is farther (k < 1: blurrier)); a row α = 0 → 0 keeps near-mirror lookups sharp. Stored
/// as an ordinary table (bilinear in α and ln k).
fn scene_table(lobe: &RoughnessFit, rules: &Rules, chosen: &[RowRule]) -> RoughnessFit {
    let mut alphas = vec![0.0f32];
    alphas.extend(ROUGH_MIX.iter().map(|r| r * r));
    let mut table = vec![0.0f32; lobe.ratios.len()];
    for (row, (&r, &rule)) in ROUGH_MIX.iter().zip(chosen).enumerate() {
        table.extend(lobe.ratios.iter().map(|&k| rules.alpha(rule, row, r, k)));
    }
    RoughnessFit {
        lobe_residual: vec![0.0; table.len()],
        alphas,
        table,
        chosen: Representation::Table,
        source: Source::SceneReferences,
        ..lobe.clone()
    }
}

/// The two exponents' α' = c0·α·k^−e (e⁺ for k > 1, e⁻ otherwise) for a lookup of
/// roughness `r` at ratio `k`, in [1e-3, 1].
fn exponent_alpha(r: f32, k: f32, c0: f64, (up, down): (f64, f64)) -> f64 {
    let lk = libm::log(k as f64);
    let e = if lk > 0.0 { up } else { down };
    (c0 * (r * r) as f64 * libm::exp(-e * lk)).clamp(1e-3, 1.0)
}

/// The two exponents' perceptual roughness for a lookup of roughness `r` at ratio `k`.
fn exponent_roughness(r: f32, k: f32, c0: f64, e: (f64, f64)) -> f32 {
    (exponent_alpha(r, k, c0, e) as f32).sqrt()
}

/// The exponents stay within the lobes' geometry on the sharp side of the lobe fit's own
/// exponent c1: e⁺ in [c1, EXPONENT_MAX] (a surface nearer the hit than the probe reads a
/// mip at least as sharp as the lobes say), e⁻ in [0, c1] (one farther away never a sharper
/// mip than r's, never a blurrier one than the lobes say). Unbounded, the fit drove both
/// towards sharper mips everywhere (compensating the mips' own blur) and the rendered views'
/// ꟻLIP got worse; bounded only by [0, 3], it drove e⁻ to 2.6 and e⁺ to 0.6 at r = 0.125
/// on `courtyard`: blur hedges a misplaced fetch in RMSE, and a viewer sees it as lost
/// detail (ꟻLIP 0.219 against Frostbite's sharper rule's 0.201 on the same maps).
const EXPONENT_MAX: f64 = 3.0;

/// The exponents (e⁺, e⁻) clamped to their bounds around the lobe exponent `c1`.
fn bounded(p: &[f64], c1: f64) -> (f64, f64) {
    (p[0].clamp(c1, EXPONENT_MAX.max(c1)), p[1].clamp(0.0, c1.max(0.0)))
}

/// One roughness's exponents (e⁺, e⁻).
struct Problem<'a> {
    warp: &'a Warp,
    queries: &'a [Query],
    exposure: f32,
    c0: f64,
    c1: f64,
}

impl CostFunction for Problem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        let e = bounded(p, self.c1);
        let err = tm_rmse(self.warp, self.queries, self.exposure, |q| exponent_roughness(q.r, q.k, self.c0, e));
        Ok(if err.is_finite() { err } else { f64::MAX })
    }
}

/// Candidate weights of the irradiance blend, tried per row: 0, 0.05, …, 1.
const BLEND_STEPS: u32 = 20;

/// The irradiance blend's weight for `queries` (of one roughness) reading the mips
/// `rough` gives: of [`BLEND_STEPS`] steps, the one with the lowest tone-mapped RMSE (ties
/// keep the smaller weight).
fn blend_weight(warp: &Warp, queries: &[Query], exposure: f32, rough: impl Fn(&Query) -> f32 + Sync) -> f32 {
    (0..=BLEND_STEPS)
        .map(|i| i as f32 / BLEND_STEPS as f32)
        .fold((0.0f32, f64::INFINITY), |best, w| {
            let e = tm_rmse_blended(warp, queries, exposure, &rough, |_| w);
            if e < best.1 { (w, e) } else { best }
        })
        .0
}

/// `candidate` with the irradiance blend (`RoughnessFit::irradiance_weight`: 0 for the
/// mirror row, then `weights`, one per roughness of [`ROUGH_MIX`]), kept only when it lowers
/// the held-out queries' tone-mapped RMSE, which comes back with it (`None`: not kept).
fn with_irradiance_blend(
    candidate: RoughnessCorrection,
    weights: &[f32],
    warp: &Warp,
    held: &[Query],
    exposure: f32,
) -> (RoughnessCorrection, Option<f64>) {
    if weights.iter().all(|&w| w == 0.0) {
        return (candidate, None);
    }
    let irradiance_weight = std::iter::once(0.0).chain(weights.iter().copied()).collect();
    let blended = RoughnessFit { irradiance_weight, ..(*candidate).clone() };
    let Ok(blended) = RoughnessCorrection::try_from(blended) else { return (candidate, None) };
    let rough = |q: &Query| candidate.corrected_roughness(q.r, q.k);
    let without = tm_rmse(warp, held, exposure, rough);
    let with = tm_rmse_blended(warp, held, exposure, rough, |q| blended.irradiance_weight(q.r));
    if with < without { (blended, Some(with)) } else { (candidate, None) }
}

/// Fits the correction to the scene through `correctives` (per roughness of [`ROUGH_MIX`],
/// Nelder-Mead on the two exponents from the lobes' exponent), then gives each roughness's
/// row the candidate rule with the lowest mean ꟻLIP on views from held-out positions (the
/// lowest held-out tone-mapped RMSE where no view can be rendered), with the comparison
/// recorded in it, and fits each row's irradiance blend (module docs). `lobe_fit` comes
/// back unchanged when the scene has no rough queries.
pub fn fit_scene_correction(
    baked: Baked,
    warp: &Warp,
    correctives: &Correctives,
    lobe_fit: &RoughnessCorrection,
    s: &FitSettings,
) -> RoughnessCorrection {
    let exposure = super::exposure_of(warp);
    // the irradiance a rough lookup blends in, as a grid written from this bake loads it
    let slots = baked.grid.dense_slots();
    let irradiance = crate::runtime::IrradianceSh::project(&baked.grid.irradiance_view(&slots));
    let Queries { train, held, held_positions } = queries(baked, warp, correctives, &irradiance, s);
    if train.is_empty() || held.is_empty() {
        return lobe_fit.clone();
    }
    let (c0, start) = (lobe_fit.c0 as f64, lobe_fit.c1 as f64);
    let exponents: Vec<(f64, f64)> = ROUGH_MIX
        .iter()
        .map(|&r| {
            let queries: Vec<Query> = train.iter().copied().filter(|q| q.r == r).collect();
            let simplex = vec![vec![start, start], vec![start + 0.5, start], vec![start, start - 0.5]];
            let problem = Problem { warp, queries: &queries, exposure, c0, c1: start };
            NelderMead::new(simplex)
                .with_sd_tolerance(1e-6)
                .ok()
                .and_then(|nm| Executor::new(problem, nm).configure(|st| st.max_iters(80)).run().ok())
                .and_then(|res| res.state().get_best_param().cloned())
                .filter(|p| p.iter().all(|x| x.is_finite()))
                .map_or((start, start), |p| bounded(&p, start))
        })
        .collect();
    let rules = Rules { lobe_fit, c0, exponents: &exponents };
    let views = perceptual::views(baked.scene, baked.tracer, &held_positions, &warp.probe_positions(), &VIEWS);
    let rows: Vec<(RowChoice, f32)> = ROUGH_MIX
        .iter()
        .enumerate()
        .map(|(row, &r)| {
            let held_r: Vec<Query> = held.iter().copied().filter(|q| q.r == r).collect();
            let tm =
                PerRule::from_fn(|rule| tm_rmse(warp, &held_r, exposure, |q| rules.roughness(rule, row, q.r, q.k)));
            let refs: Vec<ViewReference> = views
                .iter()
                .enumerate()
                .map(|(v, view)| {
                    let stream = hash_pair(hash_pair(DOMAIN_FIT, 0x5F), (row * 16 + v) as u64);
                    perceptual::reference(
                        baked.scene,
                        baked.tracer,
                        view,
                        r,
                        VIEWS.reference_spp,
                        (s.seed, stream, exposure),
                    )
                })
                .collect();
            // per rule, the ꟻLIP maps' 8×8-pixel tiles, view by view
            let tiles: Vec<Vec<Vec<perceptual::Tile>>> = RowRule::ALL
                .iter()
                .map(|&rule| {
                    perceptual::view_tiles(&refs, exposure, perceptual::CLAIM_TILE, |r, b, dir, _| {
                        let (uv, k, probe) = fetch(warp, correctives, b, dir, r);
                        read(warp, (uv, probe), rules.roughness(rule, row, r, k))
                    })
                })
                .collect();
            let all: Vec<Vec<perceptual::Tile>> = tiles.iter().map(|t| t.concat()).collect();
            let at = |rule: RowRule| RowRule::ALL.iter().position(|&x| x == rule).unwrap_or(0);
            let flip = PerRule::from_fn(|rule| perceptual::weighted_mean(&all[at(rule)]));
            let flip_se =
                PerRule::from_fn(|rule| perceptual::paired_standard_error(&all[at(rule)], &all[at(RowRule::SceneFit)]));
            let chosen = flip.chosen_with(&flip_se);
            // the irradiance blend of the chosen rule's mips: fitted on the training
            // queries, kept where the views do not look worse for it
            let train_r: Vec<Query> = train.iter().copied().filter(|q| q.r == r).collect();
            let fitted = blend_weight(warp, &train_r, exposure, |q| rules.roughness(chosen, row, q.r, q.k));
            let blended_tiles = |w: f32| {
                perceptual::view_tiles(&refs, exposure, perceptual::CLAIM_TILE, |r, b, dir, _| {
                    let (uv, k, probe) = fetch(warp, correctives, b, dir, r);
                    let spec = read(warp, (uv, probe), rules.roughness(chosen, row, r, k));
                    irradiance.read(b, dir).map_or(spec, |e| crate::runtime::mix_irradiance(spec, e, w))
                })
            };
            // the largest of the fitted weight, its half and its quarter whose views look no
            // worse than the unblended rule's (mean ꟻLIP), and none of them one by one beyond
            // 2 standard errors of its tiles: the tone-mapped error alone also pays for blur
            // that hedges a misplaced fetch, which a viewer sees as lost detail, and a mean
            // over views can hide the one view the blend darkens
            let unblended = &tiles[at(chosen)];
            let mut kept = (0.0, None);
            for w in [fitted, 0.5 * fitted, 0.25 * fitted] {
                if !(w > 0.0) {
                    break;
                }
                let tiles = blended_tiles(w);
                let f = perceptual::weighted_mean(&tiles.concat());
                let no_view_worse = tiles.iter().zip(unblended).all(|(b, u)| {
                    let worse = perceptual::weighted_mean(b) - perceptual::weighted_mean(u);
                    worse <= 2.0 * perceptual::paired_standard_error(b, u)
                });
                if f.is_finite() && f <= flip.get(chosen) && no_view_worse {
                    kept = (w, Some(f));
                    break;
                }
                kept.1 = kept.1.or(Some(f));
            }
            let (w, flip_blended) = kept;
            let row = RowChoice { roughness: r, chosen, flip, flip_se, tm_rmse: tm, flip_blended };
            (row, w)
        })
        .collect();
    let (rows, weights): (Vec<RowChoice>, Vec<f32>) = rows.into_iter().unzip();
    let chosen: Vec<RowRule> = rows.iter().map(|row| row.chosen).collect();
    let candidate = RoughnessCorrection::try_from(scene_table(lobe_fit, &rules, &chosen));
    let Ok(candidate) = candidate else { return lobe_fit.clone() };
    let (candidate, scene_fit_blended) = with_irradiance_blend(candidate, &weights, warp, &held, exposure);
    let comparison = SceneComparison {
        lookups: held.len(),
        plain: tm_rmse(warp, &held, exposure, |q| q.r),
        engine: tm_rmse(warp, &held, exposure, |q| engine_roughness(q.r, q.k)),
        lobe_fit: tm_rmse(warp, &held, exposure, |q| lobe_fit.corrected_roughness(q.r, q.k)),
        scene_fit: tm_rmse(warp, &held, exposure, |q| candidate.corrected_roughness(q.r, q.k)),
        scene_exponents: exponents.iter().map(|&(u, d)| [u as f32, d as f32]).collect(),
        scene_fit_blended,
        rows,
    };
    RoughnessCorrection::try_from(RoughnessFit { heldout_scene: Some(comparison), ..(*candidate).clone() })
        .unwrap_or_else(|_| lobe_fit.clone())
}
