//! The corrective model and how it is evaluated at runtime.
//!
//! Every cell reads probe A through the grid's proxy, its fallback method: the box or the
//! 18-DOP (seed 001), or the probe's own depth as seed 000's one-step warp reads it
//! (`warp1`), whichever the fit measured best for its cost. The ray from B meets the proxy
//! at distance `t_proxy(B, dir)` (`Warp::base_distance`), and A is fetched towards that
//! point.
//!
//! - Level 0: nothing stored; the proxy as it is. With several probes the cell reads the
//!   probe its fit chose for it (`cell_probes`; probe A unless stored).
//! - Level 2: a per-cell octahedral *shift map*. Per texel it holds Δ, how far along the
//!   lookup direction the proxy's surface must move to pass through what the cell's probe
//!   sees: `Δ = d − t_proxy(origin, dir)` (scene units; negative: nearer than the proxy).
//!   A lookup from B aims at `t_proxy(B, dir) + Δ(dir)`, Δ read bilinearly: the proxy's
//!   surface shifted along the lookup direction.
//!
//! Why this form, rather than seed 000's plane perpendicular to Dir through each texel's hit
//! (the project's earlier model, measured in docs/architecture.md of the warpfit repository):
//! - a cell without a map is the same surface with Δ = 0, so stored and unstored cells meet
//!   without a seam wherever the correction is small, and neighbouring maps differ only
//!   where the geometry makes them;
//! - where the proxy is right (a room's walls), it is right from every B, which a plane
//!   perpendicular to Dir is not: such a plane tilts against every wall it is not parallel
//!   to, and a mirror floor shows the tilt as cell-sized tiles;
//! - moving B along Dir moves the aimed point with it by the same distance, the parallax of
//!   whatever stands in front of the proxy.
//!
//! The lookup does not use the cell's origin: Δ is a function of direction alone. The origin
//! (the cell probe's position) only defines the map the fit starts from.
//!
//! Two ways to combine cells at runtime, both measured in `eval`:
//! - `Blend::Cell`: the containing cell alone (one map lookup);
//! - `Blend::Trilinear`: Δ blended with trilinear weights over the eight cells around B
//!   (cell-centre lattice), cells without a map counting Δ = 0;
//! - `Blend::Faces`: the containing cell alone except within [`FACE_MARGIN`] of a cell face,
//!   where each near cell's own lookup (its shift, its probe) is read and the radiances
//!   blend, so nothing a lookup reads jumps at a face. Near cells that aim alike (cells
//!   without a map) share one fetch. The runtime counts only the near cells the containing
//!   cell's irradiance links reach (`FittedGrid`'s `near_cells`), so it does not blend
//!   through walls. (Blending the shifts instead, one fetch, was measured
//!   too: it aims between two cells' surfaces at whatever lies there, and left more of the
//!   seams and a higher error; docs/frames.md.)
//!
//! Degenerate cases (all tested): B at the probe reads the query direction; B outside the
//! proxy, a ray through an open side of the k-DOP or one `warp1` sends to the sky reads the
//! query direction (the proxy itself does); a shift that puts the surface at or behind B
//! aims at B.

use super::glossy::Aim;
use super::{Method, Warp};
use crate::grid::GridGeometry;
use crate::octa::{self, LANES};
use glam::{UVec3, Vec3};
use serde::{Deserialize, Serialize};

/// How neighbouring cells' correctives combine at runtime.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Blend {
    Cell,
    Trilinear,
    Faces,
}

/// How far from a cell face (in cells, either side) [`Blend::Faces`] blends with the cell
/// across it: each axis's weight of the cell beyond the face ramps from 0 to ½ over the
/// last `FACE_MARGIN` before the face, so inside a cell one cell is read, near a face two,
/// near an edge four, near a corner eight. (½ would blend eight cells everywhere.)
pub const FACE_MARGIN: f32 = 0.125;

/// The cells a [`Blend::Faces`] lookup reads and their weights (summing to 1), in corner
/// order (bits x, y, z of the cell-centre lattice cube around the point); `n` of them.
#[derive(Clone, Copy, Debug)]
pub struct FaceCells {
    pub cells: [usize; 8],
    pub weights: [f32; 8],
    pub n: usize,
}

/// Where a [`Blend::Faces`] lookup reads: one aim per distinct lookup of its near cells,
/// each with its share of the radiance (summing to 1), in the order the cells first name
/// them; `n` of them. One aim inside a cell, and where the near cells aim alike.
#[derive(Clone, Copy, Debug)]
pub struct FaceAims {
    pub aims: [Aim; 8],
    pub weights: [f32; 8],
    pub n: usize,
}

