//! Fitting per-cell correctives against raytraced references with argmin.
//!
//! First the grid's proxy (the box, the 18-DOP or the probe's own depth, `proxy::choose`):
//! every lookup reads probe A through it, and the maps shift its surface
//! (`warp::corrective`). Then, for every cell
//! that is not inside geometry: draw training queries (what a viewer sees, mostly: points on
//! the surfaces around the cell with reflection directions over their hemisphere, and points
//! in the cell's volume with directions over the sphere; their own sampler domain,
//! independent of `eval`'s validation set) and a separate held-out check set, trace
//! references, start the cell's shift map from the proxy itself or from the grid's raytraced
//! distances (`celldepth`), refine it against the radiance error, fit the UV relaxation
//! strength, and keep it only if it beats the proxy alone on the held-out check set
//! (otherwise level 0). Cells are independent: rayon runs them in parallel and every random
//! choice is seeded per cell, so results are bit-identical at any thread count.

pub mod fixtures;
pub mod irradiance;
pub mod model;
pub mod objective;
pub mod probes;
pub mod proxy;
pub mod roughness;
pub mod selection;
pub mod summary;

use crate::bake::Baked;
use crate::grid::GridGeometry;
use crate::progress::Progress;
use crate::roughness::RoughnessCorrection;
use crate::sampling::{Sampler, hash_pair};
use crate::trace::Renderer;
use crate::trace::store::{self, ReferenceStore};
use crate::trace::truth::{self, QueryStreams, TracedQueries};
use crate::warp::corrective::{Correctives, NO_MAP, rough_weight};
use crate::warp::glossy::Glossy;
use crate::warp::{Method, Warp};
use glam::Vec3;
use objective::Termination;
use objective::{CellContext, CellProblem, Sample};
use rayon::prelude::*;
pub use selection::{Level, SELECTION_MARGIN, Selection, choose_level};
use serde::{Deserialize, Serialize};
use std::time::Instant;

pub const DOMAIN_FIT: u64 = 0x4649_5431; // "FIT1"

/// Which argmin solver refines a cell's warp map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
pub enum Solver {
    /// Coordinate descent: Brent's method on one texel at a time (the default, by measurement).
    Brent,
    /// L-BFGS on all texels with More-Thuente line search; gradient by central differences.
    Lbfgs,
    /// Nelder-Mead on all texels.
    NelderMead,
}

/// Fit settings, recorded in every fit's output.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitSettings {
    /// N of each cell's N×N warp map (8..=16).
    pub map_res: u32,
    pub train_positions: u32,
    pub train_dirs: u32,
    pub check_positions: u32,
    pub check_dirs: u32,
    pub reference_spp: u32,
    pub seed: u64,
    /// Relative error (mean absolute RGB error / mean reference radiance, on the check set)
    /// at or below which the plain warp is kept and nothing is stored.
    pub tol: f32,
    pub solver: Solver,
    /// Coordinate-descent sweeps (Brent) or iterations (L-BFGS, Nelder-Mead).
    pub iterations: u32,
    /// Weight of the tile-smoothness term (squared differences of neighbouring log-scales).
    pub smooth_weight: f64,
    /// Weight of the size term (squared log-scales from the anchor: stay near it).
    pub size_weight: f64,
    /// Where the size term's anchor lies, per texel: this fraction of the way in log-scale
    /// from the proxy (0) to the grid's raytraced distance (1). Fits written before it
    /// existed pulled towards the proxy (0).
    #[serde(default)]
    pub depth_prior: f64,
    /// Fit a second map per cell for rough lookups (`warp::corrective::sample_maps`): the
    /// cell's map on its training queries of roughness up to `ROUGH_MAP_FROM`, the rough
    /// map on those from `ROUGH_MAP_TO` (each judged with the other on the check queries).
    /// Fits written before it existed stored one map.
    #[serde(default)]
    pub rough_map: bool,
    /// The rough map's anchor, as `depth_prior` is the map's.
    #[serde(default)]
    pub rough_depth_prior: f64,
    /// Charbonnier ε as a fraction of the cell's mean reference radiance: errors far above
    /// it are penalised linearly (robust), errors below it quadratically.
    pub robust_scale: f64,
    /// Fraction of the training and check queries that are rough (the rest are mirror
    /// lookups); rough queries cycle through [`ROUGH_MIX`].
    #[serde(default)]
    pub rough_fraction: f32,
    /// Also fit each cell's level-1 corrective (one origin offset, depth mip and
    /// relaxation strength) on a quarter of its training queries and judge it on the check
    /// queries, to compare with the stored model; it is not stored.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub level1: bool,
    /// Also fit each cell's map at every resolution of [`STUDY_RESOLUTIONS`] and judge each
    /// on the two halves of the cell's check positions ([`ResolutionStudy`]), to measure what
    /// a per-cell choice of resolution would give; nothing of it is stored.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub resolution_study: bool,
    /// A cell stores its fitted map only when the map's held-out error is below this
    /// fraction of the fallback's ([`SELECTION_MARGIN`] unless set).
    #[serde(default = "default_margin", skip_serializing_if = "is_default_margin")]
    pub selection_margin: f64,
    /// Fraction of each cell's training and check positions drawn on the surfaces around
    /// it, with reflection directions over the surface's hemisphere (what a viewer sees);
    /// the rest lie in the cell's volume with directions over the sphere (what moving
    /// objects see). Cells with no surface near take volume positions only.
    pub surface_fraction: f32,
    /// The proxy the maps shift: chosen by measurement, or set.
    pub proxy: proxy::ProxyChoice,
    /// Check positions a cell adds when its first check positions cannot tell its fitted
    /// maps from the fallback (`selection::undecided`): the choice is then made on all of
    /// them. 0: never. Fits written before it existed added none.
    #[serde(default)]
    pub extra_check_positions: u32,
    /// Weight of the aim pull on the mirror training queries (`CellProblem::with_aim_pull`):
    /// each query's aim drawn towards its true hit where the probe it reads sees it. 0:
    /// none (fits written before it existed had none).
    #[serde(default)]
    pub aim_pull: f64,
}

fn default_margin() -> f64 {
    SELECTION_MARGIN
}

fn is_default_margin(m: &f64) -> bool {
    *m == SELECTION_MARGIN
}

/// Roughness of the rough training and check queries, in turn.
pub const ROUGH_MIX: [f32; 5] = [0.125, 0.25, 0.5, 0.75, 1.0];

impl FitSettings {
    /// The defaults of `warpfit fit` (chosen by measurement; see docs/architecture.md).
    pub const fn standard() -> Self {
        FitSettings {
            map_res: 16,
            train_positions: 16,
            train_dirs: 128,
            check_positions: 16,
            check_dirs: 64,
            reference_spp: 4,
            seed: 0xF17,
            tol: 0.02,
            solver: Solver::Brent,
            iterations: 2,
            smooth_weight: 1e-3,
            size_weight: 1.0,
            depth_prior: 0.5,
            rough_map: true,
            rough_depth_prior: 1.0,
            robust_scale: 0.05,
            rough_fraction: 0.5,
            level1: false,
            resolution_study: false,
            selection_margin: SELECTION_MARGIN,
            surface_fraction: 0.5,
            proxy: proxy::ProxyChoice::Measured,
            extra_check_positions: 48,
            aim_pull: 0.5,
        }
    }

    /// A small fit for tests and the quick stability suite: seconds, not minutes.
    pub const fn quick() -> Self {
        FitSettings {
            train_positions: 4,
            train_dirs: 32,
            check_positions: 4,
            check_dirs: 16,
            extra_check_positions: 12,
            reference_spp: 1,
            iterations: 1,
            ..Self::standard()
        }
    }

    /// Between `quick` and `standard`: the full stability suite's fits.
    pub const fn moderate() -> Self {
        FitSettings {
            train_positions: 8,
            train_dirs: 64,
            check_positions: 8,
            check_dirs: 32,
            extra_check_positions: 24,
            reference_spp: 2,
            iterations: 1,
            ..Self::standard()
        }
    }
}

