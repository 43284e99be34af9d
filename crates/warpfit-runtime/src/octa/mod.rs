//! Full-sphere octahedral maps: the direction ↔ uv mapping, images over it with seam-aware
//! bilinear lookup, exact per-texel solid angles and mip chains that respect the topology.
//!
//! Convention (written into every manifest as [`CONVENTION`]): for a unit vector `v`,
//! `p = v.xy / (|x|+|y|+|z|)`; if `v.z < 0` then `p = (1 - |p.yx|) * sign(p.xy)` with
//! `sign(0) = +1`; `uv = p * 0.5 + 0.5`. An N×N image stores texel (i = column, j = row) at
//! `uv = ((i+0.5)/N, (j+0.5)/N)`, row 0 first, in `texels[j * N + i]`. Directions are world
//! directions (no rotation): +Z is the centre of the map, −Z its four corners.
//!
//! Seams: the map's outer edge folds onto itself mirrored about its midpoint, so a texel just
//! outside the left edge at row j is texel (0, N−1−j) (pbrt-v4 `WrapMode::OctahedralSphere`).
//! Bilinear lookups use that wrap, which makes them continuous across the seams.
//!
//! Mips: for even N every texel of level k+1 covers exactly a 2×2 block of level k in uv, so a
//! solid-angle-weighted 2×2 reduction is a true box filter over the sphere.

pub mod hemi;

use glam::{Vec2, Vec3};
use std::ops::{Add, Mul};

/// `v` made unit length, for any finite non-zero `v`: scaled by its largest component first,
/// so lengths beyond f32's squared range (≈1.8e19) or below it (≈1e-19) still work. `None`
/// for zero, NaN or infinite input. A vector already unit to rounding is returned as is.
#[inline]
#[must_use]
pub fn unit_direction(v: Vec3) -> Option<Vec3> {
    if is_unit(v) {
        return Some(v);
    }
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let s = v / m;
    let l = s.length();
    (l > 0.0 && l.is_finite()).then(|| s / l)
}

/// Whether `unit_direction` takes `v` as it is: finite and of unit length to rounding.
#[inline(always)]
#[must_use]
pub fn is_unit(v: Vec3) -> bool {
    let l2 = v.length_squared();
    l2.is_finite() && (l2 - 1.0).abs() <= 4.0 * f32::EPSILON
}

/// Human-readable statement of the mapping, stored in manifests. Must match [`encode`].
pub const CONVENTION: &str = "octahedral full sphere: p = v.xy/(|x|+|y|+|z|); if v.z<0 then \
p = (1-|p.yx|)*sign(p.xy), sign(0)=+1; uv = p*0.5+0.5; texel (i=column, j=row) centre at \
uv=((i+0.5)/N,(j+0.5)/N), row 0 first, index j*N+i; world axes, +Z at the map centre";

#[inline]
fn sign_not_zero(x: f32) -> f32 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

/// Direction → uv in [0, 1]². `dir` need not be normalised; a zero, subnormal or non-finite
/// vector maps to the map centre (+Z), so no NaN ever leaves this function.
///
/// Branch-free: both hemispheres' coordinates are computed and selected, because the sign
/// of z is random for random queries (a mispredicted branch costs more than the fold) and
/// so that loops over lanes of lookups vectorise.
#[inline]
#[must_use]
pub fn encode(dir: Vec3) -> Vec2 {
    let (u, v) = encode_xyz(dir.x, dir.y, dir.z);
    Vec2::new(u, v)
}

/// `encode` on components: the one implementation behind `encode` and `encode_lanes`.
#[inline(always)]
fn encode_xyz(x: f32, y: f32, z: f32) -> (f32, f32) {
    let l1 = x.abs() + y.abs() + z.abs();
    // below MIN_POSITIVE, 1/l1 overflows and the products become NaN
    let usable = l1 >= f32::MIN_POSITIVE && l1.is_finite();
    let inv_l1 = 1.0 / l1; // one division, two multiplies
    let (px, py) = (x * inv_l1, y * inv_l1);
    let (fx, fy) = ((1.0 - py.abs()) * sign_not_zero(px), (1.0 - px.abs()) * sign_not_zero(py));
    let lower = z < 0.0;
    let (px, py) = (if lower { fx } else { px }, if lower { fy } else { py });
    let (u, v) = ((px * 0.5 + 0.5).clamp(0.0, 1.0), (py * 0.5 + 0.5).clamp(0.0, 1.0));
    if usable { (u, v) } else { (0.5, 0.5) }
}