impl FaceAims {
    /// `aim` alone, with all the radiance.
    #[must_use]
    pub fn one(aim: Aim) -> FaceAims {
        FaceAims { aims: [aim; 8], weights: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], n: 1 }
    }

    /// The aim with the greatest share (the first of equals).
    #[must_use]
    pub fn main(&self) -> Aim {
        let mut best = 0;
        for k in 1..self.n {
            if self.weights[k] > self.weights[best] {
                best = k;
            }
        }
        self.aims[best]
    }
}

/// The probe key of cells without a map when the grid relaxes them: they read the relaxed
/// proxy, not a shifted surface.
const RELAXED: u8 = u8::MAX;

/// Correctives of a whole grid, sparse: only cells at level 2 own a map.
#[derive(Clone, Debug, PartialEq)]
pub struct Correctives {
    pub geometry: GridGeometry,
    /// N of each N×N shift map.
    pub map_res: u32,
    /// Per grid cell: index into `maps` ([`NO_MAP`] = level 0, nothing stored).
    pub slot: Vec<u32>,
    /// Shift maps, `slot · N² + texel`: Δ in scene units. With `rough_maps`, the maps of
    /// mirror and near-mirror lookups.
    pub maps: Vec<f32>,
    /// Empty, or a second map per stored cell (same slots) for rough lookups: a lookup of
    /// roughness r reads `maps` up to [`ROUGH_MAP_FROM`], `rough_maps` from
    /// [`ROUGH_MAP_TO`], and blends the two shifts between ([`rough_weight`]).
    pub rough_maps: Vec<f32>,
    /// Empty (every lookup reads probe A), or per stored cell and texel (as `maps`) the
    /// probe a lookup reads (`Warp::probe_at`): the texel nearest the lookup direction's
    /// decides ([`nearest_tap`]); cells without a map read `cell_probes`.
    pub probe_maps: Vec<u8>,
    /// Empty (cells without a map read probe A), or per grid cell the probe a cell without
    /// a map reads through the proxy (ignored where the cell stores a map).
    pub cell_probes: Vec<u8>,
    /// The proxy every lookup reads through (`Method::Box`, `Method::Kdop` or
    /// `Method::Warp1`): as it is in cells without a map.
    pub fallback: Method,
    /// `geometry.cell_size()`, kept: it costs three divisions a lookup.
    cell_size: Vec3,
}

impl Correctives {
    /// Correctives over `geometry` with maps of `map_res`² texels: `slot` per cell (into
    /// `maps`, or [`NO_MAP`]) and the proxy `fallback`.
    #[must_use]
    pub fn new(geometry: GridGeometry, map_res: u32, slot: Vec<u32>, maps: Vec<f32>, fallback: Method) -> Self {
        Correctives {
            geometry,
            map_res,
            slot,
            maps,
            rough_maps: Vec::new(),
            probe_maps: Vec::new(),
            cell_probes: Vec::new(),
            fallback,
            cell_size: geometry.cell_size(),
        }
    }

    /// The same correctives with a probe index per stored texel (`probe_maps`, as `maps`).
    #[must_use]
    pub fn with_probe_maps(mut self, probe_maps: Vec<u8>) -> Self {
        self.probe_maps = probe_maps;
        self
    }

    /// The same correctives with the probe each cell without a map reads (`cell_probes`,
    /// one per grid cell; empty: probe A).
    #[must_use]
    pub fn with_cell_probes(mut self, cell_probes: Vec<u8>) -> Self {
        self.cell_probes = cell_probes;
        self
    }

    /// The probe a lookup in cell `cell` reads where the cell stores no map.
    #[inline]
    #[must_use]
    pub fn cell_probe(&self, cell: usize) -> u8 {
        self.cell_probes.get(cell).copied().unwrap_or(0)
    }

    /// The probe a lookup in stored slot `slot` with bilinear `taps` reads.
    #[inline]
    fn probe_of(&self, slot: u32, taps: &[(u32, f32); 4]) -> u8 {
        if self.probe_maps.is_empty() {
            return 0;
        }
        let n2 = (self.map_res * self.map_res) as usize;
        self.probe_maps.get(slot as usize * n2 + nearest_tap(taps) as usize).copied().unwrap_or(0)
    }

    /// The same correctives with a rough map per stored cell (`rough_maps`, as `maps`).
    #[must_use]
    pub fn with_rough_maps(mut self, rough_maps: Vec<f32>) -> Self {
        self.rough_maps = rough_maps;
        self
    }

    /// Whether stored cells keep a second map for rough lookups.
    #[inline]
    #[must_use]
    pub fn has_rough_maps(&self) -> bool {
        !self.rough_maps.is_empty()
    }

    /// The cell index of the cell a lookup at `b` reads (the containing cell, clamped).
    #[inline]
    #[must_use]
    pub fn cell_at(&self, b: Vec3) -> usize {
        self.geometry.cell_index(self.geometry.cell_of_sized(b, self.cell_size))
    }

