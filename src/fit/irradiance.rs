//! Correctives fitted into the grid's diffuse answer (seed 000: "fit corrective factors
//! directly into the dense grid" instead of renormalizing by hand).
//!
//! The runtime multiplies each cell's irradiance by the cell's map of scales over the normal
//! (4×4 octahedral) inside the DDGI blend (`runtime::IrradianceGrid::irradiance`), so the
//! answer stays continuous across cell faces. A cell's map therefore moves the answer at
//! every point whose blend it takes part in (its support: the eight cells around its
//! centre). The maps are fitted for each candidate surface bias of the blend (how far a
//! point moves along its normal before the cells are weighed, DDGI 2021; [`SURFACE_BIASES`]),
//! and the grid keeps the smallest bias whose corrected field's error on the check points
//! is within 1% of the best. The fit: training and held-out check points on the scene's surfaces
//! (`trace::truth::surface_points` on the fit's own streams, never the evaluation's), each
//! with a traced irradiance reference and the blend's terms there; then Jacobi rounds, in
//! which every cell fits its map texel by texel with argmin's Brent (in [0.2, 5], mean
//! squared tone-mapped error over its support's training points plus a pull towards 1)
//! while its neighbours keep the previous round's maps. Deterministic at any thread count:
//! a round reads only the round before. A cell keeps its map only when its support's check
//! points improve by 5% with the corrected field against the uncorrected blend.

use super::DOMAIN_FIT;
use crate::bake::Baked;
use crate::octa;
use crate::runtime::{BlendTerms, IrradianceCorrection, IrradianceView};
use crate::sampling::{Sampler, hash_pair};
use crate::tonemap::reinhard;
use crate::trace::{Renderer, truth};
use crate::warp::corrective::NO_MAP;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::brent::BrentOpt;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

/// N of each cell's N×N map of scales.
pub const CORRECTION_RES: u32 = 4;
/// Surface points per active cell drawn for training and, as many again, for checking
/// (spread by area: cells with more surface get more).
const POINTS_PER_CELL: u32 = 12;
/// Samples per irradiance reference.
const SPP: u32 = 64;
/// Weight of the pull towards a scale of 1.
const PULL: f64 = 0.02;
/// Jacobi rounds of the coupled fit.
const ROUNDS: usize = 2;
/// A cell needs this many training points in its support, and half as many check points,
/// to be fitted.
const MIN_POINTS: usize = 6;
/// The surface biases the fit chooses from (fractions of the smallest cell extent; DDGI's
/// production setting, 0.75·(0.2·n + 0.8·v) of the probe spacing, puts 0.15 along n).
pub const SURFACE_BIASES: [f32; 3] = [0.0, 0.1, 0.2];
/// The fit keeps the smallest surface bias whose corrected field's check error is within
/// this factor of the best: past a tenth of a cell the blend's error is flat, and a larger
/// bias lifts points out of contact shadows (corners get brighter, relative error grows).
pub const BIAS_TOLERANCE: f64 = 1.01;

/// One cell's diffuse corrective.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IrradianceCellFit {
    pub cell: u32,
    pub train_points: usize,
    pub check_points: usize,
    /// Tone-mapped RMSE of the check points of the cell's support: the uncorrected blend,
    /// and the corrected field with the cell's map.
    pub check_before: f64,
    pub check_after: f64,
    pub stored: bool,
}

/// One candidate surface bias: the tone-mapped RMSE of the blend on the check points, and
/// of the corrected field (with the maps fitted and stored at that bias) on the training and
/// the check points (which choose).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct BiasTrial {
    pub bias: f32,
    pub blend_check_rmse: f64,
    pub train_rmse: f64,
    pub check_rmse: f64,
}

/// The diffuse correctives of a grid.
#[derive(Clone, Debug)]
pub struct IrradianceFit {
    /// The scale maps and the surface bias they were fitted with.
    pub correction: IrradianceCorrection,
    /// Each candidate surface bias (the chosen one: the smallest within 1% of the lowest
    /// check error of the corrected field).
    pub bias_trials: Vec<BiasTrial>,
    pub cells: Vec<IrradianceCellFit>,
    pub reference_rays: u64,
    pub seconds: f64,
}

/// A point with its reference, the blend's terms there and its taps in the scale maps.
#[derive(Clone, Copy)]
struct Point {
    terms: BlendTerms,
    reference: Vec3,
    taps: [(u32, f32); 4],
}