/// uv → unit direction. uv outside [0, 1]² is clamped.
#[inline]
#[must_use]
pub fn decode(uv: Vec2) -> Vec3 {
    let p = uv.clamp(Vec2::ZERO, Vec2::ONE) * 2.0 - 1.0;
    decode_p(p).normalize()
}

/// Point on the octahedron |x|+|y|+|z| = 1 for p in [-1,1]² (not normalised).
#[inline]
fn decode_p(p: Vec2) -> Vec3 {
    let z = 1.0 - p.x.abs() - p.y.abs();
    if z < 0.0 {
        Vec3::new((1.0 - p.y.abs()) * sign_not_zero(p.x), (1.0 - p.x.abs()) * sign_not_zero(p.y), z)
    } else {
        Vec3::new(p.x, p.y, z)
    }
}

/// Unit direction through the centre of texel (i, j) of an N×N map.
#[inline]
#[must_use]
pub fn texel_dir(res: u32, i: u32, j: u32) -> Vec3 {
    decode(texel_uv(res, i, j))
}

/// uv of the centre of texel (i, j).
#[inline]
#[must_use]
pub fn texel_uv(res: u32, i: u32, j: u32) -> Vec2 {
    Vec2::new((i as f32 + 0.5) / res as f32, (j as f32 + 0.5) / res as f32)
}

/// Texel (i, j) containing `uv`.
#[inline]
#[must_use]
pub fn texel_of_uv(res: u32, uv: Vec2) -> (u32, u32) {
    let n = res as f32;
    let i = ((uv.x * n) as i64).clamp(0, res as i64 - 1) as u32;
    let j = ((uv.y * n) as i64).clamp(0, res as i64 - 1) as u32;
    (i, j)
}

/// Maps integer texel coordinates that may lie one texel outside the map back inside,
/// following the octahedral seam fold (pbrt-v4 `WrapMode::OctahedralSphere`).
#[inline]
#[must_use]
pub fn wrap_texel(res: u32, mut i: i64, mut j: i64) -> (u32, u32) {
    let n = res as i64;
    if i < 0 {
        i = -i - 1;
        j = n - 1 - j;
    } else if i >= n {
        i = 2 * n - 1 - i;
        j = n - 1 - j;
    }
    if j < 0 {
        i = n - 1 - i;
        j = -j - 1;
    } else if j >= n {
        i = n - 1 - i;
        j = 2 * n - 1 - j;
    }
    (i.clamp(0, n - 1) as u32, j.clamp(0, n - 1) as u32)
}

/// Where a bilinear lookup lands: the top-left texel of its 2×2 footprint (−1 or `res − 1`
/// at the seams, where the wrap applies) and the blend fractions.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Footprint {
    pub i0: i32,
    pub j0: i32,
    pub fx: f32,
    pub fy: f32,
}

/// The bilinear footprint of `uv` (clamped to [0, 1]²) on an N×N map.
#[inline]
#[must_use]
pub fn footprint(res: u32, uv: Vec2) -> Footprint {
    let (i0, j0, fx, fy) = footprint_of(res as f32, uv.x, uv.y);
    Footprint { i0, j0, fx, fy }
}

/// `footprint` on components: the one implementation behind `footprint` and the lane loops.
#[inline(always)]
pub fn footprint_of(n: f32, u: f32, v: f32) -> (i32, i32, f32, f32) {
    let x = u.clamp(0.0, 1.0) * n - 0.5;
    let y = v.clamp(0.0, 1.0) * n - 0.5;
    let (i0, x0) = floor_small(x);
    let (j0, y0) = floor_small(y);
    (i0, j0, x - x0, y - y0)
}

/// `floor(x)` as an integer and as a float, for |x| < 2²² (maps up to 2²¹ texels wide): adding and removing 1.5·2²³
/// rounds to the nearest integer in float arithmetic, one compare corrects it to the floor,
/// and the integer is read off the bits of `floor + 1.5·2²³`. Plain float arithmetic, so a
/// loop over lanes vectorises; `x as i32` saturates, which the x86-64 baseline cannot
/// vectorise, and `f32::floor` is a libm call there (no SSE4.1 round instruction).
#[inline(always)]
pub fn floor_small(x: f32) -> (i32, f32) {
    const SHIFT: f32 = 12_582_912.0; // 1.5·2²³
    let nearest = (x + SHIFT) - SHIFT;
    let floor = if nearest > x { nearest - 1.0 } else { nearest };
    ((floor + SHIFT).to_bits() as i32 - SHIFT.to_bits() as i32, floor)
}

