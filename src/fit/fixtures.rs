//! Closed-form fixtures of the fit: a probe before an infinite textured wall, and the cell
//! problem whose true warp map is known. Shared by the fitter's tests and the stability
//! suite.

use super::objective::Sample;
use crate::octa::{self, OctMap, OctMips};
use crate::sampling::{Sampler, uniform_sphere};
use crate::warp::WarpProbe;
use glam::Vec3;

/// Texture on the wall z = 5·scale.
fn wall_radiance(p: Vec3, scale: f32) -> Vec3 {
    let (x, y) = (p.x / scale, p.y / scale);
    Vec3::new(0.5 + 0.4 * (1.3 * x).sin() * (1.1 * y).cos(), 0.5 + 0.3 * (0.9 * x + 0.4 * y).sin(), 0.4)
}

/// Closed-form fixture: a probe at the origin (`res`² map) before an infinite textured wall
/// at z = 5·scale.
pub fn wall_probe(scale: f32, res: u32) -> WarpProbe {
    let z = 5.0 * scale;
    let rad = OctMap::from_fn(res, |_, _, d| if d.z > 0.0 { wall_radiance(d * (z / d.z), scale) } else { Vec3::ZERO });
    let dist = OctMap::from_fn(res, |_, _, d| if d.z > 0.0 { z / d.z } else { f32::INFINITY });
    WarpProbe::from_distance_mips(Vec3::ZERO, &octa::build_distance_mips(dist, 8), OctMips { levels: vec![rad] })
}

/// The wall's cell problem: a cell centred 1·scale before the probe whose 8×8 map starts 30%
/// too near, and `samples` queries in the cell with exact references. Returns the starting
/// map, the queries, the cell centre and the true map.
pub fn wall_problem(scale: f32, samples: u32) -> (Vec<f32>, Vec<Sample>, Vec3, Vec<f32>) {
    let z = 5.0 * scale;
    let c = Vec3::new(0.8, -0.5, 1.0) * scale;
    let res = 8;
    let truth: Vec<f32> = (0..res * res)
        .map(|t| {
            let d = octa::texel_dir(res, t % res, t / res);
            if d.z > 0.0 { d.z / (z - c.z) } else { 0.0 }
        })
        .collect();
    let init = truth.iter().map(|w| w * 1.3).collect();
    let qs = (0..samples)
        .map(|k| {
            let mut s = Sampler::new(5, 7, k);
            let b = c + (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
            let mut d = uniform_sphere(s.next_2d());
            d.z = d.z.abs().max(0.2);
            let d = d.normalize();
            Sample { b, dir: d, reference: wall_radiance(b + d * ((z - b.z) / d.z), scale), taps: [(0, 0.0); 4] }
        })
        .collect();
    (init, qs, c, truth)
}
