//! Diffuse lighting from the dense grid: irradiance maps and distance moments of the stored
//! cells, blended DDGI style (Majercik et al. 2019, "Dynamic Diffuse Global Illumination
//! with Ray-Traced Irradiance Fields"). The data (`gridfile::IrradianceGrid`) is read by the
//! grid file's reader; the sampling lives here.

use crate::gridfile::IrradianceGrid;
use crate::octa;
use crate::warp::corrective::NO_MAP;
use glam::{UVec3, Vec3};

/// How the cells around a point are combined: the steps of DDGI's blend, each a baseline
/// the evaluation measures (`Chebyshev` is what [`IrradianceGrid::irradiance`] does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IrradianceBlend {
    /// The containing cell alone (the nearest probe).
    Nearest,
    /// The eight cells around the point, trilinear weights only.
    Trilinear,
    /// Trilinear, and cells behind the surface count less (smooth back-face weight).
    Backface,
    /// Trilinear, back-face weight and Chebyshev visibility from the distance moments.
    Chebyshev,
}

impl IrradianceBlend {
    pub const ALL: [IrradianceBlend; 4] =
        [IrradianceBlend::Nearest, IrradianceBlend::Trilinear, IrradianceBlend::Backface, IrradianceBlend::Chebyshev];

    pub fn name(self) -> &'static str {
        match self {
            IrradianceBlend::Nearest => "nearest cell",
            IrradianceBlend::Trilinear => "trilinear",
            IrradianceBlend::Backface => "trilinear + back-face weight",
            IrradianceBlend::Chebyshev => "trilinear + back face + Chebyshev (DDGI)",
        }
    }
}

impl IrradianceGrid {
    /// Irradiance at `position` for surface normal `normal`: the eight cells around the
    /// position, weighted trilinearly, by a smooth back-face term and by Chebyshev visibility
    /// from the cells' distance moments (DDGI, Majercik et al. 2019); cells inside geometry
    /// are skipped and the weights renormalised. Black when no stored cell is near.
    /// Where the containing cell stores a fitted correction, its scale for the normal
    /// multiplies the blend.
    #[must_use]
    pub fn irradiance(&self, position: Vec3, normal: Vec3) -> Vec3 {
        let e = self.irradiance_blend(position, normal, IrradianceBlend::Chebyshev);
        if self.correction.slot.is_empty() {
            return e;
        }
        let (Some(n), true) = (crate::octa::unit_direction(normal), position.is_finite()) else { return e };
        let cell = self.geometry.cell_index(self.geometry.cell_of(position));
        let k = self.correction.scale(cell, n);
        if k.is_finite() && k >= 0.0 { e * k } else { e }
    }

    /// Irradiance of the stored cell `cell` for unit normal `n` (bilinear in its map), if
    /// the cell is stored.
    #[inline]
    fn cell_irradiance(&self, cell: usize, n: Vec3) -> Option<Vec3> {
        let slot = self.slot[cell];
        if slot == NO_MAP {
            return None;
        }
        let ir = self.resolution;
        let base = slot as usize * (ir * ir) as usize;
        let taps = octa::bilinear_taps(ir, octa::encode(n));
        Some(taps.iter().map(|&(t, wt)| self.irradiance[base + t as usize] * wt).sum())
    }

    /// [`IrradianceGrid::irradiance`] with the blend's steps chosen by `blend`.
    #[must_use]
    pub fn irradiance_blend(&self, position: Vec3, normal: Vec3, blend: IrradianceBlend) -> Vec3 {
        let Some(n) = crate::octa::unit_direction(normal) else {
            return Vec3::ZERO;
        };
        if blend == IrradianceBlend::Nearest {
            let geo = &self.geometry;
            let p = if position.is_finite() { position } else { geo.min + (geo.max - geo.min) * 0.5 };
            let e = self.cell_irradiance(geo.cell_index(geo.cell_of(p)), n).unwrap_or(Vec3::ZERO);
            return if e.is_finite() { e.max(Vec3::ZERO) } else { Vec3::ZERO };
        }
        let (backface, visibility) = (blend != IrradianceBlend::Trilinear, blend == IrradianceBlend::Chebyshev);
        let g = self;
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
            if slot == NO_MAP {
                continue;
            }
            let slot = slot as usize;
            let to_point = p - (geo.min + (c.as_vec3() + 0.5) * cell_size);
            let dist = to_point.length();
            let mut w = tri;
            if dist > 0.0 && dist.is_finite() && backface {
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
                if visibility && dist > mean {
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
}
