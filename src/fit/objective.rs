//! The fit objective of one cell as argmin problems.
//!
//! Parameters: one log-scale `s_k` per shift-map texel whose direction leaves the proxy at a
//! finite distance `t_k` from the cell's origin; the texel's surface lies at `t_k · exp(s_k)`
//! from the origin, so its shift is `Δ_k = t_k · (exp(s_k) − 1)` and `s = 0` is the proxy
//! itself. Parameters are order 1 whatever the scene's scale (a scene scaled by 1e4 has the
//! same objective). Texels without a finite proxy distance keep Δ = 0.
//!
//! Queries carry a roughness: mirror queries read mip 0 along the corrective's fetch, rough
//! ones go through the same lookup as the runtime (`warp::glossy`, the `Corrected` rule), so
//! a map that helps mirror lookups but hurts rough ones pays for it.
//!
//! Cost = data + regularisation:
//! - data: mean Charbonnier loss `√(e² + ε²) − ε` of the per-query error `e`, the mean
//!   absolute RGB difference between lookup and reference *after tone mapping both*
//!   (`tonemap::reinhard` at the scene's key exposure), divided by the mean tone-mapped
//!   reference; ε = 5% of that mean. Tone mapping bounds each query's error, so a few
//!   queries that see a lamp or the sun's disc cannot rule the fit; the Charbonnier loss
//!   keeps reference noise and queries no single fetch can fix (hidden from A) from
//!   dragging the map;
//! - `smooth_weight` × mean squared difference of neighbouring texels' `s` (tile smoothness);
//! - `size_weight` × mean `(s − a)²`: stay near the anchor `a` unless the data pays. The
//!   anchor lies between the proxy (`a = 0`) and the grid's raytraced distances, a fraction
//!   `depth_prior` of the way in log-scale (`FitSettings::depth_prior`): the proxy alone
//!   keeps a map near its neighbours (and cells without a map; seams between cells are
//!   what a viewer sees first: docs/architecture.md), but a texel the data leaves free then
//!   falls back to a surface that is not there, which rough lookups, averaging many
//!   texels, show; halfway between, both hold (measured: docs/architecture.md).
//! - the aim pull (`FitSettings::aim_pull`, [`CellProblem::with_aim_pull`]): each mirror
//!   training query whose true hit the probe it reads sees adds, to its error, the angle
//!   between the point it aims at and that hit, as the probe sees them. A pointwise error
//!   rewards an aim that averages two surfaces (it halves the error at an edge, so the
//!   edge smears or moves); a viewer sees edges, and the pull keeps them where they are
//!   (measured: docs/frames.md, "A fit that keeps structure"). Held-out errors, and so
//!   model selection, do not include it.
//!
//! Solvers (chosen by measurement, see docs/architecture.md): Brent's method per texel in
//! coordinate-descent sweeps (each texel only touches the queries in its bilinear
//! footprint, so a 1-D step is cheap), L-BFGS on all texels (gradient by central differences
//! with step 1e-3 in log-scale: 0.1% of a distance, far above f32 noise, far below the scale
//! at which the piecewise-smooth radiance changes), or Nelder-Mead.

use super::Solver;
use crate::octa::{self, LANES, wrap_texel};
use crate::tonemap::reinhard;
use crate::warp::corrective::{AimLanes, nearest_tap, sample_map, sample_maps, shifted_aim};
use crate::warp::glossy::{Aim, Glossy, MipRule, corrected_lanes, corrected_lanes_of};
use crate::warp::{Level1, Method, Warp};
use argmin::core::{CostFunction, Error, Executor, Gradient, State};
use argmin::solver::brent::BrentOpt;
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::cell::{Cell, RefCell};

/// Floor of a cell's mean tone-mapped reference in its relative errors (tone-mapped units:
/// the scene's key maps to about 0.15, so the floor is about a fifteenth of middle grey).
pub const MEAN_REFERENCE_FLOOR: f64 = 0.01;

/// Texel log-scales are clamped to ±this (a factor of e³ ≈ 20 in distance either way).
const S_LIMIT: f64 = 3.0;

/// The interval Brent searches a texel's log-scale in: a factor of e² ≈ 7.4 in distance
/// either way of the start. Searching around each texel's current value instead (so a
/// second sweep could go on to the clamp) lowered the held-out error per cell on torture by
/// 1% but raised the runtime's errors on cornell and gallery by 1–4%: more room to fit
/// the training queries.
const BRACKET: f64 = 2.0;

/// Brent's tolerance on a texel's log-scale (argmin's `eps`, relative, and `t`, absolute:
/// the answer is within 3·(eps·|s| + t)): about 3% of a distance, far below a texel's angle
/// for any parallax the probe sees. The earlier (1e-3, 1e-4) cost 68% more evaluations for
/// no lower held-out error on torture (see docs/architecture.md).
const BRENT_TOLERANCE: (f64, f64) = (3e-2, 1e-2);

/// One training or check query.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub b: Vec3,
    pub dir: Vec3,
    /// Perceptual roughness of the lookup (0 = mirror).
    pub roughness: f32,
    pub reference: Vec3,
    /// Bilinear taps of `dir` in the cell's shift map (set by [`CellProblem::new`]).
    pub taps: [(u32, f32); 4],
    /// Where the ray leaves the proxy (set by [`CellProblem::new`]): no map changes it.
    pub t_proxy: Option<f32>,
    /// The true hit of the query ray and the probe that sees it (set by the fit for the
    /// aim pull, [`CellProblem::with_aim_pull`]; `None`: no pull on this query).
    pub target: Option<(u8, Vec3)>,
}

impl Sample {
    /// A query with its reference; the problem fills in the rest.
    #[must_use]
    pub fn new(b: Vec3, dir: Vec3, roughness: f32, reference: Vec3) -> Sample {
        Sample { b, dir, roughness, reference, taps: [(0, 0.0); 4], t_proxy: None, target: None }
    }
}

/// Result of a solve.
pub struct Outcome {
    pub params: Vec<f64>,
    /// (seconds since the solve started, training objective): start, after each Brent
    /// sweep (or the whole gradient/simplex solve), after relaxation.
    pub curve: Vec<(f64, f64)>,
    pub relax: f64,
    pub cost_start: f64,
    pub cost_end: f64,
    pub iterations: u64,
    pub evaluations: u64,
    pub termination: Termination,
}