/// Linear indices (row-major) of the 2×2 texels at `(i0, j0)`, seam wrap applied.
#[inline]
#[must_use]
pub fn quad_indices(res: u32, i0: i32, j0: i32) -> [u32; 4] {
    if quad_is_interior(res, i0, j0) {
        let k = (j0 * res as i32 + i0) as u32;
        return [k, k + 1, k + res, k + res + 1];
    }
    quad_indices_at_seam(res, i0, j0)
}

/// The 2×2 block at `(i0, j0)` lies inside the map: no seam handling needed.
#[inline(always)]
fn quad_is_interior(res: u32, i0: i32, j0: i32) -> bool {
    let last = res as i32 - 1;
    i0 >= 0 && j0 >= 0 && i0 < last && j0 < last
}

/// `quad_indices` for a footprint that touches the map's edge (rare: kept out of line so
/// the interior path stays small enough to inline).
#[cold]
#[inline(never)]
fn quad_indices_at_seam(res: u32, i0: i32, j0: i32) -> [u32; 4] {
    let idx = |i: i32, j: i32| {
        let (i, j) = wrap_texel(res, i as i64, j as i64);
        j * res + i
    };
    [idx(i0, j0), idx(i0 + 1, j0), idx(i0, j0 + 1), idx(i0 + 1, j0 + 1)]
}

/// Bilinear blend of a 2×2 quad (`[t00, t10, t01, t11]`).
#[inline]
pub fn blend<T: Texel>(q: [T; 4], fx: f32, fy: f32) -> T {
    (q[0] * (1.0 - fx) + q[1] * fx) * (1.0 - fy) + (q[2] * (1.0 - fx) + q[3] * fx) * fy
}

/// The four texels (linear indices, row-major) and weights a bilinear lookup at `uv` blends,
/// with the seam wrap applied. Weights sum to 1.
#[inline]
#[must_use]
pub fn bilinear_taps(res: u32, uv: Vec2) -> [(u32, f32); 4] {
    let Footprint { i0, j0, fx, fy } = footprint(res, uv);
    footprint_taps(res, i0, j0, fx, fy)
}

/// The taps of [`bilinear_taps`] given the footprint (`footprint_of`'s values): for lane
/// loops that find the footprints of many lookups at once.
#[inline]
#[must_use]
pub fn footprint_taps(res: u32, i0: i32, j0: i32, fx: f32, fy: f32) -> [(u32, f32); 4] {
    let k = quad_indices(res, i0, j0);
    [(k[0], (1.0 - fx) * (1.0 - fy)), (k[1], fx * (1.0 - fy)), (k[2], (1.0 - fx) * fy), (k[3], fx * fy)]
}

/// Octahedral coordinates of [`LANES`] lookups, as two arrays (the layout lane loops
/// vectorise over).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvLanes {
    pub u: [f32; LANES],
    pub v: [f32; LANES],
}

impl UvLanes {
    /// Lane `k`'s coordinate.
    #[inline]
    #[must_use]
    pub fn at(&self, k: usize) -> Vec2 {
        Vec2::new(self.u[k], self.v[k])
    }
}

/// `encode` for [`LANES`] directions, bit for bit the same.
#[inline]
#[must_use]
pub fn encode_lanes(dirs: &[Vec3; LANES]) -> UvLanes {
    encode_soa(&soa(dirs))
}

/// `encode` for [`LANES`] directions given as components ([`soa`]), bit for bit the same.
#[inline(always)]
#[must_use]
pub fn encode_soa(d: &Soa3) -> UvLanes {
    let mut uv = UvLanes::default();
    for k in 0..LANES {
        (uv.u[k], uv.v[k]) = encode_xyz(d[0][k], d[1][k], d[2][k]);
    }
    uv
}

/// [`LANES`] vectors as three arrays of components (x, y, z): the layout lane loops
/// vectorise over.
pub type Soa3 = [[f32; LANES]; 3];

