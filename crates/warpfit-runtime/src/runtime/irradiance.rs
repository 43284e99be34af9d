//! Diffuse lighting from the dense grid: irradiance maps and distance moments of the stored
//! cells, blended DDGI style (Majercik et al. 2019, "Dynamic Diffuse Global Illumination
//! with Ray-Traced Irradiance Fields"). The data (`gridfile::IrradianceGrid`) is read by the
//! grid file's reader; the sampling lives here.

use crate::grid::GridGeometry;
use crate::gridfile::IrradianceGrid;
use crate::octa;
use crate::warp::corrective::{FaceCells, NO_MAP};
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
/// [`crate::sh`]), projected from its octahedral map, and which of its 26 neighbours a
/// read may blend it with: what a rough specular lookup blends in (`FittedGrid::specular`,
/// [`IrradianceSh::read`]). Derived from the maps and distance moments when a grid is
/// loaded, so files carry nothing new; smooth over directions and read without the map's
/// seams.
#[derive(Clone, Debug, PartialEq)]
pub struct IrradianceSh {
    /// The grid's cells.
    pub geometry: GridGeometry,
    /// Per grid cell: slot in `coeffs` ([`NO_MAP`]: not stored).
    pub slot: Vec<u32>,
    /// Per slot: the nine coefficients (RGB).
    pub coeffs: Vec<[glam::Vec3A; crate::sh::COEFFS]>,
    /// Per grid cell: bit [`link_bit`]`(o)` set where the cell at offset `o` ∈ {−1, 0, 1}³
    /// is stored and linked to it ([`IrradianceSh::project`]); 0 for a cell not stored,
    /// and a stored cell links to itself.
    pub links: Vec<u32>,
    /// `geometry.cell_size()`, kept: it costs three divisions a lookup.
    pub cell_size: Vec3,
}

/// Two neighbouring probes see each other when each one's mean hit distance towards the
/// other (its distance moments, bilinear) reaches this fraction of their distance.
pub const LINK_SEES: f32 = 0.9;
/// Two neighbouring cells link only when their irradiance (band 0, summed over RGB) is
/// within this factor either way: a cell beside a small lamp would otherwise spread its
/// light into cells the lamp does not reach.
pub const LINK_RATIO: f32 = 4.0;

/// The bit of offset `o` ∈ {−1, 0, 1}³ in [`IrradianceSh::links`].
#[inline(always)]
#[must_use]
pub fn link_bit(o: glam::IVec3) -> u32 {
    1 << ((o.x + 1) + 3 * (o.y + 1) + 9 * (o.z + 1))
}

impl IrradianceSh {
    /// The coefficients of every slot of `view`'s irradiance maps, and each stored cell's
    /// links: a neighbour (of the 26) is linked when it is stored, the two probes see each
    /// other ([`LINK_SEES`]) and their irradiance is within [`LINK_RATIO`].
    #[must_use]
    pub fn project(view: &IrradianceView) -> IrradianceSh {
        let coeffs = coefficients(view);
        let links = links(view, &coeffs);
        IrradianceSh::with_links(view, coeffs, links)
    }

    /// The coefficients of `view`'s maps with `self`'s links (the same grid): for maps that
    /// hold a part of the irradiance (the evaluation's emitted part), read over the cells
    /// the whole irradiance links.
    #[must_use]
    pub fn reproject(&self, view: &IrradianceView) -> IrradianceSh {
        IrradianceSh::with_links(view, coefficients(view), self.links.clone())
    }

    fn with_links(
        view: &IrradianceView,
        coeffs: Vec<[glam::Vec3A; crate::sh::COEFFS]>,
        links: Vec<u32>,
    ) -> IrradianceSh {
        let cell_size = view.geometry.cell_size();
        IrradianceSh { geometry: view.geometry, slot: view.slot.to_vec(), coeffs, links, cell_size }
    }

    /// Irradiance for unit direction `n` of the cell that contains `position` (finite), if
    /// that cell is stored: its own harmonics.
    #[inline]
    #[must_use]
    pub fn nearest(&self, position: Vec3, n: Vec3) -> Option<Vec3> {
        let geo = &self.geometry;
        self.cell(geo.cell_index(geo.cell_of_sized(position, self.cell_size)), n)
    }

    /// Irradiance of grid cell `cell` for unit direction `n`, if the cell is stored and the
    /// sum is finite.
    #[inline]
    fn cell(&self, cell: usize, n: Vec3) -> Option<Vec3> {
        let c = self.slot.get(cell).and_then(|&s| self.coeffs.get(s as usize))?;
        Some(crate::sh::eval(c, n)).filter(|e| e.is_finite())
    }