/// Texels of one map.
const N2: usize = (CORRECTION_RES * CORRECTION_RES) as usize;
/// One cell's map of scales.
type Map = [f32; N2];
/// The maps of one round, held only for the cells the fit may give one: cell `c`'s is
/// `maps[slot[c]]` (`None`, or a cell without a slot: scale 1). The uncorrected blend is
/// [`Maps::NONE`].
#[derive(Clone, Copy)]
struct Maps<'a> {
    slot: &'a [u32],
    maps: &'a [Option<Map>],
}

impl<'a> Maps<'a> {
    const NONE: Maps<'static> = Maps { slot: &[], maps: &[] };

    fn of(self, c: usize) -> Option<&'a Map> {
        let s = *self.slot.get(c)?;
        self.maps.get(s as usize)?.as_ref()
    }
}

fn scale_at(map: &Map, taps: &[(u32, f32); 4]) -> f32 {
    taps.iter().map(|&(t, w)| map[t as usize] * w).sum()
}

/// The corrected blend at `p` with `maps`, one cell's map replaced where `swap` says so.
fn predict(p: &Point, maps: Maps, swap: Option<(usize, &Map)>) -> Vec3 {
    let mut e = Vec3::ZERO;
    for &(c, w, ei) in &p.terms.terms[..p.terms.count] {
        let map = match swap {
            Some((cell, own)) if cell == c as usize => Some(own),
            _ => maps.of(c as usize),
        };
        e += ei * (w * map.map_or(1.0, |m| scale_at(m, &p.taps)));
    }
    e
}

/// Tone-mapped squared error of `e` (mean over RGB).
fn err2(e: Vec3, reference: Vec3, exposure: f32) -> f64 {
    let d = reinhard(e, exposure) - reinhard(reference, exposure);
    ((d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2)) / 3.0
}

fn rmse(points: &[&Point], maps: Maps, exposure: f32) -> f64 {
    let sq: f64 = points.iter().map(|p| err2(predict(p, maps, None), p.reference, exposure)).sum();
    (sq / points.len().max(1) as f64).sqrt()
}

/// A support point as one cell's map fit reads it: the blend's terms of the other cells
/// as the round's maps give them (fixed while the cell's map is fitted), and the tone-mapped
/// reference. [`FitPoint::error`] is the same float as `err2(predict(..))` with the cell's
/// map swapped in: the terms are added in the same order, each computed as `predict` does.
struct FitPoint<'a> {
    point: &'a Point,
    /// Per term: `None` for the fitted cell's own, else its value `eᵢ·(wᵢ·scale)`.
    terms: [Option<Vec3>; 8],
    reference: Vec3,
}

impl<'a> FitPoint<'a> {
    fn new(point: &'a Point, maps: Maps, cell: usize, exposure: f32) -> FitPoint<'a> {
        let mut terms = [None; 8];
        for (k, &(c, w, ei)) in point.terms.terms[..point.terms.count].iter().enumerate() {
            if c as usize != cell {
                terms[k] = Some(ei * (w * maps.of(c as usize).map_or(1.0, |m| scale_at(m, &point.taps))));
            }
        }
        FitPoint { point, terms, reference: reinhard(point.reference, exposure) }
    }

    /// Tone-mapped squared error with `own` as the fitted cell's map.
    fn error(&self, own: &Map, exposure: f32) -> f64 {
        let p = self.point;
        let mut e = Vec3::ZERO;
        for (k, &(_, w, ei)) in p.terms.terms[..p.terms.count].iter().enumerate() {
            e += match self.terms[k] {
                Some(term) => term,
                None => ei * (w * scale_at(own, &p.taps)),
            };
        }
        let d = reinhard(e, exposure) - self.reference;
        ((d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2)) / 3.0
    }
}

/// Texel `t` of a cell's map as a 1-D problem, the rest fixed: `touching` lists the support
/// points whose taps weigh the texel (in point order), `n` is the support's size.
struct TexelProblem<'a> {
    points: &'a [FitPoint<'a>],
    touching: &'a [u32],
    n: usize,
    own: Map,
    t: usize,
    exposure: f32,
}