/// `vectors` as components.
#[inline(always)]
#[must_use]
pub fn soa(vectors: &[Vec3; LANES]) -> Soa3 {
    let mut out = [[0.0f32; LANES]; 3];
    for k in 0..LANES {
        [out[0][k], out[1][k], out[2][k]] = vectors[k].to_array();
    }
    out
}

/// Lookups processed together by the `*_lanes` functions. Independent lookups advance
/// stage by stage in lockstep, so the processor overlaps their dependency chains (a single
/// lookup is latency-bound) and the stages vectorise.
pub const LANES: usize = 16;

/// The one driver behind every batch API: fills `out` group by group, `lanes(k)` answering
/// the [`LANES`] items from index `k` and `single(k)` each item of the tail shorter than a
/// group, so groups and tail can never be paired with the wrong items.
#[inline]
pub fn fill_in_lanes<R: Copy>(out: &mut [R], lanes: impl Fn(usize) -> [R; LANES], single: impl Fn(usize) -> R) {
    let whole = out.len() - out.len() % LANES;
    for k in (0..whole).step_by(LANES) {
        out[k..k + LANES].copy_from_slice(&lanes(k));
    }
    for (k, o) in out.iter_mut().enumerate().skip(whole) {
        *o = single(k);
    }
}

/// The [`LANES`] items of `items` from index `k` (which must be a whole group).
#[inline]
pub fn group_at<T>(items: &[T], k: usize) -> &[T; LANES] {
    items[k..].first_chunk().expect("a whole group of lanes")
}

/// A value stored per texel: radiance (`Vec3`), distance (`f32`), …
pub trait Texel: Copy + Default + Add<Output = Self> + Mul<f32, Output = Self> + Send + Sync {}
impl<T> Texel for T where T: Copy + Default + Add<Output = T> + Mul<f32, Output = T> + Send + Sync {}

/// A square octahedral image: plain data, `texels[j * res + i]`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OctMap<T> {
    pub res: u32,
    pub texels: Vec<T>,
}

impl<T: Texel> OctMap<T> {
    #[must_use]
    pub fn new(res: u32, texels: Vec<T>) -> Self {
        assert_eq!(texels.len(), (res * res) as usize, "octahedral map size");
        Self { res, texels }
    }

    /// Builds a map by evaluating `f(i, j, dir)` at every texel centre.
    pub fn from_fn(res: u32, mut f: impl FnMut(u32, u32, Vec3) -> T) -> Self {
        let mut texels = Vec::with_capacity((res * res) as usize);
        for j in 0..res {
            for i in 0..res {
                texels.push(f(i, j, texel_dir(res, i, j)));
            }
        }
        Self { res, texels }
    }

    #[inline]
    #[must_use]
    pub fn get(&self, i: u32, j: u32) -> T {
        self.texels[(j * self.res + i) as usize]
    }

    /// Texel lookup with the octahedral seam wrap for coordinates just outside the map.
    #[inline]
    #[must_use]
    pub fn get_wrapped(&self, i: i64, j: i64) -> T {
        let (i, j) = wrap_texel(self.res, i, j);
        self.get(i, j)
    }

    /// Nearest-texel lookup.
    #[inline]
    #[must_use]
    pub fn nearest(&self, dir: Vec3) -> T {
        let (i, j) = texel_of_uv(self.res, encode(dir));
        self.get(i, j)
    }

    /// Bilinear lookup at `uv`, continuous across the octahedral seams.
    #[inline]
    #[must_use]
    pub fn bilinear_uv(&self, uv: Vec2) -> T {
        let f = footprint(self.res, uv);
        blend(self.quad(f.i0, f.j0), f.fx, f.fy)
    }

    /// `bilinear_uv`, always inlined: for lane loops that interleave many lookups (a call
    /// per lane would serialise them). The scalar form stays an ordinary inline candidate.
    #[inline(always)]
    fn bilinear_uv_inline(&self, uv: Vec2) -> T {
        let f = footprint(self.res, uv);
        blend(self.quad(f.i0, f.j0), f.fx, f.fy)
    }

    /// The 2×2 texels at `(i0, j0)`, seam wrap applied.
    #[inline]
    #[must_use]
    pub fn quad(&self, i0: i32, j0: i32) -> [T; 4] {
        if quad_is_interior(self.res, i0, j0) {
            // one bounds check for the whole 2×2 block
            let (k, r) = ((j0 * self.res as i32 + i0) as usize, self.res as usize);
            let block = &self.texels[k..k + r + 2];
            return [block[0], block[1], block[r], block[r + 1]];
        }
        quad_indices_at_seam(self.res, i0, j0).map(|k| self.texels[k as usize])
    }