/// Why a cell's solve stopped.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "stop", rename_all = "snake_case")]
pub enum Termination {
    /// No texel saw geometry: nothing to fit.
    NothingToFit,
    /// The solver ran its budget or met its own criterion (`reason`, argmin's words, for the
    /// gradient and simplex solvers). `kept_start`: the result was no better than the start,
    /// which was kept.
    Finished { solver: Solver, iterations: u32, texels: usize, reason: Option<String>, kept_start: bool },
    /// The solver failed; the start was kept.
    SolverError { message: String },
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Termination::NothingToFit => f.write_str("nothing to fit (no texel saw geometry)"),
            Termination::Finished { solver, iterations, texels, reason, kept_start } => {
                match (solver, reason) {
                    (Solver::Brent, _) => write!(f, "{iterations} Brent sweeps over {texels} texels")?,
                    (s, Some(r)) => write!(f, "{s:?} over {texels} texels: {r}")?,
                    (s, None) => write!(f, "{s:?} over {texels} texels")?,
                }
                if *kept_start {
                    f.write_str("; no improvement, kept the start")?;
                }
                Ok(())
            }
            Termination::SolverError { message } => write!(f, "solver error: {message}; kept the start"),
        }
    }
}

/// A cell's fit problem.
pub struct CellProblem<'a> {
    glossy: Glossy<'a>,
    /// Exposure of the tone mapping the errors are measured after.
    exposure: f32,
    res: u32,
    /// Per texel, the proxy's exit distance from the cell's origin (+inf: none).
    proxy_distance: Vec<f32>,
    /// The log-scales the solve starts from.
    start: Vec<f64>,
    samples: Vec<Sample>,
    /// Per sample, its reference tone-mapped at `exposure`.
    tm_reference: Vec<Vec3>,
    /// Per sample, the probe its lookups read (`Warp::probe_at`; empty: probe A for all):
    /// the probe map's texel nearest its direction, as the runtime reads it.
    probe: Vec<u8>,
    /// Every sample, in order.
    all: QuerySet,
    /// Per texel, the samples whose bilinear footprint includes it.
    touching: Vec<QuerySet>,
    /// Neighbouring texel pairs (right and down, seam-wrapped).
    pairs: Vec<(u32, u32)>,
    /// Per texel, the indices of the pairs it belongs to, in `pairs`' order (a texel's
    /// smoothness terms without a scan of every pair).
    texel_pairs: Vec<Vec<u32>>,
    mean_reference: f64,
    eps: f64,
    smooth_weight: f64,
    size_weight: f64,
    /// The log-scales the size term pulls towards.
    anchor: Vec<f64>,
    /// Weight of the aim pull in the training objective (0: none; see
    /// [`CellProblem::with_aim_pull`]).
    aim_weight: f64,
    evaluations: Cell<u64>,
    /// The errors of the sum being formed (one buffer for every evaluation).
    scratch: RefCell<Vec<f64>>,
}

/// Queries a sum runs over: `idx` in the sum's order, `lanes` the order their lookups are
/// made in (positions in `idx`, the mirror queries first, so that a group of [`LANES`]
/// reads one mip wherever it can; a query's error does not depend on its group).
struct QuerySet {
    idx: Vec<u32>,
    lanes: Vec<u32>,
}

impl QuerySet {
    fn new(idx: Vec<u32>, samples: &[Sample]) -> Self {
        let mut lanes: Vec<u32> = (0..idx.len() as u32).collect();
        // (stable: mirror queries first, each kind in the sum's order)
        lanes.sort_by_key(|&p| samples[idx[p as usize] as usize].roughness != 0.0);
        QuerySet { idx, lanes }
    }
}

/// Where a cell problem lives: the lookup it shades with, the exposure its errors are
/// measured after, the proxy its map shifts, the map's origin (the cell probe) and
/// resolution.
#[derive(Clone, Copy, Debug)]
pub struct CellContext<'a> {
    pub glossy: Glossy<'a>,
    pub exposure: f32,
    pub proxy: Method,
    pub origin: Vec3,
    pub res: u32,
    /// The probe each texel's lookups read (`fit::probes`; empty: probe A for all).
    pub probe_map: &'a [u8],
}

impl CellContext<'_> {
    /// Per texel of the map, the proxy's exit distance from the origin (+inf: none).
    #[must_use]
    pub fn proxy_distances(&self) -> Vec<f32> {
        (0..self.res * self.res)
            .map(|t| {
                let d = octa::texel_dir(self.res, t % self.res, t / self.res);
                match self.glossy.warp.base_distance(self.proxy, self.origin, d) {
                    Some(x) if x.is_finite() && x > 0.0 => x,
                    _ => f32::INFINITY,
                }
            })
            .collect()
    }

    /// The log-scales of a map of distances from the origin (`distance[k]`: +inf for sky):
    /// `ln(distance / proxy distance)`, clamped to ±`S_LIMIT` (sky: the far end); 0 where
    /// the proxy has no finite distance.
    #[must_use]
    pub fn log_scales_of(&self, distance: &[f32]) -> Vec<f64> {
        self.proxy_distances()
            .iter()
            .zip(distance)
            .map(|(&t, &d)| {
                if !t.is_finite() {
                    0.0
                } else if d.is_finite() && d > 0.0 {
                    libm::log(d as f64 / t as f64).clamp(-S_LIMIT, S_LIMIT)
                } else if d.is_nan() {
                    0.0
                } else {
                    S_LIMIT
                }
            })
            .collect()
    }
}

impl<'a> CellProblem<'a> {
    /// The problem of the cell in `ctx` with a solve starting at log-scales `start` (one per
    /// texel; see the module docs) and its queries; no regularisation (see
    /// [`CellProblem::with_weights`]).
    pub fn new(ctx: CellContext<'a>, start: Vec<f64>, mut samples: Vec<Sample>) -> Self {
        let CellContext { glossy, exposure, res, proxy, probe_map, .. } = ctx;
        let proxy_distance = ctx.proxy_distances();
        let n2 = (res * res) as usize;
        debug_assert_eq!(start.len(), n2);
        let mut touching: Vec<Vec<u32>> = vec![Vec::new(); n2];
        for (i, s) in samples.iter_mut().enumerate() {
            s.taps = octa::bilinear_taps(res, octa::encode(s.dir));
            s.t_proxy = glossy.warp.base_distance(proxy, s.b, s.dir);
            for &(k, w) in &s.taps {
                // (two taps of one query on one texel, at a seam: the query was pushed
                // last, so the list's last entry tells, not a scan of the whole list)
                if w > 0.0 && touching[k as usize].last() != Some(&(i as u32)) {
                    touching[k as usize].push(i as u32);
                }
            }
        }
        let mut pairs = Vec::new();
        for j in 0..res as i64 {
            for i in 0..res as i64 {
                let k = (j * res as i64 + i) as u32;
                for (di, dj) in [(1, 0), (0, 1)] {
                    let (ni, nj) = wrap_texel(res, i + di, j + dj);
                    pairs.push((k, nj * res + ni));
                }
            }
        }
        let mut texel_pairs = vec![Vec::new(); n2];
        for (p, &(a, b)) in pairs.iter().enumerate() {
            texel_pairs[a as usize].push(p as u32);
            if b != a {
                texel_pairs[b as usize].push(p as u32);
            }
        }
        let tm_reference: Vec<Vec3> = samples.iter().map(|s| reinhard(s.reference, exposure)).collect();
        let mean_reference =
            tm_reference.iter().map(|t| ((t.x + t.y + t.z) / 3.0) as f64).sum::<f64>() / samples.len().max(1) as f64;
        // floored: a cell that sees almost nothing would turn tiny absolute errors into
        // relative ones in the millions
        let mean_reference = mean_reference.max(MEAN_REFERENCE_FLOOR);
        let mut problem = CellProblem {
            glossy,
            exposure,
            res,
            proxy_distance,
            start,
            all: QuerySet::new((0..samples.len() as u32).collect(), &samples),
            touching: touching.into_iter().map(|idx| QuerySet::new(idx, &samples)).collect(),
            samples,
            tm_reference,
            probe: Vec::new(),
            pairs,
            texel_pairs,
            mean_reference,
            eps: 0.05 * mean_reference,
            smooth_weight: 0.0,
            size_weight: 0.0,
            anchor: vec![0.0; n2],
            aim_weight: 0.0,
            evaluations: Cell::new(0),
            scratch: RefCell::new(Vec::new()),
        };
        problem.set_probe_map(probe_map);
        problem
    }