impl Default for FitSettings {
    fn default() -> Self {
        Self::standard()
    }
}

/// Outcome of one cell's fit.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CellFit {
    pub cell: u32,
    pub level: Level,
    pub selection: Selection,
    /// Which map the refinement started from.
    pub start: Start,
    /// Held-out relative errors (mean abs RGB error / mean reference) of the unfitted
    /// methods and of the fitted map.
    pub check_err_warp1: f64,
    pub check_err_box: f64,
    pub check_err_kdop: f64,
    /// Error of the grid's fallback method (one of the three above).
    pub check_err_fallback: f64,
    pub check_err_celldepth: f64,
    pub check_err_fitted: f64,
    /// Training objective before and after.
    pub train_cost_start: f64,
    pub train_cost_end: f64,
    pub relax: f64,
    pub iterations: u64,
    pub evaluations: u64,
    pub termination: Termination,
    pub seconds: f64,
    /// Of `seconds`, the time spent tracing the cell's training and check references.
    #[serde(default)]
    pub trace_seconds: f64,
    /// Training objective against solve time (see `objective::Outcome::curve`).
    pub curve: Vec<(f64, f64)>,
    /// The rough map's solve, with `FitSettings::rough_map` (the fields above are the
    /// mirror map's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rough_map: Option<RoughMapFit>,
    /// Fraction of the cell's check queries whose true hit is hidden from the probe.
    pub hidden_fraction: f64,
    /// Check positions the selection was made on: `FitSettings::check_positions`, plus
    /// the extra ones of an undecided cell (0 in fits written before they existed).
    #[serde(default)]
    pub check_positions: u32,
    /// The level-1 corrective, when the settings ask for it (measured, not stored). Boxed,
    /// as the study below: a record is held for every active cell until the fit is written,
    /// and an absent study costs a null pointer, not its size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level1: Option<Box<Level1Fit>>,
    /// The cell's maps at every studied resolution, when the settings ask for it (measured,
    /// not stored).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolutions: Option<Box<ResolutionStudy>>,
}

/// How a cell's rough map was refined (`FitSettings::rough_map`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoughMapFit {
    pub start: Start,
    pub train_cost_start: f64,
    pub train_cost_end: f64,
    pub relax: f64,
    pub evaluations: u64,
}

/// Map resolutions the resolution study fits every cell at (`FitSettings::resolution_study`).
pub const STUDY_RESOLUTIONS: [u32; 4] = [4, 8, 16, 32];

/// A cell's map fitted at each of [`STUDY_RESOLUTIONS`] as the fit fits its map (the same
/// training queries, starts and solver), and the held-out errors of the fallback and of
/// each map on the two halves of the cell's check positions (even and odd positions): one
/// half can choose what the cell stores and the other judge it, and the other way round
/// (two-fold cross-validation; `summary::ResolutionSummary`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResolutionStudy {
    /// `errors[half]`: the fallback's relative error, then each resolution's map's, as
    /// `check_err_fitted` is measured.
    pub errors: [[f64; 1 + STUDY_RESOLUTIONS.len()]; 2],
}

/// A cell's level-1 corrective and its held-out error (`FitSettings::level1`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Level1Fit {
    pub params: crate::warp::Level1,
    /// Held-out error on the cell's check queries, as `check_err_fitted`.
    pub check_err: f64,
    pub evaluations: u64,
}

/// Where a cell's refinement started: the proxy itself (no shift) or the grid's raytraced
/// distances, whichever explains the training queries better.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Start {
    Celldepth,
    Proxy,
}

/// The map sets a fit keeps beside the stored ones.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapSets {
    /// The stored maps alone: what a grid is written from (`warpfit fit`, a merge of shards).
    #[default]
    Stored,
    /// Also [`UnfittedMaps`]: the evaluation's rows for them (`warpfit run`).
    WithUnfitted,
}

/// Map sets an evaluation compares with the stored model.
#[derive(Clone, Debug, PartialEq)]
pub struct UnfittedMaps {
    /// The maps of the grid's raytraced distances, unfitted, in every active cell: `celldepth`.
    pub celldepth: Correctives,
    /// The fitted map of every active cell, before model selection (level 2 everywhere).
    pub fitted_all: Correctives,
    /// With several probes: every active cell's map fitted with one probe for the cell
    /// (`CellOutcome::per_cell`), the `per-cell` row.
    pub per_cell: Option<Correctives>,
}

impl UnfittedMaps {
    /// The two sets of the outcomes `results` (cells of `geometry`'s grid, maps of `proxy`).
    fn of(geometry: GridGeometry, map_res: u32, proxy: Method, results: &[CellOutcome]) -> UnfittedMaps {
        let n2 = (map_res * map_res) as usize;
        let several = results.iter().any(|r| !r.probes.is_empty());
        let set = |map: fn(&CellOutcome) -> &[f32], rough: fn(&CellOutcome) -> &[f32]| {
            let mut c = Correctives::new(geometry, map_res, vec![NO_MAP; geometry.cell_count()], Vec::new(), proxy);
            for (k, r) in results.iter().enumerate() {
                c.slot[r.fit.cell as usize] = k as u32;
                c.maps.extend_from_slice(map(r));
                c.rough_maps.extend_from_slice(rough(r));
                if several {
                    c.probe_maps.extend(r.probes.iter().copied().chain(std::iter::repeat(0)).take(n2));
                }
            }
            c
        };
        let per_cell = results.iter().all(|r| r.per_cell.is_some()).then(|| {
            let mut c = Correctives::new(geometry, map_res, vec![NO_MAP; geometry.cell_count()], Vec::new(), proxy);
            for (k, r) in results.iter().enumerate() {
                let Some((map, rough, p)) = &r.per_cell else { continue };
                c.slot[r.fit.cell as usize] = k as u32;
                c.maps.extend_from_slice(map);
                c.rough_maps.extend_from_slice(rough);
                c.probe_maps.extend(std::iter::repeat_n(*p, n2));
            }
            c
        });
        let per_cell = per_cell.filter(|_| !results.is_empty());
        UnfittedMaps {
            celldepth: set(|r| &r.init, |_| &[]),
            fitted_all: set(|r| &r.fitted, |r| &r.fitted_rough),
            per_cell,
        }
    }
}

/// A fitted grid: the correctives plus what happened in every cell.
pub struct Fit {
    pub correctives: Correctives,
    /// The unfitted map sets, when the fit was asked to keep them ([`MapSets`]).
    pub unfitted: Option<UnfittedMaps>,
    pub cells: Vec<CellFit>,
    /// The roughness correction chosen on this scene (`roughness::fit_scene_correction`):
    /// absent when the fit was given none to start from.
    pub roughness: Option<RoughnessCorrection>,
    /// The diffuse correctives fitted into the grid (`irradiance`).
    pub irradiance: irradiance::IrradianceFit,
    /// The proxy the maps shift, and how it was chosen.
    pub proxy: proxy::ProxyOutcome,
    pub settings: FitSettings,
    pub seconds: f64,
    /// Where the time went.
    pub times: FitTimes,
    pub reference_rays: u64,
}

/// Where a fit's time goes: wall seconds per step, and the cells' CPU seconds (summed over
/// threads) with the part of them spent tracing references.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FitTimes {
    /// Wall seconds fitting the cells (their reference tracing included).
    pub cells: f64,
    /// CPU seconds of the cells, and of those, tracing their references.
    pub cells_cpu: f64,
    pub cells_tracing_cpu: f64,
    /// Wall seconds drawing the diffuse fit's surface points and tracing their references.
    pub surface_points: f64,
    pub irradiance_references: f64,
    /// Wall seconds of the grid-wide steps: the scene's roughness correction (its rough
    /// queries traced) and the coupled diffuse fit.
    pub roughness: f64,
    pub irradiance_fit: f64,
    /// 0 when one machine fitted: otherwise the merge of this many shards, whose cells,
    /// surface points and their references are the shards' seconds summed (the grid-wide
    /// steps ran in the merge).
    #[serde(default)]
    pub shards: u32,
}