    /// `bilinear_uv` for [`LANES`] lookups at once, bit for bit the same values.
    #[inline(always)]
    #[must_use]
    pub fn bilinear_uv_lanes(&self, uv: &UvLanes) -> [T; LANES] {
        // Each stage is a plain loop over lanes so that it vectorises; only the gather is
        // per lane.
        let n = self.res as f32;
        let (mut i0, mut j0) = ([0i32; LANES], [0i32; LANES]);
        let (mut fx, mut fy) = ([0f32; LANES], [0f32; LANES]);
        for k in 0..LANES {
            (i0[k], j0[k], fx[k], fy[k]) = footprint_of(n, uv.u[k], uv.v[k]);
        }
        // explicit loops: `std::array::from_fn` is not reliably inlined here
        let mut q = [[T::default(); LANES]; 4];
        for k in 0..LANES {
            [q[0][k], q[1][k], q[2][k], q[3][k]] = self.quad(i0[k], j0[k]);
        }
        let mut out = [T::default(); LANES];
        for k in 0..LANES {
            out[k] = blend([q[0][k], q[1][k], q[2][k], q[3][k]], fx[k], fy[k]);
        }
        out
    }

    /// [`Self::bilinear_uv_lanes`] with lane k reading map `maps[k]`: bit for bit what each
    /// lane's own map answers (several probes, each lane reading its own).
    #[inline(always)]
    #[must_use]
    pub fn bilinear_uv_lanes_of(maps: &[&OctMap<T>; LANES], uv: &UvLanes) -> [T; LANES] {
        let (mut i0, mut j0) = ([0i32; LANES], [0i32; LANES]);
        let (mut fx, mut fy) = ([0f32; LANES], [0f32; LANES]);
        for k in 0..LANES {
            (i0[k], j0[k], fx[k], fy[k]) = footprint_of(maps[k].res as f32, uv.u[k], uv.v[k]);
        }
        let mut out = [T::default(); LANES];
        for k in 0..LANES {
            out[k] = blend(maps[k].quad(i0[k], j0[k]), fx[k], fy[k]);
        }
        out
    }

    /// Bilinear lookup towards `dir`.
    #[inline]
    #[must_use]
    pub fn bilinear(&self, dir: Vec3) -> T {
        self.bilinear_uv(encode(dir))
    }

    /// Solid-angle-weighted 2×2 reduction to the next mip (box filter over the sphere).
    /// `res` must be even.
    #[must_use]
    pub fn downsample(&self) -> Self {
        let weights = texel_solid_angles(self.res);
        self.downsample_weighted(&weights, |t| t, |t| t)
    }

    /// 2×2 reduction in a transformed domain: averages `to(t)` weighted by solid angle and maps
    /// the mean back with `from`. Used for distances, which are averaged as inverse distance
    /// so that misses (+inf) contribute 0 and parallax (linear in 1/d) is averaged correctly.
    pub fn downsample_weighted(&self, solid_angles: &[f32], to: impl Fn(T) -> T, from: impl Fn(T) -> T) -> Self {
        assert!(self.res >= 2 && self.res.is_multiple_of(2), "mip reduction needs an even resolution");
        let half = self.res / 2;
        Self::from_fn(half, |i, j, _| {
            let mut sum = T::default();
            let mut wsum = 0.0f32;
            for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (si, sj) = (2 * i + di, 2 * j + dj);
                let w = solid_angles[(sj * self.res + si) as usize];
                sum = sum + to(self.get(si, sj)) * w;
                wsum += w;
            }
            from(sum * (1.0 / wsum))
        })
    }
}

