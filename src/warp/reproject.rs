//! Literal reprojection (seed 000's "boring" baseline): treat probe A as a point cloud,
//! scatter every texel into a new probe at B with a depth test, then fill the holes.
//! Expensive per location (O(N²) scatter), cheap per lookup. Two hole fillings:
//! - [`HoleFill::PushPull`]: a push-pull pyramid (every hole takes the coarser levels'
//!   average: smooth, and it blends foreground into disocclusions);
//! - [`HoleFill::MedianDilate`]: seed 002's, for its reprojected depth buffer: a median over
//!   the 3×3 neighbours closes the small gaps where the scatter undersampled (holes with at
//!   least [`MEDIAN_MIN`] written neighbours take the neighbour of median distance), then a
//!   dilation taking the *farthest* neighbour, 3×3 then 5×5, fills disocclusions with
//!   background, as what a disocclusion reveals is behind; what is still empty then (gaps
//!   wider than 5 texels) falls back to push-pull. Neighbourhoods are clamped at the map's
//!   border (the octahedral seams are not followed).
//!
//! The depth test packs the distance from B above the payload (A's texel index) in one u64
//! and keeps the minimum: positive f32 bit patterns order like the floats, +inf last.

use super::WarpProbe;
use crate::octa::{self, OctMap};
use glam::{Vec3, Vec4};

/// How holes left by the scatter are filled (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HoleFill {
    PushPull,
    MedianDilate,
}

/// A hole takes the median of its 3×3 neighbours when at least this many are written.
pub const MEDIAN_MIN: usize = 4;

/// An empty texel's key.
const EMPTY: u64 = u64::MAX;

/// Reprojects probe A's mirror radiance to position `b` at resolution `res` (power of two),
/// holes filled by push-pull.
#[must_use]
pub fn reproject(p: &WarpProbe, b: Vec3, res: u32) -> OctMap<Vec3> {
    reproject_with(p, b, res, HoleFill::PushPull)
}

/// [`reproject`] with the hole filling chosen by `fill`.
#[must_use]
pub fn reproject_with(p: &WarpProbe, b: Vec3, res: u32, fill: HoleFill) -> OctMap<Vec3> {
    let mut keys = scatter(p, b, res);
    if fill == HoleFill::MedianDilate {
        median_fill(&mut keys, res);
        for radius in [1, 2] {
            farthest_fill(&mut keys, res, radius);
        }
    }
    let src_rad = &p.radiance.levels[0];
    let base: Vec<Vec4> = keys
        .iter()
        .map(|&k| if k == EMPTY { Vec4::ZERO } else { src_rad.texels[(k & 0xFFFF_FFFF) as usize].extend(1.0) })
        .collect();
    push_pull(OctMap::new(res, base))
}

/// Scatters A's texels into a `res`² map seen from `b`: per texel the key of the nearest.
fn scatter(p: &WarpProbe, b: Vec3, res: u32) -> Vec<u64> {
    let src_inv = &p.inv_depth.levels[0];
    let n = src_inv.res;
    let mut keys = vec![EMPTY; (res * res) as usize];
    for j in 0..n {
        for i in 0..n {
            let t = j * n + i;
            let dir_a = octa::texel_dir(n, i, j);
            let w = src_inv.texels[t as usize];
            let (dir_b, dist_b) = if w > 0.0 {
                let q = p.position + dir_a / w - b;
                let l = q.length();
                if l > 0.0 && l.is_finite() { (q / l, l) } else { (dir_a, 0.0) }
            } else {
                (dir_a, f32::INFINITY)
            };
            let (bi, bj) = octa::texel_of_uv(res, octa::encode(dir_b));
            let key = ((dist_b.to_bits() as u64) << 32) | t as u64;
            let slot = &mut keys[(bj * res + bi) as usize];
            *slot = (*slot).min(key);
        }
    }
    keys
}

/// The written keys around texel (i, j) within `radius` (clamped at the border).
fn neighbours(keys: &[u64], res: u32, i: u32, j: u32, radius: u32) -> impl Iterator<Item = u64> + '_ {
    let (i0, i1) = (i.saturating_sub(radius), (i + radius).min(res - 1));
    let (j0, j1) = (j.saturating_sub(radius), (j + radius).min(res - 1));
    (j0..=j1)
        .flat_map(move |y| (i0..=i1).map(move |x| (x, y)))
        .filter(move |&(x, y)| (x, y) != (i, j))
        .map(move |(x, y)| keys[(y * res + x) as usize])
        .filter(|&k| k != EMPTY)
}

