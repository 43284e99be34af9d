//! The runtime sampler: load a fitted grid folder and answer specular and irradiance queries.
//!
//! This module (with `octa`, `warp`, `grid` and `roughness`) is all a game or tool needs at
//! runtime; it builds without the offline tool (`cargo build --lib --no-default-features`
//! depends only on glam, serde, serde_json and exr).
//!
//! ```no_run
//! use warpfit::runtime::FittedGrid;
//! use glam::Vec3;
//! let grid = FittedGrid::load("fits/torture")?;
//! let reflected = grid.specular(Vec3::new(1.0, 1.2, 0.5), Vec3::new(0.0, 0.3, -1.0), 0.25);
//! let diffuse = grid.irradiance(Vec3::new(1.0, 1.2, 0.5), Vec3::Y);
//! # Ok::<(), warpfit::runtime::LoadError>(())
//! ```
//!
//! Conventions (all documented behaviour, all tested):
//! - `specular(p, dir, r)`: the direction need not be unit length; a zero or non-finite
//!   direction returns black. A non-finite position is treated as the probe's own position
//!   (no parallax). Roughness is perceptual (GGX α = r²), clamped to [0, 1]; NaN reads as 0.
//! - Positions outside the grid use the nearest cell's corrective (the cell lookup clamps),
//!   while the warp itself still starts from the true position; the irradiance blend clamps
//!   the position into the lattice of cell centres.
//! - Results are always finite and ≥ 0 (the payloads are validated on load).
//! - `FittedGrid` is `Send + Sync` and immutable; sampling never allocates.

pub mod exr_layers;
mod load;
pub mod manifest;

pub use load::{LoadError, read_manifest};
pub use manifest::{GridManifest, Precision};

use crate::grid::GridGeometry;
use crate::octa;
use crate::roughness::RoughnessCorrection;
use crate::warp::Warp;
use crate::warp::corrective::{Blend, Correctives};
use glam::{UVec3, Vec3};
use std::path::Path;

/// A loaded fitted grid. Immutable; share it between threads freely.
#[derive(Clone, Debug)]
pub struct FittedGrid {
    /// Probe A, the proxies and the warp options of the fallback method.
    pub warp: Warp,
    /// Perceptual roughness of each radiance mip (increasing, mip 0 = 0).
    pub mip_roughness: Vec<f32>,
    pub blend: Blend,
    pub correctives: Correctives,
    pub irradiance: IrradianceGrid,
    pub roughness: Option<RoughnessLut>,
    pub manifest: GridManifest,
}

/// A valid specular query: position (finite), unit direction, roughness in [0, 1].
#[derive(Clone, Copy, Debug)]
struct SpecularQuery {
    b: Vec3,
    dir: Vec3,
    r: f32,
}

/// Irradiance and distance moments of the stored (not inside geometry) cells.
#[derive(Clone, Debug, PartialEq)]
pub struct IrradianceGrid {
    pub geometry: GridGeometry,
    pub resolution: u32,
    pub depth_resolution: u32,
    /// Per grid cell: slot in the arrays below (`u32::MAX` = not stored).
    pub slot: Vec<u32>,
    /// `slot · resolution² + texel`.
    pub irradiance: Vec<Vec3>,
    /// `slot · depth_resolution² + texel`: mean and mean square of the hit distance.
    pub depth_mean: Vec<f32>,
    pub depth_mean_sq: Vec<f32>,
}

/// The roughness correction, validated, with the table's log-k axis precomputed: the same
/// α' as `RoughnessCorrection::corrected_alpha`, without a logarithm per axis node.
#[derive(Clone, Debug)]
pub struct RoughnessLut {
    alphas: Vec<f32>,
    log_ratios: Vec<f32>,
    table: Vec<f32>,
    /// `Some((c0, c1))` when the analytic model was chosen over the table.
    analytic: Option<(f32, f32)>,
}