impl CostFunction for TexelProblem<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, Error> {
        let mut own = self.own;
        own[self.t] = *x as f32;
        let data: f64 = self.touching.iter().map(|&i| self.points[i as usize].error(&own, self.exposure)).sum::<f64>()
            / self.n.max(1) as f64;
        Ok(data + PULL * (x - 1.0).powi(2) / N2 as f64)
    }
}

/// Fits cell `cell`'s map on its support's training points, the neighbours' maps fixed;
/// `prepared`: a buffer for the points as the fit reads them (reused from cell to cell).
fn fit_map<'a>(
    points: &[&'a Point],
    maps: Maps,
    (cell, exposure): (usize, f32),
    prepared: &mut Vec<FitPoint<'a>>,
) -> Map {
    let mut own = maps.of(cell).copied().unwrap_or([1.0; N2]);
    prepared.clear();
    prepared.extend(points.iter().map(|p| FitPoint::new(p, maps, cell, exposure)));
    // the points each texel's taps weigh, in point order: texel t's are
    // `touching[start[t]..start[t + 1]]` (one array, not one per texel)
    let weighs = |p: &Point, t: usize| p.taps.iter().any(|&(k, w)| k as usize == t && w > 0.0);
    let mut start = [0u32; N2 + 1];
    for p in points {
        for t in 0..N2 {
            start[t + 1] += u32::from(weighs(p, t));
        }
    }
    for t in 0..N2 {
        start[t + 1] += start[t];
    }
    let mut next = start;
    let mut touching = vec![0u32; start[N2] as usize];
    for (i, p) in points.iter().enumerate() {
        for t in 0..N2 {
            if weighs(p, t) {
                touching[next[t] as usize] = i as u32;
                next[t] += 1;
            }
        }
    }
    for _ in 0..2 {
        for t in 0..N2 {
            let touching = &touching[start[t] as usize..start[t + 1] as usize];
            if touching.is_empty() {
                continue;
            }
            let problem = TexelProblem { points: prepared, touching, n: points.len(), own, t, exposure };
            let current = problem.cost(&(own[t] as f64)).unwrap_or(f64::INFINITY);
            let solver = BrentOpt::new(0.2, 5.0).set_tolerance(1e-3, 1e-4);
            let res = Executor::new(problem, solver).configure(|st| st.param(own[t] as f64).max_iters(24)).run();
            if let Ok(r) = res {
                let st = r.state();
                if let Some(&best) = st.get_best_param()
                    && best.is_finite()
                    && st.get_best_cost() <= current
                {
                    own[t] = best as f32;
                }
            }
        }
    }
    own
}

/// The surface points of a diffuse fit, training and check, drawn over the grid's bounds
/// (`POINTS_PER_CELL` per active cell each) on the fit's own streams.
pub struct SurfacePoints<'a> {
    pub train: PointSet<'a>,
    pub check: PointSet<'a>,
}

/// One set of surface points, held as the draw's attempts that gave them (4 bytes a point;
/// a 300k-cell fit draws 7 million): each point is computed again where it is used.
pub struct PointSet<'a> {
    draw: truth::SurfaceSampler<'a>,
    attempts: Vec<u32>,
}

impl PointSet<'_> {
    /// Points in the set.
    #[must_use]
    pub fn len(&self) -> usize {
        self.attempts.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.attempts.is_empty()
    }

    /// Point `k`: (position, shading normal). An attempt that succeeded always gives its
    /// candidate again.
    #[must_use]
    pub fn get(&self, k: usize) -> (Vec3, Vec3) {
        self.draw.candidate(self.attempts[k]).unwrap_or((Vec3::ZERO, Vec3::Z))
    }
}

/// A contiguous part of the training and check points (what one shard traces).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PointRanges {
    pub train: std::ops::Range<usize>,
    pub check: std::ops::Range<usize>,
}

/// The traced irradiance references of the points of some [`PointRanges`], in point order,
/// and the rays they took.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct References {
    pub train: Vec<Vec3>,
    pub check: Vec<Vec3>,
    pub rays: u64,
}

impl References {
    /// Appends the references of the ranges that follow this one's.
    pub fn append(&mut self, mut next: References) {
        self.train.append(&mut next.train);
        self.check.append(&mut next.check);
        self.rays += next.rays;
    }
}