    /// Lookups read the probes of `map` (per texel, as `Correctives::probe_maps`; empty:
    /// probe A everywhere, as a cell without a map reads).
    pub fn set_probe_map(&mut self, map: &[u8]) {
        self.probe = if map.is_empty() {
            Vec::new()
        } else {
            self.samples.iter().map(|q| map[nearest_tap(&q.taps) as usize]).collect()
        };
    }

    /// The probe sample `i`'s lookups read.
    #[inline(always)]
    fn probe_of(&self, i: usize) -> u8 {
        self.probe.get(i).copied().unwrap_or(0)
    }

    /// The problem's queries, given back (to judge them again with more).
    #[must_use]
    pub fn into_samples(self) -> Vec<Sample> {
        self.samples
    }

    /// Starts the solve from log-scales `start` instead.
    pub fn set_start(&mut self, start: Vec<f64>) {
        debug_assert_eq!(start.len(), self.start.len());
        self.start = start;
    }

    /// Sets the weights of the tile-smoothness and size terms.
    pub fn with_weights(mut self, smooth_weight: f64, size_weight: f64) -> Self {
        (self.smooth_weight, self.size_weight) = (smooth_weight, size_weight);
        self
    }

    /// Sets the log-scales the size term pulls towards (the proxy itself, all 0, unless set).
    pub fn with_anchor(mut self, anchor: Vec<f64>) -> Self {
        debug_assert_eq!(anchor.len(), self.anchor.len());
        self.anchor = anchor;
        self
    }

    /// Pulls each training query's aim towards its true hit (`Sample::target`) where the
    /// probe the query reads sees it: the query's error in the training objective (not in
    /// the held-out errors) gains `weight` × the mean tone-mapped reference per
    /// [`AIM_ANGLE_SCALE`] of angle between the aimed point and the hit as the probe sees
    /// them. A pointwise error alone rewards an aim that averages two surfaces (it halves
    /// the error at an edge); the pull keeps the edge where it is.
    pub fn with_aim_pull(mut self, weight: f64) -> Self {
        self.aim_weight = weight.max(0.0);
        self
    }

    /// Sets the Charbonnier ε to `scale` × the mean reference radiance.
    pub fn with_robust_scale(mut self, scale: f64) -> Self {
        self.eps = scale.max(1e-6) * self.mean_reference;
        self
    }

    /// Texels whose parameter matters (a finite proxy distance, touched by some query).
    fn free_texels(&self) -> Vec<usize> {
        (0..self.proxy_distance.len())
            .filter(|&k| self.proxy_distance[k].is_finite() && !self.touching[k].idx.is_empty())
            .collect()
    }

    /// Texel `k`'s shift at log-scale `s`.
    #[inline]
    fn texel_shift(&self, k: usize, s: f64) -> f32 {
        let t = self.proxy_distance[k];
        if t.is_finite() { t * ((libm::exp(s.clamp(-S_LIMIT, S_LIMIT)) - 1.0) as f32) } else { 0.0 }
    }

    /// Shift map for log-scales `s` (full length).
    pub fn map(&self, s: &[f64]) -> Vec<f32> {
        s.iter().enumerate().map(|(k, &sk)| self.texel_shift(k, sk)).collect()
    }

    /// The log-scales the solve starts from.
    #[must_use]
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// Map with UV relaxation of strength `relax` ∈ [0, 1]: blend towards its seam-aware 3×3
    /// box blur (in inverse distance).
    pub fn map_with_relax(&self, s: &[f64], relax: f64) -> Vec<f32> {
        let map = self.map(s);
        if relax <= 0.0 {
            return map;
        }
        let res = self.res as i64;
        let mut out = map.clone();
        for j in 0..res {
            for i in 0..res {
                let mut sum = 0.0f32;
                for dj in -1..=1 {
                    for di in -1..=1 {
                        let (ni, nj) = wrap_texel(self.res, i + di, j + dj);
                        sum += map[(nj * self.res + ni) as usize];
                    }
                }
                let k = (j * res + i) as usize;
                out[k] = ((1.0 - relax) as f32) * map[k] + (relax as f32) * sum / 9.0;
            }
        }
        out
    }

    /// Radiance of sample `i`'s lookup under `map`: the runtime's corrective fetch
    /// (`shifted_aim`) and, for a rough query, its mip (`warp::glossy`).
    #[inline]
    fn lookup(&self, i: usize, map: &[f32], rough: &[f32]) -> Vec3 {
        let q = &self.samples[i];
        let delta = sample_maps(map, rough, &q.taps, q.roughness);
        let probe = self.probe_of(i);
        let aim = shifted_aim(self.glossy.warp.probe_at(probe.into()).position, q.t_proxy, delta, q.b, q.dir);
        self.glossy.radiance(MipRule::Corrected, q.b, q.dir, Aim { probe, ..aim }, q.roughness)
    }

    /// Tone-mapped absolute error of sample `i` under `map`, one lookup at a time: the
    /// reference the lane errors (`errors`) are tested against.
    #[cfg(test)]
    fn sample_error(&self, i: usize, map: &[f32]) -> f64 {
        abs_error(reinhard(self.lookup(i, map, &[]), self.exposure), self.tm_reference[i])
    }

    /// The tone-mapped absolute error of each query of `set` under `map`, in the set's
    /// order: the scalar lookup's (`sample_error` in the tests) bit for bit, the lookups
    /// made [`LANES`] at a time.
    #[cfg(test)]
    fn errors(&self, set: &QuerySet, map: &[f32]) -> Vec<f64> {
        let mut out = Vec::new();
        self.errors_by(set, |q: &Sample| sample_map(map, &q.taps), false, &mut out);
        out
    }

