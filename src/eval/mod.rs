//! Evaluation of warp methods against raytraced references on a held-out validation set.
//!
//! The validation set is seeded in its own sampler domain, independent of anything a fitter
//! sees: positions uniformly random inside grid cells that are not inside geometry (never at
//! cell centres; positions whose rays mostly hit back faces are rejected), and uniformly
//! random directions per position. References are traced with the same radiance model as
//! the probe, so the only difference between a method and its reference is the warp (plus
//! sampling noise, which the `oracle` row bounds from below).

use crate::bake::{ProbeGrid, SpecularProbe};
use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer, bvh::intersect_sphere, trace_batch};
use crate::warp::{self, Method, Proxies, WarpOptions, WarpProbe, proxy, reproject::reproject, toward};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::hint::black_box;
use std::time::Instant;

pub const DOMAIN_EVAL: u64 = 0x4556_414C; // "EVAL"

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

impl Default for EvalSettings {
    fn default() -> Self {
        EvalSettings {
            positions: 256,
            dirs_per_position: 256,
            reference_spp: 16,
            seed: 0xE7A1,
            options: WarpOptions::default(),
            timing_lookups: 32_768,
        }
    }
}

/// Held-out queries and their ground truth.
pub struct ValidationSet {
    pub positions: Vec<Vec3>,
    /// `positions.len() × dirs_per_position` query directions, position-major.
    pub dirs: Vec<Vec3>,
    pub dirs_per_position: usize,
    /// Reference radiance traced from each position along each direction.
    pub reference: Vec<Vec3>,
    /// Direction from A towards the true hit point (the query direction on a miss).
    pub oracle_dir: Vec<Vec3>,
    /// The true hit point is hidden from A: no single fetch of A can be right.
    pub hidden: Vec<bool>,
    pub reference_rays: u64,
}

impl ValidationSet {
    pub fn position_of(&self, k: usize) -> Vec3 {
        self.positions[k / self.dirs_per_position]
    }
}

/// Draws the validation set and traces its references and oracle directions.
pub fn validation_set(
    scene: &Scene,
    tracer: &Tracer,
    grid: &ProbeGrid,
    probe_pos: Vec3,
    s: &EvalSettings,
) -> ValidationSet {
    let renderer = Renderer::new(scene, tracer);
    let active: Vec<usize> = (0..grid.geometry.cell_count()).filter(|&c| !grid.inside[c]).collect();
    let mut positions = Vec::with_capacity(s.positions as usize);
    let mut attempt = 0u32;
    while positions.len() < s.positions as usize && !active.is_empty() && attempt < s.positions * 64 {
        let mut sampler = Sampler::new(s.seed, hash_pair(DOMAIN_EVAL, 1), attempt);
        attempt += 1;
        let cell = active[((sampler.next_1d() * active.len() as f32) as usize).min(active.len() - 1)];
        let c = grid.geometry.cell_coords(cell).as_vec3();
        let u = Vec3::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d());
        let p = grid.geometry.min + (c + u) * grid.geometry.cell_size();
        if is_inside_geometry(tracer, p, s.seed, attempt) {
            continue;
        }
        positions.push(p);
    }
    let dpp = s.dirs_per_position as usize;
    let mut dirs = Vec::with_capacity(positions.len() * dpp);
    for k in 0..positions.len() {
        for d in 0..dpp {
            let mut sampler = Sampler::new(s.seed, hash_pair(DOMAIN_EVAL, 2 + k as u64), d as u32);
            dirs.push(uniform_sphere(sampler.next_2d()));
        }
    }
    let origins: Vec<Vec3> = (0..dirs.len()).map(|k| positions[k / dpp]).collect();
    let (samples, reference_rays) =
        trace_batch(&renderer, &origins, &dirs, s.seed, hash_pair(DOMAIN_EVAL, 0), s.reference_spp);
    let (oracle_dir, hidden): (Vec<Vec3>, Vec<bool>) =
        (0..dirs.len()).into_par_iter().map(|k| oracle(scene, tracer, probe_pos, origins[k], dirs[k])).unzip();
    ValidationSet {
        positions,
        dirs,
        dirs_per_position: dpp,
        reference: samples.iter().map(|r| r.radiance).collect(),
        oracle_dir,
        hidden,
        reference_rays,
    }
}

