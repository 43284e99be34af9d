//! The corrective model and how it is evaluated at runtime.
//!
//! Level 0: nothing stored; the cell uses the grid's fallback method, the unfitted warp
//! (`warp1`, `box` or `kdop`) that the fit measured best on its held-out queries.
//! Level 2: a per-cell octahedral *warp map*: per texel, the inverse distance from the cell
//! centre to what that direction hits (0 = sky). A lookup makes one warp step against the
//! map of the cell (plane perpendicular to Dir at the cell's hit estimate, intersected with
//! the ray from B) and fetches probe A towards the estimated hit.
//!
//! Level 1 (one origin offset per cell) is not implemented: see ARCHITECTURE.md.
//!
//! Two ways to combine cells at runtime, both measured in `eval`:
//! - `Blend::Cell`: the containing cell alone (one map lookup);
//! - `Blend::Trilinear`: the eight cells around B (cell-centre lattice), each giving a hit
//!   distance along the ray; blended as inverse distance with trilinear weights, cells
//!   without a map dropped and the weights renormalised.

use super::glossy::Aim;
use super::{Method, Warp};
use crate::grid::GridGeometry;
use crate::octa::{self, LANES};
use glam::{UVec3, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// How neighbouring cells' correctives combine at runtime.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Blend {
    Cell,
    Trilinear,
}

/// Correctives of a whole grid, sparse: only cells at level 2 own a map.
#[derive(Clone, Debug, PartialEq)]
pub struct Correctives {
    pub geometry: GridGeometry,
    /// N of each N×N warp map.
    pub map_res: u32,
    /// Per grid cell: index into `maps` ([`NO_MAP`] = level 0, nothing stored).
    pub slot: Vec<u32>,
    /// Warp maps, `slot · N² + texel`: inverse distance from the cell's origin (0 = sky).
    pub maps: Vec<f32>,
    /// Method of level-0 cells.
    pub fallback: Method,
    /// Per grid cell: its map's origin relative to the cell centre (the cell probe's
    /// relocation offset); empty when every origin is the centre.
    pub origin_offset: Vec<Vec3>,
}

impl Correctives {
    #[must_use]
    pub fn stored_cells(&self) -> usize {
        self.slot.iter().filter(|s| **s != NO_MAP).count()
    }

    /// Origin of cell `cell`'s map: its centre, moved by the cell probe's relocation.
    #[inline]
    #[must_use]
    pub fn origin_sized(&self, cell: UVec3, cell_size: Vec3) -> Vec3 {
        let centre = self.geometry.centre_of_sized(cell, cell_size);
        match self.origin_offset.get(self.geometry.cell_index(cell)) {
            Some(o) => centre + *o,
            None => centre,
        }
    }

    #[inline]
    fn map(&self, slot: u32) -> &[f32] {
        let n2 = (self.map_res * self.map_res) as usize;
        &self.maps[slot as usize * n2..(slot as usize + 1) * n2]
    }

    /// Where cell `cell` keeps its map; `None` for a level-0 cell (the fallback method).
    #[inline]
    #[must_use]
    pub fn slot_of(&self, cell: usize) -> Option<u32> {
        let s = self.slot[cell];
        (s != NO_MAP).then_some(s)
    }

    /// Whether cell `cell` stores a warp map.
    #[inline]
    #[must_use]
    pub fn stores_map(&self, cell: usize) -> bool {
        self.slot[cell] != NO_MAP
    }

    /// The map in `slot` sampled with bilinear `taps`: inverse distance from the cell centre.
    #[inline]
    fn map_w(&self, slot: u32, taps: &[(u32, f32); 4]) -> f32 {
        sample_map(self.map(slot), taps)
    }

    /// Distance along the ray (B, dir) to the hit estimated from cell `cell`'s map, as
    /// inverse distance (0 = at infinity); `None` when the cell stores no map.
    #[inline]
    fn cell_inv_t(&self, cell: UVec3, cell_size: Vec3, taps: &[(u32, f32); 4], b: Vec3, dir: Vec3) -> Option<f32> {
        let slot = self.slot_of(self.geometry.cell_index(cell))?;
        Some(inv_t_from_map(self.origin_sized(cell, cell_size), self.map_w(slot, taps), b, dir))
    }