    /// The errors of the queries of `set` into `out` (in the set's order), each query's
    /// shift given by `delta`; the lookups are made [`LANES`] at a time in the set's lane
    /// order (its mirror queries together), each query's error the same in any group.
    /// `pull`: add the aim pull ([`Self::with_aim_pull`]), as the training objective does.
    fn errors_by(&self, set: &QuerySet, delta: impl Fn(&Sample) -> f32, pull: bool, out: &mut Vec<f64>) {
        out.clear();
        out.resize(set.idx.len(), 0.0);
        for group in set.lanes.chunks(LANES) {
            let ids: [u32; LANES] = std::array::from_fn(|l| set.idx[group[l.min(group.len() - 1)] as usize]);
            let e = self.errors_lanes(&ids, &delta, pull && self.aim_weight > 0.0);
            for (l, &p) in group.iter().enumerate() {
                out[p as usize] = e[l];
            }
        }
    }

    /// The errors of [`LANES`] queries (`errors_by` pads a short group with its last
    /// query): the lanes' shifted aims (`AimLanes::shifted`), then their probe reads
    /// together (a mirror group at mip 0, otherwise `glossy::corrected_lanes`): the
    /// runtime's batch lookup.
    #[inline]
    fn errors_lanes(&self, ids: &[u32; LANES], delta_of: impl Fn(&Sample) -> f32, pull: bool) -> [f64; LANES] {
        let idx = ids.map(|i| i as usize);
        let warp = self.glossy.warp;
        let (mut b, mut d, mut a) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3]);
        let mut probe = [0u8; LANES];
        let (mut t, mut has_t) = ([0.0f32; LANES], [false; LANES]);
        let (mut delta, mut r) = ([0.0f32; LANES], [0.0f32; LANES]);
        for l in 0..LANES {
            let q = &self.samples[idx[l]];
            [b[0][l], b[1][l], b[2][l]] = q.b.to_array();
            [d[0][l], d[1][l], d[2][l]] = q.dir.to_array();
            (t[l], has_t[l]) = (q.t_proxy.unwrap_or(0.0), q.t_proxy.is_some());
            delta[l] = delta_of(q);
            r[l] = q.roughness;
            probe[l] = self.probe_of(idx[l]);
            [a[0][l], a[1][l], a[2][l]] = warp.probe_at(probe[l].into()).position.to_array();
        }
        let aims = AimLanes::shifted_from(&a, &t, &has_t, &delta, &b, d);
        let est = if r.iter().all(|&r| r == 0.0) {
            let uv = octa::encode_soa(&aims.vectors());
            warp.by_probe(
                &probe,
                |p| p.radiance.levels[0].bilinear_uv_lanes(&uv),
                |ps| octa::OctMap::bilinear_uv_lanes_of(&std::array::from_fn(|l| &ps[l].radiance.levels[0]), &uv),
            )
        } else {
            let (v, k) = aims.vectors_and_ratios();
            let c = self.glossy.correction;
            warp.by_probe(&probe, |p| corrected_lanes(p, c, &r, &v, &k), |ps| corrected_lanes_of(ps, c, &r, &v, &k))
        };
        // `abs_error(reinhard(estimate), reference)` as components, so the loop vectorises
        let (mut est_c, mut ref_c) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3]);
        for l in 0..LANES {
            let reference = self.tm_reference[idx[l]];
            for c in 0..3 {
                (est_c[c][l], ref_c[c][l]) = (est[l][c], reference[c]);
            }
        }
        let mut e = [0.0f64; LANES];
        for l in 0..LANES {
            let d = [0, 1, 2].map(|c| reinhard_channel(est_c[c][l], self.exposure) - ref_c[c][l]);
            e[l] = ((d[0].abs() + d[1].abs() + d[2].abs()) / 3.0) as f64;
        }
        if pull {
            let v = aims.vectors();
            let scale = self.aim_weight * self.mean_reference / AIM_ANGLE_SCALE;
            for l in 0..LANES {
                if let Some((p, hit)) = self.samples[idx[l]].target
                    && p == probe[l]
                {
                    let u = hit - Vec3::new(a[0][l], a[1][l], a[2][l]);
                    e[l] += scale * angle_between(Vec3::new(v[0][l], v[1][l], v[2][l]), u);
                }
            }
        }
        e
    }

    /// The mean angle in radians, as each query's probe sees them, between the point a
    /// query aims at under `map` and its true hit, over the queries with a target
    /// (`Sample::target`) whose probe is the one they read; 0 without any.
    #[must_use]
    pub fn mean_aim_angle(&self, map: &[f32]) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        for (i, q) in self.samples.iter().enumerate() {
            let probe = self.probe_of(i);
            let Some((p, hit)) = q.target.filter(|&(p, _)| p == probe) else { continue };
            let a = self.glossy.warp.probe_at(p.into()).position;
            let aim = shifted_aim(a, q.t_proxy, sample_map(map, &q.taps), q.b, q.dir);
            sum += angle_between(aim.v, hit - a);
            n += 1;
        }
        if n == 0 { 0.0 } else { sum / n as f64 }
    }

    /// Each query's linear absolute error (mean over RGB) under `map` and the rough map
    /// `rough` (empty: none), in query order: what the runtime's `specular` answers against
    /// the same references.
    pub fn query_errors(&self, map: &[f32], rough: &[f32]) -> Vec<f64> {
        (0..self.samples.len()).map(|i| abs_error(self.lookup(i, map, rough), self.samples[i].reference)).collect()
    }

    fn data_over(&self, set: &QuerySet, map: &[f32]) -> f64 {
        let n = self.samples.len().max(1) as f64;
        let mut e = self.scratch.borrow_mut();
        self.errors_by(set, |q: &Sample| sample_map(map, &q.taps), true, &mut e);
        // the losses in a pass of their own (it vectorises), then their sum in order
        let eps = self.eps;
        for x in e.iter_mut() {
            *x = rho(*x, eps);
        }
        e.iter().sum::<f64>() / (n * self.mean_reference)
    }

    fn regulariser(&self, s: &[f64]) -> f64 {
        let smooth = self.pairs.iter().map(|&(a, b)| (s[a as usize] - s[b as usize]).powi(2)).sum::<f64>()
            / self.pairs.len().max(1) as f64;
        let size = s.iter().zip(&self.anchor).map(|(x, a)| (x - a) * (x - a)).sum::<f64>() / s.len().max(1) as f64;
        self.smooth_weight * smooth + self.size_weight * size
    }

    /// Data term of a whole map (no regularisation): compares candidate starting maps.
    pub fn data_cost_map(&self, map: &[f32]) -> f64 {
        self.data_over(&self.all, map)
    }

    /// Full objective at log-scales `s`.
    pub fn cost(&self, s: &[f64]) -> f64 {
        let (data, regulariser) = self.cost_parts(s);
        data + regulariser
    }

    /// Root-mean-square of the per-query tone-mapped errors of `map`, relative to the mean
    /// tone-mapped reference: the held-out criterion of model selection (RMSE, so a map that
    /// misplaces edges loses to a method that does not; tone-mapped, so a lamp in view does
    /// not decide it alone).
    pub fn relative_error_map(&self, map: &[f32]) -> f64 {
        self.relative_error_maps(map, &[])
    }

    /// [`Self::relative_error_map`] of a mirror map and a rough map (empty: none), each
    /// query's shift blended from the two by its roughness as the runtime blends them
    /// (`warp::corrective::sample_maps`).
    pub fn relative_error_maps(&self, mirror: &[f32], rough: &[f32]) -> f64 {
        let delta = |q: &Sample| sample_maps(mirror, rough, &q.taps, q.roughness);
        let mut e = self.scratch.borrow_mut();
        self.errors_by(&self.all, delta, false, &mut e);
        self.rms(e.iter().copied()) / self.mean_reference
    }

    /// Root-mean-square of one error per query.
    fn rms(&self, errors: impl Iterator<Item = f64>) -> f64 {
        (errors.map(|e| e * e).sum::<f64>() / self.samples.len().max(1) as f64).sqrt()
    }

    /// Per position (each run of `per` queries, in query order), the sum of the squared
    /// tone-mapped errors that [`Self::relative_error_maps`] adds up: what the selection
    /// compares position by position (`selection::undecided`).
    pub fn position_square_errors(&self, mirror: &[f32], rough: &[f32], per: usize) -> Vec<f64> {
        let delta = |q: &Sample| sample_maps(mirror, rough, &q.taps, q.roughness);
        let mut e = Vec::new();
        self.errors_by(&self.all, delta, false, &mut e);
        let sq: Vec<f64> = e.iter().map(|e| e.powi(2)).collect();
        sq.chunks(per.max(1)).map(|c| c.iter().sum()).collect()
    }

    /// The same error for the level-1 corrective `l`.
    pub fn relative_error_level1(&self, l: &Level1) -> f64 {
        self.rms((0..self.samples.len()).map(|i| self.level1_error(i, l))) / self.mean_reference
    }

    fn level1_error(&self, i: usize, l: &Level1) -> f64 {
        let q = &self.samples[i];
        self.fetch_error(q, self.glossy.warp.level1_vector(l, q.b, q.dir))
    }

    /// Tone-mapped error of query `q` shaded along fetch vector `v` (the `Corrected` rule).
    fn fetch_error(&self, q: &Sample, v: Vec3) -> f64 {
        let est = self.glossy.radiance(MipRule::Corrected, q.b, q.dir, v, q.roughness);
        tm_error(est, q.reference, self.exposure)
    }

    /// Fits the cell's level-1 corrective (origin offset, depth mip, relaxation) to the
    /// problem's data term with Nelder-Mead from the plain warp (`start_lod`, no offset, no
    /// relaxation); the offset is searched in units of `cell_size`, clamped to a cell
    /// either way. Returns it with the evaluations spent.
    pub fn fit_level1(&self, cell_size: Vec3, start_lod: f32) -> (Level1, u64) {
        let max_lod = (self.glossy.warp.probe.inv_depth.levels.len() - 1) as f64;
        let problem = Level1Problem { cell: self, cell_size, max_lod, evaluations: Cell::new(0) };
        let x0 = vec![0.0, 0.0, 0.0, start_lod as f64, 0.0];
        let steps = [0.25, 0.25, 0.25, 1.0, 0.5];
        let mut simplex = vec![x0.clone()];
        for (i, step) in steps.iter().enumerate() {
            let mut v = x0.clone();
            v[i] += step;
            simplex.push(v);
        }
        let start = problem.level1(&x0);
        let start_cost = (&problem).cost(&x0).unwrap_or(f64::INFINITY);
        let best = NelderMead::new(simplex)
            .with_sd_tolerance(1e-4)
            .and_then(|nm| Executor::new(&problem, nm).configure(|st| st.max_iters(60)).run())
            .ok()
            .and_then(|r| {
                let st = r.state();
                let cost = st.get_best_cost();
                st.get_best_param().filter(|_| cost < start_cost).map(|x| problem.level1(x))
            });
        (best.unwrap_or(start), problem.evaluations.get())
    }

    /// The same error for an unfitted per-lookup method of the problem's warp.
    pub fn relative_error_method(&self, method: Method) -> f64 {
        let warp: &Warp = self.glossy.warp;
        let errors = self.samples.iter().map(|q| self.fetch_error(q, warp.fetch_vector(method, q.b, q.dir)));
        self.rms(errors) / self.mean_reference
    }

    /// Refines the map from the start with `solver`, then fits the relaxation strength
    /// with Brent.
    pub fn solve(&mut self, solver: Solver, iterations: u32) -> Outcome {
        let mut s = self.start.clone();
        let clock = std::time::Instant::now();
        // (data, regularisation) of the start, and of `s` as it goes: each whole-map cost
        // is computed once and its data term reused by the relaxation's start
        let start_parts = self.cost_parts(&s);
        let cost_start = start_parts.0 + start_parts.1;
        let mut parts = start_parts;
        let mut curve = vec![(0.0, cost_start)];
        let free = self.free_texels();
        let (mut iters, mut termination) = (0u64, Termination::NothingToFit);
        if !free.is_empty() {
            let r = match solver {
                Solver::Brent => {
                    // one sweep at a time, so the convergence curve has a point per sweep
                    let mut total = 0;
                    let mut result: Result<(u64, Option<String>), Error> = Ok((0, None));
                    for _ in 0..iterations.max(1) {
                        match self.sweep(&mut s, &free) {
                            Ok(i) => total += i,
                            Err(e) => {
                                result = Err(e);
                                break;
                            }
                        }
                        parts = self.cost_parts(&s);
                        curve.push((clock.elapsed().as_secs_f64(), parts.0 + parts.1));
                    }
                    result.map(|_| (total, None))
                }
                Solver::Lbfgs => self.lbfgs(&mut s, &free, iterations),
                Solver::NelderMead => self.nelder_mead(&mut s, &free, iterations),
            };
            match r {
                Ok((i, reason)) => {
                    iters = i;
                    termination = Termination::Finished {
                        solver,
                        iterations: iterations.max(1),
                        texels: free.len(),
                        reason,
                        kept_start: false,
                    };
                }
                Err(e) => termination = Termination::SolverError { message: e.to_string() },
            }
            if solver != Solver::Brent || matches!(termination, Termination::SolverError { .. }) {
                parts = self.cost_parts(&s);
            }
            if solver != Solver::Brent {
                curve.push((clock.elapsed().as_secs_f64(), parts.0 + parts.1));
            }
            if parts.0 + parts.1 > cost_start || s.iter().any(|x| !x.is_finite()) {
                s = self.start.clone();
                parts = start_parts;
                if let Termination::Finished { kept_start, .. } = &mut termination {
                    *kept_start = true;
                }
            }
        }
        let (relax, data) = self.fit_relax(&s, parts.0);
        let cost_end = data + parts.1;
        curve.push((clock.elapsed().as_secs_f64(), cost_end));
        Outcome {
            curve,
            params: s,
            relax,
            cost_start,
            cost_end,
            iterations: iters,
            evaluations: self.evaluations.get(),
            termination,
        }
    }

    /// The data and regularisation terms of the full objective at log-scales `s` (their
    /// sum is [`Self::cost`]).
    fn cost_parts(&self, s: &[f64]) -> (f64, f64) {
        self.evaluations.set(self.evaluations.get() + 1);
        let map = self.map(s);
        (self.data_over(&self.all, &map), self.regulariser(s))
    }

    /// One Brent sweep over the free texels, each texel's log-scale searched in ±[`BRACKET`];
    /// returns Brent's iterations.
    fn sweep(&self, s: &mut [f64], free: &[usize]) -> Result<u64, Error> {
        let mut iters = 0u64;
        // the map at `s`, kept in step with it: a texel's evaluations rewrite only its own
        // entry, which is set back to the texel's value once its step is done
        let map = RefCell::new(self.map(s));
        for &k in free {
            let current = TexelProblem { cell: self, s, k, map: &map }.cost(&s[k])?;
            let solver = BrentOpt::new(-BRACKET, BRACKET).set_tolerance(BRENT_TOLERANCE.0, BRENT_TOLERANCE.1);
            let res = Executor::new(TexelProblem { cell: self, s, k, map: &map }, solver)
                .configure(|st| st.param(s[k]).max_iters(24))
                .run()?;
            let st = res.state();
            iters += st.get_iter();
            let best = st.get_best_param().copied();
            let best_cost = st.get_best_cost();
            if let Some(best) = best
                && best.is_finite()
                && best_cost <= current
            {
                s[k] = best;
            }
            map.borrow_mut()[k] = self.texel_shift(k, s[k]);
        }
        Ok(iters)
    }

    fn lbfgs(&self, s: &mut [f64], free: &[usize], iterations: u32) -> Result<(u64, Option<String>), Error> {
        let problem = FullProblem { cell: self, free, base: s.to_vec() };
        let x0: Vec<f64> = free.iter().map(|&k| s[k]).collect();
        let solver =
            LBFGS::new(MoreThuenteLineSearch::new(), 7).with_tolerance_grad(1e-6)?.with_tolerance_cost(1e-9)?;
        let res = Executor::new(problem, solver)
            .configure(|st| st.param(x0).max_iters(10 * iterations.max(1) as u64).target_cost(0.0))
            .run()?;
        let st = res.state();
        scatter_best(s, free, st.get_best_param());
        Ok((st.get_iter(), st.get_termination_reason().map(|r| r.to_string())))
    }

    fn nelder_mead(&self, s: &mut [f64], free: &[usize], iterations: u32) -> Result<(u64, Option<String>), Error> {
        let problem = FullProblem { cell: self, free, base: s.to_vec() };
        let x0: Vec<f64> = free.iter().map(|&k| s[k]).collect();
        let mut simplex = vec![x0.clone()];
        for i in 0..x0.len() {
            let mut v = x0.clone();
            v[i] += 0.3;
            simplex.push(v);
        }
        let solver = NelderMead::new(simplex).with_sd_tolerance(1e-7)?;
        let res = Executor::new(problem, solver)
            .configure(|st| st.max_iters(100 * iterations.max(1) as u64).target_cost(0.0))
            .run()?;
        let st = res.state();
        scatter_best(s, free, st.get_best_param());
        Ok((st.get_iter(), st.get_termination_reason().map(|r| r.to_string())))
    }

    /// UV relaxation strength in [0, 1] minimising the data term (Brent), and the data term
    /// there; `at_zero`: the data term of `s` unrelaxed (the map of `s` itself).
    fn fit_relax(&self, s: &[f64], at_zero: f64) -> (f64, f64) {
        let at_zero = if at_zero.is_finite() { at_zero } else { f64::MAX };
        let res = Executor::new(RelaxProblem { cell: self, s }, BrentOpt::new(0.0, 1.0).set_tolerance(1e-2, 5e-3))
            .configure(|st| st.param(0.0).max_iters(20))
            .run();
        match res {
            Ok(r) => {
                let st = r.state();
                match st.get_best_param() {
                    // (the relaxation's cost clamps to [0, 1] as this does: the same map)
                    Some(&x) if x.is_finite() && st.get_best_cost() < at_zero => {
                        (x.clamp(0.0, 1.0), st.get_best_cost())
                    }
                    _ => (0.0, at_zero),
                }
            }
            Err(_) => (0.0, at_zero),
        }
    }
}