/// Direction from A towards the true hit of the ray (B, dir), and whether A sees that point.
/// Sphere lights count as hits (primary rays see them).
pub fn oracle(scene: &Scene, tracer: &Tracer, a: Vec3, b: Vec3, dir: Vec3) -> (Vec3, bool) {
    if a == b {
        return (dir, false); // A's own data is exact at A
    }
    let mut t = tracer.closest_hit(b, dir, f32::INFINITY).map_or(f32::INFINITY, |h| h.t);
    for l in &scene.lights.sphere_lights {
        t = t.min(intersect_sphere(b.into(), dir.into(), l.position.into(), l.radius, 0.0, t));
    }
    if !t.is_finite() {
        return (dir, false);
    }
    let p = b + dir * t;
    let d = toward(a, p, dir);
    let dist = (p - a).length();
    let mut hidden = dist > 0.0 && tracer.occluded(a, d, dist * (1.0 - 1e-3));
    for l in &scene.lights.sphere_lights {
        hidden |=
            intersect_sphere(a.into(), d.into(), l.position.into(), l.radius, 0.0, dist * (1.0 - 1e-3)).is_finite();
    }
    (d, hidden)
}

fn is_inside_geometry(tracer: &Tracer, p: Vec3, seed: u64, attempt: u32) -> bool {
    let mut back = 0;
    for k in 0..16 {
        let d = uniform_sphere(Sampler::new(seed, hash_pair(DOMAIN_EVAL, 0xB ^ attempt as u64), k).next_2d());
        if tracer.closest_hit(p, d, f32::INFINITY).is_some_and(|h| h.backface) {
            back += 1;
        }
    }
    back > 4
}

/// Error and cost of one method on the validation set. Keys as in `eval.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MethodResult {
    pub name: String,
    /// RMSE of linear RGB radiance over the mean reference radiance.
    pub rel_rmse: f64,
    /// Mean absolute error (mean over RGB), radiance units.
    pub mae: f64,
    /// 95th percentile of the per-lookup error (mean abs over RGB).
    pub p95: f64,
    pub max: f64,
    /// Mean angle between the method's fetch direction and the oracle's, degrees (null for
    /// methods without a single fetch direction).
    pub angular_deg: Option<f64>,
    /// Single-threaded warm-loop cost per lookup, queries in coherent order (see
    /// `timing_order`).
    pub ns_per_lookup: f64,
    /// The same with queries in random order (cache-hostile).
    pub ns_per_lookup_random: f64,
    /// Per lookup through the method's batch API (queries in coherent order, [`LANES`](crate::octa::LANES)
    /// lookups in lockstep), for methods that have one.
    #[serde(default)]
    pub ns_per_lookup_batched: Option<f64>,
    pub note: String,
}

/// Per-lookup error statistics.
pub fn error_stats(estimate: &[Vec3], reference: &[Vec3]) -> (f64, f64, f64, f64) {
    let n = estimate.len().max(1) as f64;
    let mut sq = 0.0f64;
    let mut abs = Vec::with_capacity(estimate.len());
    let mut ref_sum = 0.0f64;
    for (e, r) in estimate.iter().zip(reference) {
        let d = *e - *r;
        sq += (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2);
        abs.push(((d.x.abs() + d.y.abs() + d.z.abs()) / 3.0) as f64);
        ref_sum += ((r.x + r.y + r.z) / 3.0) as f64;
    }
    let rmse = (sq / (3.0 * n)).sqrt();
    let mean_ref = (ref_sum / n).max(1e-30);
    let mae = abs.iter().sum::<f64>() / n;
    abs.sort_by(f64::total_cmp);
    let p95 = abs.get(((abs.len() as f64 * 0.95) as usize).min(abs.len().saturating_sub(1))).copied().unwrap_or(0.0);
    let max = abs.last().copied().unwrap_or(0.0);
    (rmse / mean_ref, mae, p95, max)
}

