//! Hemi-octahedral maps: the upper hemisphere (+Z, a surface's tangent-space normal) on a
//! square, as seed 003 packs one reflection probe per surface point into an atlas tile.
//!
//! Convention: for a tangent-space vector `v` with `z` clamped to ≥ 0,
//! `p = v.xy / (|x|+|y|+z)` (the upper octahedron's faces), turned 45° and scaled onto the
//! square: `a = p.x + p.y`, `b = p.x − p.y`, `uv = (a, b) * 0.5 + 0.5`. The square's centre is
//! the normal, its edges the horizon; texel (i, j) centre at `((i+.5)/N, (j+.5)/N)`, row 0
//! first, index `j*N + i`. The face boundaries (p.x = 0, p.y = 0) are the square's
//! diagonals, which run through texel corners for any N.
//!
//! Directions below the horizon (a lobe reaching under the surface) map to the horizon point
//! above them; straight down, zero and non-finite vectors map to the centre. Lookups clamp
//! to the tile's edge texels: the tile's border is the horizon, with nothing beyond it.

use super::Texel;
use glam::{Vec2, Vec3};

/// Human-readable statement of the mapping. Must match [`encode`].
pub const CONVENTION: &str = "hemi-octahedral: z clamped to >= 0; p = v.xy/(|x|+|y|+z); \
a = p.x+p.y, b = p.x-p.y; uv = (a,b)*0.5+0.5; texel (i,j) centre ((i+.5)/N,(j+.5)/N), index j*N+i; \
+Z (the surface normal) at the centre, the horizon on the edges";

/// Tangent-space direction → uv in [0, 1]²; never NaN (see the module's convention).
#[inline]
#[must_use]
pub fn encode(dir: Vec3) -> Vec2 {
    let z = dir.z.max(0.0);
    let l1 = dir.x.abs() + dir.y.abs() + z;
    if !(l1 >= f32::MIN_POSITIVE && l1.is_finite()) {
        return Vec2::splat(0.5);
    }
    let (px, py) = (dir.x / l1, dir.y / l1);
    Vec2::new(((px + py) * 0.5 + 0.5).clamp(0.0, 1.0), ((px - py) * 0.5 + 0.5).clamp(0.0, 1.0))
}

/// uv → unit tangent-space direction (z ≥ 0). uv outside [0, 1]² is clamped.
#[inline]
#[must_use]
pub fn decode(uv: Vec2) -> Vec3 {
    decode_point(uv).normalize()
}

/// The point on the upper octahedron |x|+|y|+z = 1 of `uv` (not normalised).
#[inline]
fn decode_point(uv: Vec2) -> Vec3 {
    let q = uv.clamp(Vec2::ZERO, Vec2::ONE) * 2.0 - 1.0;
    let (px, py) = ((q.x + q.y) * 0.5, (q.x - q.y) * 0.5);
    Vec3::new(px, py, (1.0 - px.abs() - py.abs()).max(0.0))
}

/// Unit direction through the centre of texel (i, j) of an N×N tile.
#[inline]
#[must_use]
pub fn texel_dir(res: u32, i: u32, j: u32) -> Vec3 {
    decode(super::texel_uv(res, i, j))
}

/// Exact solid angle of every texel of an N×N tile (N even), in steradians; sums to 2π.
///
/// As for the full-sphere map ([`super::texel_solid_angles`]): the mapping is linear on each
/// face, so a texel is two spherical triangles; a texel the face boundary crosses is split
/// along that boundary (the diagonal `i = j` or `i + j = N − 1`; for even N no texel is
/// crossed by both).
#[must_use]
pub fn texel_solid_angles(res: u32) -> Vec<f32> {
    let n = res as f64;
    let corner =
        |i: u32, j: u32| super::unit_f64(decode_point(Vec2::new((i as f64 / n) as f32, (j as f64 / n) as f32)));
    let mut out = Vec::with_capacity((res * res) as usize);
    for j in 0..res {
        for i in 0..res {
            let (a, b, c, d) = (corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1));
            let omega = if i == j {
                super::spherical_triangle_area(a, b, c) + super::spherical_triangle_area(a, c, d)
            } else {
                super::spherical_triangle_area(a, b, d) + super::spherical_triangle_area(b, c, d)
            };
            out.push(omega as f32);
        }
    }
    out
}