impl<'a> SurfacePoints<'a> {
    /// The points of a bake with `seed` (the fit's).
    pub fn draw(baked: Baked<'a>, seed: u64) -> SurfacePoints<'a> {
        let Baked { scene, tracer, grid, .. } = baked;
        let g = grid.geometry;
        let active = grid.active_cells() as u32;
        let draw = |tag: u64| {
            let draw = truth::SurfaceSampler::new(scene, tracer, (g.min, g.max), (seed, hash_pair(DOMAIN_FIT, tag)));
            PointSet { attempts: draw.successes(active * POINTS_PER_CELL), draw }
        };
        SurfacePoints { train: draw(0x1A), check: draw(0x1B) }
    }

    /// Every point.
    pub fn all(&self) -> PointRanges {
        PointRanges { train: 0..self.train.len(), check: 0..self.check.len() }
    }

    /// Part `k` of `n` equal parts of the training and of the check points.
    pub fn part(&self, k: usize, n: usize) -> PointRanges {
        let split = |len: usize| len * k / n.max(1)..len * (k + 1) / n.max(1);
        PointRanges { train: split(self.train.len()), check: split(self.check.len()) }
    }
}

/// Traces the irradiance references of the points in `ranges` (each point on its own
/// stream, so any split traces the same values).
pub fn trace_references(baked: Baked, points: &SurfacePoints, seed: u64, ranges: &PointRanges) -> References {
    let renderer = Renderer::new(baked.scene, baked.tracer);
    let trace = |pts: &PointSet, range: std::ops::Range<usize>, tag: u64| -> (Vec<Vec3>, u64) {
        let Some(store) = baked.references else { return trace_range(&renderer, pts, range, (seed, tag)) };
        let (p, n): (Vec<Vec3>, Vec<Vec3>) = range.clone().map(|i| pts.get(i)).unzip();
        let key = store.key("irradiance").vec3s(&p).vec3s(&n).words([u64::from(SPP), seed, tag]);
        let len = range.len();
        let codec = (crate::trace::store::traced_to_words, |w: &[u32]| crate::trace::store::traced_from_words(w, len));
        store.cached("irradiance", key, codec, || trace_range(&renderer, pts, range, (seed, tag)))
    };
    let (train, train_rays) = trace(&points.train, ranges.train.clone(), 0x1C);
    let (check, check_rays) = trace(&points.check, ranges.check.clone(), 0x1D);
    References { train, check, rays: train_rays + check_rays }
}

/// The irradiance references of `pts` in `range` (the streams of `tag`), with the rays
/// traced for them.
fn trace_range(
    renderer: &Renderer,
    pts: &PointSet,
    range: std::ops::Range<usize>,
    (seed, tag): (u64, u64),
) -> (Vec<Vec3>, u64) {
    // rays summed as they go (an integer sum: any order gives the same), the references
    // collected straight into their vector
    let rays = AtomicU64::new(0);
    let traced: Vec<Vec3> = range
        .into_par_iter()
        .map(|i| {
            let (p, n) = pts.get(i);
            let mut k = 0;
            let stream = hash_pair(hash_pair(DOMAIN_FIT, tag), i as u64);
            let (reference, _) =
                truth::irradiance_reference(renderer, p, n, SPP, |j| Sampler::new(seed, stream, j), &mut k);
            rays.fetch_add(k, Ordering::Relaxed);
            reference
        })
        .collect();
    (traced, rays.into_inner())
}

/// Fits the diffuse correctives of `grid` (irradiance without corrections) for the baked
/// scene: draws the surface points, traces their references and fits; `exposure` is the
/// tone mapping's, `seed` the fit's.
pub fn fit_irradiance(baked: Baked, grid: IrradianceView, exposure: f32, seed: u64) -> IrradianceFit {
    let points = SurfacePoints::draw(baked, seed);
    let references = trace_references(baked, &points, seed, &points.all());
    fit_from_references(grid, exposure, &points, references)
}

/// [`fit_irradiance`] from the surface points and their traced references (every point's,
/// in order): the scale maps fitted at each candidate surface bias, and the smallest bias
/// whose corrected field's check error is within [`BIAS_TOLERANCE`] of the best kept.
pub fn fit_from_references(
    grid: IrradianceView,
    exposure: f32,
    points: &SurfacePoints,
    references: References,
) -> IrradianceFit {
    let t0 = std::time::Instant::now();
    let reference_rays = references.rays;
    let mut bias_trials = Vec::new();
    let mut fits = Vec::new();
    for &bias in &SURFACE_BIASES {
        let (fit, trial) = fit_at_bias(grid, exposure, points, &references, bias);
        bias_trials.push(trial);
        fits.push(fit);
    }
    let best = bias_trials.iter().map(|t| t.check_rmse).filter(|e| e.is_finite()).fold(f64::INFINITY, f64::min);
    let chosen = bias_trials.iter().position(|t| t.check_rmse <= best * BIAS_TOLERANCE).unwrap_or(0);
    let (correction, cells) = fits.swap_remove(chosen);
    IrradianceFit { correction, bias_trials, cells, reference_rays, seconds: t0.elapsed().as_secs_f64() }
}

/// The points of one set (training or check) bucketed by the lowest layer of the cells
/// their blend weighs at one surface bias, layers taken along the grid axis that spreads
/// the points most evenly (a level's big walls and floors lie in one layer of the axis
/// across them): a cell's support lies in the buckets of its layer and the one below, so
/// the fit visits the layers in order holding two buckets' prepared points at a time, not
/// every point's blend terms (memory stays bounded as the grid grows). Buckets list their
/// points in increasing order.
struct Layering {
    /// The axis the layers are taken along (0 = x, 1 = y, 2 = z), and the grid.
    axis: usize,
    g: crate::grid::GridGeometry,
    /// Points of bucket z: `order[start[z]..start[z + 1]]`.
    order: Vec<u32>,
    start: Vec<u32>,
}

impl Layering {
    /// Buckets `pts` by the lowest layer of their blend's cells (layer 0 for a point no cell
    /// weighs) along the axis whose largest pair of neighbouring buckets is smallest (z on a
    /// tie), counting each cell's support (points it takes part in) into `support`.
    fn new(grid: IrradianceView, pts: &PointSet, bias: f32, support: &mut [u32]) -> Layering {
        let g = grid.geometry;
        let counts = g.counts.to_array().map(|n| n as usize);
        // each point's lowest cell coordinates, kept as the index of the cell there (4 bytes a
        // point: the blend weighs a 2×2×2 block, so its lowest coordinates are a cell's; a
        // point no cell weighs counts as cell 0); the supports are counted as the points go
        // (integer sums: any order gives the same)
        let counted: Vec<AtomicU32> = support.iter().map(|_| AtomicU32::new(0)).collect();
        let lowest: Vec<u32> = (0..pts.len())
            .into_par_iter()
            .map(|k| {
                let (p, n) = pts.get(k);
                let t = grid.biased_terms(p, n, bias);
                let mut low = glam::UVec3::MAX;
                for &(c, w, _) in &t.terms[..t.count] {
                    if w > 0.0 {
                        counted[c as usize].fetch_add(1, Ordering::Relaxed);
                        low = low.min(g.cell_coords(c as usize));
                    }
                }
                if low == glam::UVec3::MAX { 0 } else { g.cell_index(low) as u32 }
            })
            .collect();
        for (s, c) in support.iter_mut().zip(counted) {
            *s += c.into_inner();
        }
        let mut sizes: [Vec<u32>; 3] = counts.map(|n| vec![0u32; n]);
        for &low in &lowest {
            let xyz = g.cell_coords(low as usize);
            for a in 0..3 {
                sizes[a][xyz[a] as usize] += 1;
            }
        }
        let widest = |a: usize| (0..counts[a]).map(|k| sizes[a][k] + if k > 0 { sizes[a][k - 1] } else { 0 }).max();
        let axis = [2, 0, 1].into_iter().min_by_key(|&a| widest(a)).unwrap_or(2);
        let mut start = vec![0u32; counts[axis] + 1];
        for (k, &n) in sizes[axis].iter().enumerate() {
            start[k + 1] = start[k] + n;
        }
        let mut next = start.clone();
        let mut order = vec![0u32; pts.len()];
        for (k, &low) in lowest.iter().enumerate() {
            let z = g.cell_coords(low as usize)[axis] as usize;
            order[next[z] as usize] = k as u32;
            next[z] += 1;
        }
        Layering { axis, g, order, start }
    }