    #[must_use]
    pub fn stored_cells(&self) -> usize {
        self.slot.iter().filter(|s| **s != NO_MAP).count()
    }

    #[inline]
    fn map(&self, slot: u32) -> &[f32] {
        let n2 = (self.map_res * self.map_res) as usize;
        &self.maps[slot as usize * n2..(slot as usize + 1) * n2]
    }

    /// Where cell `cell` keeps its map; `None` for a level-0 cell (the proxy as it is).
    #[inline]
    #[must_use]
    pub fn slot_of(&self, cell: usize) -> Option<u32> {
        let s = self.slot[cell];
        (s != NO_MAP).then_some(s)
    }

    /// Whether cell `cell` stores a shift map.
    #[inline]
    #[must_use]
    pub fn stores_map(&self, cell: usize) -> bool {
        self.slot[cell] != NO_MAP
    }

    /// The rough map in `slot` (empty without `rough_maps`).
    #[inline]
    fn rough_map(&self, slot: u32) -> &[f32] {
        let n2 = (self.map_res * self.map_res) as usize;
        self.rough_maps.get(slot as usize * n2..(slot as usize + 1) * n2).unwrap_or(&[])
    }

    /// The shift Δ of slot `slot` for a lookup of roughness `r`, its maps sampled with
    /// bilinear `taps` ([`sample_maps`]).
    #[inline]
    fn map_delta(&self, slot: u32, taps: &[(u32, f32); 4], r: f32) -> f32 {
        // (the map alone, the usual case, without slicing the rough maps: the same value)
        if self.rough_maps.is_empty() || rough_weight(r) <= 0.0 {
            return sample_map(self.map(slot), taps);
        }
        sample_maps(self.map(slot), self.rough_map(slot), taps, r)
    }

