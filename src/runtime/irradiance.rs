//! Diffuse lighting from the dense grid: irradiance maps and distance moments of the stored
//! cells, blended DDGI style (Majercik et al. 2019, "Dynamic Diffuse Global Illumination
//! with Ray-Traced Irradiance Fields"). The data (`gridfile::IrradianceGrid`) is read by the
//! grid file's reader; the sampling lives here.

use crate::grid::GridGeometry;
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
    /// Trilinear, back-face weight and Chebyshev visibility from the distance moments
    /// (DDGI as published in 2019).
    Chebyshev,
    /// `Chebyshev` at the point moved along its normal by the grid's fitted surface bias
    /// ([`IrradianceCorrection::surface_bias`](crate::runtime::IrradianceCorrection), DDGI's
    /// surface bias, Majercik et al. 2021): a point on a wall is weighed from just off it,
    /// so the wall's own probes see it in front of their moments and probes behind a thin
    /// wall see it further behind.
    Biased,
}

impl IrradianceBlend {
    /// Every step, simplest first.
    pub const ALL: [IrradianceBlend; 5] = [
        IrradianceBlend::Nearest,
        IrradianceBlend::Trilinear,
        IrradianceBlend::Backface,
        IrradianceBlend::Chebyshev,
        IrradianceBlend::Biased,
    ];

    /// The step's name in tables.
    pub fn name(self) -> &'static str {
        match self {
            IrradianceBlend::Nearest => "nearest cell",
            IrradianceBlend::Trilinear => "trilinear",
            IrradianceBlend::Backface => "trilinear + back-face weight",
            IrradianceBlend::Chebyshev => "trilinear + back face + Chebyshev (DDGI)",
            IrradianceBlend::Biased => "DDGI + fitted surface bias",
        }
    }
}

/// The terms of one blend (see [`IrradianceGrid::blend_terms`]).
#[derive(Clone, Copy, Debug)]
pub struct BlendTerms {
    /// (cell, blend weight, the cell's irradiance for the normal) of each contributing cell.
    pub terms: [(u32, f32, Vec3); 8],
    /// How many of `terms` are used.
    pub count: usize,
}

/// What a blend reads, borrowed: a grid's irradiance maps and distance moments by slot.
/// A loaded grid's own arrays ([`IrradianceGrid::view`]), or a bake's dense per-cell arrays
/// with each cell its own slot (what the fit weighs with, without a copy of them).
#[derive(Clone, Copy, Debug)]
pub struct IrradianceView<'a> {
    /// The grid's cells.
    pub geometry: GridGeometry,
    /// N of each cell's N×N irradiance map.
    pub resolution: u32,
    /// N of each cell's N×N distance-moment maps.
    pub depth_resolution: u32,
    /// Per grid cell: slot in the arrays below ([`NO_MAP`]: not stored).
    pub slot: &'a [u32],
    /// `slot · resolution² + texel`: the cosine-convolved irradiance.
    pub irradiance: &'a [Vec3],
    /// `slot · depth_resolution² + texel`: mean hit distance.
    pub depth_mean: &'a [f32],
    /// `slot · depth_resolution² + texel`: mean squared hit distance.
    pub depth_mean_sq: &'a [f32],
    /// Per grid cell: its probe's offset from the cell centre (may be empty: none moved).
    pub probe_offset: &'a [Vec3],
}

/// Each stored cell's irradiance as nine spherical-harmonic coefficients (bands 0–2,
/// [`crate::sh`]), projected from its octahedral map: what a rough specular lookup blends in
/// (`FittedGrid::specular`). Derived from the maps when a grid is loaded, so files carry
/// nothing new; smooth over directions and read without the map's seams.
#[derive(Clone, Debug, PartialEq)]
pub struct IrradianceSh {
    /// The grid's cells.
    pub geometry: GridGeometry,
    /// Per grid cell: slot in `coeffs` ([`NO_MAP`]: not stored).
    pub slot: Vec<u32>,
    /// Per slot: the nine coefficients (RGB).
    pub coeffs: Vec<[glam::Vec3A; crate::sh::COEFFS]>,
    /// `geometry.cell_size()`, kept: it costs three divisions a lookup.
    pub cell_size: Vec3,
}

impl IrradianceSh {
    /// The coefficients of every slot of `view`'s irradiance maps.
    #[must_use]
    pub fn project(view: &IrradianceView) -> IrradianceSh {
        let texels = (view.resolution * view.resolution) as usize;
        let weights = crate::sh::projection_weights(view.resolution);
        let coeffs = view.irradiance.chunks_exact(texels.max(1)).map(|map| crate::sh::project(map, &weights)).collect();
        let cell_size = view.geometry.cell_size();
        IrradianceSh { geometry: view.geometry, slot: view.slot.to_vec(), coeffs, cell_size }
    }