/// Exact solid angle of every texel of an N×N map (N even), in steradians; sums to 4π.
///
/// The mapping is linear on each octahedron face, and straight segments on a face project to
/// great-circle arcs, so a texel split along the diagonal parallel to its quadrant's fold line
/// is two spherical triangles whose areas are exact (Van Oosterom & Strackee 1983). For even N
/// the fold lines run through texel corners, so no triangle straddles a fold.
#[must_use]
pub fn texel_solid_angles(res: u32) -> Vec<f32> {
    let n = res as f64;
    let corner = |i: u32, j: u32| {
        unit_f64(decode_p(Vec2::new((2.0 * i as f64 / n - 1.0) as f32, (2.0 * j as f64 / n - 1.0) as f32)))
    };
    let mut out = Vec::with_capacity((res * res) as usize);
    for j in 0..res {
        for i in 0..res {
            let a = corner(i, j);
            let b = corner(i + 1, j);
            let c = corner(i + 1, j + 1);
            let d = corner(i, j + 1);
            // Quadrant of the texel centre decides which diagonal is parallel to the fold.
            let px = (i as f64 + 0.5) / n * 2.0 - 1.0;
            let py = (j as f64 + 0.5) / n * 2.0 - 1.0;
            let omega = if (px >= 0.0) == (py >= 0.0) {
                // fold |px|+|py|=1 runs along (1,-1): split along the b-d diagonal
                spherical_triangle_area(a, b, d) + spherical_triangle_area(b, c, d)
            } else {
                spherical_triangle_area(a, b, c) + spherical_triangle_area(a, c, d)
            };
            out.push(omega as f32);
        }
    }
    out
}

/// `v` made unit length in f64 (the corners of exact texel solid angles).
fn unit_f64(v: Vec3) -> [f64; 3] {
    let (x, y, z) = (v.x as f64, v.y as f64, v.z as f64);
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}

/// Area of the spherical triangle with unit-vector corners a, b, c (Van Oosterom & Strackee).
fn spherical_triangle_area(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let cross =
        |u: [f64; 3], v: [f64; 3]| [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let triple = dot(a, cross(b, c)).abs();
    let denom = 1.0 + dot(a, b) + dot(b, c) + dot(c, a);
    2.0 * libm::atan2(triple, denom)
}

/// A mip chain of octahedral maps, level 0 first, each half the resolution of the previous.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OctMips<T> {
    pub levels: Vec<OctMap<T>>,
}

impl<T: Texel> OctMips<T> {
    /// Trilinear lookup at fractional `lod` (clamped to the chain).
    #[inline]
    #[must_use]
    pub fn sample_lod(&self, dir: Vec3, lod: f32) -> T {
        let uv = encode(dir);
        self.sample_lod_uv(uv, lod)
    }

    #[inline]
    #[must_use]
    pub fn sample_lod_uv(&self, uv: Vec2, lod: f32) -> T {
        self.lod_blend(uv, lod, OctMap::bilinear_uv)
    }

    /// `sample_lod_uv` with its reads always inlined: for a rough lookup, whose trilinear
    /// read ends a long dependency chain (calls there cost more than the code they save).
    #[inline(always)]
    #[must_use]
    pub fn sample_lod_uv_inline(&self, uv: Vec2, lod: f32) -> T {
        self.lod_blend(
            uv,
            lod,
            #[inline(always)]
            |m, uv| m.bilinear_uv_inline(uv),
        )
    }

    /// The two mips around `lod` read by `read` at `uv`, blended.
    #[inline(always)]
    fn lod_blend(&self, uv: Vec2, lod: f32, read: impl Fn(&OctMap<T>, Vec2) -> T) -> T {
        let (l0, f) = self.split_lod(lod);
        let a = read(&self.levels[l0], uv);
        if f == 0.0 || l0 + 1 >= self.levels.len() {
            return a;
        }
        let b = read(&self.levels[l0 + 1], uv);
        a * (1.0 - f) + b * f
    }