    /// Fetch vector for query (B, dir); the fallback method where no map applies.
    #[inline]
    #[must_use]
    pub fn fetch_vector(&self, blend: Blend, warp: &Warp, b: Vec3, dir: Vec3) -> Vec3 {
        self.fetch(blend, warp, b, dir).v
    }

    /// Where query (B, dir) reads probe A: a map's aim carries its distance ratio (no depth
    /// fetch needed for a rough lookup), the fallback method's does not.
    #[inline]
    #[must_use]
    pub fn fetch(&self, blend: Blend, warp: &Warp, b: Vec3, dir: Vec3) -> Aim {
        self.fetch_at(blend, warp, b, dir, octa::encode(dir))
    }

    /// `fetch` for [`LANES`] queries, bit for bit the same. With `Blend::Cell` the
    /// lanes are first sorted (without branches) into those whose cell stores a map and
    /// those that use the fallback method, and each group then runs as its own loop: whether
    /// a cell stores a map is random from lookup to lookup, and a mispredicted branch per
    /// lane would serialise the lanes.
    #[inline]
    #[must_use]
    pub fn fetch_lanes(&self, blend: Blend, warp: &Warp, b: &[Vec3; LANES], dir: &[Vec3; LANES]) -> [Aim; LANES] {
        self.lanes::<true>(blend, warp, b, dir)
    }

    /// The fetch vectors of [`fetch_lanes`](Self::fetch_lanes) alone (what a mirror lookup
    /// reads), without the distance ratios' square roots.
    #[inline]
    #[must_use]
    pub fn fetch_vector_lanes(
        &self,
        blend: Blend,
        warp: &Warp,
        b: &[Vec3; LANES],
        dir: &[Vec3; LANES],
    ) -> [Vec3; LANES] {
        self.lanes::<false>(blend, warp, b, dir).map(|a| a.v)
    }