/// The angle of the aim pull ([`CellProblem::with_aim_pull`]) that costs its weight × the
/// mean reference: 0.1 rad, about 6°, the size of an edge that moved in a reflection.
pub const AIM_ANGLE_SCALE: f64 = 0.1;

/// The angle between two vectors in radians (0 where either is zero or not finite), with
/// `libm`'s `atan2` so that every machine forms the same value.
#[inline]
fn angle_between(v: Vec3, u: Vec3) -> f64 {
    let (v, u) = (v.as_dvec3(), u.as_dvec3());
    let a = libm::atan2(v.cross(u).length(), v.dot(u));
    if a.is_finite() { a } else { 0.0 }
}

/// The Charbonnier loss `√(e² + ε²) − ε` of an error `e`.
#[inline]
fn rho(e: f64, eps: f64) -> f64 {
    (e * e + eps * eps).sqrt() - eps
}

/// One channel of [`reinhard`], bit for bit (glam's comparisons, NaN to 0).
#[inline(always)]
fn reinhard_channel(c: f32, exposure: f32) -> f32 {
    let x = c * exposure;
    let v = if x > 0.0 { x } else { 0.0 };
    let v = v / (1.0 + v);
    let v = if v >= 0.0 { v } else { 0.0 };
    if v < 1.0 { v } else { 1.0 }
}