impl RoughnessLut {
    /// `None` when the table's axes are not finite and increasing or its size is wrong.
    pub fn new(c: &RoughnessCorrection) -> Option<Self> {
        let increasing =
            |a: &[f32]| a.len() >= 2 && a.iter().all(|x| x.is_finite()) && a.windows(2).all(|w| w[0] < w[1]);
        let ok = increasing(&c.alphas)
            && increasing(&c.ratios)
            && c.ratios[0] > 0.0
            && c.table.len() == c.alphas.len() * c.ratios.len()
            && c.table.iter().all(|x| x.is_finite())
            && c.c0.is_finite()
            && c.c1.is_finite()
            && (c.chosen == "table" || c.chosen == "analytic");
        ok.then(|| RoughnessLut {
            alphas: c.alphas.clone(),
            log_ratios: c.ratios.iter().map(|r| r.ln()).collect(),
            table: c.table.clone(),
            analytic: (c.chosen == "analytic").then_some((c.c0, c.c1)),
        })
    }

    /// Probe-side α' for surface α and distance ratio k = d_probe / d_surface (clamped to
    /// the fitted range); always finite, in [1e-3, 1].
    #[inline]
    pub fn corrected_alpha(&self, alpha: f32, k: f32) -> f32 {
        if !alpha.is_finite() {
            return 1e-3;
        }
        if !(k.is_finite() && k > 0.0) {
            return alpha.clamp(1e-3, 1.0);
        }
        if let Some((c0, c1)) = self.analytic {
            let v = c0 * alpha * k.powf(-c1);
            return if v.is_finite() { v.clamp(1e-3, 1.0) } else { alpha.clamp(1e-3, 1.0) };
        }
        crate::roughness::table_lookup(&self.alphas, &self.log_ratios, |x| x, &self.table, alpha, k.ln())
    }
}

impl FittedGrid {
    /// Loads a fitted grid folder (`manifest.json` + EXR payloads), verifying versions,
    /// checksums, sizes and values.
    pub fn load(dir: impl AsRef<Path>) -> Result<FittedGrid, LoadError> {
        load::load(dir.as_ref())
    }

    /// Fetch vector of probe A for the query (unit `dir`): exactly what the fit evaluated.
    #[inline]
    pub fn fetch_vector(&self, position: Vec3, dir: Vec3) -> Vec3 {
        let b = if position.is_finite() { position } else { self.warp.probe.position };
        self.correctives.fetch_vector(self.blend, &self.warp, b, dir)
    }

    /// Distance ratio k = d_probe / d_surface of the point probe A sees along `v` (whose
    /// octahedral coordinate is `uv`, shared with the radiance fetch).
    #[inline]
    fn distance_ratio(&self, b: Vec3, v: Vec3, uv: glam::Vec2) -> f32 {
        let l = v.length();
        let w = self.warp.probe.inv_depth.sample_lod_uv(uv, self.warp.options.depth_lod);
        if !(l > 0.0 && l.is_finite() && w > 0.0 && w.is_finite()) {
            return 1.0; // sky: both distances infinite
        }
        let d_probe = 1.0 / w;
        let d_surface = (self.warp.probe.position + v * (d_probe / l) - b).length();
        let k = d_probe / d_surface;
        if k.is_finite() && k > 0.0 { k } else { 1.0 }
    }

    /// Fractional radiance mip of perceptual roughness `r` (linear between the mips' values).
    #[inline]
    fn lod(&self, r: f32) -> f32 {
        let m = &self.mip_roughness;
        if m.len() < 2 || !(r > m[0]) {
            return 0.0;
        }
        let last = m.len() - 1;
        if r >= m[last] {
            return last as f32;
        }
        let i = m.iter().map(|&x| (x <= r) as usize).sum::<usize>().clamp(1, last) - 1;
        let span = m[i + 1] - m[i];
        let f = if span > 0.0 { (r - m[i]) / span } else { 0.0 };
        i as f32 + f.clamp(0.0, 1.0)
    }

    /// Radiance reflected towards `dir` from `position` for perceptual roughness `roughness`:
    /// the fitted warp picks where to read probe A, the roughness correction picks the mip.
    #[inline]
    pub fn specular(&self, position: Vec3, direction: Vec3, roughness: f32) -> Vec3 {
        let Some(q) = self.specular_query(position, direction, roughness) else {
            return Vec3::ZERO;
        };
        let v = self.correctives.fetch_vector(self.blend, &self.warp, q.b, q.dir);
        self.shade(q, v)
    }