/// Where a bilinear lookup at `uv` reads an N×N tile: the four texels (row-major indices,
/// clamped to the edge) and the blend's fractions. The same for every tile of an atlas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Taps {
    pub texels: [usize; 4],
    pub fx: f32,
    pub fy: f32,
}

/// The taps of a lookup at `uv` (clamped to the tile's edge texels).
#[inline]
#[must_use]
pub fn taps(res: u32, uv: Vec2) -> Taps {
    let n = res as f32;
    let x = (uv.x * n - 0.5).clamp(0.0, n - 1.0);
    let y = (uv.y * n - 0.5).clamp(0.0, n - 1.0);
    let (x0, y0) = (x.floor(), y.floor());
    let (i0, j0) = (x0 as usize, y0 as usize);
    let last = res as usize - 1;
    let (i1, j1) = ((i0 + 1).min(last), (j0 + 1).min(last));
    let w = res as usize;
    Taps { texels: [j0 * w + i0, j0 * w + i1, j1 * w + i0, j1 * w + i1], fx: x - x0, fy: y - y0 }
}

/// The bilinear value of one tile (`tile`, row-major) at `taps`: with [`taps`], the
/// tile's bilinear lookup, clamped to its edge texels.
#[inline]
#[must_use]
pub fn gather<T: Texel>(tile: &[T], t: Taps) -> T {
    super::blend(t.texels.map(|k| tile[k]), t.fx, t.fy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_over_the_upper_hemisphere() {
        for k in 0..4096u32 {
            // a spiral over the hemisphere, horizon included
            let z = 1.0 - (k as f32 + 0.5) / 4096.0;
            let phi = k as f32 * 2.399_963;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let d = Vec3::new(s * libm::cosf(phi), s * libm::sinf(phi), z);
            let back = decode(encode(d));
            assert!((back - d).length() < 1e-5, "{d} → {back}");
        }
    }

    #[test]
    fn centre_is_the_normal_and_edges_the_horizon() {
        assert!((decode(Vec2::splat(0.5)) - Vec3::Z).length() < 1e-6);
        for uv in [Vec2::new(0.0, 0.3), Vec2::new(1.0, 0.8), Vec2::new(0.2, 0.0), Vec2::new(0.7, 1.0)] {
            assert!(decode(uv).z.abs() < 1e-6, "{uv}");
        }
    }

    #[test]
    fn degenerate_directions_map_to_the_centre_or_the_horizon() {
        for d in [Vec3::ZERO, -Vec3::Z, Vec3::NAN, Vec3::splat(f32::INFINITY), Vec3::new(1e-40, 0.0, 0.0)] {
            let uv = encode(d);
            assert!(uv.is_finite() && uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all(), "{d} → {uv}");
        }
        assert_eq!(encode(-Vec3::Z), Vec2::splat(0.5));
        // below the horizon: the horizon point above it
        let below = encode(Vec3::new(1.0, 0.5, -0.7));
        assert!((decode(below) - Vec3::new(1.0, 0.5, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn solid_angles_sum_to_the_hemisphere_and_are_positive() {
        for res in [2u32, 4, 8, 16, 32] {
            let w = texel_solid_angles(res);
            let sum: f64 = w.iter().map(|&x| x as f64).sum();
            assert!((sum - 2.0 * std::f64::consts::PI).abs() < 1e-4, "N = {res}: {sum}");
            assert!(w.iter().all(|&x| x > 0.0));
        }
    }

    #[test]
    fn bilinear_interpolates_and_clamps() {
        let tile: Vec<f32> = (0..16).map(|k| k as f32).collect();
        let bilinear = |tile: &[f32], res: u32, uv: Vec2| gather(tile, taps(res, uv));
        assert_eq!(bilinear(&tile, 4, super::super::texel_uv(4, 2, 1)), 6.0);
        assert_eq!(bilinear(&tile, 4, Vec2::ZERO), 0.0);
        assert_eq!(bilinear(&tile, 4, Vec2::ONE), 15.0);
        let mid = bilinear(&tile, 4, Vec2::new(0.5, 0.5));
        assert!((mid - 7.5).abs() < 1e-6);
    }
}