impl FitTimes {
    /// How the cells' and surface points' seconds were counted, for the printed time lines.
    #[must_use]
    pub fn counted(&self) -> String {
        if self.shards > 1 {
            format!(" (cells and surface points: seconds summed over {} shards)", self.shards)
        } else {
            String::new()
        }
    }
}

/// The streams of one cell's training (`tag` 1) or check (`tag` 2) queries: the last
/// `rough` of each position's `dirs` directions are rough lookups, cycling through
/// [`ROUGH_MIX`]; positions on a surface (`normals`) look over its hemisphere.
struct CellStreams {
    seed: u64,
    stream: u64,
    dirs: usize,
    rough: usize,
    normals: Vec<Option<Vec3>>,
}

impl QueryStreams for CellStreams {
    fn direction(&self, p: usize, d: usize) -> Sampler {
        Sampler::new(self.seed, hash_pair(self.stream, 1 + p as u64), d as u32)
    }
    fn reference(&self, p: usize, d: usize, k: u32) -> Sampler {
        Sampler::new(self.seed, hash_pair(hash_pair(self.stream, 0xABC + p as u64), d as u64), k)
    }
    fn roughness(&self, p: usize, d: usize) -> f32 {
        let first_rough = self.dirs - self.rough;
        if d < first_rough { 0.0 } else { ROUGH_MIX[(p + d - first_rough) % ROUGH_MIX.len()] }
    }
    fn hemisphere(&self, p: usize) -> Option<Vec3> {
        self.normals.get(p).copied().flatten()
    }
}

/// Draws per volume position before a cell's volume positions are taken as they come.
const VOLUME_ATTEMPTS: u32 = 64;

/// Training or check queries of one cell: `surface_fraction` of the positions on the
/// surfaces seen from inside the cell (reflection directions over their hemisphere), the
/// rest uniform in the cell where the inside rule does not reject them (uniform
/// directions); references traced by `trace::truth`.
fn cell_samples(
    (renderer, store): (&Renderer, Option<&ReferenceStore>),
    geometry: &GridGeometry,
    cell: usize,
    q: QuerySize,
    seed: u64,
    tag: u64,
) -> TracedQueries {
    let Some(store) = store else { return trace_cell_samples(renderer, geometry, cell, q, (seed, tag)) };
    // everything the set depends on (its positions and directions are drawn from these)
    let key = store.key("cell").vec3s(&[geometry.min, geometry.max]).words([
        u64::from(geometry.counts.x),
        u64::from(geometry.counts.y),
        u64::from(geometry.counts.z),
        cell as u64,
        u64::from(q.positions),
        u64::from(q.dirs),
        u64::from(q.spp),
        u64::from(q.rough_fraction.to_bits()),
        u64::from(q.surface_fraction.to_bits()),
        seed,
        tag,
    ]);
    let trace = || trace_cell_samples(renderer, geometry, cell, q, (seed, tag));
    store.cached("cell", key, (store::queries_to_words, store::queries_from_words), trace)
}

/// [`cell_samples`], traced.
fn trace_cell_samples(
    renderer: &Renderer,
    geometry: &GridGeometry,
    cell: usize,
    q: QuerySize,
    (seed, tag): (u64, u64),
) -> TracedQueries {
    let (lo, size) = (geometry.min + geometry.cell_coords(cell).as_vec3() * geometry.cell_size(), geometry.cell_size());
    let stream = hash_pair(hash_pair(DOMAIN_FIT, tag), cell as u64);
    let on_surfaces = (q.positions as f32 * q.surface_fraction.clamp(0.0, 1.0)).round() as u32;
    let surface = cell_surface_points(renderer, geometry, cell, on_surfaces, (seed, hash_pair(stream, 0x5EF)));
    let mut positions: Vec<Vec3> = surface.iter().map(|&(b, _)| b).collect();
    let mut normals: Vec<Option<Vec3>> = surface.iter().map(|&(_, n)| Some(n)).collect();
    // the rest uniform in the cell, redrawn where the inside rule rejects them (as the
    // evaluation's positions are: no lookup is ever made from inside a solid); a cell where
    // every attempt is inside keeps its first draws
    let first = positions.len() as u32;
    let volume = q.positions.saturating_sub(first);
    let candidate = |a: u32| {
        let mut s = Sampler::new(seed, stream, first + a);
        lo + Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * size
    };
    let (scene, tracer) = (renderer.scene, renderer.tracer);
    let threshold = scene.config.grid.inside_backface_fraction;
    let mut open = truth::first_successes(volume, volume.saturating_mul(VOLUME_ATTEMPTS), |a| {
        let b = candidate(a);
        let inside_stream = hash_pair(stream, 0x1F ^ (a as u64 + 1));
        (!truth::is_inside(scene, tracer, b, threshold, |j| Sampler::new(seed, inside_stream, j))).then_some(b)
    });
    if open.is_empty() {
        open = (0..volume).map(candidate).collect();
    }
    normals.extend(open.iter().map(|_| None));
    positions.extend(open);
    let dirs = q.dirs as usize;
    let rough = ((dirs as f32 * q.rough_fraction).round() as usize).min(dirs);
    truth::trace_queries(renderer, &positions, dirs, q.spp, &CellStreams { seed, stream, dirs, rough, normals })
}

/// Up to `count` points on the surfaces seen from inside cell `cell`, with their normals
/// (`truth::cell_surface_points`). A cell on the grid's border also takes the surfaces just
/// beyond it (lookups clamp to the nearest cell): a room's walls a little outside the grid,
/// a floor below it.
fn cell_surface_points(
    renderer: &Renderer,
    geometry: &GridGeometry,
    cell: usize,
    count: u32,
    streams: (u64, u64),
) -> Vec<(Vec3, Vec3)> {
    let (size, coords) = (geometry.cell_size(), geometry.cell_coords(cell));
    let lo = geometry.min + coords.as_vec3() * size;
    let last = geometry.counts - glam::UVec3::ONE;
    let outer = |at_border: glam::BVec3| Vec3::select(at_border, size, Vec3::ZERO);
    let accept = (lo - outer(coords.cmpeq(glam::UVec3::ZERO)), lo + size + outer(coords.cmpeq(last)));
    truth::cell_surface_points(renderer.scene, renderer.tracer, (lo, lo + size), accept, count, streams)
}

/// How many queries a cell set holds: positions × directions, with `spp`-sample references,
/// `rough_fraction` of them rough.
#[derive(Clone, Copy, Debug)]
struct QuerySize {
    positions: u32,
    dirs: u32,
    spp: u32,
    rough_fraction: f32,
    surface_fraction: f32,
}

/// The queries of a set as the objective reads them.
fn samples(q: &TracedQueries) -> Vec<Sample> {
    (0..q.dirs.len()).map(|k| Sample::new(q.position_of(k), q.dirs[k], q.roughness[k], q.reference[k])).collect()
}

/// Exposure the fit's errors are tone-mapped at: the key of probe A's mirror image (the
/// evaluation uses the same).
pub fn exposure_of(warp: &Warp) -> f32 {
    warp.probe.key_exposure()
}

/// The cells a fit works on: every cell whose probe is not inside geometry, in index order.
pub fn active_cells(grid: &crate::bake::ProbeGrid) -> Vec<usize> {
    (0..grid.geometry.cell_count()).filter(|&c| !grid.inside[c]).collect()
}