    /// `sample_lod_uv` for [`LANES`] lookups, each at its own `lod`, bit for bit the same
    /// values: the mips and footprints of all lanes first, then the reads side by side.
    #[inline]
    #[must_use]
    pub fn sample_each_lod_uv_lanes(&self, uv: &UvLanes, lod: &[f32; LANES]) -> [T; LANES] {
        // Each stage is a plain loop over lanes so that it vectorises; only the gathers (a
        // mip's size, its 2×2 texels) are per lane. Every lane reads two mips, the next one
        // (or the last again) with weight 0 where `lod_blend` reads one.
        let last = self.levels.len().saturating_sub(1);
        let (mut l0, mut l1, mut f) = ([0usize; LANES], [0usize; LANES], [0.0f32; LANES]);
        for k in 0..LANES {
            (l0[k], f[k]) = self.split_lod(lod[k]);
            l1[k] = (l0[k] + 1).min(last);
        }
        let (mut n0, mut n1) = ([0.0f32; LANES], [0.0f32; LANES]);
        for k in 0..LANES {
            (n0[k], n1[k]) = (self.levels[l0[k]].res as f32, self.levels[l1[k]].res as f32);
        }
        let mut at = [[0i32; LANES]; 4];
        let mut frac = [[0.0f32; LANES]; 4];
        for k in 0..LANES {
            (at[0][k], at[1][k], frac[0][k], frac[1][k]) = footprint_of(n0[k], uv.u[k], uv.v[k]);
            (at[2][k], at[3][k], frac[2][k], frac[3][k]) = footprint_of(n1[k], uv.u[k], uv.v[k]);
        }
        let mut out = [T::default(); LANES];
        for k in 0..LANES {
            let a = blend(self.levels[l0[k]].quad(at[0][k], at[1][k]), frac[0][k], frac[1][k]);
            let b = blend(self.levels[l1[k]].quad(at[2][k], at[3][k]), frac[2][k], frac[3][k]);
            // `lod_blend`'s choice: the lower mip alone at a whole lod or the chain's end
            out[k] = if (f[k] == 0.0) | (l0[k] >= last) { a } else { a * (1.0 - f[k]) + b * f[k] };
        }
        out
    }

    /// [`Self::sample_each_lod_uv_lanes`] with lane k reading chain `chains[k]`: bit for bit
    /// what each lane's own chain answers (several probes, each lane reading its own).
    #[inline]
    #[must_use]
    pub fn sample_each_lod_uv_lanes_of(chains: &[&OctMips<T>; LANES], uv: &UvLanes, lod: &[f32; LANES]) -> [T; LANES] {
        // the stages of `sample_each_lod_uv_lanes`, each lane on its own chain
        let (mut l0, mut l1, mut f, mut last) = ([0usize; LANES], [0usize; LANES], [0.0f32; LANES], [0usize; LANES]);
        for k in 0..LANES {
            last[k] = chains[k].levels.len().saturating_sub(1);
            (l0[k], f[k]) = chains[k].split_lod(lod[k]);
            l1[k] = (l0[k] + 1).min(last[k]);
        }
        let (mut m0, mut m1): ([&OctMap<T>; LANES], [&OctMap<T>; LANES]) =
            (std::array::from_fn(|k| &chains[k].levels[0]), std::array::from_fn(|k| &chains[k].levels[0]));
        for k in 0..LANES {
            (m0[k], m1[k]) = (&chains[k].levels[l0[k]], &chains[k].levels[l1[k]]);
        }
        let mut at = [[0i32; LANES]; 4];
        let mut frac = [[0.0f32; LANES]; 4];
        for k in 0..LANES {
            (at[0][k], at[1][k], frac[0][k], frac[1][k]) = footprint_of(m0[k].res as f32, uv.u[k], uv.v[k]);
            (at[2][k], at[3][k], frac[2][k], frac[3][k]) = footprint_of(m1[k].res as f32, uv.u[k], uv.v[k]);
        }
        let mut out = [T::default(); LANES];
        for k in 0..LANES {
            let a = blend(m0[k].quad(at[0][k], at[1][k]), frac[0][k], frac[1][k]);
            let b = blend(m1[k].quad(at[2][k], at[3][k]), frac[2][k], frac[3][k]);
            out[k] = if (f[k] == 0.0) | (l0[k] >= last[k]) { a } else { a * (1.0 - f[k]) + b * f[k] };
        }
        out
    }

    /// `sample_lod_uv` for [`LANES`] lookups at one `lod`, bit for bit the same values.
    #[inline]
    #[must_use]
    pub fn sample_lod_uv_lanes(&self, uv: &UvLanes, lod: f32) -> [T; LANES] {
        let (l0, f) = self.split_lod(lod);
        let a = self.levels[l0].bilinear_uv_lanes(uv);
        if f == 0.0 || l0 + 1 >= self.levels.len() {
            return a;
        }
        let b = self.levels[l0 + 1].bilinear_uv_lanes(uv);
        let mut out = a;
        for k in 0..LANES {
            out[k] = a[k] * (1.0 - f) + b[k] * f;
        }
        out
    }