    /// The layer of cell `c`.
    fn layer_of(&self, c: usize) -> usize {
        self.g.cell_coords(c)[self.axis] as usize
    }

    /// Cells in one layer.
    fn layer_len(&self) -> usize {
        self.g.cell_count() / self.g.counts[self.axis] as usize
    }

    /// Cell `c`'s place in its layer, and back: the other two coordinates, lower axis first.
    fn in_layer(&self, c: usize) -> usize {
        let (xyz, (u, v)) = (self.g.cell_coords(c), self.others());
        (xyz[u] + self.g.counts[u] * xyz[v]) as usize
    }

    fn cell(&self, layer: usize, i: usize) -> usize {
        let (u, v) = self.others();
        let mut xyz = glam::UVec3::ZERO;
        xyz[self.axis] = layer as u32;
        xyz[u] = i as u32 % self.g.counts[u];
        xyz[v] = i as u32 / self.g.counts[u];
        self.g.cell_index(xyz)
    }

    fn others(&self) -> (usize, usize) {
        match self.axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        }
    }

    fn bucket(&self, z: usize) -> &[u32] {
        &self.order[self.start[z] as usize..self.start[z + 1] as usize]
    }

    /// Calls `visit(z, window)` for each layer z in order: `window` borrows the prepared
    /// points of buckets z − 1 and z (every point whose blend weighs a cell of layer z), in
    /// increasing point order.
    fn visit(&self, prepare: impl Fn(usize) -> Point + Sync, mut visit: impl FnMut(usize, &[&Point])) {
        let mut prev: Vec<(u32, Point)> = Vec::new();
        for z in 0..self.start.len() - 1 {
            let cur: Vec<(u32, Point)> = self.bucket(z).par_iter().map(|&k| (k, prepare(k as usize))).collect();
            // merge the two buckets by point index (each is increasing), borrowing the points
            let mut window = Vec::with_capacity(prev.len() + cur.len());
            let (mut i, mut j) = (0, 0);
            while i < prev.len() || j < cur.len() {
                if j == cur.len() || (i < prev.len() && prev[i].0 < cur[j].0) {
                    window.push(&prev[i].1);
                    i += 1;
                } else {
                    window.push(&cur[j].1);
                    j += 1;
                }
            }
            visit(z, &window);
            drop(window);
            prev = cur;
        }
    }
}