/// Absolute error of an estimate, mean over RGB.
#[inline]
fn abs_error(estimate: Vec3, reference: Vec3) -> f64 {
    let d = estimate - reference;
    ((d.x.abs() + d.y.abs() + d.z.abs()) / 3.0) as f64
}

/// Absolute error after tone mapping estimate and reference at `exposure`, mean over RGB.
#[inline]
fn tm_error(estimate: Vec3, reference: Vec3, exposure: f32) -> f64 {
    abs_error(reinhard(estimate, exposure), reinhard(reference, exposure))
}

/// Writes the best reduced parameter vector of a solve back into the full one.
fn scatter_best(s: &mut [f64], free: &[usize], best: Option<&Vec<f64>>) {
    if let Some(best) = best {
        for (i, &k) in free.iter().enumerate() {
            s[k] = best[i];
        }
    }
}

/// One texel's 1-D problem: only the queries it touches and its regularisation terms change.
struct TexelProblem<'p, 'a> {
    cell: &'p CellProblem<'a>,
    s: &'p [f64],
    k: usize,
    /// The map at `s` (the sweep's, kept in step with it); evaluations rewrite texel `k`.
    map: &'p RefCell<Vec<f32>>,
}

impl CostFunction for TexelProblem<'_, '_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, Error> {
        let c = self.cell;
        c.evaluations.set(c.evaluations.get() + 1);
        let mut map = self.map.borrow_mut();
        map[self.k] = c.texel_shift(self.k, *x);
        let data = c.data_over(&c.touching[self.k], &map);
        let mut smooth = 0.0;
        for &p in &c.texel_pairs[self.k] {
            let (a, b) = c.pairs[p as usize];
            let sa = if a as usize == self.k { *x } else { self.s[a as usize] };
            let sb = if b as usize == self.k { *x } else { self.s[b as usize] };
            smooth += (sa - sb).powi(2);
        }
        let n = self.s.len().max(1) as f64;
        let cost = data
            + c.smooth_weight * smooth / c.pairs.len().max(1) as f64
            + c.size_weight * (x - c.anchor[self.k]).powi(2) / n;
        Ok(if cost.is_finite() { cost } else { f64::MAX })
    }
}