/// Seed 002's median: holes with at least [`MEDIAN_MIN`] written 3×3 neighbours take the
/// neighbour of median distance (one pass, reading the scatter only).
fn median_fill(keys: &mut [u64], res: u32) {
    let before = keys.to_vec();
    for j in 0..res {
        for i in 0..res {
            let k = (j * res + i) as usize;
            if before[k] != EMPTY {
                continue;
            }
            let (mut near, mut n) = ([EMPTY; 8], 0);
            for key in neighbours(&before, res, i, j, 1) {
                (near[n], n) = (key, n + 1);
            }
            if n >= MEDIAN_MIN {
                near[..n].sort_unstable();
                keys[k] = near[n / 2];
            }
        }
    }
}

/// Seed 002's dilation: holes take the farthest written neighbour within `radius` (one
/// pass, reading the map as it was before the pass).
fn farthest_fill(keys: &mut [u64], res: u32, radius: u32) {
    let before = keys.to_vec();
    for j in 0..res {
        for i in 0..res {
            let k = (j * res + i) as usize;
            if before[k] == EMPTY
                && let Some(far) = neighbours(&before, res, i, j, radius).max()
            {
                keys[k] = far;
            }
        }
    }
}

/// Fills texels of weight 0 from coarser levels (pull: sum 2×2 blocks of (rgb·w, w); push:
/// holes take the coarser level's seam-aware bilinear value).
fn push_pull(base: OctMap<Vec4>) -> OctMap<Vec3> {
    let mut levels = vec![base];
    while levels.last().is_some_and(|l| l.res > 1 && l.res % 2 == 0) {
        let prev = levels.last().expect("non-empty");
        let half = prev.res / 2;
        let next = OctMap::from_fn(half, |i, j, _| {
            prev.get(2 * i, 2 * j)
                + prev.get(2 * i + 1, 2 * j)
                + prev.get(2 * i, 2 * j + 1)
                + prev.get(2 * i + 1, 2 * j + 1)
        });
        levels.push(next);
    }
    let normalise = |v: Vec4| if v.w > 0.0 { v / v.w } else { Vec4::ZERO };
    let mut filled: OctMap<Vec4> = {
        let top = levels.last().expect("non-empty");
        OctMap::new(top.res, top.texels.iter().map(|&v| normalise(v)).collect())
    };
    for level in levels.iter().rev().skip(1) {
        let coarse = filled;
        filled = OctMap::from_fn(level.res, |i, j, _| {
            let v = level.get(i, j);
            if v.w > 0.0 { normalise(v) } else { coarse.bilinear_uv(octa::texel_uv(level.res, i, j)) }
        });
    }
    OctMap::new(filled.res, filled.texels.iter().map(|v| v.truncate()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(dist: f32, texel: u32) -> u64 {
        ((dist.to_bits() as u64) << 32) | texel as u64
    }

    #[test]
    fn the_median_closes_a_small_gap_with_the_middle_neighbour() {
        // a 4×4 map, hole at (1, 1) with all 8 neighbours written at distances 1..=8
        let res = 4;
        let mut keys = vec![key(9.0, 99); 16];
        let around = [(0, 0), (1, 0), (2, 0), (0, 1), (2, 1), (0, 2), (1, 2), (2, 2)];
        for (n, &(i, j)) in around.iter().enumerate() {
            keys[j * 4 + i] = key(1.0 + n as f32, n as u32);
        }
        keys[5] = EMPTY;
        median_fill(&mut keys, res);
        assert_eq!(keys[5], key(5.0, 4), "the 5th of 8 sorted neighbours");
    }

    #[test]
    fn the_median_leaves_wide_holes_and_the_dilation_fills_them_with_background() {
        // an 8×8 map: everything empty but a near column (x = 0) and a far column (x = 7)
        let res = 8;
        let mut keys = vec![EMPTY; 64];
        for j in 0..8 {
            keys[j * 8] = key(1.0, 0);
            keys[j * 8 + 7] = key(10.0, 1);
        }
        let before = keys.clone();
        median_fill(&mut keys, res);
        assert_eq!(keys, before, "no hole has 4 written neighbours");
        farthest_fill(&mut keys, res, 1);
        // x = 1 touches only the near column, x = 6 only the far one
        assert_eq!(keys[8 + 1], key(1.0, 0));
        assert_eq!(keys[8 + 6], key(10.0, 1));
        farthest_fill(&mut keys, res, 2);
        // the 5×5 pass: x = 4 sees the far x = 6 and x = 3 the near x = 1 only
        assert_eq!(keys[8 + 4], key(10.0, 1));
        assert_eq!(keys[8 + 3], key(1.0, 0));
    }
}
