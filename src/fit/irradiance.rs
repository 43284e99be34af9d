//! Correctives fitted into the grid's diffuse answer (seed 000: "fit corrective factors
//! directly into the dense grid" instead of renormalizing by hand).
//!
//! Per cell that holds surfaces: training and held-out check points on the scene's
//! surfaces inside the cell (`trace::truth::surface_points` on the fit's own streams,
//! never the evaluation's), each with a traced irradiance reference; the grid's blended
//! answer there (trilinear, back face, Chebyshev: `runtime::IrradianceBlend::Chebyshev`);
//! and a 4×4 octahedral map of scales over the normal that multiplies it. The scales are
//! fitted texel by texel with argmin's Brent (two coordinate-descent sweeps, in [0.2, 5]),
//! minimising the mean squared tone-mapped error plus a pull towards 1. A cell stores its map
//! only when it lowers the check points' tone-mapped RMSE by 5% (never worse); the runtime
//! applies the containing cell's map (`IrradianceGrid::irradiance`).

use super::DOMAIN_FIT;
use crate::bake::Baked;
use crate::octa;
use crate::runtime::{IrradianceBlend, IrradianceCorrection, IrradianceGrid};
use crate::sampling::{Sampler, hash_pair};
use crate::tonemap::reinhard;
use crate::trace::{Renderer, truth};
use crate::warp::corrective::NO_MAP;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::brent::BrentOpt;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// N of each cell's N×N map of scales.
pub const CORRECTION_RES: u32 = 4;
/// Surface points per active cell drawn for training and, as many again, for checking
/// (spread by area: cells with more surface get more).
const POINTS_PER_CELL: u32 = 12;
/// Samples per irradiance reference.
const SPP: u32 = 64;
/// Weight of the pull towards a scale of 1.
const PULL: f64 = 0.02;
/// A cell needs this many training and check points to be fitted.
const MIN_POINTS: usize = 6;

/// One cell's diffuse corrective.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IrradianceCellFit {
    pub cell: u32,
    pub train_points: usize,
    pub check_points: usize,
    /// Check points' tone-mapped RMSE without and with the fitted map.
    pub check_before: f64,
    pub check_after: f64,
    pub stored: bool,
}

/// The diffuse correctives of a grid.
#[derive(Clone, Debug)]
pub struct IrradianceFit {
    pub correction: IrradianceCorrection,
    pub cells: Vec<IrradianceCellFit>,
    pub reference_rays: u64,
    pub seconds: f64,
}

/// A point with its reference, the grid's blended answer and its taps in the scale map.
#[derive(Clone, Copy)]
struct Point {
    blended: Vec3,
    reference: Vec3,
    taps: [(u32, f32); 4],
}

/// Tone-mapped squared error of `k · blended` (mean over RGB).
fn err2(p: &Point, k: f32, exposure: f32) -> f64 {
    let d = reinhard(p.blended * k, exposure) - reinhard(p.reference, exposure);
    ((d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2)) / 3.0
}

fn scale_at(map: &[f32], taps: &[(u32, f32); 4]) -> f32 {
    taps.iter().map(|&(t, w)| map[t as usize] * w).sum()
}

fn rmse(points: &[Point], map: Option<&[f32]>, exposure: f32) -> f64 {
    let sq: f64 = points.iter().map(|p| err2(p, map.map_or(1.0, |m| scale_at(m, &p.taps)), exposure)).sum();
    (sq / points.len().max(1) as f64).sqrt()
}

/// Texel `t`'s scale as a 1-D problem, the rest of the map fixed.
struct TexelProblem<'a> {
    points: &'a [Point],
    map: &'a [f32],
    t: usize,
    exposure: f32,
}

impl CostFunction for TexelProblem<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, x: &f64) -> Result<f64, Error> {
        let mut map = self.map.to_vec();
        map[self.t] = *x as f32;
        let data: f64 = self
            .points
            .iter()
            .filter(|p| p.taps.iter().any(|&(t, w)| t as usize == self.t && w > 0.0))
            .map(|p| err2(p, scale_at(&map, &p.taps), self.exposure))
            .sum::<f64>()
            / self.points.len().max(1) as f64;
        Ok(data + PULL * (x - 1.0).powi(2) / map.len() as f64)
    }
}