fn mean_angle_deg(a: &[Vec3], b: &[Vec3]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| (x.dot(*y).clamp(-1.0, 1.0) as f64).acos().to_degrees()).sum();
    sum / a.len().max(1) as f64
}

/// The context all per-lookup methods share.
pub struct MethodContext {
    pub probe: WarpProbe,
    pub proxies: Proxies,
}

impl MethodContext {
    pub fn new(scene: &Scene, probe: &SpecularProbe) -> Self {
        let (lo, hi) = scene.bounds();
        let wp = WarpProbe::new(probe);
        let kdop = proxy::Kdop::fit(probe.position, probe.distance());
        MethodContext { probe: wp, proxies: Proxies { aabb: proxy::BoxProxy::aabb(lo, hi), kdop } }
    }
}

/// Fetch directions of a per-lookup method for the whole set (parallel, deterministic).
pub fn fetch_dirs(ctx: &MethodContext, set: &ValidationSet, method: Method, opts: &WarpOptions) -> Vec<Vec3> {
    if method == Method::Oracle {
        return set.oracle_dir.clone();
    }
    (0..set.dirs.len())
        .into_par_iter()
        .map(|k| warp::fetch_dir(method, &ctx.probe, &ctx.proxies, opts, set.position_of(k), set.dirs[k]))
        .collect()
}

/// Radiance estimates of `reproject` (one reprojected probe per position).
pub fn reproject_estimates(ctx: &MethodContext, set: &ValidationSet) -> Vec<Vec3> {
    let res = ctx.probe.radiance.levels[0].res;
    let per_pos: Vec<Vec<Vec3>> = set
        .positions
        .par_iter()
        .enumerate()
        .map(|(k, &b)| {
            let map = reproject(&ctx.probe, b, res);
            (0..set.dirs_per_position).map(|d| map.bilinear(set.dirs[k * set.dirs_per_position + d])).collect()
        })
        .collect();
    per_pos.into_iter().flatten().collect()
}

/// Order in which timing loops issue lookups: per position, query directions sorted along a
/// Morton curve over their octahedral uv, the coherent order in which neighbouring pixels
/// of a shaded surface query a probe. `random = true` keeps the validation set's order.
pub fn timing_order(set: &ValidationSet, random: bool) -> Vec<usize> {
    let mut order: Vec<usize> = (0..set.dirs.len()).collect();
    if !random {
        let spread = |mut x: u64| {
            x &= 0xFFFF;
            x = (x | (x << 8)) & 0x00FF_00FF;
            x = (x | (x << 4)) & 0x0F0F_0F0F;
            x = (x | (x << 2)) & 0x3333_3333;
            (x | (x << 1)) & 0x5555_5555
        };
        order.sort_by_key(|&k| {
            let uv = crate::octa::encode(set.dirs[k]) * 65535.0;
            ((k / set.dirs_per_position) as u64) << 32 | spread(uv.x as u64) | spread(uv.y as u64) << 1
        });
    }
    order
}

/// Single-threaded warm-loop ns per lookup of `fetch` (query B, dir, oracle dir → fetch
/// vector) followed by the probe's radiance lookup.
pub fn time_lookups(
    ctx: &MethodContext,
    set: &ValidationSet,
    lookups: usize,
    random: bool,
    fetch: impl Fn(Vec3, Vec3, Vec3) -> Vec3,
) -> f64 {
    time_queries(set, lookups, random, |b, dir, oracle| ctx.probe.radiance(fetch(b, dir, oracle)))
}

/// ns per call of `radiance(B, query dir, oracle dir)` over the first `lookups` queries in
/// coherent or shuffled order; best of three warm runs.
pub fn time_queries(
    set: &ValidationSet,
    lookups: usize,
    random: bool,
    radiance: impl Fn(Vec3, Vec3, Vec3) -> Vec3,
) -> f64 {
    let order = timing_order(set, random);
    let n = lookups.min(set.dirs.len()).max(1);
    // (B, query dir, oracle dir) laid out in issue order, so the loop times only the lookup.
    let queries: Vec<(Vec3, Vec3, Vec3)> =
        order[..n].iter().map(|&k| (set.position_of(k), set.dirs[k], set.oracle_dir[k])).collect();
    best_of_three_ns(n, || {
        let mut acc = Vec3::ZERO;
        for &(b, dir, oracle) in &queries {
            acc += black_box(radiance(b, dir, oracle));
        }
        black_box(acc);
    })
}