    /// The cells a [`Blend::Faces`] lookup at `b` reads, with their weights: the containing
    /// cell alone inside it (one cell, weight 1); within [`FACE_MARGIN`] of a face, the
    /// cells on both sides, weighted by a linear ramp across the margin on each axis.
    #[inline]
    #[must_use]
    pub fn face_cells(&self, b: Vec3) -> FaceCells {
        let g = &self.geometry;
        let mut out =
            FaceCells { cells: [self.cell_at(b); 8], weights: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], n: 1 };
        let top = g.counts - UVec3::ONE;
        let f = (b - g.min) / self.cell_size - 0.5;
        let f = if f.is_finite() { f.clamp(Vec3::ZERO, top.as_vec3()) } else { Vec3::ZERO };
        // (f ≥ 0: truncation is the floor)
        let base = UVec3::new(f.x as u32, f.y as u32, f.z as u32);
        let ramp = |x: f32| ((x - (0.5 - FACE_MARGIN)) / (2.0 * FACE_MARGIN)).clamp(0.0, 1.0);
        let frac = f - base.as_vec3();
        let t = Vec3::new(ramp(frac.x), ramp(frac.y), ramp(frac.z));
        // per axis the lattice offsets with a weight (one inside the margin's reach)
        let axis = |t: f32| -> ([(u32, f32); 2], usize) {
            match t {
                0.0 => ([(0, 1.0), (0, 0.0)], 1),
                1.0 => ([(1, 1.0), (0, 0.0)], 1),
                t => ([(0, 1.0 - t), (1, t)], 2),
            }
        };
        let ((x, nx), (y, ny), (z, nz)) = (axis(t.x), axis(t.y), axis(t.z));
        if nx * ny * nz == 1 {
            // inside a cell: the containing cell as every other lookup finds it
            return out;
        }
        // the corners in lattice order (x fastest), each weight the product x · y · z
        out.n = 0;
        for &(oz, wz) in &z[..nz] {
            for &(oy, wy) in &y[..ny] {
                for &(ox, wx) in &x[..nx] {
                    out.cells[out.n] = g.cell_index((base + UVec3::new(ox, oy, oz)).min(top));
                    out.weights[out.n] = wx * wy * wz;
                    out.n += 1;
                }
            }
        }
        out
    }

    /// Where a [`Blend::Faces`] lookup of (B, dir, r) reads ([`FaceAims`]): inside a cell
    /// [`fetch`](Self::fetch) with `Blend::Cell` bit for bit; near a face, each near cell's
    /// own lookup, as `fetch_in` that cell with `Blend::Cell` (its probe and shift; cells
    /// without a map read their own probe with Δ = 0, or, reading probe A, the relaxed proxy
    /// when the grid relaxes),
    /// the proxy's distance found once, and cells with the same probe and shift merged.
    #[must_use]
    pub fn face_aims(&self, warp: &Warp, b: Vec3, dir: Vec3, r: f32) -> FaceAims {
        self.face_aims_in(self.face_cells(b), warp, b, dir, r)
    }

    /// [`face_aims`](Self::face_aims) of the near cells `cells` ([`face_cells`](Self::face_cells)
    /// at `b`).
    #[must_use]
    pub fn face_aims_in(&self, cells: FaceCells, warp: &Warp, b: Vec3, dir: Vec3, r: f32) -> FaceAims {
        if cells.n == 1 {
            return FaceAims::one(self.fetch_in(cells.cells[0], Blend::Cell, warp, b, dir, r));
        }
        let (groups, n) = self.face_groups(&cells, warp, dir, r);
        let t = warp.base_distance(self.fallback, b, dir);
        let mut out = FaceAims { aims: [Aim { v: dir, k: Some(1.0), probe: 0 }; 8], weights: [0.0; 8], n };
        for (k, &(key, w, delta)) in groups[..n].iter().enumerate() {
            out.weights[k] = w;
            out.aims[k] = if key == RELAXED {
                warp.fetch_vector(self.fallback, b, dir).into()
            } else {
                let a = warp.probe_at(key.into()).position;
                let aim =
                    if b == a { Aim { v: dir, k: Some(1.0), probe: 0 } } else { shifted_aim(a, t, delta, b, dir) };
                Aim { probe: key, ..aim }
            };
        }
        out
    }

    /// The distinct lookups of a faces blend over `cells` for direction `dir` at roughness
    /// `r`: (the probe each reads, or `RELAXED` for a cell without a map that reads the
    /// relaxed proxy; the cells' summed weight; the shift), in the order the cells first
    /// name them, and how many. [`face_aims_in`](Self::face_aims_in) aims each.
    #[inline]
    pub(crate) fn face_groups(
        &self,
        cells: &FaceCells,
        warp: &Warp,
        dir: Vec3,
        r: f32,
    ) -> ([(u8, f32, f32); 8], usize) {
        let taps = octa::bilinear_taps(self.map_res, octa::encode(dir));
        let relax = warp.options.relax_texels > 0.0;
        let mut groups = [(0u8, 0.0f32, 0.0f32); 8];
        let mut n = 0;
        for k in 0..cells.n {
            let cell = cells.cells[k];
            let (key, delta) = match self.slot_of(cell) {
                Some(slot) => (self.probe_of(slot, &taps), self.map_delta(slot, &taps, r)),
                // (the relaxed proxy is probe A's: a cell reading another probe reads it unrelaxed)
                None if relax && self.cell_probe(cell) == 0 => (RELAXED, 0.0),
                None => (self.cell_probe(cell), 0.0),
            };
            let at = match groups[..n].iter().position(|g| g.0 == key && g.2.to_bits() == delta.to_bits()) {
                Some(at) => at,
                None => {
                    groups[n] = (key, 0.0, delta);
                    n += 1;
                    n - 1
                }
            };
            groups[at].1 += cells.weights[k];
        }
        (groups, n)
    }

    /// Where the proxy the maps shift lets each of [`LANES`] rays go (`Warp::base_distance`
    /// lane by lane, the box's for all lanes at once): the distance, and whether there is one.
    #[inline(always)]
    pub(crate) fn proxy_exit_lanes(
        &self,
        warp: &Warp,
        b: &[Vec3; LANES],
        dir: &[Vec3; LANES],
    ) -> ([f32; LANES], [bool; LANES]) {
        match self.fallback {
            Method::Box => warp.proxies.aabb.exit_distance_soa(&octa::soa(b), &octa::soa(dir)),
            method => {
                let (mut t, mut ok) = ([0.0f32; LANES], [false; LANES]);
                for k in 0..LANES {
                    if let Some(x) = warp.base_distance(method, b[k], dir[k]) {
                        (t[k], ok[k]) = (x, true);
                    }
                }
                (t, ok)
            }
        }
    }

    /// Fetch vector for the mirror query (B, dir).
    #[inline]
    #[must_use]
    pub fn fetch_vector(&self, blend: Blend, warp: &Warp, b: Vec3, dir: Vec3) -> Vec3 {
        self.fetch(blend, warp, b, dir, 0.0).v
    }

    /// Where query (B, dir) of roughness `r` reads probe A: the aimed point and its
    /// distance ratio (no depth fetch needed for a rough lookup).
    #[inline]
    #[must_use]
    pub fn fetch(&self, blend: Blend, warp: &Warp, b: Vec3, dir: Vec3, r: f32) -> Aim {
        if blend == Blend::Faces {
            // (one aim: the one with the greatest share; a lookup reads them all)
            return self.face_aims(warp, b, dir, r).main();
        }
        self.fetch_in(self.cell_at(b), blend, warp, b, dir, r)
    }

    /// [`fetch`](Self::fetch) as if B lay in cell `cell`: its map's shift and the probe it
    /// reads (with `Blend::Cell`, and `Blend::Faces` as if no face were near), the aim from
    /// B itself.
    #[inline]
    #[must_use]
    pub fn fetch_in(&self, cell: usize, blend: Blend, warp: &Warp, b: Vec3, dir: Vec3, r: f32) -> Aim {
        // the cell's map: the shift (Blend::Cell) and the probe it reads
        let own = self.slot_of(cell).map(|slot| {
            let taps = octa::bilinear_taps(self.map_res, octa::encode(dir));
            (slot, taps, self.probe_of(slot, &taps))
        });
        let probe = own.map_or_else(|| self.cell_probe(cell), |o| o.2);
        let a = warp.probe_at(probe.into()).position;
        if b == a {
            return Aim { v: dir, k: Some(1.0), probe };
        }
        let delta = match blend {
            Blend::Cell | Blend::Faces => own.map(|(slot, taps, _)| self.map_delta(slot, &taps, r)),
            Blend::Trilinear => self.trilinear_delta(b, dir, r),
        };
        let aim = match delta {
            Some(delta) => shifted_aim(a, warp.base_distance(self.fallback, b, dir), delta, b, dir),
            None if warp.options.relax_texels > 0.0 && probe == 0 => warp.fetch_vector(self.fallback, b, dir).into(),
            None => shifted_aim(a, warp.base_distance(self.fallback, b, dir), 0.0, b, dir),
        };
        Aim { probe, ..aim }
    }

    /// `fetch` for [`LANES`] queries of roughness `r`, bit for bit the same, in
    /// structure-of-arrays form:
    /// the fetch vectors as components ([`octa::soa`]) and each lane's distance ratio
    /// ([`Aim::ratio`]: read from A's depth where the lookup aimed at no known point). With
    /// `Blend::Cell` every lane runs the same steps side by side: the proxy's exit (the box
    /// in structure-of-arrays form), each lane's map gathered (Δ = 0 where its cell stores
    /// none), the aim.
    #[inline]
    #[must_use]
    pub fn fetch_lanes(
        &self,
        blend: Blend,
        warp: &Warp,
        b: &[Vec3; LANES],
        dir: &[Vec3; LANES],
        r: &[f32; LANES],
    ) -> (octa::Soa3, [f32; LANES], [u8; LANES]) {
        let Some(aims) = self.aim_lanes(blend, warp, b, dir, r) else {
            let (mut v, mut ratio, mut probe) = ([Vec3::Z; LANES], [1.0f32; LANES], [0u8; LANES]);
            for k in 0..LANES {
                let aim = self.fetch(blend, warp, b[k], dir[k], r[k]);
                (v[k], ratio[k], probe[k]) = (aim.v, aim.ratio(warp, b[k], octa::encode(aim.v)), aim.probe);
            }
            return (octa::soa(&v), ratio, probe);
        };
        let (v, ratio) = aims.vectors_and_ratios();
        (v, ratio, aims.probe)
    }

    /// The fetch vectors of [`fetch_lanes`](Self::fetch_lanes) alone (what a mirror lookup
    /// reads), as components ([`octa::soa`]), and the probe each lane reads.
    #[inline]
    #[must_use]
    pub fn fetch_vector_lanes(
        &self,
        blend: Blend,
        warp: &Warp,
        b: &[Vec3; LANES],
        dir: &[Vec3; LANES],
    ) -> (octa::Soa3, [u8; LANES]) {
        let Some(aims) = self.aim_lanes(blend, warp, b, dir, &[0.0; LANES]) else {
            let (mut out, mut probe) = ([Vec3::Z; LANES], [0u8; LANES]);
            for k in 0..LANES {
                let aim = self.fetch(blend, warp, b[k], dir[k], 0.0);
                (out[k], probe[k]) = (aim.v, aim.probe);
            }
            return (octa::soa(&out), probe);
        };
        (aims.vectors(), aims.probe)
    }

    /// The lane form of `fetch` → `shifted_aim` with `Blend::Cell` and no relaxation (the
    /// same operations in the same order): the aimed points, how far along each ray they
    /// are, and which lanes aim at all (the others read their query direction). `None` for
    /// the other settings, which go lane by lane.
    #[inline(always)]
    fn aim_lanes(
        &self,
        blend: Blend,
        warp: &Warp,
        b: &[Vec3; LANES],
        dir: &[Vec3; LANES],
        r: &[f32; LANES],
    ) -> Option<AimLanes> {
        if blend != Blend::Cell || warp.options.relax_texels > 0.0 {
            return None;
        }
        let (bb, d) = (octa::soa(b), octa::soa(dir));
        // the proxy's exit for every lane
        let (t, has_t) = self.proxy_exit_lanes(warp, b, dir);
        // each lane's shift: its cell's map, bilinear (a gather for the lanes with a map)
        let uv = octa::encode_soa(&d);
        let cells = self.geometry.cell_index_soa(&bb, self.cell_size);
        let n = self.map_res as f32;
        let mut foot = ([0i32; LANES], [0i32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for k in 0..LANES {
            (foot.0[k], foot.1[k], foot.2[k], foot.3[k]) = octa::footprint_of(n, uv.u[k], uv.v[k]);
        }
        // each lane's map and, in the blend band and above, its rough map, sampled with
        // the same taps; then `weighted_shift` for all lanes at once
        let n2 = (self.map_res * self.map_res) as usize;
        let mut w = [0.0f32; LANES];
        if !self.rough_maps.is_empty() {
            for k in 0..LANES {
                w[k] = rough_weight(r[k]);
            }
        }
        let (mut mirror, mut rough) = ([0.0f32; LANES], [0.0f32; LANES]);
        let mut probe = [0u8; LANES];
        for k in 0..LANES {
            let slot = self.slot[cells[k]];
            if slot == NO_MAP {
                probe[k] = self.cell_probe(cells[k]);
            } else {
                let taps = octa::footprint_taps(self.map_res, foot.0[k], foot.1[k], foot.2[k], foot.3[k]);
                probe[k] = self.probe_of(slot, &taps);
                let at = slot as usize * n2;
                // (a slot with no rough map reads its map alone, as `rough_map` gives it)
                let rough_map = if w[k] > 0.0 { self.rough_maps.get(at..at + n2) } else { None };
                if rough_map.is_none() {
                    w[k] = 0.0;
                }
                if w[k] < 1.0 {
                    mirror[k] = sample_map(&self.maps[at..at + n2], &taps);
                }
                if let Some(map) = rough_map {
                    rough[k] = sample_map(map, &taps);
                }
            }
        }
        let mut delta = [0.0f32; LANES];
        for k in 0..LANES {
            delta[k] = weighted_shift(mirror[k], rough[k], w[k]);
        }
        let mut a = [[0.0f32; LANES]; 3];
        for k in 0..LANES {
            [a[0][k], a[1][k], a[2][k]] = warp.probe_at(probe[k].into()).position.to_array();
        }
        Some(AimLanes::shifted_from(&a, &t, &has_t, &delta, &bb, d).with_probes(probe))
    }

    /// Δ blended over the eight cells around B (cell-centre lattice) with trilinear
    /// weights, cells without a map counting 0; `None` when none of them stores one.
    fn trilinear_delta(&self, b: Vec3, dir: Vec3, r: f32) -> Option<f32> {
        let g = &self.geometry;
        let taps = octa::bilinear_taps(self.map_res, octa::encode(dir));
        // position in the lattice of cell centres
        let size = g.cell_size();
        let f = (b - g.min) / size - 0.5;
        let hi = (g.counts - UVec3::ONE).as_vec3();
        let f = if f.is_finite() { f.clamp(Vec3::ZERO, hi) } else { Vec3::ZERO };
        let base = f.floor();
        let frac = f - base;
        let base = base.as_uvec3();
        let (mut sum, mut any) = (0.0f32, false);
        for corner in 0..8u32 {
            let o = UVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let c = (base + o).min(g.counts - UVec3::ONE);
            let w = (if o.x == 1 { frac.x } else { 1.0 - frac.x })
                * (if o.y == 1 { frac.y } else { 1.0 - frac.y })
                * (if o.z == 1 { frac.z } else { 1.0 - frac.z });
            if let Some(slot) = self.slot_of(g.cell_index(c)) {
                sum += w * self.map_delta(slot, &taps, r);
                any = true;
            }
        }
        any.then_some(sum)
    }
}

/// [`LANES`] aims in structure-of-arrays form (see `Correctives::aim_lanes`).
pub struct AimLanes {
    /// The aimed points seen from A, as components.
    v: octa::Soa3,
    /// How far along each query ray the aimed point lies (`along`).
    s: [f32; LANES],
    /// Whether the lane aims at `v` (otherwise it reads its query direction).
    aims: [bool; LANES],
    /// The query directions, as components (what a lane that does not aim reads).
    d: octa::Soa3,
    /// The probe each lane reads (`Warp::probe_at`).
    pub probe: [u8; LANES],
}

impl AimLanes {
    /// [`shifted_aim`] for [`LANES`] queries (B `bb` and directions `d` as components), the
    /// same operations in the same order: lane k's ray leaves the proxy at `t[k]` where
    /// `has_t[k]`, and its surface is shifted by `delta[k]`. Shared by the runtime's batches
    /// and the fit's objective.
    #[inline(always)]
    pub fn shifted(
        a: Vec3,
        t: &[f32; LANES],
        has_t: &[bool; LANES],
        delta: &[f32; LANES],
        bb: &octa::Soa3,
        d: octa::Soa3,
    ) -> AimLanes {
        let a3 = a.to_array();
        let each = [[a3[0]; LANES], [a3[1]; LANES], [a3[2]; LANES]];
        Self::shifted_from(&each, t, has_t, delta, bb, d)
    }

    /// [`Self::shifted`] with each lane's probe at its own position (`a`, as components).
    #[inline(always)]
    pub fn shifted_from(
        a: &octa::Soa3,
        t: &[f32; LANES],
        has_t: &[bool; LANES],
        delta: &[f32; LANES],
        bb: &octa::Soa3,
        d: octa::Soa3,
    ) -> AimLanes {
        let mut out =
            AimLanes { v: [[0.0f32; LANES]; 3], s: [0.0f32; LANES], aims: [false; LANES], d, probe: [0; LANES] };
        for k in 0..LANES {
            out.s[k] = along(t[k] + delta[k]);
            for c in 0..3 {
                out.v[c][k] = (bb[c][k] + d[c][k] * out.s[k]) - a[c][k];
            }
        }
        // (bitwise `&`: no short circuits, so the loop vectorises)
        for k in 0..LANES {
            let v = [out.v[0][k], out.v[1][k], out.v[2][k]];
            let finite = v[0].is_finite() & v[1].is_finite() & v[2].is_finite();
            let zero = (v[0] == 0.0) & (v[1] == 0.0) & (v[2] == 0.0);
            let at_a = (bb[0][k] == a[0][k]) & (bb[1][k] == a[1][k]) & (bb[2][k] == a[2][k]);
            out.aims[k] = has_t[k] & t[k].is_finite() & !at_a & finite & !zero;
        }
        out
    }

    /// The same aims, lane k reading probe `probe[k]`.
    #[inline(always)]
    #[must_use]
    pub fn with_probes(mut self, probe: [u8; LANES]) -> AimLanes {
        self.probe = probe;
        self
    }

    /// The fetch vectors as components: the aimed point, or the query direction where the
    /// lane does not aim.
    #[inline(always)]
    pub fn vectors(&self) -> octa::Soa3 {
        let mut v = self.v;
        for c in 0..3 {
            for k in 0..LANES {
                v[c][k] = if self.aims[k] { v[c][k] } else { self.d[c][k] };
            }
        }
        v
    }

    /// [`Self::vectors`] and each lane's distance ratio (1 where it does not aim), as
    /// [`shifted_aim`]'s `Aim` carries it.
    #[inline(always)]
    pub fn vectors_and_ratios(&self) -> (octa::Soa3, [f32; LANES]) {
        // `distance_ratio`, the length as glam forms it (std's square root is the same
        // correctly rounded `sqrtss`, and vectorises)
        let v = &self.v;
        let mut ratio = [1.0f32; LANES];
        for k in 0..LANES {
            let l = ((v[0][k] * v[0][k]) + (v[1][k] * v[1][k]) + (v[2][k] * v[2][k])).sqrt() / self.s[k];
            let l = if l.is_finite() && l > 0.0 { l } else { 1.0 };
            ratio[k] = if self.aims[k] { l } else { 1.0 };
        }
        (self.vectors(), ratio)
    }
}

/// The slot value of a cell that stores no map.
pub const NO_MAP: u32 = u32::MAX;

/// With rough maps, the roughness up to which a lookup reads the (mirror) map alone.
pub const ROUGH_MAP_FROM: f32 = 0.5;
/// With rough maps, the roughness from which a lookup reads the rough map alone.
pub const ROUGH_MAP_TO: f32 = 0.75;

/// How much of the rough map's shift a lookup of roughness `r` takes: 0 up to
/// [`ROUGH_MAP_FROM`], 1 from [`ROUGH_MAP_TO`], linear between (0 for NaN).
#[inline]
#[must_use]
pub fn rough_weight(r: f32) -> f32 {
    let w = (r - ROUGH_MAP_FROM) / (ROUGH_MAP_TO - ROUGH_MAP_FROM);
    if w > 0.0 { w.min(1.0) } else { 0.0 }
}

/// The shift of a lookup of roughness `r` from a cell's `mirror` map and its `rough` map
/// (empty: none), sampled with bilinear `taps`: the mirror map's up to [`ROUGH_MAP_FROM`],
/// the rough map's from [`ROUGH_MAP_TO`], blended between ([`blend_shift`]). Shared by the
/// runtime and the fit's objective.
#[inline]
#[must_use]
pub fn sample_maps(mirror: &[f32], rough: &[f32], taps: &[(u32, f32); 4], r: f32) -> f32 {
    if rough.is_empty() {
        return sample_map(mirror, taps);
    }
    let w = rough_weight(r);
    // (each map sampled only where its weight is not 0)
    let m = if w < 1.0 { sample_map(mirror, taps) } else { 0.0 };
    let g = if w > 0.0 { sample_map(rough, taps) } else { 0.0 };
    weighted_shift(m, g, w)
}

/// The shift a lookup of rough weight `w` takes from its map's sample `mirror` and its
/// rough map's `rough`: the one where `w` is 0 or 1, [`blend_shift`] between. The rule of
/// [`sample_maps`], also applied to lanes of samples (`Correctives::aim_lanes`).
#[inline]
#[must_use]
pub fn weighted_shift(mirror: f32, rough: f32, w: f32) -> f32 {
    if w <= 0.0 {
        mirror
    } else if w >= 1.0 {
        rough
    } else {
        blend_shift(mirror, rough, w)
    }
}

/// The shift between a mirror map's `mirror` and a rough map's `rough` at rough weight `w`
/// ∈ (0, 1) (the fit and the runtime share it; shaders write the same `mix`).
#[inline]
#[must_use]
pub fn blend_shift(mirror: f32, rough: f32, w: f32) -> f32 {
    mirror + (rough - mirror) * w
}

/// The tap of bilinear `taps` with the greatest weight (the first of equals): the texel
/// whose probe a lookup reads.
#[inline]
#[must_use]
pub fn nearest_tap(taps: &[(u32, f32); 4]) -> u32 {
    let mut best = taps[0];
    for &t in &taps[1..] {
        if t.1 > best.1 {
            best = t;
        }
    }
    best.0
}

/// A shift map sampled with bilinear `taps`.
#[inline]
#[must_use]
pub fn sample_map(map: &[f32], taps: &[(u32, f32); 4]) -> f32 {
    taps.iter().map(|&(k, wt)| map[k as usize] * wt).sum()
}

/// The corrective lookup, shared by the fit's objective and the runtime: the ray (B, dir)
/// leaves the proxy at `t_proxy` (`None`: B is outside it); its surface shifted by `delta`
/// along `dir` is where probe A (at `a`) is fetched towards. Outside the proxy and through
/// an open side (`t_proxy` infinite) the query direction; a surface at or behind B aims at
/// B (at `NEAREST` along the ray).
#[inline]
#[must_use]
pub fn shifted_aim(a: Vec3, t_proxy: Option<f32>, delta: f32, b: Vec3, dir: Vec3) -> Aim {
    match t_proxy {
        Some(t) if t.is_finite() && b != a => {
            let s = along(t + delta);
            let v = (b + dir * s) - a;
            if v.is_finite() && v != Vec3::ZERO {
                return Aim { v, k: Some(distance_ratio(v, s)), probe: 0 };
            }
            Aim { v: dir, k: Some(1.0), probe: 0 }
        }
        _ => Aim { v: dir, k: Some(1.0), probe: 0 },
    }
}

/// How far along the ray a shifted surface at `s` is aimed at: `s`, or [`NEAREST`] for a
/// surface at or behind B (and NaN).
#[inline(always)]
fn along(s: f32) -> f32 {
    if s > NEAREST { s } else { NEAREST }
}

/// The nearest an aim comes to B along the ray: "at B" without a zero distance.
const NEAREST: f32 = 1e-30;

/// The distance ratio `|v| / s` of an aimed point `v` from A, `s` from B (1 where it
/// degenerates).
#[inline]
fn distance_ratio(v: Vec3, s: f32) -> f32 {
    let k = v.length() / s;
    if k.is_finite() && k > 0.0 { k } else { 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lookup_blends_the_two_maps_over_the_band_only() {
        assert_eq!(rough_weight(0.0), 0.0);
        assert_eq!(rough_weight(ROUGH_MAP_FROM), 0.0);
        assert_eq!(rough_weight(ROUGH_MAP_TO), 1.0);
        assert_eq!(rough_weight(1.0), 1.0);
        assert_eq!(rough_weight(f32::NAN), 0.0);
        let mid = 0.5 * (ROUGH_MAP_FROM + ROUGH_MAP_TO);
        assert!((rough_weight(mid) - 0.5).abs() < 1e-6);
        // a 2×2 map of 1s and one of 3s, read at a texel's centre
        let (mirror, rough) = ([1.0f32; 4], [3.0f32; 4]);
        let taps = [(0, 1.0), (1, 0.0), (2, 0.0), (3, 0.0)];
        assert_eq!(sample_maps(&mirror, &[], &taps, 1.0), 1.0, "no rough map: the map at any roughness");
        assert_eq!(sample_maps(&mirror, &rough, &taps, ROUGH_MAP_FROM), 1.0);
        assert_eq!(sample_maps(&mirror, &rough, &taps, ROUGH_MAP_TO), 3.0);
        assert!((sample_maps(&mirror, &rough, &taps, mid) - 2.0).abs() < 1e-6);
        let mut last = 1.0;
        for k in 0..=64 {
            let x = sample_maps(&mirror, &rough, &taps, k as f32 / 64.0);
            assert!(x >= last && x.is_finite(), "monotone in roughness");
            last = x;
        }
    }
}