/// All free texels at once (L-BFGS, Nelder-Mead).
struct FullProblem<'p, 'a> {
    cell: &'p CellProblem<'a>,
    free: &'p [usize],
    base: Vec<f64>,
}

impl FullProblem<'_, '_> {
    fn full(&self, x: &[f64]) -> Vec<f64> {
        let mut s = self.base.clone();
        for (i, &k) in self.free.iter().enumerate() {
            s[k] = x[i];
        }
        s
    }
}

impl CostFunction for FullProblem<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        let c = self.cell.cost(&self.full(x));
        Ok(if c.is_finite() { c } else { f64::MAX })
    }
}

impl Gradient for FullProblem<'_, '_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    /// Central differences per texel, evaluating only the queries the texel touches.
    fn gradient(&self, x: &Vec<f64>) -> Result<Vec<f64>, Error> {
        const H: f64 = 1e-3;
        let s = self.full(x);
        let mut g = vec![0.0; x.len()];
        let map = RefCell::new(self.cell.map(&s));
        for (i, &k) in self.free.iter().enumerate() {
            let tp = TexelProblem { cell: self.cell, s: &s, k, map: &map };
            let (up, down) = (tp.cost(&(x[i] + H))?, tp.cost(&(x[i] - H))?);
            g[i] = (up - down) / (2.0 * H);
            map.borrow_mut()[k] = self.cell.texel_shift(k, s[k]);
        }
        Ok(g)
    }
}

/// A cell's level-1 corrective: (offset in cell sizes along x, y, z; depth mip; relaxation
/// in probe texels), clamped to a cell, the probe's depth chain and [0, 3] texels.
struct Level1Problem<'p, 'a> {
    cell: &'p CellProblem<'a>,
    cell_size: Vec3,
    max_lod: f64,
    evaluations: Cell<u64>,
}

impl Level1Problem<'_, '_> {
    fn level1(&self, x: &[f64]) -> Level1 {
        let c = |v: f64, lo: f64, hi: f64| if v.is_finite() { v.clamp(lo, hi) as f32 } else { 0.0 };
        Level1 {
            offset: Vec3::new(c(x[0], -1.0, 1.0), c(x[1], -1.0, 1.0), c(x[2], -1.0, 1.0)) * self.cell_size,
            depth_lod: c(x[3], 0.0, self.max_lod),
            relax_texels: c(x[4], 0.0, f64::from(crate::warp::MAX_RELAX_TEXELS)),
        }
    }
}

impl CostFunction for &Level1Problem<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        self.evaluations.set(self.evaluations.get() + 1);
        let (c, l) = (self.cell, self.level1(x));
        let n = c.samples.len().max(1) as f64;
        let v = (0..c.samples.len()).map(|i| rho(c.level1_error(i, &l), c.eps)).sum::<f64>() / (n * c.mean_reference);
        Ok(if v.is_finite() { v } else { f64::MAX })
    }
}

/// Relaxation strength (1-D).
struct RelaxProblem<'p, 'a> {
    cell: &'p CellProblem<'a>,
    s: &'p [f64],
}

impl CostFunction for RelaxProblem<'_, '_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, Error> {
        let c = self.cell;
        c.evaluations.set(c.evaluations.get() + 1);
        let map = c.map_with_relax(self.s, x.clamp(0.0, 1.0));
        let v = c.data_over(&c.all, &map);
        Ok(if v.is_finite() { v } else { f64::MAX })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::fixtures::{wall_probe_rough, wall_problem, wall_warp};
    use proptest::prelude::*;

    /// The objective's lane lookups answer what the scalar lookup answers, bit for bit, for
    /// mirror and rough queries, with and without the roughness correction, in whole groups
    /// and in a short tail.
    #[test]
    fn the_lane_errors_are_the_scalar_errors_bit_for_bit() {
        let mut warp = wall_warp(1.0, 64);
        warp.probe = wall_probe_rough(1.0, 64);
        let correction = crate::roughness::fit_correction();
        for with_correction in [false, true] {
            let mut w = wall_problem(&warp, 1.0, 299);
            w.ctx.glossy.correction = with_correction.then_some(&correction);
            for (i, s) in w.samples.iter_mut().enumerate() {
                // the first two groups all mirror lookups, then every roughness mixed
                s.roughness = if i < 32 { 0.0 } else { [0.0, 0.125, 0.3, 0.5, 0.77, 1.0][i % 6] };
            }
            let start = w.ctx.log_scales_of(&w.distance);
            let cell = CellProblem::new(w.ctx, start, w.samples);
            let s: Vec<f64> = (0..64).map(|k| ((k * 37 % 11) as f64 - 5.0) / 4.0).collect();
            for map in [cell.map(&s), w.truth.clone()] {
                let lanes: Vec<u64> = cell.errors(&cell.all, &map).into_iter().map(f64::to_bits).collect();
                let scalar: Vec<u64> = (0..cell.samples.len()).map(|i| cell.sample_error(i, &map).to_bits()).collect();
                assert_eq!(lanes, scalar, "correction {with_correction}");
                for k in 0..64 {
                    let set = &cell.touching[k];
                    let lanes: Vec<u64> = cell.errors(set, &map).into_iter().map(f64::to_bits).collect();
                    let scalar: Vec<u64> =
                        set.idx.iter().map(|&i| cell.sample_error(i as usize, &map).to_bits()).collect();
                    assert_eq!(lanes, scalar, "texel {k}, correction {with_correction}");
                }
            }
        }
    }