/// One cell's fit, its model selected, before the grid-wide steps: what a shard of a fit
/// hands to the merge.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CellOutcome {
    /// The cell's diagnostics, its model selected.
    pub fit: CellFit,
    /// The refined shift map (level 2), `map_res²` shifts: kept where the cell stores it
    /// (or every cell's, with [`MapSets::WithUnfitted`]), empty otherwise.
    pub fitted: Vec<f32>,
    /// The refined rough map, kept as `fitted` is (empty without `FitSettings::rough_map`).
    #[serde(default)]
    pub fitted_rough: Vec<f32>,
    /// The unfitted shift map of the grid's raytraced distances (`celldepth`): kept only
    /// with [`MapSets::WithUnfitted`].
    pub init: Vec<f32>,
    /// The probe each texel of `fitted` reads (`fit::probes`), kept as `fitted` is; empty
    /// with one probe.
    #[serde(default)]
    pub probes: Vec<u8>,
    /// With several probes and [`MapSets::WithUnfitted`]: the cell's map refined with one
    /// probe for the whole cell (the one most of its texels chose, [`probes::per_cell`]),
    /// its rough map and that probe: the evaluation's `per-cell` row, never stored.
    #[serde(default)]
    pub per_cell: Option<(Vec<f32>, Vec<f32>, u8)>,
    /// The probe the cell reads without a map (through the proxy): the one most of its
    /// texels chose ([`probes::per_cell`]); probe A with one probe.
    #[serde(default)]
    pub cell_probe: u8,
    /// Reference rays traced for the cell's training and check queries.
    pub rays: u64,
}

/// Fits every active cell of a bake. `glossy` is the lookup the cells are fitted for: its
/// warp holds probe A, the proxies and the options of the fallback methods, its correction
/// picks the mips of rough queries.
///
/// The same as [`fit_cells`] over [`active_cells`], the irradiance references of
/// [`irradiance::trace_references`] over all points, and [`assemble`]: the path a sharded
/// fit takes, so that a merged fit is the same fit. `sets`: the map sets kept beside the
/// stored ones. Runs the stages [`diffuse_stage`], [`cells_stage`] and [`finish`] in turn;
/// a caller that owns the bake can run them itself and hold the grid's hit counts for the
/// cells stage alone (`jobs::run::fit_staged`).
pub fn fit(baked: Baked, glossy: Glossy, s: &FitSettings, sets: MapSets, progress: &Progress) -> Fit {
    let diffuse = diffuse_stage(baked, glossy, s);
    let cells = cells_stage(baked, glossy, s, sets, progress);
    finish(baked, glossy, s, diffuse, cells)
}

/// A fit's diffuse stage: the diffuse correctives and the wall seconds of its steps.
pub struct DiffuseStage {
    irradiance: irradiance::IrradianceFit,
    /// Drawing the surface points, tracing their references, fitting.
    seconds: [f64; 3],
}

/// The diffuse correctives of a fit: they need nothing of the cells' (nor the grid's hit
/// counts), so they come first and their surface points and references are gone before
/// the cells' results accumulate.
pub fn diffuse_stage(baked: Baked, glossy: Glossy, s: &FitSettings) -> DiffuseStage {
    let t0 = Instant::now();
    let points = irradiance::SurfacePoints::draw(baked, s.seed);
    let t_points = t0.elapsed().as_secs_f64();
    let references = irradiance::trace_references(baked, &points, s.seed, &points.all());
    let t_references = t0.elapsed().as_secs_f64();
    let irradiance = fit_diffuse(baked, glossy, &points, references);
    let t_diffuse = t0.elapsed().as_secs_f64();
    DiffuseStage { irradiance, seconds: [t_points, t_references - t_points, t_diffuse - t_references] }
}

/// A fit's cells stage: the proxy the maps shift, every active cell's outcome (in cell
/// order), the unfitted map sets if asked for, and its wall seconds.
pub struct CellsStage {
    proxy: proxy::ProxyOutcome,
    cells: Vec<CellOutcome>,
    unfitted: Option<UnfittedMaps>,
    seconds: f64,
}

/// Chooses the proxy and fits every active cell ([`fit_cells`]): the one stage that reads
/// the grid's hit counts.
pub fn cells_stage(baked: Baked, glossy: Glossy, s: &FitSettings, sets: MapSets, progress: &Progress) -> CellsStage {
    let t0 = Instant::now();
    let proxy = proxy::choose(baked, glossy, s);
    let cells = fit_cells(baked, glossy, s, proxy.method, &active_cells(baked.grid), sets, progress);
    let unfitted =
        (sets == MapSets::WithUnfitted).then(|| UnfittedMaps::of(baked.grid.geometry, s.map_res, proxy.method, &cells));
    CellsStage { proxy, cells, unfitted, seconds: t0.elapsed().as_secs_f64() }
}

/// The fit of its two stages: each cell's model selected, the scene's roughness correction
/// fitted for the maps as stored, the grid's records made ([`assemble`]'s last step).
pub fn finish(baked: Baked, glossy: Glossy, s: &FitSettings, diffuse: DiffuseStage, cells: CellsStage) -> Fit {
    let t0 = Instant::now();
    let CellsStage { proxy, cells, unfitted, seconds } = cells;
    let mut f = assemble_cells(baked, glossy, s, proxy, cells, diffuse.irradiance);
    f.unfitted = unfitted;
    let [points, references, fitted] = diffuse.seconds;
    f.times.surface_points = points;
    f.times.irradiance_references = references;
    f.times.irradiance_fit = fitted;
    f.times.cells = seconds;
    f.seconds = points + references + fitted + seconds + t0.elapsed().as_secs_f64();
    f
}

/// The rough fraction a fit uses with this probe: none without rough mips.
fn rough_fraction(glossy: &Glossy, s: &FitSettings) -> f32 {
    if glossy.warp.probe.radiance.levels.len() > 1 { s.rough_fraction.clamp(0.0, 1.0) } else { 0.0 }
}

