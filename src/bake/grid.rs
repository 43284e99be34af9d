//! The dense probe grid (Black Ops 3 / DDGI style): per cell centre, a cosine-convolved
//! irradiance octahedral map and distance moments (mean, mean of squares, hit fraction) on a
//! separate octahedral map. Cells whose centre is inside geometry are flagged.
//!
//! Each cell traces `depth_resolution² × depth_samples` rays, stratified inside the distance
//! texels; the same rays' radiance is convolved with the clamped cosine for irradiance, each
//! weighted by its texel's exact solid angle.

use crate::octa::{self, texel_solid_angles};
use crate::progress::Progress;
use crate::sampling::{Sampler, hash_pair};
use crate::trace::Renderer;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

pub const DOMAIN_GRID: u64 = 0x4752_4944; // "GRID"

pub use crate::grid::GridGeometry;

/// Baked grid as plain arrays, cell-major (`cell · res² + texel`).
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeGrid {
    pub geometry: GridGeometry,
    pub irradiance_resolution: u32,
    pub depth_resolution: u32,
    pub depth_samples: u32,
    /// Irradiance E(n) (W/m²-like units of the scene's radiance × sr) for each texel normal.
    pub irradiance: Vec<Vec3>,
    /// Mean distance per depth texel, misses counted as `far_distance`.
    pub depth_mean: Vec<f32>,
    /// Mean squared distance per depth texel (same convention).
    pub depth_mean_sq: Vec<f32>,
    /// Fraction of the texel's rays that hit geometry.
    pub hit_fraction: Vec<f32>,
    /// Cell centre inside geometry (too many back-face hits).
    pub inside: Vec<bool>,
    /// Distance standing in for "miss" in the moments: 4 × the scene's bounds diagonal.
    pub far_distance: f32,
}

impl ProbeGrid {
    pub fn active_cells(&self) -> usize {
        self.inside.iter().filter(|x| !**x).count()
    }
}

pub struct GridSettings {
    pub geometry: GridGeometry,
    pub irradiance_resolution: u32,
    pub depth_resolution: u32,
    pub depth_samples: u32,
    pub inside_backface_fraction: f32,
    pub far_distance: f32,
    pub seed: u64,
}

struct CellBake {
    irradiance: Vec<Vec3>,
    mean: Vec<f32>,
    mean_sq: Vec<f32>,
    hit: Vec<f32>,
    inside: bool,
    rays: u64,
}

/// Bakes every cell; returns the grid and the number of rays traced.
pub fn bake_grid(renderer: &Renderer, s: &GridSettings, progress: &Progress) -> (ProbeGrid, u64) {
    let cells = s.geometry.cell_count();
    let dres = s.depth_resolution;
    let ires = s.irradiance_resolution;
    let depth_omega = texel_solid_angles(dres);
    let irr_normals: Vec<Vec3> = (0..ires * ires).map(|t| octa::texel_dir(ires, t % ires, t / ires)).collect();
    let bar = progress.bar(cells as u64, "grid cells");
    let baked: Vec<CellBake> = (0..cells)
        .into_par_iter()
        .map(|cell| {
            let r = bake_cell(renderer, s, cell, &depth_omega, &irr_normals);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut grid = ProbeGrid {
        geometry: s.geometry,
        irradiance_resolution: ires,
        depth_resolution: dres,
        depth_samples: s.depth_samples,
        irradiance: Vec::with_capacity(cells * (ires * ires) as usize),
        depth_mean: Vec::with_capacity(cells * (dres * dres) as usize),
        depth_mean_sq: Vec::with_capacity(cells * (dres * dres) as usize),
        hit_fraction: Vec::with_capacity(cells * (dres * dres) as usize),
        inside: Vec::with_capacity(cells),
        far_distance: s.far_distance,
    };
    let mut rays = 0;
    for c in baked {
        grid.irradiance.extend(c.irradiance);
        grid.depth_mean.extend(c.mean);
        grid.depth_mean_sq.extend(c.mean_sq);
        grid.hit_fraction.extend(c.hit);
        grid.inside.push(c.inside);
        rays += c.rays;
    }
    (grid, rays)
}

fn bake_cell(
    renderer: &Renderer,
    s: &GridSettings,
    cell: usize,
    depth_omega: &[f32],
    irr_normals: &[Vec3],
) -> CellBake {
    let dres = s.depth_resolution;
    let centre = s.geometry.cell_centre(cell);
    let cell_stream = hash_pair(DOMAIN_GRID, cell as u64);
    let mut rays = 0u64;
    let mut irradiance = vec![Vec3::ZERO; irr_normals.len()];
    let mut cosine_sum = vec![0.0f32; irr_normals.len()];
    let mut mean = Vec::with_capacity((dres * dres) as usize);
    let mut mean_sq = Vec::with_capacity((dres * dres) as usize);
    let mut hit = Vec::with_capacity((dres * dres) as usize);
    let mut backfaces = crate::trace::truth::Backfaces::default();
    let spp = s.depth_samples;
    for t in 0..dres * dres {
        let (i, j) = (t % dres, t / dres);
        let stream = hash_pair(cell_stream, t as u64);
        let weight = depth_omega[t as usize] / spp as f32;
        let (mut d1, mut d2, mut hits) = (0.0f64, 0.0f64, 0u32);
        for k in 0..spp {
            let mut sampler = Sampler::new(s.seed, stream, k);
            let uv = (Vec2::new(i as f32, j as f32) + sampler.next_2d()) / dres as f32;
            let dir = octa::decode(uv);
            let r = renderer.sample(centre, dir, &mut sampler, &mut rays);
            let d = if r.distance.is_finite() {
                hits += 1;
                r.distance.min(s.far_distance)
            } else {
                s.far_distance
            };
            d1 += d as f64;
            d2 += (d as f64) * (d as f64);
            backfaces.add(r.backface || r.backface_two_sided, r.backface_two_sided);
            for ((e, cs), n) in irradiance.iter_mut().zip(&mut cosine_sum).zip(irr_normals) {
                let c = n.dot(dir);
                if c > 0.0 {
                    *e += r.radiance * (c * weight);
                    *cs += c * weight;
                }
            }
        }
        mean.push((d1 / spp as f64) as f32);
        mean_sq.push((d2 / spp as f64) as f32);
        hit.push(hits as f32 / spp as f32);
    }
    // Ratio estimator: normalise by the quadrature of ∫cos = π itself, which makes a constant
    // environment exact and removes the quadrature's bias elsewhere.
    for (e, cs) in irradiance.iter_mut().zip(&cosine_sum) {
        *e = if *cs > 0.0 { *e * (std::f32::consts::PI / *cs) } else { Vec3::ZERO };
    }
    let inside = crate::trace::truth::inside_by_backfaces(backfaces, s.inside_backface_fraction);
    CellBake { irradiance, mean, mean_sq, hit, inside, rays }
}