    /// Irradiance for unit direction `n` of the cell that contains `position` (finite), if
    /// that cell is stored.
    #[inline]
    #[must_use]
    pub fn nearest(&self, position: Vec3, n: Vec3) -> Option<Vec3> {
        let geo = &self.geometry;
        self.cell(geo.cell_index(geo.cell_of_sized(position, self.cell_size)), n)
    }

    /// Irradiance of grid cell `cell` for unit direction `n`, if the cell is stored and the
    /// sum is finite: every read of the harmonics goes through it.
    #[inline]
    fn cell(&self, cell: usize, n: Vec3) -> Option<Vec3> {
        let c = self.slot.get(cell).and_then(|&s| self.coeffs.get(s as usize))?;
        Some(crate::sh::eval(c, n)).filter(|e| e.is_finite())
    }

    /// The grid cells that contain `positions` (finite or not), as
    /// [`IrradianceSh::nearest`] finds each.
    #[inline]
    #[must_use]
    pub fn lane_cells(&self, positions: &[Vec3; octa::LANES]) -> [usize; octa::LANES] {
        self.geometry.cell_index_soa(&octa::soa(positions), self.cell_size)
    }

    /// `out[k]` blended with lane k's [`IrradianceSh::nearest`] by weight `w[k]`
    /// ([`super::mix_irradiance`]) where the weight is positive and the cell stored; bit
    /// for bit the single calls. `cells` are the lanes' [`IrradianceSh::lane_cells`].
    #[inline]
    pub fn mix_lanes(
        &self,
        cells: &[usize; octa::LANES],
        n: &[Vec3; octa::LANES],
        w: &[f32; octa::LANES],
        out: &mut [Vec3; octa::LANES],
    ) {
        for k in 0..octa::LANES {
            if !(w[k] > 0.0) {
                continue;
            }
            if let Some(e) = self.cell(cells[k], n[k]) {
                out[k] = super::mix_irradiance(out[k], e, w[k]);
            }
        }
    }
}

impl IrradianceGrid {
    /// The grid's arrays as a blend reads them.
    #[inline]
    #[must_use]
    pub fn view(&self) -> IrradianceView<'_> {
        IrradianceView {
            geometry: self.geometry,
            resolution: self.resolution,
            depth_resolution: self.depth_resolution,
            slot: &self.slot,
            irradiance: &self.irradiance,
            depth_mean: &self.depth_mean,
            depth_mean_sq: &self.depth_mean_sq,
            probe_offset: &self.probe_offset,
        }
    }

    /// Irradiance at `position` for surface normal `normal`: the eight cells around the
    /// position moved along the normal by the fitted surface bias, weighted trilinearly, by
    /// a smooth back-face term and by Chebyshev visibility from the cells' distance moments
    /// (DDGI, Majercik et al. 2019 and 2021: [`IrradianceBlend::Biased`]); cells inside
    /// geometry are skipped and the weights renormalised. Each cell's irradiance is multiplied by its
    /// fitted correction for the normal where it stores one, inside the blend, so the answer
    /// stays continuous across cell faces. Black when no stored cell is near.
    #[must_use]
    pub fn irradiance(&self, position: Vec3, normal: Vec3) -> Vec3 {
        let Some(n) = crate::octa::unit_direction(normal) else {
            return Vec3::ZERO;
        };
        let terms = self.blend_terms(position, n, IrradianceBlend::Biased);
        let c = &self.correction;
        let ctaps = (!c.slot.is_empty()).then(|| octa::bilinear_taps(c.resolution, octa::encode(n)));
        let mut e = Vec3::ZERO;
        for &(cell, w, ei) in &terms.terms[..terms.count] {
            let k = ctaps.as_ref().map_or(1.0, |t| c.scale_taps(cell as usize, t));
            e += ei * (w * k);
        }
        if e.is_finite() { e.max(Vec3::ZERO) } else { Vec3::ZERO }
    }

    /// [`IrradianceGrid::irradiance`] without the fitted corrections, with the blend's steps
    /// chosen by `blend`.
    #[must_use]
    pub fn irradiance_blend(&self, position: Vec3, normal: Vec3, blend: IrradianceBlend) -> Vec3 {
        let Some(n) = crate::octa::unit_direction(normal) else {
            return Vec3::ZERO;
        };
        let terms = self.blend_terms(position, n, blend);
        let e: Vec3 = terms.terms[..terms.count].iter().map(|&(_, w, e)| e * w).sum();
        if e.is_finite() { e.max(Vec3::ZERO) } else { Vec3::ZERO }
    }

    /// The blend's terms at `position` for unit normal `n`: up to eight (cell, normalised
    /// weight, the cell's irradiance for `n`). The weights sum to 1 when any cell counts.
    #[must_use]
    pub fn blend_terms(&self, position: Vec3, n: Vec3, blend: IrradianceBlend) -> BlendTerms {
        match blend {
            IrradianceBlend::Biased => self.view().biased_terms(position, n, self.correction.surface_bias),
            _ => self.view().terms(position, n, blend),
        }
    }

    /// The terms of [`IrradianceBlend::Biased`] with surface bias `bias` (a fraction of the
    /// smallest cell extent) instead of the grid's: what the fit chooses the bias with.
    #[must_use]
    pub fn biased_terms(&self, position: Vec3, n: Vec3, bias: f32) -> BlendTerms {
        self.view().biased_terms(position, n, bias)
    }

    /// How far [`IrradianceBlend::Biased`] moves a point along its normal, in scene units:
    /// the fitted surface bias times the smallest cell extent.
    #[must_use]
    pub fn surface_shift(&self) -> f32 {
        self.view().shift(self.correction.surface_bias)
    }
}