/// Fits the cells `cells` (active cells of the bake), in that order: each cell's shift map of
/// `proxy` refined against its training references, judged on its check references and its
/// model selected; `sets` says which maps an outcome keeps (a map the cell does not store is
/// dropped as soon as the cell is done, unless every cell's is asked for).
pub fn fit_cells(
    baked: Baked,
    glossy: Glossy,
    s: &FitSettings,
    proxy: Method,
    cells: &[usize],
    sets: MapSets,
    progress: &Progress,
) -> Vec<CellOutcome> {
    let Baked { scene, tracer, grid, .. } = baked;
    let warp = glossy.warp;
    let wp = &warp.probe;
    let exposure = exposure_of(warp);
    let rough_fraction = rough_fraction(&glossy, s);
    let renderer = Renderer::new(scene, tracer);
    let g = grid.geometry;
    assert!(
        grid.holds_hits(),
        "fit_cells: the grid's hit counts are not loaded (a bake read with `bakefile::Hits::Later` needs `bakefile::read_hits` first)"
    );
    let bar = progress.bar(cells.len() as u64, "fit cells");
    let size = |positions, dirs| QuerySize {
        positions,
        dirs,
        spp: s.reference_spp,
        rough_fraction,
        surface_fraction: s.surface_fraction,
    };
    let (train_size, check_size) = (size(s.train_positions, s.train_dirs), size(s.check_positions, s.check_dirs));
    let two_maps = two_maps(&glossy, s);
    let results: Vec<CellOutcome> = cells
        .par_iter()
        .map(|&cell| {
            let tc = Instant::now();
            // the grid's raytraced distances at a map resolution
            let depth_at = |res: u32| cell_distances(grid, &grid.hits, cell, res);
            let distance = depth_at(s.map_res);
            let sees_only_sky = distance.iter().all(|d| !d.is_finite());
            let tt = Instant::now();
            let train = cell_samples((&renderer, baked.references), &g, cell, train_size, s.seed, 1);
            let check = cell_samples((&renderer, baked.references), &g, cell, check_size, s.seed, 2);
            let rays = train.rays + check.rays;
            let hidden = hidden_fraction(baked, wp.position, &check);
            // the map's origin: the cell probe's position (its centre unless relocated)
            let origin = g.cell_centre(cell) + grid.probe_offset[cell];
            // with several probes, which one each texel reads (from the training queries' hits)
            let hits = (warp.probe_count() > 1).then(|| true_hits(baked, &train));
            let probe_map =
                hits.as_ref().map_or_else(Vec::new, |h| probes::choose(warp, origin, s.map_res, &distance, h));
            // without a map the cell reads the probe most of its texels chose, through the proxy
            let cell_probe = probes::per_cell(&probe_map);
            let unmapped =
                if cell_probe == 0 { Vec::new() } else { vec![cell_probe; (s.map_res * s.map_res) as usize] };
            let check_dirs = check.dirs_per_position;
            let (mut train, check) = (samples(&train), samples(&check));
            if s.aim_pull > 0.0 {
                set_targets(baked, warp, (s.map_res, &probe_map), hits.as_deref(), &mut train);
            }
            let trace_seconds = tt.elapsed().as_secs_f64();
            let ctx = CellContext { glossy, exposure, proxy, origin, res: s.map_res, probe_map: &probe_map };
            let n2 = (s.map_res * s.map_res) as usize;
            let level1_train: Vec<_> = if s.level1 { train.iter().step_by(4).copied().collect() } else { Vec::new() };
            // the study's inputs, kept only when it is asked for
            let study = s.resolution_study.then(|| (train.clone(), check_halves(&check, check_dirs)));
            let (train, rough_train) = split_rough(train, two_maps);
            // the evaluation's per-cell row: the same refinement with one probe for the cell
            let per_cell = (sets == MapSets::WithUnfitted && !probe_map.is_empty())
                .then(|| per_cell_maps(ctx, (&train, rough_train.as_deref()), (&distance, sees_only_sky), s));
            let Refined { start, outcome, fitted, init } =
                refine(ctx, train, &distance, sees_only_sky, s.depth_prior, s);
            let rough = rough_train.map(|t| refine(ctx, t, &distance, sees_only_sky, s.rough_depth_prior, s));
            // the fallback: the proxy unshifted, a map of zero shifts
            let no_map = vec![0.0f32; n2];
            let mut check_problem = CellProblem::new(ctx, vec![0.0; n2], check);
            // a cell whose check positions cannot tell its maps from the fallback judges
            // them on more positions (a stream of their own)
            let (mut extra_rays, mut extra_seconds, mut check_positions) = (0, 0.0, s.check_positions);
            let rough_fitted = rough.as_ref().map_or(&[][..], |r| r.fitted.as_slice());
            // (the fallback, a cell without a map, reads the cell's probe)
            let fallback_errors = |p: &mut CellProblem| {
                p.set_probe_map(&unmapped);
                let e = p.position_square_errors(&no_map, &[], check_dirs);
                p.set_probe_map(&probe_map);
                e
            };
            if !sees_only_sky
                && s.extra_check_positions > 0
                && selection::undecided(
                    &fallback_errors(&mut check_problem),
                    &check_problem.position_square_errors(&fitted, rough_fitted, check_dirs),
                )
            {
                let te = Instant::now();
                let extra_size = size(s.extra_check_positions, s.check_dirs);
                let extra = cell_samples((&renderer, baked.references), &g, cell, extra_size, s.seed, 4);
                (extra_rays, check_positions) = (extra.rays, check_positions + extra.positions.len() as u32);
                let mut check = check_problem.into_samples();
                check.extend(samples(&extra));
                check_problem = CellProblem::new(ctx, vec![0.0; n2], check);
                extra_seconds = te.elapsed().as_secs_f64();
            }
            let rough_map = rough.as_ref().map(|r| r.fitted.as_slice());
            let [warp1, boxed_err, kdop, fallback, celldepth, fitted_err] =
                check_errors(&mut check_problem, (&probe_map, &unmapped), (&no_map, &init), (&fitted, rough_map));
            let selection = if sees_only_sky {
                Selection::SeesOnlySky
            } else {
                choose_level(fallback, fitted_err, s.tol as f64, s.selection_margin)
            };
            let level1 = s.level1.then(|| level1_fit(ctx, level1_train, &check_problem, g.cell_size(), s));
            let resolutions = study.map(|(train, halves)| {
                // (a one-map study: with rough maps the fit's own map saw only part of
                // the queries, so it is refined again like the other resolutions)
                let own = rough.is_none().then_some(fitted.as_slice());
                Box::new(study_resolutions(ctx, (&train, &halves), own, depth_at, s))
            });
            bar.inc(1);
            let fit = CellFit {
                cell: cell as u32,
                level: selection.level(),
                selection,
                start,
                check_err_warp1: warp1,
                check_err_box: boxed_err,
                check_err_kdop: kdop,
                check_err_fallback: fallback,
                check_err_celldepth: celldepth,
                check_err_fitted: fitted_err,
                train_cost_start: outcome.cost_start,
                train_cost_end: outcome.cost_end,
                relax: outcome.relax,
                iterations: outcome.iterations,
                evaluations: outcome.evaluations,
                termination: outcome.termination,
                seconds: tc.elapsed().as_secs_f64(),
                trace_seconds: trace_seconds + extra_seconds,
                check_positions,
                curve: outcome.curve.clone(),
                rough_map: rough.as_ref().map(RoughMapFit::of),
                hidden_fraction: hidden,
                level1,
                resolutions,
            };
            let mut outcome = outcome_keeping(sets, fit, (fitted, rough.map(|r| r.fitted), init), rays + extra_rays);
            if !outcome.fitted.is_empty() {
                outcome.probes = probe_map;
            }
            outcome.cell_probe = cell_probe;
            outcome.per_cell = per_cell;
            outcome
        })
        .collect();
    bar.finish_and_clear();
    results
}

/// The held-out errors a cell's model selection compares (`CellProblem::relative_error_map`
/// on its check problem `p`, whose texels read `probe_map`): `warp1`, the box and the 18-DOP,
/// the fallback (`no_map`, the proxy unshifted, its texels reading `unmapped`: the cell's
/// probe, or probe A when empty), the unfitted map `init`,
/// and the fitted map with its rough map when it has one.
fn check_errors(
    p: &mut CellProblem,
    (probe_map, unmapped): (&[u8], &[u8]),
    (no_map, init): (&[f32], &[f32]),
    (fitted, rough): (&[f32], Option<&[f32]>),
) -> [f64; 6] {
    let [warp1, boxed, kdop] = [Method::Warp1, Method::Box, Method::Kdop].map(|m| p.relative_error_method(m));
    p.set_probe_map(unmapped);
    let fallback = p.relative_error_map(no_map);
    p.set_probe_map(probe_map);
    let celldepth = p.relative_error_map(init);
    let fitted = match rough {
        Some(r) => p.relative_error_maps(fitted, r),
        None => p.relative_error_map(fitted),
    };
    [warp1, boxed, kdop, fallback, celldepth, fitted]
}

/// Cell `cell`'s raytraced distances (`ProbeGrid::depth_mean`, with its hit counts `hits`)
/// at a `res`² map: what a map's start and prior are made from.
fn cell_distances(grid: &crate::bake::ProbeGrid, hits: &[u8], cell: usize, res: u32) -> Vec<f32> {
    let d2 = (grid.depth_resolution * grid.depth_resolution) as usize;
    model::celldepth_distances(
        grid.depth_resolution,
        &grid.depth_mean[cell * d2..(cell + 1) * d2],
        &hits[cell * d2..(cell + 1) * d2],
        grid.depth_samples,
        grid.far_distance,
        res,
    )
}