/// The timing harness: ns per lookup of `run` (which makes `lookups` lookups), best of
/// three runs after one warm-up run.
fn best_of_three_ns(lookups: usize, mut run: impl FnMut()) -> f64 {
    run(); // warm
    (0..3)
        .map(|_| {
            let t = Instant::now();
            run();
            t.elapsed().as_nanos() as f64 / lookups as f64
        })
        .fold(f64::INFINITY, f64::min)
}

/// One table row from a method's radiance estimates, its fetch directions (none for
/// methods without a single fetch) and its coherent/random-order costs.
fn method_row(
    set: &ValidationSet,
    name: &str,
    note: String,
    est: &[Vec3],
    dirs: Option<&[Vec3]>,
    (ns_per_lookup, ns_per_lookup_random): (f64, f64),
) -> MethodResult {
    let (rel_rmse, mae, p95, max) = error_stats(est, &set.reference);
    MethodResult {
        name: name.into(),
        rel_rmse,
        mae,
        p95,
        max,
        angular_deg: dirs.map(|d| mean_angle_deg(d, &set.oracle_dir)),
        ns_per_lookup,
        ns_per_lookup_random,
        ns_per_lookup_batched: None,
        note,
    }
}

/// A loaded fitted grid (`runtime::FittedGrid`) on the validation set: mirror queries
/// (roughness 0), timed through `specular` itself.
pub fn evaluate_runtime(
    set: &ValidationSet,
    name: &str,
    note: &str,
    grid: &crate::runtime::FittedGrid,
    timing_lookups: usize,
) -> MethodResult {
    let est: Vec<Vec3> =
        (0..set.dirs.len()).into_par_iter().map(|k| grid.specular(set.position_of(k), set.dirs[k], 0.0)).collect();
    let dirs: Vec<Vec3> = (0..set.dirs.len())
        .map(|k| grid.fetch_vector(set.position_of(k), set.dirs[k]).try_normalize().unwrap_or(set.dirs[k]))
        .collect();
    let ns = (
        time_queries(set, timing_lookups, false, |b, d, _| grid.specular(b, d, 0.0)),
        time_queries(set, timing_lookups, true, |b, d, _| grid.specular(b, d, 0.0)),
    );
    method_row(set, name, note.into(), &est, Some(&dirs), ns)
}

/// ns per lookup of `warp1` through its batch API (`warp1_batch` then `radiance_batch`),
/// over the first `lookups` queries in coherent order; best of three warm runs.
pub fn time_warp1_batched(ctx: &MethodContext, set: &ValidationSet, opts: &WarpOptions, lookups: usize) -> f64 {
    let order = timing_order(set, false);
    let n = lookups.min(set.dirs.len()).max(1);
    let queries: Vec<(Vec3, Vec3)> = order[..n].iter().map(|&k| (set.position_of(k), set.dirs[k])).collect();
    let (mut vectors, mut radiance) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    best_of_three_ns(n, || {
        warp::depth::warp1_batch(&ctx.probe, &queries, opts.depth_lod, &mut vectors);
        ctx.probe.radiance_batch(&vectors, &mut radiance);
        black_box(&radiance);
    })
}

/// Timing of a per-lookup method.
pub fn time_method(
    ctx: &MethodContext,
    set: &ValidationSet,
    method: Method,
    opts: &WarpOptions,
    lookups: usize,
    random: bool,
) -> f64 {
    time_lookups(ctx, set, lookups, random, |b, dir, oracle| {
        if method == Method::Oracle {
            oracle
        } else {
            warp::fetch_vector(method, &ctx.probe, &ctx.proxies, opts, b, dir)
        }
    })
}