    /// One channel of the tone mapping is `reinhard`'s, bit for bit, at the values that
    /// test its comparisons.
    #[test]
    fn a_tone_mapped_channel_is_reinhards_bit_for_bit() {
        let values =
            [0.0, -0.0, 1e-30, -1.0, 0.5, 1.0, 3.0, 1e30, f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        for exposure in [0.18, 1.0, 1e-20, 1e20, f32::INFINITY] {
            for &x in &values {
                let whole = reinhard(Vec3::new(x, 0.25, -x), exposure);
                let channels = [x, 0.25, -x].map(|c| reinhard_channel(c, exposure));
                assert_eq!(whole.to_array().map(f32::to_bits), channels.map(f32::to_bits), "{x} at {exposure}");
            }
        }
    }

    /// The size term pulls towards the anchor, not towards the proxy: where it outweighs the
    /// data, a solved texel lands on its anchor, and with no pull it does not.
    #[test]
    fn the_size_term_pulls_each_texel_towards_its_anchor() {
        let warp = wall_warp(1.0, 64);
        let w = wall_problem(&warp, 1.0, 300);
        let anchor: Vec<f64> = (0..64).map(|i| ((i * 13 % 7) as f64 - 3.0) / 4.0).collect();
        let solve = |size_weight: f64| {
            let mut cell = CellProblem::new(w.ctx, vec![0.0; 64], w.samples.clone())
                .with_weights(0.0, size_weight)
                .with_anchor(anchor.clone())
                .with_robust_scale(0.05);
            let free = cell.free_texels();
            assert!(free.len() > 8, "the wall's queries touch {} texels", free.len());
            (cell.solve(Solver::Brent, 2).params, free)
        };
        let (pulled, free) = solve(1e6);
        for &k in &free {
            assert!((pulled[k] - anchor[k]).abs() < 1e-3, "texel {k}: {} against anchor {}", pulled[k], anchor[k]);
        }
        let (free_fit, _) = solve(0.0);
        let off = free.iter().filter(|&&k| (free_fit[k] - anchor[k]).abs() > 0.05).count();
        assert!(off > free.len() / 2, "without the pull only {off} of {} texels leave the anchor", free.len());
    }

    /// The aim pull draws aims towards the true hits where the data cannot tell: with
    /// references that the proxy's own lookups answer exactly, the solve without the pull
    /// keeps the proxy, and with it the aims come close to the wall's true hits.
    #[test]
    fn the_aim_pull_draws_aims_towards_the_true_hits() {
        let warp = wall_warp(1.0, 64);
        let w = wall_problem(&warp, 1.0, 300);
        let z = 5.0;
        let at_proxy = CellProblem::new(w.ctx, vec![0.0; 64], w.samples.clone());
        let zero = vec![0.0f32; 64];
        let samples: Vec<Sample> = w
            .samples
            .iter()
            .enumerate()
            .map(|(i, q)| Sample {
                reference: at_proxy.lookup(i, &zero, &[]),
                target: Some((0, q.b + q.dir * ((z - q.b.z) / q.dir.z))),
                ..*q
            })
            .collect();
        let solve = |weight: f64| {
            let mut cell = CellProblem::new(w.ctx, vec![0.0; 64], samples.clone())
                .with_weights(1e-4, 0.0)
                .with_robust_scale(0.05)
                .with_aim_pull(weight);
            let out = cell.solve(Solver::Brent, 2);
            let map = cell.map_with_relax(&out.params, out.relax);
            (cell.mean_aim_angle(&zero), cell.mean_aim_angle(&map), cell.mean_aim_angle(&w.truth))
        };
        let (proxy, unpulled, truth) = solve(0.0);
        assert!(proxy > 0.02, "the proxy's aims are {proxy} rad off: the fixture tests nothing");
        assert!((unpulled - proxy).abs() < 1e-9, "without the pull the solve left the proxy: {unpulled} vs {proxy}");
        let (_, pulled, _) = solve(1.0);
        assert!(pulled < 0.5 * proxy, "pulled aims {pulled} rad off, the proxy's {proxy}");
        assert!(pulled < truth + 0.5 * (proxy - truth), "pulled {pulled}, true map {truth}, proxy {proxy}");
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
        /// Coordinate descent is only right if a texel's 1-D problem changes exactly as the
        /// whole cell objective does when that one texel moves: the Brent step minimises a
        /// slice of the real objective, not an approximation of it.
        #[test]
        fn a_texel_problem_is_an_exact_slice_of_the_cell_objective(
            seed in 0u32..1000, k in 0usize..64, x1 in -3.5f64..3.5, x2 in -3.5f64..3.5,
        ) {
            let warp = wall_warp(1.0, 64);
            let mut w = wall_problem(&warp, 1.0, 300);
            // every third query pulled towards its true hit on the wall
            for q in w.samples.iter_mut().step_by(3) {
                q.target = Some((0, q.b + q.dir * ((5.0 - q.b.z) / q.dir.z)));
            }
            let start = w.ctx.log_scales_of(&w.distance).iter().map(|s| s * 1.3).collect();
            let anchor = (0..64).map(|i| ((i * 13 % 7) as f64 - 3.0) / 4.0).collect();
            let cell = CellProblem::new(w.ctx, start, w.samples)
                .with_weights(1e-3, 1e-4)
                .with_anchor(anchor)
                .with_robust_scale(0.05)
                .with_aim_pull(0.5);
            let s: Vec<f64> = (0..64)
                .map(|i| (((i as u32).wrapping_mul(2654435761) ^ seed) % 1000) as f64 / 500.0 - 1.0)
                .collect();
            let at = |x: f64| {
                let mut v = s.clone();
                v[k] = x;
                cell.cost(&v)
            };
            let map = RefCell::new(cell.map(&s));
            let texel = TexelProblem { cell: &cell, s: &s, k, map: &map };
            let slice = texel.cost(&x1).unwrap() - texel.cost(&x2).unwrap();
            let whole = at(x1) - at(x2);
            prop_assert!((slice - whole).abs() <= 1e-10 * at(x1).abs().max(1.0), "texel {k}: {slice} vs {whole}");
        }
    }
}