/// Fits the map of one cell's training points.
fn fit_map(points: &[Point], exposure: f32) -> Vec<f32> {
    let n2 = (CORRECTION_RES * CORRECTION_RES) as usize;
    let mut map = vec![1.0f32; n2];
    for _ in 0..2 {
        for t in 0..n2 {
            if !points.iter().any(|p| p.taps.iter().any(|&(k, w)| k as usize == t && w > 0.0)) {
                continue;
            }
            let current =
                TexelProblem { points, map: &map, t, exposure }.cost(&(map[t] as f64)).unwrap_or(f64::INFINITY);
            let solver = BrentOpt::new(0.2, 5.0).set_tolerance(1e-3, 1e-4);
            let res = Executor::new(TexelProblem { points, map: &map, t, exposure }, solver)
                .configure(|st| st.param(map[t] as f64).max_iters(24))
                .run();
            if let Ok(r) = res {
                let st = r.state();
                if let Some(&best) = st.get_best_param()
                    && best.is_finite()
                    && st.get_best_cost() <= current
                {
                    map[t] = best as f32;
                }
            }
        }
    }
    map
}

/// Fits the diffuse correctives of `grid` (its irradiance without corrections) for the
/// baked scene; `exposure` is the tone mapping's, `seed` the fit's.
pub fn fit_irradiance(baked: Baked, grid: &IrradianceGrid, exposure: f32, seed: u64) -> IrradianceFit {
    let t0 = std::time::Instant::now();
    let Baked { scene, tracer, .. } = baked;
    let g = grid.geometry;
    let active = grid.slot.iter().filter(|&&s| s != NO_MAP).count() as u32;
    let bounds = (g.min, g.max);
    let draw = |tag: u64| {
        truth::surface_points(scene, tracer, bounds, active * POINTS_PER_CELL, (seed, hash_pair(DOMAIN_FIT, tag)))
    };
    let (train, check) = (draw(0x1A), draw(0x1B));
    let renderer = Renderer::new(scene, tracer);
    let trace = |pts: &[(Vec3, Vec3)], tag: u64| -> Vec<(usize, Point, u64)> {
        pts.par_iter()
            .enumerate()
            .map(|(i, &(p, n))| {
                let mut rays = 0;
                let stream = hash_pair(hash_pair(DOMAIN_FIT, tag), i as u64);
                let (reference, _) =
                    truth::irradiance_reference(&renderer, p, n, SPP, |k| Sampler::new(seed, stream, k), &mut rays);
                let point = Point {
                    blended: grid.irradiance_blend(p, n, IrradianceBlend::Chebyshev),
                    reference,
                    taps: octa::bilinear_taps(CORRECTION_RES, octa::encode(n)),
                };
                (g.cell_index(g.cell_of(p)), point, rays)
            })
            .collect()
    };
    let (train, check) = (trace(&train, 0x1C), trace(&check, 0x1D));
    let reference_rays = train.iter().chain(&check).map(|x| x.2).sum();
    let mut by_cell: Vec<(Vec<Point>, Vec<Point>)> = vec![(Vec::new(), Vec::new()); g.cell_count()];
    for (c, p, _) in &train {
        by_cell[*c].0.push(*p);
    }
    for (c, p, _) in &check {
        by_cell[*c].1.push(*p);
    }
    let fits: Vec<(IrradianceCellFit, Option<Vec<f32>>)> = by_cell
        .par_iter()
        .enumerate()
        .filter(|(c, (tr, ch))| grid.slot[*c] != NO_MAP && tr.len() >= MIN_POINTS && ch.len() >= MIN_POINTS / 2)
        .map(|(c, (tr, ch))| {
            let map = fit_map(tr, exposure);
            let (before, after) = (rmse(ch, None, exposure), rmse(ch, Some(&map), exposure));
            let stored = after < 0.95 * before;
            let fit = IrradianceCellFit {
                cell: c as u32,
                train_points: tr.len(),
                check_points: ch.len(),
                check_before: before,
                check_after: after,
                stored,
            };
            (fit, stored.then_some(map))
        })
        .collect();
    let mut correction =
        IrradianceCorrection { resolution: CORRECTION_RES, slot: vec![NO_MAP; g.cell_count()], scale: Vec::new() };
    for (f, map) in &fits {
        if let Some(map) = map {
            correction.slot[f.cell as usize] = (correction.scale.len() / map.len()) as u32;
            correction.scale.extend_from_slice(map);
        }
    }
    IrradianceFit {
        correction,
        cells: fits.into_iter().map(|(f, _)| f).collect(),
        reference_rays,
        seconds: t0.elapsed().as_secs_f64(),
    }
}