    /// A specular query made safe (see the module conventions); `None` means black.
    #[inline]
    fn specular_query(&self, position: Vec3, direction: Vec3, roughness: f32) -> Option<SpecularQuery> {
        let l2 = direction.length_squared();
        if !(l2 > 0.0 && l2.is_finite()) {
            return None;
        }
        // unit to rounding: used as is (as the fit used it); otherwise normalised
        let dir = if (l2 - 1.0).abs() <= 4.0 * f32::EPSILON { direction } else { direction / l2.sqrt() };
        let b = if position.is_finite() { position } else { self.warp.probe.position };
        let r = if roughness.is_finite() { roughness.clamp(0.0, 1.0) } else { 0.0 };
        Some(SpecularQuery { b, dir, r })
    }

    /// Radiance of probe A along fetch vector `v` for the query's roughness.
    #[inline]
    fn shade(&self, q: SpecularQuery, v: Vec3) -> Vec3 {
        if q.r == 0.0 {
            return self.warp.probe.radiance(v);
        }
        let uv = octa::encode(v);
        let r = match &self.roughness {
            Some(lut) => {
                let k = self.distance_ratio(q.b, v, uv);
                lut.corrected_alpha(q.r * q.r, k).sqrt()
            }
            None => q.r,
        };
        self.warp.probe.radiance.sample_lod_uv(uv, self.lod(r))
    }

    /// `specular` for [`octa::LANES`] queries at once, bit for bit the same values: the
    /// lanes' fetch vectors are found in lockstep and, when every lane is a mirror query,
    /// the probe is read with the lane sampler.
    #[inline]
    fn specular_lanes(
        &self,
        positions: &[Vec3; octa::LANES],
        directions: &[Vec3; octa::LANES],
        roughness: &[f32; octa::LANES],
    ) -> [Vec3; octa::LANES] {
        let mut q = [SpecularQuery { b: self.warp.probe.position, dir: Vec3::Z, r: 0.0 }; octa::LANES];
        let mut valid = [false; octa::LANES];
        for k in 0..octa::LANES {
            if let Some(query) = self.specular_query(positions[k], directions[k], roughness[k]) {
                (q[k], valid[k]) = (query, true);
            }
        }
        let v = self.correctives.fetch_vector_lanes(self.blend, &self.warp, &q.map(|q| q.b), &q.map(|q| q.dir));
        let mut out = [Vec3::ZERO; octa::LANES];
        if q.iter().all(|q| q.r == 0.0) {
            // mirror lanes (invalid lanes hold a mirror placeholder and are zeroed)
            let radiance = self.warp.probe.radiance_lanes(&v);
            for k in 0..octa::LANES {
                out[k] = if valid[k] { radiance[k] } else { Vec3::ZERO };
            }
            return out;
        }
        for k in 0..octa::LANES {
            if valid[k] {
                out[k] = self.shade(q[k], v[k]);
            }
        }
        out
    }