/// Error and cost of a fitted (or unfitted) corrective grid, as one table row.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_correctives(
    ctx: &MethodContext,
    set: &ValidationSet,
    name: &str,
    note: &str,
    correctives: &crate::fit::Correctives,
    blend: crate::fit::Blend,
    opts: &WarpOptions,
    timing_lookups: usize,
) -> MethodResult {
    let fetch = |b: Vec3, dir: Vec3| correctives.fetch_vector(blend, &ctx.probe, &ctx.proxies, opts, b, dir);
    let vectors: Vec<Vec3> =
        (0..set.dirs.len()).into_par_iter().map(|k| fetch(set.position_of(k), set.dirs[k])).collect();
    let est: Vec<Vec3> = vectors.par_iter().map(|&v| ctx.probe.radiance(v)).collect();
    let dirs: Vec<Vec3> = vectors.iter().zip(&set.dirs).map(|(v, d)| v.try_normalize().unwrap_or(*d)).collect();
    let ns = (
        time_lookups(ctx, set, timing_lookups, false, |b, d, _| fetch(b, d)),
        time_lookups(ctx, set, timing_lookups, true, |b, d, _| fetch(b, d)),
    );
    method_row(set, name, note.into(), &est, Some(&dirs), ns)
}

/// Amortised ns per lookup of `reproject`: the per-location build spread over the lookups
/// it serves, plus the lookup.
pub fn time_reproject(ctx: &MethodContext, set: &ValidationSet) -> f64 {
    let res = ctx.probe.radiance.levels[0].res;
    let count = set.positions.len().clamp(1, 8);
    let t = Instant::now();
    let mut acc = Vec3::ZERO;
    for k in 0..count {
        let map = reproject(&ctx.probe, set.positions[k], res);
        for d in 0..set.dirs_per_position {
            acc += map.bilinear(set.dirs[k * set.dirs_per_position + d]);
        }
    }
    black_box(acc);
    t.elapsed().as_nanos() as f64 / (count * set.dirs_per_position) as f64
}

/// ns per reference ray (radiance of one sample, single-threaded).
pub fn time_reference(renderer: &Renderer, set: &ValidationSet, rays: usize) -> f64 {
    let n = rays.min(set.dirs.len()).max(1);
    let mut count = 0u64;
    let t = Instant::now();
    let mut acc = Vec3::ZERO;
    for k in 0..n {
        let mut s = Sampler::new(1, k as u64, 0);
        acc += renderer.sample(set.position_of(k), set.dirs[k], &mut s, &mut count).radiance;
    }
    black_box(acc);
    t.elapsed().as_nanos() as f64 / n as f64
}

/// Evaluates `methods`; errors on the whole set, timings single-threaded.
pub fn evaluate_methods(
    ctx: &MethodContext,
    set: &ValidationSet,
    methods: &[Method],
    opts: &WarpOptions,
    timing_lookups: usize,
) -> Vec<MethodResult> {
    methods
        .iter()
        .map(|&m| {
            if m == Method::Reproject {
                let est = reproject_estimates(ctx, set);
                // one per-location pass serves a location's lookups in any order: timed once
                let ns = time_reproject(ctx, set);
                let note = format!(
                    "per-location scatter + push-pull amortised over {} lookups per location",
                    set.dirs_per_position
                );
                return method_row(set, m.name(), note, &est, None, (ns, ns));
            }
            let dirs = fetch_dirs(ctx, set, m, opts);
            let est: Vec<Vec3> = dirs.par_iter().map(|&d| ctx.probe.radiance(d)).collect();
            let note = match m {
                Method::Oracle => "bound: fetch towards the true hit traced from B (tracing cost not counted)".into(),
                Method::Box => "scene bounds as the box; query direction outside it".into(),
                Method::Kdop => "18-DOP fitted to the probe's depth samples".into(),
                _ => String::new(),
            };
            let ns = (
                time_method(ctx, set, m, opts, timing_lookups, false),
                time_method(ctx, set, m, opts, timing_lookups, true),
            );
            let mut row = method_row(set, m.name(), note, &est, Some(&dirs), ns);
            if m == Method::Warp1 && opts.relax_texels == 0.0 {
                row.ns_per_lookup_batched = Some(time_warp1_batched(ctx, set, opts, timing_lookups));
            }
            row
        })
        .collect()
}