impl IrradianceView<'_> {
    /// The terms of [`IrradianceBlend::Biased`] with surface bias `bias` (a fraction of the
    /// smallest cell extent).
    #[must_use]
    pub fn biased_terms(&self, position: Vec3, n: Vec3, bias: f32) -> BlendTerms {
        self.terms(position + n * self.shift(bias), n, IrradianceBlend::Chebyshev)
    }

    /// `bias` (a fraction of the smallest cell extent) in scene units.
    fn shift(&self, bias: f32) -> f32 {
        bias * self.geometry.cell_size().min_element()
    }

    /// Irradiance for unit direction `n` of the cell that contains `position` (finite), if
    /// that cell is stored, bilinear in its map: [`IrradianceBlend::Nearest`] without its
    /// bookkeeping. (Rough specular lookups read the same cell's harmonics instead,
    /// [`IrradianceSh::nearest`].)
    #[inline]
    #[must_use]
    pub fn nearest(&self, position: Vec3, n: Vec3) -> Option<Vec3> {
        let geo = &self.geometry;
        self.cell_irradiance(geo.cell_index(geo.cell_of(position)), n).filter(|e| e.is_finite())
    }

    /// Irradiance of the stored cell `cell` for unit normal `n` (bilinear in its map), if
    /// the cell is stored.
    #[inline]
    fn cell_irradiance(&self, cell: usize, n: Vec3) -> Option<Vec3> {
        let slot = self.slot[cell];
        (slot != NO_MAP)
            .then(|| self.slot_irradiance(slot as usize, &octa::bilinear_taps(self.resolution, octa::encode(n))))
    }

    /// The irradiance map of slot `slot` blended over bilinear `taps` (texel, weight), summed
    /// in tap order: every read of one cell's map goes through it.
    #[inline]
    fn slot_irradiance(&self, slot: usize, taps: &[(u32, f32); 4]) -> Vec3 {
        let base = slot * (self.resolution * self.resolution) as usize;
        taps.iter().map(|&(t, wt)| self.irradiance[base + t as usize] * wt).sum()
    }

    /// The terms of `blend` (not `Biased`: see [`IrradianceView::biased_terms`]).
    fn terms(&self, position: Vec3, n: Vec3, blend: IrradianceBlend) -> BlendTerms {
        let mut out = BlendTerms { terms: [(0, 0.0, Vec3::ZERO); 8], count: 0 };
        let g = self;
        let geo = &g.geometry;
        let p = if position.is_finite() { position } else { geo.min + (geo.max - geo.min) * 0.5 };
        if blend == IrradianceBlend::Nearest {
            let cell = geo.cell_index(geo.cell_of(p));
            if let Some(e) = self.cell_irradiance(cell, n).filter(|e| e.is_finite()) {
                out.terms[0] = (cell as u32, 1.0, e);
                out.count = 1;
            }
            return out;
        }
        let (backface, visibility) = (blend != IrradianceBlend::Trilinear, blend == IrradianceBlend::Chebyshev);
        let f = (p - geo.min) / geo.cell_size() - 0.5;
        let hi = (geo.counts - UVec3::ONE).as_vec3();
        let f = if f.is_finite() { f.clamp(Vec3::ZERO, hi) } else { Vec3::ZERO };
        let base = f.floor();
        let frac = f - base;
        let base = base.as_uvec3();
        let taps_n = octa::bilinear_taps(g.resolution, octa::encode(n));
        let cell_size = geo.cell_size();
        let dr = g.depth_resolution;
        let mut wsum = 0.0f32;
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
            let probe =
                geo.min + (c.as_vec3() + 0.5) * cell_size + g.probe_offset.get(cell).copied().unwrap_or(Vec3::ZERO);
            let to_point = p - probe;
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
            let e = g.slot_irradiance(slot, &taps_n);
            out.terms[out.count] = (cell as u32, w, e);
            out.count += 1;
            wsum += w;
        }
        if wsum > 0.0 {
            for t in &mut out.terms[..out.count] {
                t.1 /= wsum;
            }
        } else {
            out.count = 0;
        }
        out
    }
}