/// The evaluation's `per-cell` row of a cell: its map (and rough map, with `rough_train`)
/// refined as the fit refines them, every texel reading the one probe most of the cell's
/// texels chose (`ctx.probe_map`), and that probe.
fn per_cell_maps(
    ctx: CellContext,
    (train, rough_train): (&[Sample], Option<&[Sample]>),
    (distance, sees_only_sky): (&[f32], bool),
    s: &FitSettings,
) -> (Vec<f32>, Vec<f32>, u8) {
    let p = probes::per_cell(ctx.probe_map);
    let one = vec![p; ctx.probe_map.len()];
    let ctx = CellContext { probe_map: &one, ..ctx };
    let map = refine(ctx, train.to_vec(), distance, sees_only_sky, s.depth_prior, s).fitted;
    let rough = rough_train
        .map_or_else(Vec::new, |t| refine(ctx, t.to_vec(), distance, sees_only_sky, s.rough_depth_prior, s).fitted);
    (map, rough, p)
}

impl RoughMapFit {
    /// The record of a refined rough map.
    fn of(r: &Refined) -> RoughMapFit {
        RoughMapFit {
            start: r.start,
            train_cost_start: r.outcome.cost_start,
            train_cost_end: r.outcome.cost_end,
            relax: r.outcome.relax,
            evaluations: r.outcome.evaluations,
        }
    }
}

/// A cell's level-1 corrective (one origin offset, depth mip and relaxation), fitted on
/// `train` and judged on the cell's check problem: measured, never stored.
fn level1_fit(
    ctx: CellContext,
    train: Vec<objective::Sample>,
    check: &CellProblem,
    cell_size: Vec3,
    s: &FitSettings,
) -> Box<Level1Fit> {
    let n2 = (s.map_res * s.map_res) as usize;
    let p = CellProblem::new(ctx, vec![0.0; n2], train).with_robust_scale(s.robust_scale);
    let (params, evaluations) = p.fit_level1(cell_size, ctx.glossy.warp.options.depth_lod);
    Box::new(Level1Fit { params, check_err: check.relative_error_level1(&params), evaluations })
}

/// The share of a cell's check queries whose true hit probe A cannot see, kept beside the
/// references (it depends on the scene, probe A's position and the queries alone), so a
/// second run traces none of its rays.
fn hidden_fraction(baked: Baked, a: Vec3, check: &truth::TracedQueries) -> f64 {
    let trace = || {
        let hidden = (0..check.dirs.len())
            .filter(|&k| truth::oracle(baked.scene, baked.tracer, a, check.position_of(k), check.dirs[k]).1)
            .count();
        hidden as f64 / check.dirs.len().max(1) as f64
    };
    let Some(store) = baked.references else { return trace() };
    let key = store.key("hidden").vec3s(&[a]).vec3s(&check.positions).vec3s(&check.dirs);
    let from = |w: &[u32]| store::f64_from_words(w).filter(|h| (0.0..=1.0).contains(h));
    store.cached("hidden", key, (store::f64_to_words, from), trace)
}

/// A cell's outcome with the maps `sets` asks for: every map (the unfitted start
/// included) for the evaluation's unfitted rows, else only the maps the cell stores.
fn outcome_keeping(
    sets: MapSets,
    fit: CellFit,
    (fitted, fitted_rough, init): (Vec<f32>, Option<Vec<f32>>, Vec<f32>),
    rays: u64,
) -> CellOutcome {
    let keep_all = sets == MapSets::WithUnfitted;
    let keep = keep_all || fit.level == Level::Map;
    let fitted_rough = fitted_rough.filter(|_| keep).unwrap_or_default();
    let fitted = if keep { fitted } else { Vec::new() };
    let init = if keep_all { init } else { Vec::new() };
    CellOutcome { fit, fitted, fitted_rough, init, probes: Vec::new(), per_cell: None, cell_probe: 0, rays }
}

/// The true hits of a cell's queries (`fit::probes`): one ray each.
fn true_hits(baked: Baked, q: &truth::TracedQueries) -> Vec<probes::Hit> {
    (0..q.dirs.len())
        .map(|k| {
            let (b, dir) = (q.position_of(k), q.dirs[k]);
            probes::Hit { b, dir, t: truth::first_visible(baked.scene, baked.tracer, b, dir) }
        })
        .collect()
}

/// The aim pull's targets of a cell's mirror training queries: each query's true hit
/// (from `hits`, in query order, where the probe choice traced them; else traced here, one
/// ray per mirror query) where the probe its texel of a `res`² map reads (`probe_map`;
/// empty: probe A) sees it. One shadow ray per mirror query with a hit.
fn set_targets(
    baked: Baked,
    warp: &Warp,
    (res, probe_map): (u32, &[u8]),
    hits: Option<&[probes::Hit]>,
    train: &mut [Sample],
) {
    for (k, q) in train.iter_mut().enumerate() {
        if q.roughness != 0.0 {
            continue;
        }
        let t = hits.map_or_else(|| truth::first_visible(baked.scene, baked.tracer, q.b, q.dir), |h| h[k].t);
        if !t.is_finite() {
            continue;
        }
        let p = if probe_map.is_empty() {
            0
        } else {
            probe_map[crate::warp::corrective::nearest_tap(&crate::octa::bilinear_taps(res, crate::octa::encode(q.dir)))
                as usize]
        };
        let hit = q.b + q.dir * t;
        if truth::sees(baked.scene, baked.tracer, warp.probe_at(p.into()).position, hit) {
            q.target = Some((p, hit));
        }
    }
}

/// Whether a fit stores a rough map per cell: asked for, and the probe has rough mips.
fn two_maps(glossy: &Glossy, s: &FitSettings) -> bool {
    s.rough_map && rough_fraction(glossy, s) > 0.0
}

/// A cell's training queries for its map and, with `two_maps`, for its rough map: the
/// queries the runtime reads mostly from the rough map (`rough_weight` ≥ ½) go to it.
fn split_rough(train: Vec<Sample>, two_maps: bool) -> (Vec<Sample>, Option<Vec<Sample>>) {
    if !two_maps {
        return (train, None);
    }
    let (rough, mirror): (Vec<Sample>, Vec<Sample>) = train.into_iter().partition(|q| rough_weight(q.roughness) >= 0.5);
    (mirror, Some(rough))
}

/// A cell's map refined from the better of its two starts, and the unfitted map.
struct Refined {
    start: Start,
    outcome: objective::Outcome,
    /// The refined map, its relaxation applied.
    fitted: Vec<f32>,
    /// The map of the grid's raytraced distances (`celldepth`).
    init: Vec<f32>,
}

/// Refines a cell's map at `ctx.res` against `train`. Two starts: the proxy itself and the
/// grid's raytraced distances `distance` (at the map's resolution); the one that explains the
/// training queries better is refined (the size term pulls towards the anchor, `depth_prior`
/// of the way to the raytraced distances, either way).
fn refine(
    ctx: CellContext,
    train: Vec<Sample>,
    distance: &[f32],
    sees_only_sky: bool,
    depth_prior: f64,
    s: &FitSettings,
) -> Refined {
    let n2 = (ctx.res * ctx.res) as usize;
    let celldepth_start = ctx.log_scales_of(distance);
    let prior = if sees_only_sky { 0.0 } else { depth_prior };
    let anchor = celldepth_start.iter().map(|x| x * prior).collect();
    let mut problem = CellProblem::new(ctx, vec![0.0; n2], train)
        .with_weights(s.smooth_weight, s.size_weight)
        .with_anchor(anchor)
        .with_robust_scale(s.robust_scale)
        .with_aim_pull(s.aim_pull);
    let start = if !sees_only_sky && problem.cost(&celldepth_start) < problem.cost(&vec![0.0; n2]) {
        problem.set_start(celldepth_start.clone());
        Start::Celldepth
    } else {
        Start::Proxy
    };
    let outcome = problem.solve(s.solver, s.iterations);
    let fitted = problem.map_with_relax(&outcome.params, outcome.relax);
    let init = problem.map(&celldepth_start);
    Refined { start, outcome, fitted, init }
}

