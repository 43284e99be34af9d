//! Grid geometry shared by the bake, the fit and the runtime sampler: an axis-aligned box
//! split into cells, one probe (and one corrective) per cell, at its centre unless the bake
//! relocated it.

use glam::{UVec3, Vec3};

/// Grid geometry: an axis-aligned box split into `counts` cells; probes at cell centres.
/// Cell (x, y, z) has linear index `x + nx·(y + ny·z)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridGeometry {
    pub min: Vec3,
    pub max: Vec3,
    pub counts: UVec3,
}

impl GridGeometry {
    #[must_use]
    pub fn cell_count(&self) -> usize {
        (self.counts.x * self.counts.y * self.counts.z) as usize
    }
    #[must_use]
    pub fn cell_size(&self) -> Vec3 {
        (self.max - self.min) / self.counts.as_vec3()
    }
    #[must_use]
    pub fn cell_coords(&self, index: usize) -> UVec3 {
        let i = index as u32;
        UVec3::new(i % self.counts.x, (i / self.counts.x) % self.counts.y, i / (self.counts.x * self.counts.y))
    }
    #[must_use]
    pub fn cell_index(&self, c: UVec3) -> usize {
        (c.x + self.counts.x * (c.y + self.counts.y * c.z)) as usize
    }
    #[must_use]
    pub fn cell_centre(&self, index: usize) -> Vec3 {
        self.centre_of(self.cell_coords(index))
    }
    /// Centre of the cell at integer coordinates `c` (no index round trip).
    #[must_use]
    pub fn centre_of(&self, c: UVec3) -> Vec3 {
        self.centre_of_sized(c, self.cell_size())
    }
    /// `centre_of` given `cell_size()` (hoisted out of loops: it costs three divisions).
    #[inline]
    #[must_use]
    pub fn centre_of_sized(&self, c: UVec3, cell_size: Vec3) -> Vec3 {
        self.min + (c.as_vec3() + 0.5) * cell_size
    }
    /// Cell containing `p` (clamped to the grid).
    #[must_use]
    pub fn cell_of(&self, p: Vec3) -> UVec3 {
        self.cell_of_sized(p, self.cell_size())
    }
    /// `cell_of` given `cell_size()`.
    #[inline]
    #[must_use]
    pub fn cell_of_sized(&self, p: Vec3, cell_size: Vec3) -> UVec3 {
        self.cell_of_units((p - self.min) / cell_size)
    }
    /// The cell at `u`, a position in cell units from `min` (`(p − min) / cell_size`).
    #[inline]
    #[must_use]
    pub fn cell_of_units(&self, u: Vec3) -> UVec3 {
        // floor without libm calls (the x86-64 baseline has no round instruction); exact for
        // |f| < 2²², far beyond any grid, and larger values are clamped below anyway
        let f = u.to_array().map(|x| crate::octa::floor_small(x).1);
        let finite = f[0].is_finite() & f[1].is_finite() & f[2].is_finite();
        let hi = self.counts - UVec3::ONE;
        UVec3::new(coord(f[0], hi.x, finite), coord(f[1], hi.y, finite), coord(f[2], hi.z, finite))
    }

    /// `cell_index(cell_of_sized(p, cell_size))` for [`LANES`](crate::octa::LANES)
    /// positions given as components ([`crate::octa::soa`]), the same values from the same
    /// operations, each stage a plain loop over the lanes.
    #[inline(always)]
    #[must_use]
    pub fn cell_index_soa(&self, p: &crate::octa::Soa3, cell_size: Vec3) -> [usize; crate::octa::LANES] {
        const L: usize = crate::octa::LANES;
        let (min, size) = (self.min.to_array(), cell_size.to_array());
        let hi = (self.counts - UVec3::ONE).to_array();
        let mut f = [[0.0f32; L]; 3];
        for c in 0..3 {
            for k in 0..L {
                f[c][k] = crate::octa::floor_small((p[c][k] - min[c]) / size[c]).1;
            }
        }
        // `cell_index`'s arithmetic in u32, as it does it; the loop vectorises
        let (nx, ny) = (self.counts.x, self.counts.y);
        let mut index = [0u32; L];
        for k in 0..L {
            let finite = f[0][k].is_finite() & f[1][k].is_finite() & f[2][k].is_finite();
            let at = |c: usize| coord(f[c][k], hi[c], finite);
            index[k] = at(0) + nx * (at(1) + ny * at(2));
        }
        index.map(|i| i as usize)
    }
}

/// A cell coordinate from `f`, the floor of a position in cell units: clamped to
/// [0, `hi`] (`Vec3::clamp`'s `max(0).min(hi)` by these comparisons), 0 where the position
/// is not finite. Converted by adding 1.5·2²³ and reading the bits, which a loop over lanes
/// vectorises (`as u32` saturates, and the x86-64 baseline has no instruction for it): exact
/// below 2²², as `floor_small` is, and held to `hi` above it.
#[inline(always)]
fn coord(f: f32, hi: u32, finite: bool) -> u32 {
    const SHIFT: f32 = 12_582_912.0;
    let top = hi as f32;
    let x = if f > 0.0 { f } else { 0.0 };
    let x = if x < top { x } else { top };
    let x = if finite { x } else { 0.0 };
    let i = ((x + SHIFT).to_bits() - SHIFT.to_bits()) as i32;
    // (a u32 minimum is SSE4.1; both are below 2³¹)
    (if i < hi as i32 { i } else { hi as i32 }) as u32
}

/// The sparse form files store per-cell probe offsets in: the cells whose probe is off its
/// centre, in cell order, with the offset.
#[must_use]
pub fn relocated_cells(probe_offset: &[Vec3]) -> Vec<(u32, [f32; 3])> {
    probe_offset.iter().enumerate().filter(|(_, o)| **o != Vec3::ZERO).map(|(k, o)| (k as u32, o.to_array())).collect()
}