    /// Mip index and blend fraction of `lod`, clamped to the chain (non-finite → 0).
    #[inline]
    fn split_lod(&self, lod: f32) -> (usize, f32) {
        let max = self.levels.len().saturating_sub(1) as u32 as f32;
        let lod = if lod.is_finite() { lod.max(0.0).min(max) } else { 0.0 };
        // lod ≥ 0 and small: its floor off the float's bits (`as u32` is branchy on x86-64)
        let (l0, floor) = floor_small(lod);
        (l0 as usize, lod - floor)
    }
}

/// Box mip chain of `base` down to `min_res` (inclusive), solid-angle weighted.
#[must_use]
pub fn build_mips<T: Texel>(base: OctMap<T>, min_res: u32) -> OctMips<T> {
    let mut levels = vec![base];
    while let Some(last) = levels.last() {
        if last.res / 2 < min_res.max(1) || last.res % 2 != 0 {
            break;
        }
        let next = last.downsample();
        levels.push(next);
    }
    OctMips { levels }
}

/// Distance mip chain: each level averages inverse distance (misses, +inf, count as 0), so
/// a blurred depth keeps sky as sky and averages parallax linearly.
pub fn build_distance_mips(base: OctMap<f32>, min_res: u32) -> OctMips<f32> {
    let mut levels = vec![base];
    while let Some(last) = levels.last() {
        if last.res / 2 < min_res.max(1) || last.res % 2 != 0 {
            break;
        }
        let w = texel_solid_angles(last.res);
        let next = last.downsample_weighted(&w, inverse_distance, distance_from_inverse);
        levels.push(next);
    }
    OctMips { levels }
}

/// Inverse distance `1/d`, the one conversion every distance map and warp uses: a miss
/// (+inf) and NaN give 0 (sky), zero or negative distance (a probe touching geometry) gives
/// `f32::MAX`, so the result is always finite and ≥ 0.
#[inline]
#[must_use]
pub fn inverse_distance(d: f32) -> f32 {
    if d.is_nan() || d.is_infinite() {
        0.0
    } else if d <= 0.0 {
        f32::MAX
    } else {
        (1.0 / d).min(f32::MAX)
    }
}

/// Distance from inverse distance `w`: 0 and NaN (sky) give +inf, the way back of
/// [`inverse_distance`] for stored distance layers (where +inf means a miss).
#[inline]
#[must_use]
pub fn distance_from_inverse(w: f32) -> f32 {
    if w > 0.0 { 1.0 / w } else { f32::INFINITY }
}

/// Orthonormal basis around unit `n` (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited"). Returns (tangent, bitangent).
#[inline]
#[must_use]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poles_and_axes() {
        assert_eq!(encode(Vec3::Z), Vec2::splat(0.5));
        assert_eq!(encode(Vec3::X), Vec2::new(1.0, 0.5));
        assert_eq!(encode(Vec3::Y), Vec2::new(0.5, 1.0));
        // -Z folds onto the four corners; sign(0)=+1 picks (1,1).
        assert_eq!(encode(-Vec3::Z), Vec2::new(1.0, 1.0));
        assert!((decode(Vec2::ZERO) - -Vec3::Z).length() < 1e-6);
        assert_eq!(encode(Vec3::ZERO), Vec2::splat(0.5));
        assert_eq!(encode(Vec3::NAN), Vec2::splat(0.5));
    }

    #[test]
    fn wrap_is_involution_on_border() {
        let n = 8;
        for j in 0..n as i64 {
            assert_eq!(wrap_texel(n, -1, j), (0, (n as i64 - 1 - j) as u32));
            assert_eq!(wrap_texel(n, n as i64, j), (n - 1, (n as i64 - 1 - j) as u32));
        }
    }

    #[test]
    fn floor_small_is_floor_at_the_edges() {
        for x in
            [0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 1e-40, -1e-40, 2.999_999_8, -2.999_999_8, 4_194_303.5, -4_194_303.5]
        {
            let (i, f) = floor_small(x);
            assert_eq!(f, x.floor(), "{x}");
            assert_eq!(i, x.floor() as i32, "{x}");
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        for res in [2u32, 4, 8, 16, 64, 256] {
            let sum: f64 = texel_solid_angles(res).iter().map(|&w| w as f64).sum();
            assert!((sum - 4.0 * std::f64::consts::PI).abs() < 1e-4, "res {res}: {sum}");
        }
    }
}