    /// `fetch_lanes`, with the maps' aims carrying their distance ratio only if `RATIO`.
    /// Three passes: sort the lanes (see `fetch_lanes`), gather each mapped lane's map value
    /// and origin, then the one warp step for all lanes at once in structure-of-arrays form
    /// (the same operations in the same order as `map_fetch`, lane by lane: bit for bit its
    /// values, and the compiler runs the lanes side by side).
    #[inline(always)]
    fn lanes<const RATIO: bool>(
        &self,
        blend: Blend,
        warp: &Warp,
        b: &[Vec3; LANES],
        dir: &[Vec3; LANES],
    ) -> [Aim; LANES] {
        let uv = octa::encode_lanes(dir);
        let uv_of = |k: usize| Vec2::new(uv.u[k], uv.v[k]);
        let mut out = dir.map(|v| Aim { v, k: Some(1.0) }); // lanes at the probe keep the query direction
        if blend != Blend::Cell {
            for k in 0..LANES {
                out[k] = self.fetch_at(blend, warp, b[k], dir[k], uv_of(k));
            }
            return out;
        }
        let a = warp.probe.position;
        let (mut mapped, mut unmapped) = ([0u8; LANES], [0u8; LANES]);
        let (mut n_mapped, mut n_unmapped) = (0usize, 0usize);
        let (mut cells, mut slots) = ([UVec3::ZERO; LANES], [NO_MAP; LANES]);
        let size = self.geometry.cell_size();
        for k in 0..LANES {
            cells[k] = self.geometry.cell_of_sized(b[k], size);
            slots[k] = self.slot[self.geometry.cell_index(cells[k])];
            let has_map = slots[k] != NO_MAP;
            let at_probe = b[k] == a;
            // write the lane to both lists, advance the one it belongs to
            (mapped[n_mapped], unmapped[n_unmapped]) = (k as u8, k as u8);
            n_mapped += (has_map && !at_probe) as usize;
            n_unmapped += (!has_map && !at_probe) as usize;
        }
        if n_mapped > 0 {
            // the maps' bilinear footprints for every lane at once (a loop that vectorises)
            let n = self.map_res as f32;
            let (mut i0, mut j0) = ([0i32; LANES], [0i32; LANES]);
            let (mut fx, mut fy) = ([0f32; LANES], [0f32; LANES]);
            for k in 0..LANES {
                (i0[k], j0[k], fx[k], fy[k]) = octa::footprint_of(n, uv.u[k], uv.v[k]);
            }
            // gather: the map's inverse distance and the map's origin minus B, per lane
            let (mut w, mut cb) = ([0.0f32; LANES], [[0.0f32; LANES]; 3]);
            for &k in &mapped[..n_mapped] {
                let k = k as usize;
                let taps = octa::footprint_taps(self.map_res, i0[k], j0[k], fx[k], fy[k]);
                w[k] = self.map_w(slots[k], &taps);
                let c = self.origin_sized(cells[k], size) - b[k];
                (cb[0][k], cb[1][k], cb[2][k]) = (c.x, c.y, c.z);
            }
            let d = [dir.map(|v| v.x), dir.map(|v| v.y), dir.map(|v| v.z)];
            let bb = [b.map(|v| v.x), b.map(|v| v.y), b.map(|v| v.z)];
            // the warp step (`inv_t_from_map`, then `aimed_point`) for every lane
            let mut v = [[0.0f32; LANES]; 3];
            let mut u = [0.0f32; LANES];
            let a3 = a.to_array();
            for k in 0..LANES {
                let t = ((d[0][k] * cb[0][k]) + (d[1][k] * cb[1][k]) + (d[2][k] * cb[2][k])) + 1.0 / w[k];
                let inv_t = if t > 0.0 { (1.0 / t).min(1e30) } else { 1e30 };
                u[k] = if w[k] > 0.0 { inv_t } else { 0.0 };
                for c in 0..3 {
                    v[c][k] = (bb[c][k] + d[c][k] / u[k]) - a3[c];
                }
            }
            for &k in &mapped[..n_mapped] {
                let k = k as usize;
                let p = Vec3::new(v[0][k], v[1][k], v[2][k]);
                out[k] = match (u[k] > 0.0 && p.is_finite() && p != Vec3::ZERO, RATIO) {
                    (true, true) => Aim { v: p, k: Some(distance_ratio(p, u[k])) },
                    (true, false) => Aim { v: p, k: None },
                    (false, _) => Aim { v: dir[k], k: Some(1.0) },
                };
            }
        }
        if n_unmapped > 0 && self.fallback == Method::Box && warp.options.relax_texels <= 0.0 {
            // the box for every lane at once, kept for the fallback lanes
            let boxed = warp.proxies.aabb.fetch_dir_lanes(a, b, dir);
            for &k in &unmapped[..n_unmapped] {
                out[k as usize] = boxed[k as usize].into();
            }
        } else {
            for &k in &unmapped[..n_unmapped] {
                let k = k as usize;
                out[k] = warp.fetch_vector(self.fallback, b[k], dir[k]).into();
            }
        }
        out
    }

    /// `fetch` given `uv = encode(dir)`.
    #[inline]
    fn fetch_at(&self, blend: Blend, warp: &Warp, b: Vec3, dir: Vec3, uv: Vec2) -> Aim {
        let a = warp.probe.position;
        if b == a {
            return Aim { v: dir, k: Some(1.0) };
        }
        let taps = octa::bilinear_taps(self.map_res, uv);
        match blend {
            Blend::Cell => {
                let size = self.geometry.cell_size();
                let cell = self.geometry.cell_of_sized(b, size);
                match self.slot_of(self.geometry.cell_index(cell)) {
                    Some(slot) => {
                        let origin = self.origin_sized(cell, size);
                        map_fetch(a, origin, self.map_w(slot, &taps), b, dir)
                    }
                    None => warp.fetch_vector(self.fallback, b, dir).into(),
                }
            }
            Blend::Trilinear => match self.trilinear_inv_t(&taps, b, dir) {
                Some(u) => fetch_from_inv_t(a, u, b, dir),
                None => warp.fetch_vector(self.fallback, b, dir).into(),
            },
        }
    }