    /// Irradiance for unit direction `n` at `position` (finite), smooth across cells, if
    /// the cell that contains the point is stored: what a rough lookup blends in. The cells
    /// whose centres surround the point are interpolated over the tetrahedron of their
    /// lattice cube that holds it (the cube split along its diagonal into six, the corners
    /// taken in the order of the point's fractions: four cells, linear inside each
    /// tetrahedron and continuous across them). The containing cell is always one of the
    /// four; the others count only where it links to them ([`IrradianceSh::links`]), and
    /// the kept weights are renormalised. The coefficients are summed, then read once.
    #[inline]
    #[must_use]
    pub fn read(&self, position: Vec3, n: Vec3) -> Option<Vec3> {
        // the point in cell units: its cell (as `cell_of_sized` finds it) and its place in
        // the lattice of cell centres
        let units = (position - self.geometry.min) / self.cell_size;
        self.read_from(self.geometry.cell_of_units(units), units, n)
    }

    /// [`read`](Self::read) as if the point lay in the cell at `home_at` (one of the cells
    /// whose centres surround it): that cell's links decide which neighbours count.
    #[inline]
    #[must_use]
    pub fn read_in(&self, home_at: UVec3, position: Vec3, n: Vec3) -> Option<Vec3> {
        self.read_from(home_at, (position - self.geometry.min) / self.cell_size, n)
    }

    /// The irradiance a faces-blend lookup blends in at `position` (near cells `cells`,
    /// `Correctives::face_cells`): the near cells' reads ([`read_in`](Self::read_in)), each
    /// as if the point lay in it, averaged over those that hold irradiance by their weights,
    /// and the share of the weight those hold; `None` where none does.
    #[inline]
    #[must_use]
    pub fn read_near(&self, cells: &FaceCells, position: Vec3, n: Vec3) -> Option<(Vec3, f32)> {
        let (mut sum, mut share) = (Vec3::ZERO, 0.0f32);
        for k in 0..cells.n {
            if let Some(e) = self.read_in(self.geometry.cell_coords(cells.cells[k]), position, n) {
                sum += cells.weights[k] * e;
                share += cells.weights[k];
            }
        }
        (share > 0.0).then(|| (sum / share, share))
    }

    #[inline]
    fn read_from(&self, home_at: UVec3, units: Vec3, n: Vec3) -> Option<Vec3> {
        let geo = &self.geometry;
        let home = geo.cell_index(home_at);
        let links = *self.links.get(home)?;
        if links == 0 {
            return None;
        }
        let f = units - 0.5;
        if !f.is_finite() {
            return self.cell(home, n);
        }
        let (counts, home_at) = (geo.counts.to_array(), home_at.to_array());
        let top = [counts[0] - 1, counts[1] - 1, counts[2] - 1];
        let f = f.clamp(Vec3::ZERO, UVec3::from_array(top).as_vec3()).to_array();
        let (mut base, mut frac) = ([0u32; 3], [0.0f32; 3]);
        for x in 0..3 {
            let (i, fl) = octa::floor_small(f[x]);
            (base[x], frac[x]) = (i as u32, f[x] - fl);
        }
        // the axes by decreasing fraction (ties in axis order): the tetrahedron's corners
        // are base, then base plus each axis in turn (held to the grid's last cell); its
        // weights the fractions' steps
        let (mut a, mut b, mut c) = (0usize, 1usize, 2usize);
        if frac[b] > frac[a] {
            (a, b) = (b, a);
        }
        if frac[c] > frac[b] {
            (b, c) = (c, b);
            if frac[b] > frac[a] {
                (a, b) = (b, a);
            }
        }
        let weights = [1.0 - frac[a], frac[a] - frac[b], frac[b] - frac[c], frac[c]];
        // each corner's index and its bit in `links` (base is the containing cell or the
        // one below it on each axis), stepped along with it
        let cell_stride = [1, counts[0], counts[0] * counts[1]];
        let bit_stride = [1u32, 3, 9];
        let (mut cells, mut bits) = ([geo.cell_index(UVec3::from_array(base)) as u32; 4], [0u32; 4]);
        for x in 0..3 {
            // 0 or 1 (held there for coordinates past 2²², where floors are not exact)
            bits[0] += (base[x] + 1).saturating_sub(home_at[x]).min(2) * bit_stride[x];
        }
        let axes = [a, b, c];
        for k in 1..4 {
            let x = axes[k - 1];
            let step = base[x] < top[x];
            cells[k] = cells[k - 1] + if step { cell_stride[x] } else { 0 };
            bits[k] = bits[k - 1] + if step { bit_stride[x] } else { 0 };
        }
        // the corners the containing cell links to keep their weights; the others weigh 0
        // and read the containing cell, so the sum below runs the same for every point
        let home_slot = self.slot.get(home).copied().filter(|&s| (s as usize) < self.coeffs.len())?;
        let (mut w, mut slot) = ([0.0f32; 4], [home_slot; 4]);
        for k in 0..4 {
            let s = self.slot.get(cells[k] as usize).copied().unwrap_or(NO_MAP);
            if links.checked_shr(bits[k]).unwrap_or(0) & 1 != 0 && (s as usize) < self.coeffs.len() {
                (w[k], slot[k]) = (weights[k], s);
            }
        }
        let wsum = (w[0] + w[1]) + (w[2] + w[3]);
        if !(wsum > 0.0) {
            return self.cell(home, n);
        }
        let cs = slot.map(|s| &self.coeffs[s as usize]);
        let acc: [glam::Vec3A; crate::sh::COEFFS] =
            std::array::from_fn(|i| (cs[0][i] * w[0] + cs[1][i] * w[1]) + (cs[2][i] * w[2] + cs[3][i] * w[3]));
        Some(Vec3::from(crate::sh::eval_a(&acc, n) / wsum)).filter(|e| e.is_finite())
    }

