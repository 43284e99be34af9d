//! Literal reprojection (seed 000's "boring" baseline): treat probe A as a point cloud,
//! scatter every texel into a new probe at B with a depth test, then fill the holes with a
//! push-pull pyramid. Expensive per location (O(N²) scatter), cheap per lookup.
//!
//! The depth test packs the distance from B above the payload (A's texel index) in one u64
//! and keeps the minimum: positive f32 bit patterns order like the floats, +inf last.

use super::WarpProbe;
use crate::octa::{self, OctMap};
use glam::{Vec3, Vec4};

/// Reprojects probe A's mirror radiance to position `b` at resolution `res` (power of two).
#[must_use]
pub fn reproject(p: &WarpProbe, b: Vec3, res: u32) -> OctMap<Vec3> {
    let src_inv = &p.inv_depth.levels[0];
    let src_rad = &p.radiance.levels[0];
    let n = src_inv.res;
    let mut keys = vec![u64::MAX; (res * res) as usize];
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
    let base: Vec<Vec4> = keys
        .iter()
        .map(|&k| if k == u64::MAX { Vec4::ZERO } else { src_rad.texels[(k & 0xFFFF_FFFF) as usize].extend(1.0) })
        .collect();
    push_pull(OctMap::new(res, base))
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