    /// Irradiance at `position` for surface normal `normal`: the eight cells around the
    /// position, weighted trilinearly, by a smooth back-face term and by Chebyshev visibility
    /// from the cells' distance moments (DDGI, Majercik et al. 2019); cells inside geometry
    /// are skipped and the weights renormalised. Black when no stored cell is near.
    pub fn irradiance(&self, position: Vec3, normal: Vec3) -> Vec3 {
        let n = normal.normalize_or(Vec3::ZERO);
        if n == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let g = &self.irradiance;
        let geo = &g.geometry;
        let p = if position.is_finite() { position } else { geo.min + (geo.max - geo.min) * 0.5 };
        let f = (p - geo.min) / geo.cell_size() - 0.5;
        let hi = (geo.counts - UVec3::ONE).as_vec3();
        let f = if f.is_finite() { f.clamp(Vec3::ZERO, hi) } else { Vec3::ZERO };
        let base = f.floor();
        let frac = f - base;
        let base = base.as_uvec3();
        let taps_n = octa::bilinear_taps(g.resolution, octa::encode(n));
        let cell_size = geo.cell_size();
        let (ir, dr) = (g.resolution, g.depth_resolution);
        let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
        for corner in 0..8u32 {
            let o = UVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let c = (base + o).min(geo.counts - UVec3::ONE);
            let tri = (if o.x == 1 { frac.x } else { 1.0 - frac.x })
                * (if o.y == 1 { frac.y } else { 1.0 - frac.y })
                * (if o.z == 1 { frac.z } else { 1.0 - frac.z });
            if tri <= 0.0 {
                continue;
            }
            let cell = geo.cell_index(c);
            let slot = g.slot[cell];
            if slot == u32::MAX {
                continue;
            }
            let slot = slot as usize;
            let to_point = p - (geo.min + (c.as_vec3() + 0.5) * cell_size);
            let dist = to_point.length();
            let mut w = tri;
            if dist > 0.0 && dist.is_finite() {
                let u = to_point / dist;
                // smooth back face: cells behind the surface count less
                let facing = (n.dot(-u) + 1.0) * 0.5;
                w *= facing * facing + 0.2;
                // Chebyshev visibility of the point from the cell
                let taps = octa::bilinear_taps(dr, octa::encode(u));
                let (mut mean, mut mean_sq) = (0.0f32, 0.0f32);
                let base = slot * (dr * dr) as usize;
                for (t, wt) in taps {
                    mean += g.depth_mean[base + t as usize] * wt;
                    mean_sq += g.depth_mean_sq[base + t as usize] * wt;
                }
                if dist > mean {
                    let var = (mean_sq - mean * mean).abs().max(1e-12 * mean * mean);
                    let d = dist - mean;
                    let cheb = var / (var + d * d);
                    w *= (cheb * cheb * cheb).max(0.0);
                }
            }
            // keep a trace of every stored neighbour so a fully occluded blend stays defined
            let w = w.max(1e-6 * tri);
            let base = slot * (ir * ir) as usize;
            let e: Vec3 = taps_n.iter().map(|&(t, wt)| g.irradiance[base + t as usize] * wt).sum();
            sum += e * w;
            wsum += w;
        }
        if wsum > 0.0 {
            let e = sum / wsum;
            if e.is_finite() { e.max(Vec3::ZERO) } else { Vec3::ZERO }
        } else {
            Vec3::ZERO
        }
    }

    /// `specular` over slices; every slice must have `out.len()` elements.
    pub fn specular_batch(
        &self,
        positions: &[Vec3],
        directions: &[Vec3],
        roughness: &[f32],
        out: &mut [Vec3],
    ) -> Result<(), BatchError> {
        let n = out.len();
        if positions.len() != n || directions.len() != n || roughness.len() != n {
            return Err(BatchError { expected: n, found: [positions.len(), directions.len(), roughness.len()] });
        }
        use octa::group_at;
        octa::fill_in_lanes(
            out,
            |k| self.specular_lanes(group_at(positions, k), group_at(directions, k), group_at(roughness, k)),
            |k| self.specular(positions[k], directions[k], roughness[k]),
        );
        Ok(())
    }

    /// `irradiance` over slices; every slice must have `out.len()` elements.
    pub fn irradiance_batch(&self, positions: &[Vec3], normals: &[Vec3], out: &mut [Vec3]) -> Result<(), BatchError> {
        let n = out.len();
        if positions.len() != n || normals.len() != n {
            return Err(BatchError { expected: n, found: [positions.len(), normals.len(), n] });
        }
        for k in 0..n {
            out[k] = self.irradiance(positions[k], normals[k]);
        }
        Ok(())
    }

    /// Bytes of the loaded data (probe, correctives, irradiance).
    pub fn memory_bytes(&self) -> usize {
        let p = &self.warp.probe;
        let probe: usize = p.radiance.levels.iter().map(|l| l.texels.len() * 12).sum::<usize>()
            + p.inv_depth.levels.iter().map(|l| l.texels.len() * 4).sum::<usize>();
        let c = &self.correctives;
        let g = &self.irradiance;
        probe
            + c.maps.len() * 4
            + c.slot.len() * 4
            + g.irradiance.len() * 12
            + (g.depth_mean.len() + g.depth_mean_sq.len()) * 4
            + g.slot.len() * 4
    }
}

/// Slices of a batch call with different lengths.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BatchError {
    pub expected: usize,
    pub found: [usize; 3],
}

impl std::fmt::Display for BatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "batch slices must all hold {} elements, found {:?}", self.expected, self.found)
    }
}

impl std::error::Error for BatchError {}