    fn trilinear_inv_t(&self, taps: &[(u32, f32); 4], b: Vec3, dir: Vec3) -> Option<f32> {
        let g = &self.geometry;
        // position in the lattice of cell centres
        let size = g.cell_size();
        let f = (b - g.min) / size - 0.5;
        let hi = (g.counts - UVec3::ONE).as_vec3();
        let f = if f.is_finite() { f.clamp(Vec3::ZERO, hi) } else { Vec3::ZERO };
        let base = f.floor();
        let frac = f - base;
        let base = base.as_uvec3();
        let (mut sum, mut wsum) = (0.0f32, 0.0f32);
        for corner in 0..8u32 {
            let o = UVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let c = (base + o).min(g.counts - UVec3::ONE);
            let w = (if o.x == 1 { frac.x } else { 1.0 - frac.x })
                * (if o.y == 1 { frac.y } else { 1.0 - frac.y })
                * (if o.z == 1 { frac.z } else { 1.0 - frac.z });
            if w <= 0.0 {
                continue;
            }
            if let Some(u) = self.cell_inv_t(c, size, taps, b, dir) {
                sum += w * u;
                wsum += w;
            }
        }
        (wsum > 0.0).then(|| sum / wsum)
    }
}

/// The slot value of a cell that stores no map.
pub const NO_MAP: u32 = u32::MAX;

/// A warp map sampled with bilinear `taps`.
#[inline]
#[must_use]
pub fn sample_map(map: &[f32], taps: &[(u32, f32); 4]) -> f32 {
    taps.iter().map(|&(k, wt)| map[k as usize] * wt).sum()
}

/// The corrective lookup, shared by the fit's objective and the runtime: the cell centred at
/// `centre` sees its hit at inverse distance `w` along `dir`; one warp step against that
/// estimate gives the point to fetch probe A (at `a`) towards.
#[inline]
#[must_use]
pub fn map_fetch_vector(a: Vec3, centre: Vec3, w: f32, b: Vec3, dir: Vec3) -> Vec3 {
    map_fetch(a, centre, w, b, dir).v
}

/// [`map_fetch_vector`] with the aimed point's distance ratio (`warp::glossy`).
#[inline]
#[must_use]
pub fn map_fetch(a: Vec3, centre: Vec3, w: f32, b: Vec3, dir: Vec3) -> Aim {
    fetch_from_inv_t(a, inv_t_from_map(centre, w, b, dir), b, dir)
}

/// Aim at the point at inverse distance `u` along the ray (B, dir) (the query direction
/// when the hit is at infinity). The point is `|v|` from A and `1/u` from B, so its
/// distance ratio is `|v| · u`; 1 at infinity and wherever that degenerates.
#[inline]
fn fetch_from_inv_t(a: Vec3, u: f32, b: Vec3, dir: Vec3) -> Aim {
    if u > 0.0 {
        let v = b + dir / u - a;
        if v.is_finite() && v != Vec3::ZERO {
            return Aim { v, k: Some(distance_ratio(v, u)) };
        }
    }
    Aim { v: dir, k: Some(1.0) } // hit at infinity: sky along Dir
}

/// The distance ratio `|v| · u` of an aimed point (1 where it degenerates).
#[inline]
fn distance_ratio(v: Vec3, u: f32) -> f32 {
    let k = v.length() * u;
    if k.is_finite() && k > 0.0 { k } else { 1.0 }
}

/// One warp step against a cell map: the cell (centre `c`) sees its hit at inverse distance
/// `w` along `dir`; the plane perpendicular to `dir` there is crossed by the ray from `b` at
/// distance `t`. Returns 1/t (0 for sky; 1e30, i.e. the hit at B, if the plane is behind B).
#[inline]
#[must_use]
pub fn inv_t_from_map(c: Vec3, w: f32, b: Vec3, dir: Vec3) -> f32 {
    if !(w > 0.0) {
        return 0.0;
    }
    let t = dir.dot(c - b) + 1.0 / w;
    if t > 0.0 { (1.0 / t).min(1e30) } else { 1e30 }
}

/// Warp map of a cell from a box proxy: inverse distance from the cell centre to the box's
/// boundary along each texel direction (0 where the centre is outside the box).
#[must_use]
pub fn box_map(centre: Vec3, proxy: &crate::warp::proxy::BoxProxy, map_res: u32) -> Vec<f32> {
    (0..map_res * map_res)
        .map(|t| {
            let d = octa::texel_dir(map_res, t % map_res, t / map_res);
            match proxy.exit_distance(centre, d) {
                Some(t) if t > 0.0 => (1.0 / t).min(1e30),
                _ => 0.0,
            }
        })
        .collect()
}