/// The scale maps fitted for the blend at surface bias `bias`, and the trial's errors.
///
/// Layer by layer (see [`Layering`]): each Jacobi round and the selection visit the layers
/// in order, preparing each point's blend terms when its layer comes; the maps, the
/// supports and every sum are those of the whole set in point order, so the result does not
/// depend on the layering.
fn fit_at_bias(
    grid: IrradianceView,
    exposure: f32,
    points: &SurfacePoints,
    references: &References,
    bias: f32,
) -> ((IrradianceCorrection, Vec<IrradianceCellFit>), BiasTrial) {
    let g = grid.geometry;
    let point = |pts: &PointSet, refs: &[Vec3], k: usize| {
        let (p, n) = pts.get(k);
        Point {
            terms: grid.biased_terms(p, n, bias),
            reference: refs[k],
            taps: octa::bilinear_taps(CORRECTION_RES, octa::encode(n)),
        }
    };
    let (train_pts, check_pts) = (&points.train, &points.check);
    let (train_refs, check_refs) = (&references.train, &references.check);
    let (mut train_count, mut check_count) = (vec![0u32; g.cell_count()], vec![0u32; g.cell_count()]);
    let train = Layering::new(grid, train_pts, bias, &mut train_count);
    let check = Layering::new(grid, check_pts, bias, &mut check_count);
    let fitted = |c: usize| {
        grid.slot[c] != NO_MAP && train_count[c] as usize >= MIN_POINTS && check_count[c] as usize >= MIN_POINTS / 2
    };
    // the points of `window` in the support of each fitted cell of layer z, in point order
    let supports = |layering: &Layering, z: usize, window: &[&Point]| -> Vec<(usize, Vec<u32>)> {
        let mut of: Vec<Vec<u32>> = vec![Vec::new(); layering.layer_len()];
        for (i, p) in window.iter().enumerate() {
            for &(c, w, _) in &p.terms.terms[..p.terms.count] {
                if w > 0.0 && layering.layer_of(c as usize) == z {
                    of[layering.in_layer(c as usize)].push(i as u32);
                }
            }
        }
        of.into_iter().enumerate().map(|(i, s)| (layering.cell(z, i), s)).filter(|(c, _)| fitted(*c)).collect()
    };
    // the cells that may get a map, each with its slot in a round's maps
    let mut slot = vec![NO_MAP; g.cell_count()];
    let mut n_fitted = 0;
    for (c, s) in slot.iter_mut().enumerate() {
        if fitted(c) {
            *s = n_fitted;
            n_fitted += 1;
        }
    }
    let mut maps: Vec<Option<Map>> = vec![None; n_fitted as usize];
    for _ in 0..ROUNDS {
        let mut next = maps.clone();
        let current = Maps { slot: &slot, maps: &maps };
        train.visit(
            |k| point(train_pts, train_refs, k),
            |z, window| {
                let cells = supports(&train, z, window);
                let fits: Vec<(usize, Map)> = cells
                    .par_iter()
                    .map_init(Vec::new, |prepared, (c, idx)| {
                        (*c, fit_map(&gather(window, idx), current, (*c, exposure), prepared))
                    })
                    .collect();
                for (c, m) in fits {
                    next[slot[c] as usize] = Some(m);
                }
            },
        );
        maps = next;
    }
    let fitted_maps = Maps { slot: &slot, maps: &maps };
    // selection: a cell keeps its map where its support's check points improve by 5% with
    // the corrected field against the uncorrected blend (neighbouring maps share their
    // points, so one map alone rarely makes the difference: they are judged as a field)
    let mut fits: Vec<IrradianceCellFit> = Vec::new();
    check.visit(
        |k| point(check_pts, check_refs, k),
        |z, window| {
            let cells = supports(&check, z, window);
            let judged: Vec<IrradianceCellFit> = cells
                .par_iter()
                .map(|(c, idx)| {
                    let refs = gather(window, idx);
                    let (before, after) = (rmse(&refs, Maps::NONE, exposure), rmse(&refs, fitted_maps, exposure));
                    IrradianceCellFit {
                        cell: *c as u32,
                        train_points: train_count[*c] as usize,
                        check_points: check_count[*c] as usize,
                        check_before: before,
                        check_after: after,
                        stored: after < 0.95 * before,
                    }
                })
                .collect();
            fits.extend(judged);
        },
    );
    // in cell order, whatever axis the layers were taken along
    fits.sort_unstable_by_key(|f| f.cell);
    let mut correction = IrradianceCorrection {
        resolution: CORRECTION_RES,
        slot: vec![NO_MAP; g.cell_count()],
        scale: Vec::new(),
        surface_bias: bias,
    };
    let mut stored: Vec<Option<Map>> = vec![None; n_fitted as usize];
    for f in fits.iter().filter(|f| f.stored) {
        let c = f.cell as usize;
        if let Some(map) = fitted_maps.of(c) {
            correction.slot[c] = (correction.scale.len() / map.len()) as u32;
            correction.scale.extend_from_slice(map);
            stored[slot[c] as usize] = Some(*map);
        }
    }
    drop(maps);
    let stored = Maps { slot: &slot, maps: &stored };
    // the whole field's errors on every training and check point, [the blend as it is, with
    // the stored maps], each point's error summed in point order (the points prepared a block
    // at a time, so no error vector or layer window is held)
    let field_rmse = |pts: &PointSet, refs: &[Vec3]| -> [f64; 2] {
        const BLOCK: usize = 1 << 16;
        // running sums from the start `Iterator::sum` takes, point after point: the same
        // floats as summing a vector of every point's error
        let mut sums = [std::iter::empty::<f64>().sum::<f64>(); 2];
        for start in (0..pts.len()).step_by(BLOCK) {
            let block: Vec<[f64; 2]> = (start..(start + BLOCK).min(pts.len()))
                .into_par_iter()
                .map(|k| {
                    let p = point(pts, refs, k);
                    [Maps::NONE, stored].map(|m| err2(predict(&p, m, None), p.reference, exposure))
                })
                .collect();
            for e in &block {
                sums[0] += e[0];
                sums[1] += e[1];
            }
        }
        sums.map(|sum| (sum / pts.len().max(1) as f64).sqrt())
    };
    let [blend_check_rmse, check_rmse] = field_rmse(check_pts, check_refs);
    let trial = BiasTrial { bias, blend_check_rmse, train_rmse: field_rmse(train_pts, train_refs)[1], check_rmse };
    ((correction, fits), trial)
}

/// The prepared points of `window` listed in `idx`.
fn gather<'a>(window: &[&'a Point], idx: &[u32]) -> Vec<&'a Point> {
    idx.iter().map(|&i| window[i as usize]).collect()
}