/// The in-sample bound of the model class: each cell's map refitted (as the fit refits one,
/// `refine`, its texels reading the probes the fit chose) on the queries `q` that fall in
/// it, as the runtime finds a query's cell. With `q` the evaluation's own mirror queries,
/// the error of these maps on `q` is what a per-cell shift map could reach on them: a
/// bound, not a model, since nothing held out judges it. `hits`: the grid's hit counts
/// (`ProbeGrid::hits`, which a staged fit drops). `None` when `f` did not keep its maps
/// before model selection (the fit's probe maps are read from them) or `hits` does not
/// fit the grid.
pub fn in_sample(
    grid: &crate::bake::ProbeGrid,
    hits: &[u8],
    warp: &Warp,
    f: &Fit,
    q: &TracedQueries,
) -> Option<Correctives> {
    let all = &f.unfitted.as_ref()?.fitted_all;
    if hits.len() != grid.depth_mean.len() {
        return None;
    }
    let s = &f.settings;
    let g = grid.geometry;
    let n2 = (s.map_res * s.map_res) as usize;
    let (glossy, exposure) = (Glossy { warp, correction: f.roughness.as_ref() }, exposure_of(warp));
    let mut by_cell: Vec<Vec<Sample>> = vec![Vec::new(); g.cell_count()];
    for k in 0..q.dirs.len() {
        let b = q.position_of(k);
        by_cell[all.cell_at(b)].push(Sample::new(b, q.dirs[k], q.roughness[k], q.reference[k]));
    }
    let cells: Vec<(usize, Vec<Sample>)> =
        by_cell.into_iter().enumerate().filter(|(c, q)| !q.is_empty() && !grid.inside[*c]).collect();
    let probe_map_of = |cell: usize| -> Vec<u8> {
        match all.slot_of(cell) {
            Some(slot) if !all.probe_maps.is_empty() => all.probe_maps[slot as usize * n2..][..n2].to_vec(),
            _ if warp.probe_count() > 1 => vec![0; n2],
            _ => Vec::new(),
        }
    };
    let maps: Vec<(Vec<f32>, Vec<u8>)> = cells
        .par_iter()
        .map(|(cell, queries)| {
            let cell = *cell;
            let distance = cell_distances(grid, hits, cell, s.map_res);
            let sees_only_sky = distance.iter().all(|d| !d.is_finite());
            let probe_map = probe_map_of(cell);
            let origin = g.cell_centre(cell) + grid.probe_offset[cell];
            let ctx =
                CellContext { glossy, exposure, proxy: f.proxy.method, origin, res: s.map_res, probe_map: &probe_map };
            let map = refine(ctx, queries.clone(), &distance, sees_only_sky, s.depth_prior, s).fitted;
            (map, probe_map)
        })
        .collect();
    let mut slot = vec![NO_MAP; g.cell_count()];
    let (mut flat, mut probes) = (Vec::with_capacity(cells.len() * n2), Vec::new());
    for (k, ((cell, _), (map, probe_map))) in cells.iter().zip(&maps).enumerate() {
        slot[*cell] = k as u32;
        flat.extend_from_slice(map);
        probes.extend_from_slice(probe_map);
    }
    Some(Correctives::new(g, s.map_res, slot, flat, all.fallback).with_probe_maps(probes))
}

/// The check queries of even and odd positions (`dirs` queries a position, in order).
fn check_halves(check: &[Sample], dirs: usize) -> [Vec<Sample>; 2] {
    let mut halves = [Vec::new(), Vec::new()];
    for (k, q) in check.iter().enumerate() {
        halves[(k / dirs.max(1)) % 2].push(*q);
    }
    halves
}

/// The resolution study of one cell: its map refined at each of [`STUDY_RESOLUTIONS`] from
/// `train` (`fitted`, the fit's own map at `ctx.res` when it was fitted on all of `train`, is
/// reused), one map per cell for every roughness, each judged with the fallback
/// on both halves of the check queries; `depth_at(res)`: the grid's raytraced distances at
/// a map resolution.
fn study_resolutions(
    ctx: CellContext,
    (train, halves): (&[Sample], &[Vec<Sample>; 2]),
    fitted: Option<&[f32]>,
    depth_at: impl Fn(u32) -> Vec<f32>,
    s: &FitSettings,
) -> ResolutionStudy {
    let maps: Vec<(u32, Vec<f32>)> = STUDY_RESOLUTIONS
        .iter()
        .map(|&res| {
            if let Some(fitted) = fitted.filter(|_| res == ctx.res) {
                return (res, fitted.to_vec());
            }
            let distance = depth_at(res);
            let sees_only_sky = distance.iter().all(|d| !d.is_finite());
            (
                res,
                refine(
                    CellContext { res, probe_map: &[], ..ctx },
                    train.to_vec(),
                    &distance,
                    sees_only_sky,
                    s.depth_prior,
                    s,
                )
                .fitted,
            )
        })
        .collect();
    let mut errors = [[0.0; 1 + STUDY_RESOLUTIONS.len()]; 2];
    for (h, half) in halves.iter().enumerate() {
        for (k, (res, map)) in maps.iter().enumerate() {
            let p =
                CellProblem::new(CellContext { res: *res, probe_map: &[], ..ctx }, vec![0.0; map.len()], half.clone());
            if k == 0 {
                errors[h][0] = p.relative_error_map(&vec![0.0; map.len()]);
            }
            errors[h][1 + k] = p.relative_error_map(map);
        }
    }
    ResolutionStudy { errors }
}

/// Makes a fit of the outcomes of every active cell (in cell order), fitted for `proxy`,
/// and the irradiance references of every surface point: the grid-wide steps. Fits the
/// diffuse correctives, selects each cell's model and fits the scene's roughness correction
/// for the maps as stored.
pub fn assemble(
    baked: Baked,
    glossy: Glossy,
    s: &FitSettings,
    proxy: proxy::ProxyOutcome,
    results: Vec<CellOutcome>,
    points: &irradiance::SurfacePoints,
    references: irradiance::References,
) -> Fit {
    let t0 = Instant::now();
    let diffuse = fit_diffuse(baked, glossy, points, references);
    let irradiance_fit = t0.elapsed().as_secs_f64();
    let mut f = assemble_cells(baked, glossy, s, proxy, results, diffuse);
    f.times.irradiance_fit = irradiance_fit;
    f.seconds = t0.elapsed().as_secs_f64();
    f
}

/// The diffuse correctives of a bake, against its irradiance (read in place), from the
/// surface points and their references.
fn fit_diffuse(
    baked: Baked,
    glossy: Glossy,
    points: &irradiance::SurfacePoints,
    references: irradiance::References,
) -> irradiance::IrradianceFit {
    let slots = baked.grid.dense_slots();
    irradiance::fit_from_references(baked.grid.irradiance_view(&slots), exposure_of(glossy.warp), points, references)
}