    /// `out[k]` blended with lane k's [`IrradianceSh::read`] by weight `w[k]`
    /// ([`super::mix_irradiance`]) where the weight is positive and the cell stored; bit
    /// for bit the single calls.
    #[inline]
    pub fn mix_lanes(
        &self,
        positions: &[Vec3; octa::LANES],
        n: &[Vec3; octa::LANES],
        w: &[f32; octa::LANES],
        out: &mut [Vec3; octa::LANES],
    ) {
        for k in 0..octa::LANES {
            if !(w[k] > 0.0) {
                continue;
            }
            if let Some(e) = self.read(positions[k], n[k]) {
                out[k] = super::mix_irradiance(out[k], e, w[k]);
            }
        }
    }
}

/// The nine coefficients of every slot of `view`'s irradiance maps.
fn coefficients(view: &IrradianceView) -> Vec<[glam::Vec3A; crate::sh::COEFFS]> {
    let texels = (view.resolution * view.resolution) as usize;
    let weights = crate::sh::projection_weights(view.resolution);
    view.irradiance.chunks_exact(texels.max(1)).map(|map| crate::sh::project(map, &weights)).collect()
}

/// [`IrradianceSh::links`] of every cell of `view`, whose slots hold `coeffs`.
fn links(view: &IrradianceView, coeffs: &[[glam::Vec3A; crate::sh::COEFFS]]) -> Vec<u32> {
    let geo = view.geometry;
    let size = geo.cell_size();
    let slot = |cell: usize| view.slot.get(cell).copied().filter(|&s| s != NO_MAP && (s as usize) < coeffs.len());
    let probe = |cell: usize| view.probe_at(geo.cell_coords(cell), cell, size);
    let sees = |from: usize, sf: u32, to: usize| {
        let v = probe(to) - probe(from);
        let d = v.length();
        !(d > 0.0) || view.moments(sf as usize, v / d).0 >= LINK_SEES * d
    };
    let level = |s: u32| {
        let c = coeffs[s as usize][0];
        c.x + c.y + c.z
    };
    let counts = geo.counts.as_ivec3();
    (0..geo.cell_count())
        .map(|cell| {
            let Some(sc) = slot(cell) else { return 0 };
            let at = geo.cell_coords(cell).as_ivec3();
            let mut bits = link_bit(glam::IVec3::ZERO);
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let o = glam::IVec3::new(dx, dy, dz);
                        let other = at + o;
                        if o == glam::IVec3::ZERO || other.cmplt(glam::IVec3::ZERO).any() || other.cmpge(counts).any() {
                            continue;
                        }
                        let oc = geo.cell_index(other.as_uvec3());
                        let Some(so) = slot(oc) else { continue };
                        let (l, lo) = (level(sc), level(so));
                        let similar = l <= LINK_RATIO * lo && lo <= LINK_RATIO * l;
                        if similar && sees(cell, sc, oc) && sees(oc, so, cell) {
                            bits |= link_bit(o);
                        }
                    }
                }
            }
            bits
        })
        .collect()
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

    /// The probe of grid cell `cell` at coordinates `c`: the cell centre (cells of
    /// `cell_size`) moved by its relocation offset.
    #[inline]
    fn probe_at(&self, c: UVec3, cell: usize, cell_size: Vec3) -> Vec3 {
        self.geometry.centre_of_sized(c, cell_size) + self.probe_offset.get(cell).copied().unwrap_or(Vec3::ZERO)
    }

    /// The distance moments (mean, mean square) of the probe in slot `slot` towards unit
    /// direction `u`, bilinear in its maps (0 where the grid holds none).
    #[inline]
    fn moments(&self, slot: usize, u: Vec3) -> (f32, f32) {
        let dr = self.depth_resolution;
        let base = slot * (dr * dr) as usize;
        let (mut mean, mut mean_sq) = (0.0f32, 0.0f32);
        for (t, wt) in octa::bilinear_taps(dr, octa::encode(u)) {
            let at = base + t as usize;
            mean += self.depth_mean.get(at).copied().unwrap_or(0.0) * wt;
            mean_sq += self.depth_mean_sq.get(at).copied().unwrap_or(0.0) * wt;
        }
        (mean, mean_sq)
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
            let to_point = p - g.probe_at(c, cell, cell_size);
            let dist = to_point.length();
            let mut w = tri;
            if dist > 0.0 && dist.is_finite() && backface {
                let u = to_point / dist;
                // smooth back face: cells behind the surface count less
                let facing = (n.dot(-u) + 1.0) * 0.5;
                w *= facing * facing + 0.2;
                // Chebyshev visibility of the point from the cell
                let (mean, mean_sq) = g.moments(slot, u);
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
