//! Closed-form fixtures of the fit: a probe before an infinite textured wall, and the cell
//! problem whose true shift map is known. Shared by the fitter's tests and the stability
//! suite.

use super::objective::{CellContext, CellProblem, Sample};
use crate::octa::{self, OctMap, OctMips};
use crate::sampling::{Sampler, uniform_sphere};
use crate::warp::proxy::{BoxProxy, Kdop};
use crate::warp::{Proxies, Warp, WarpOptions, WarpProbe};
use glam::Vec3;

/// Texture on the wall z = 5·scale.
fn wall_radiance(p: Vec3, scale: f32) -> Vec3 {
    let (x, y) = (p.x / scale, p.y / scale);
    Vec3::new(0.5 + 0.4 * libm::sinf(1.3 * x) * libm::cosf(1.1 * y), 0.5 + 0.3 * libm::sinf(0.9 * x + 0.4 * y), 0.4)
}

/// Closed-form fixture: a probe at the origin (`res`² map) before an infinite textured wall
/// at z = 5·scale.
pub fn wall_probe(scale: f32, res: u32) -> WarpProbe {
    let (radiance, distance) = wall_maps(scale, res);
    WarpProbe::from_distance_mips(Vec3::ZERO, &distance, OctMips { levels: vec![radiance] }, vec![0.0])
}

/// [`wall_probe`] with a box-filtered radiance chain down to 8², mip m standing for
/// roughness m/(n−1) as a bake's does: for rough lookups.
pub fn wall_probe_rough(scale: f32, res: u32) -> WarpProbe {
    let (radiance, distance) = wall_maps(scale, res);
    let chain = octa::build_mips(radiance, 8);
    let n = chain.levels.len();
    let mip_roughness = (0..n).map(|m| m as f32 / (n - 1).max(1) as f32).collect();
    WarpProbe::from_distance_mips(Vec3::ZERO, &distance, chain, mip_roughness)
}

/// The wall's radiance map and distance chain as seen from the origin.
fn wall_maps(scale: f32, res: u32) -> (OctMap<Vec3>, OctMips<f32>) {
    let z = 5.0 * scale;
    let rad = OctMap::from_fn(res, |_, _, d| if d.z > 0.0 { wall_radiance(d * (z / d.z), scale) } else { Vec3::ZERO });
    let dist = OctMap::from_fn(res, |_, _, d| if d.z > 0.0 { z / d.z } else { f32::INFINITY });
    (rad, octa::build_distance_mips(dist, 8))
}

/// [`wall_probe`] as a warp context: a box proxy around the wall's half space whose far face
/// stands 1.5·scale behind the wall (so the proxy alone is wrong by a known amount), no k-DOP.
pub fn wall_warp(scale: f32, res: u32) -> Warp {
    let probe = wall_probe(scale, res);
    let aabb = BoxProxy::aabb(Vec3::new(-100.0, -100.0, -10.0) * scale, Vec3::new(100.0, 100.0, 6.5) * scale);
    let kdop = Kdop { normals: Vec::new(), offsets: Vec::new() };
    Warp { probe, others: Default::default(), proxies: Proxies { aabb, kdop }, options: WarpOptions::standard() }
}

/// The wall's cell problem (see [`wall_warp`]): its context, the queries and the true shift
/// map.
pub struct WallProblem<'a> {
    pub ctx: CellContext<'a>,
    /// `samples` queries in the cell with exact references.
    pub samples: Vec<Sample>,
    /// Per texel, the distance from the origin to the wall (+inf where it sees none) and
    /// the shift map it makes.
    pub distance: Vec<f32>,
    pub truth: Vec<f32>,
}

/// The wall's cell problem for `warp` (a [`wall_warp`] at `scale`): a cell centred 1·scale
/// before the probe with an 8×8 map, and `samples` queries in it.
pub fn wall_problem(warp: &Warp, scale: f32, samples: u32) -> WallProblem<'_> {
    let z = 5.0 * scale;
    let origin = Vec3::new(0.8, -0.5, 1.0) * scale;
    let res = 8;
    let glossy = crate::warp::glossy::Glossy { warp, correction: None };
    let ctx = CellContext { glossy, exposure: 1.0, proxy: crate::warp::Method::Box, origin, res, probe_map: &[] };
    let distance: Vec<f32> = (0..res * res)
        .map(|t| {
            let d = octa::texel_dir(res, t % res, t / res);
            if d.z > 0.0 { (z - origin.z) / d.z } else { f32::INFINITY }
        })
        .collect();
    let truth =
        ctx.proxy_distances().iter().zip(&distance).map(|(t, d)| if d.is_finite() { d - t } else { 0.0 }).collect();
    let samples = (0..samples)
        .map(|k| {
            let mut s = Sampler::new(5, 7, k);
            let b = origin + (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
            let mut d = uniform_sphere(s.next_2d());
            d.z = d.z.abs().max(0.2);
            let d = d.normalize();
            Sample::new(b, d, 0.0, wall_radiance(b + d * ((z - b.z) / d.z), scale))
        })
        .collect();
    WallProblem { ctx, samples, distance, truth }
}

/// What fitting the wall problem gave.
pub struct WallFit {
    /// Log-scale parameters of the fitted map.
    pub params: Vec<f64>,
    /// Relative error (the selection criterion) of the start (the proxy alone) and of the
    /// fit, on the training queries.
    pub before: f64,
    pub after: f64,
    /// The same error of the true map: not zero, as the lookup interpolates the map
    /// bilinearly between texel centres over queries spread through the cell.
    pub truth_err: f64,
    pub fitted: Vec<f32>,
    pub truth: Vec<f32>,
    /// Per texel, the distance from the origin to the proxy and to the wall.
    pub proxy_distance: Vec<f32>,
    pub distance: Vec<f32>,
}

/// Fits the wall problem at `scale` (probe of `res`², `samples` queries) with `solver`,
/// `sweeps` iterations, smoothness 1e-4, no size term and no relaxation, from the proxy.
pub fn fit_wall(scale: f32, res: u32, samples: u32, solver: super::Solver, sweeps: u32) -> WallFit {
    let warp = wall_warp(scale, res);
    let WallProblem { ctx, samples, distance, truth } = wall_problem(&warp, scale, samples);
    let start = vec![0.0; 64];
    let mut problem = CellProblem::new(ctx, start.clone(), samples).with_weights(1e-4, 0.0);
    let before = problem.relative_error_map(&problem.map(&start));
    let out = problem.solve(solver, sweeps);
    let fitted = problem.map_with_relax(&out.params, 0.0);
    let after = problem.relative_error_map(&fitted);
    let truth_err = problem.relative_error_map(&truth);
    WallFit {
        params: out.params,
        before,
        after,
        truth_err,
        fitted,
        truth,
        proxy_distance: ctx.proxy_distances(),
        distance,
    }
}