/// The cells' part of [`assemble`]: each cell's model selected, the scene's roughness
/// correction fitted for the maps as stored; `irradiance` the diffuse correctives.
fn assemble_cells(
    baked: Baked,
    glossy: Glossy,
    s: &FitSettings,
    proxy: proxy::ProxyOutcome,
    results: Vec<CellOutcome>,
    irradiance: irradiance::IrradianceFit,
) -> Fit {
    let t0 = Instant::now();
    let grid = baked.grid;
    let warp = glossy.warp;
    let rough_fraction = rough_fraction(&glossy, s);
    let g = grid.geometry;
    let n2 = (s.map_res * s.map_res) as usize;

    // the stored maps gathered into one exactly sized array, and the outcomes turned into
    // their records in place (the records are smaller: the outcomes' buffer is reused, so
    // the two are never held side by side)
    let stored = results.iter().filter(|r| r.fit.level == Level::Map).count();
    let two_maps = two_maps(&glossy, s);
    let mut correctives =
        Correctives::new(g, s.map_res, vec![NO_MAP; g.cell_count()], Vec::with_capacity(stored * n2), proxy.method)
            .with_rough_maps(Vec::with_capacity(if two_maps { stored * n2 } else { 0 }));
    let mut reference_rays = 0;
    let cells: Vec<CellFit> = results
        .into_iter()
        .map(|CellOutcome { fit, fitted, fitted_rough, probes, cell_probe, rays, .. }| {
            if cell_probe != 0 && fit.level != Level::Map {
                correctives.cell_probes.resize(g.cell_count(), 0);
                correctives.cell_probes[fit.cell as usize] = cell_probe;
            }
            if fit.level == Level::Map {
                correctives.slot[fit.cell as usize] = (correctives.maps.len() / n2) as u32;
                correctives.maps.extend_from_slice(&fitted);
                correctives.rough_maps.extend_from_slice(&fitted_rough);
                if warp.probe_count() > 1 {
                    // (a map fitted without a probe map reads probe A: zeros)
                    correctives.probe_maps.extend(probes.iter().copied().chain(std::iter::repeat(0)).take(n2));
                }
            }
            reference_rays += rays;
            fit
        })
        .collect();
    lend_maps_to_inside_cells(&mut correctives, &grid.inside);
    let cells_cpu = cells.iter().map(|c| c.seconds).sum::<f64>();
    let cells_tracing_cpu = cells.iter().map(|c| c.trace_seconds).sum::<f64>();
    // the correction for the maps as stored: fitted to the scene, kept if it beats the lobes
    let t_roughness = Instant::now();
    let roughness = glossy
        .correction
        .filter(|_| rough_fraction > 0.0)
        .map(|lobe| roughness::fit_scene_correction(baked, warp, &correctives, lobe, s));
    let roughness_s = t_roughness.elapsed().as_secs_f64();
    let reference_rays = reference_rays + irradiance.reference_rays;
    Fit {
        correctives,
        unfitted: None,
        cells,
        roughness,
        irradiance,
        proxy,
        settings: s.clone(),
        seconds: t0.elapsed().as_secs_f64(),
        times: FitTimes { cells_cpu, cells_tracing_cpu, roughness: roughness_s, ..FitTimes::default() },
        reference_rays,
    }
}

/// Gives each cell left out as inside geometry a copy of the maps (shift, rough, probe) of
/// its nearest stored cell within two cells (the nearest Chebyshev shell, then the nearest
/// centre, then the lowest index). Such a cell straddles a wall or a solid, and the
/// surfaces at its edge are shaded from inside it: without a map they read probe A through
/// the proxy, and with several probes a room probe A does not see shows what A sees (a
/// courtyard's light on a room's wall).
fn lend_maps_to_inside_cells(c: &mut Correctives, inside: &[bool]) {
    const REACH: i32 = 2;
    let g = c.geometry;
    let n2 = (c.map_res * c.map_res) as usize;
    let counts = g.counts.as_ivec3();
    let lenders: Vec<(usize, u32)> = (0..g.cell_count())
        .filter(|&cell| inside.get(cell).copied().unwrap_or(false) && c.slot[cell] == NO_MAP)
        .filter_map(|cell| {
            let at = g.cell_coords(cell).as_ivec3();
            let centre = g.cell_centre(cell);
            (1..=REACH).find_map(|k| {
                let mut best: Option<(f32, usize, u32)> = None;
                for dz in -k..=k {
                    for dy in -k..=k {
                        for dx in -k..=k {
                            let o = glam::IVec3::new(dx, dy, dz);
                            let q = at + o;
                            if o.abs().max_element() != k || q.cmplt(glam::IVec3::ZERO).any() || q.cmpge(counts).any() {
                                continue;
                            }
                            let other = g.cell_index(q.as_uvec3());
                            let Some(slot) = c.slot_of(other) else { continue };
                            let d = (g.cell_centre(other) - centre).length_squared();
                            if best.is_none_or(|(bd, bi, _)| d < bd || (d == bd && other < bi)) {
                                best = Some((d, other, slot));
                            }
                        }
                    }
                }
                best.map(|(_, _, slot)| (cell, slot))
            })
        })
        .collect();
    for (cell, from) in lenders {
        let (at, new) = (from as usize * n2, c.maps.len() / n2);
        c.slot[cell] = new as u32;
        c.maps.extend_from_within(at..at + n2);
        if !c.rough_maps.is_empty() {
            c.rough_maps.extend_from_within(at..at + n2);
        }
        if !c.probe_maps.is_empty() {
            c.probe_maps.extend_from_within(at..at + n2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use crate::trace::Tracer;
    use glam::UVec3;

    #[test]
    fn a_cell_inside_geometry_borrows_its_nearest_stored_neighbours_maps() {
        // six cells in a row: 0 and 2 store maps (values 1 and 2, probes 1 and 2); 1 and 5
        // are inside geometry, 3 is a level-0 cell; 5's nearest stored cell is 3 away
        let g = GridGeometry { min: Vec3::ZERO, max: Vec3::new(6.0, 1.0, 1.0), counts: UVec3::new(6, 1, 1) };
        let n2 = 4;
        let mut slot = vec![NO_MAP; 6];
        (slot[0], slot[2]) = (0, 1);
        let maps: Vec<f32> = [1.0; 4].into_iter().chain([2.0; 4]).collect();
        let mut c = Correctives::new(g, 2, slot, maps.clone(), Method::Box)
            .with_rough_maps(maps.iter().map(|m| m * 10.0).collect())
            .with_probe_maps([1u8; 4].into_iter().chain([2u8; 4]).collect());
        let inside = [false, true, false, false, false, true];
        lend_maps_to_inside_cells(&mut c, &inside);
        // cell 1 lies between 0 and 2, equally near: the lower index lends
        let s1 = c.slot_of(1).expect("cell 1 borrows a map") as usize;
        assert_eq!(&c.maps[s1 * n2..(s1 + 1) * n2], &[1.0; 4]);
        assert_eq!(&c.rough_maps[s1 * n2..(s1 + 1) * n2], &[10.0; 4]);
        assert_eq!(&c.probe_maps[s1 * n2..(s1 + 1) * n2], &[1; 4]);
        // the level-0 cell keeps the proxy; the far inside cell has no lender within reach
        assert!(c.slot_of(3).is_none() && c.slot_of(5).is_none());
        assert_eq!((c.maps.len(), c.rough_maps.len(), c.probe_maps.len()), (3 * n2, 3 * n2, 3 * n2));
    }

    #[test]
    fn a_cells_volume_positions_are_never_inside_a_solid() {
        // one 2 m cell in a room, its lower three quarters inside a solid box
        let scene = Scene::parse(
            "[probe]\nposition = [0.0, 1.8, 0.0]\n[grid]\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\ncounts = [1, 1, 1]\n\
             [[geometry]]\ntype = \"room\"\nmin = [-3.0, -1.0, -3.0]\nmax = [3.0, 4.0, 3.0]\n\
             [[geometry]]\ntype = \"box\"\nmin = [-1.5, -0.5, -1.5]\nmax = [1.5, 1.5, 1.5]\n",
            std::path::Path::new("half_solid.toml"),
        )
        .expect("the test scene parses");
        let tracer = Tracer::new(&scene);
        let renderer = Renderer::new(&scene, &tracer);
        let g = GridGeometry { min: Vec3::new(-1.0, 0.0, -1.0), max: Vec3::new(1.0, 2.0, 1.0), counts: UVec3::ONE };
        let size = QuerySize { positions: 32, dirs: 4, spp: 1, rough_fraction: 0.0, surface_fraction: 0.0 };
        let q = cell_samples((&renderer, None), &g, 0, size, 7, 1);
        assert_eq!(q.positions.len(), 32, "the open quarter of the cell has room for every position");
        // every position above the box's top, where uniform draws would put three in four
        // inside it
        assert!(q.positions.iter().all(|p| p.y > 1.5), "{:?}", q.positions);
    }
}
