//! Warps that read the probe's own depth.
//!
//! - `plane_warp` with one step is seed 000's warp: sample A along Dir → S1; plane
//!   perpendicular to Dir at S1; intersect the ray from B → I; sample A towards I → S2;
//!   project S2 on the ray from B. With two steps it repeats from S2, either keeping planes
//!   perpendicular to Dir (`warp2-fixed`) or perpendicular to the direction found in the
//!   previous step (`warp2-new`), the two variants the seed compares.
//! - `secant`: distance impostors (Szirmay-Kalos, Aszódi, Lazányi & Premecz 2005): secant
//!   iteration along the ray from B on `g(t) = |r(t) − A| / d(dir(A→r(t))) − 1`, i.e. through
//!   the plane spanned by the last two approximations, guarded against near-parallel steps.
//! - `raymarch`: relief / parallax-occlusion mapping: linear steps along the ray from B until
//!   it passes behind A's depth, then binary refinement.

use super::{WarpProbe, toward};
use crate::octa::{LANES, encode_lanes, fill_in_lanes, group_at};
use glam::Vec3;
#[allow(unused_imports)]
use glam::Vec3Swizzles as _;

/// Distance along `dir` from `b` to the plane through `s` with normal `n`, or `None` when
/// the ray is (nearly) parallel to the plane.
#[inline]
fn ray_plane(b: Vec3, dir: Vec3, s: Vec3, n: Vec3) -> Option<f32> {
    let denom = n.dot(dir);
    if denom.abs() < 1e-4 {
        return None;
    }
    let t = n.dot(s - b) / denom;
    t.is_finite().then_some(t.max(0.0))
}

/// Seed 000's plane warp with `steps` steps; `new_plane` re-orients each further plane
/// perpendicular to the previous sample direction. Returns a fetch *vector* (any positive
/// multiple of the fetch direction): the octahedral lookup does not need it normalised.
///
/// Points are carried in homogeneous form, each scaled by a positive factor the next step
/// does not need to undo: with `ab = A − B` and `w1` the probe's inverse distance along
/// Dir, `v = w1·(I − A) = Dir·max(w1·(Dir·ab) + 1, 0) − w1·ab`; with `λ = |v|·w(v)`,
/// `λ·(S − B) = λ·ab + v`. The textbook form divides by `w1` and by `λ`; this one needs no
/// division besides the octahedral encode's, which shortens the dependent chain of a lookup.
#[inline]
#[must_use]
pub fn plane_warp(p: &WarpProbe, b: Vec3, dir: Vec3, lod: f32, steps: u32, new_plane: bool) -> Vec3 {
    let a = p.position;
    if b == a {
        return dir;
    }
    let w1 = p.inv_dist(dir, lod);
    if w1 == 0.0 {
        return dir; // the probe sees sky along Dir: treat the hit as infinitely far
    }
    let ab = a - b;
    let dir_ab = dir.dot(ab);
    // Plane perpendicular to Dir at S1 = A + Dir/w1, crossed by the ray from B at I.
    let mut v = first_plane(dir, ab, dir_ab, w1);
    let mut normal = dir;
    for _ in 1..steps.max(1) {
        let lambda = v.length() * p.inv_dist(v, lod);
        if !(lambda > 0.0) {
            return dir; // sky towards I (or I at A)
        }
        let s_b = ab * lambda + v; // λ·(S − B)
        if new_plane {
            normal = v;
        }
        let denom = normal.dot(dir);
        if denom.abs() > 1e-4 * normal.length() {
            // next plane through S with normal `normal`, crossed by the ray from B
            let t = (normal.dot(s_b) / denom).max(0.0); // λ·t
            v = dir * t - ab * lambda; // λ·(I − A)
        }
    }
    let lambda = v.length() * p.inv_dist(v, lod);
    let f = project_on_ray(dir, ab, dir_ab, v, lambda);
    if lambda > 0.0 { fetch_vector(Vec3::ZERO, f, dir) } else { dir }
}

/// Distance along the ray from B to the point seed 000's one-step warp aims at (the probe's
/// second hit projected on the ray): the `plane_warp` of one step, the same operations, its
/// homogeneous point divided out. `+inf` where that warp reads sky (and fetches the query
/// direction); `None` for B at the probe.
#[inline]
#[must_use]
pub fn warp1_distance(p: &WarpProbe, b: Vec3, dir: Vec3, lod: f32) -> Option<f32> {
    let a = p.position;
    if b == a {
        return None;
    }
    let w1 = p.inv_dist(dir, lod);
    if w1 == 0.0 {
        return Some(f32::INFINITY);
    }
    let ab = a - b;
    let dir_ab = dir.dot(ab);
    let v = first_plane(dir, ab, dir_ab, w1);
    let lambda = v.length() * p.inv_dist(v, lod);
    if !(lambda > 0.0) {
        return Some(f32::INFINITY);
    }
    let t = (dir_ab * lambda + dir.dot(v)).max(0.0) / lambda;
    Some(if t.is_finite() { t } else { f32::INFINITY })
}

/// `w1·(I − A)`: I is where the ray from B crosses the plane perpendicular to Dir at the
/// probe's hit `A + Dir/w1` (`w1 > 0`; `ab = A − B`, `dir_ab = Dir·ab`).
#[inline]
pub(super) fn first_plane(dir: Vec3, ab: Vec3, dir_ab: f32, w1: f32) -> Vec3 {
    dir * (dir_ab * w1 + 1.0).max(0.0) - ab * w1
}

/// `λ·(P − A)` for P, the projection of the probe's hit S on the ray from B, given
/// `v ∝ (I − A)` and `λ = |v|·w(v)` (so that `λ·(S − B) = λ·ab + v`).
#[inline]
fn project_on_ray(dir: Vec3, ab: Vec3, dir_ab: f32, v: Vec3, lambda: f32) -> Vec3 {
    let t = (dir_ab * lambda + dir.dot(v)).max(0.0); // λ·t
    dir * t - ab * lambda
}

/// `to − from` when usable as a fetch vector, else `fallback`.
#[inline]
#[must_use]
pub fn fetch_vector(from: Vec3, to: Vec3, fallback: Vec3) -> Vec3 {
    let v = to - from;
    let l2 = v.length_squared();
    if l2 > 0.0 && l2.is_finite() { v } else { fallback }
}

/// `g(t) = l/d − 1`: negative in front of the probe's surface, positive behind, −1 where
/// the probe sees sky.
#[inline]
fn behind(p: &WarpProbe, b: Vec3, dir: Vec3, t: f32, lod: f32) -> (f32, Vec3) {
    let a = p.position;
    let r = b + dir * t;
    let v = r - a;
    let l = v.length();
    if !(l > 0.0) {
        return (-1.0, dir);
    }
    let d = v / l;
    (l * p.inv_dist(d, lod) - 1.0, d)
}

/// Distance impostors: secant iteration on `g` from t = 0 and the one-step plane estimate.
#[inline]
#[must_use]
pub fn secant(p: &WarpProbe, b: Vec3, dir: Vec3, lod: f32, steps: u32) -> Vec3 {
    let a = p.position;
    if b == a {
        return dir;
    }
    let w1 = p.inv_dist(dir, lod);
    if w1 == 0.0 {
        return dir;
    }
    let Some(t1) = ray_plane(b, dir, a + dir / w1, dir) else {
        return dir;
    };
    let t_max = 4.0 * (p.max_distance + (b - a).length());
    let (mut t0, mut t1) = (0.0f32, t1.min(t_max));
    let (mut g0, _) = behind(p, b, dir, t0, lod);
    let (mut g1, mut d1) = behind(p, b, dir, t1, lod);
    for _ in 0..steps {
        let dg = g1 - g0;
        if dg.abs() < 1e-6 {
            break; // near-parallel secant: keep the current estimate
        }
        let t2 = (t1 - g1 * (t1 - t0) / dg).clamp(0.0, t_max);
        if !t2.is_finite() {
            break;
        }
        let (g2, d2) = behind(p, b, dir, t2, lod);
        (t0, g0) = (t1, g1);
        (t1, g1, d1) = (t2, g2, d2);
        if g1.abs() < 1e-6 {
            break;
        }
    }
    if p.inv_dist(d1, lod) == 0.0 {
        return dir;
    }
    toward(a, b + dir * t1, dir)
}

/// Ray marching against the probe's depth: `steps` linear steps, then 8 bisections.
#[inline]
#[must_use]
pub fn raymarch(p: &WarpProbe, b: Vec3, dir: Vec3, lod: f32, steps: u32) -> Vec3 {
    let a = p.position;
    if b == a {
        return dir;
    }
    let t_max = 2.0 * (p.max_distance + (b - a).length());
    let steps = steps.max(1);
    let dt = t_max / steps as f32;
    let mut prev = 0.0f32;
    for k in 1..=steps {
        let t = dt * k as f32;
        let (g, _) = behind(p, b, dir, t, lod);
        if g >= 0.0 {
            let (mut lo, mut hi) = (prev, t);
            for _ in 0..8 {
                let mid = 0.5 * (lo + hi);
                if behind(p, b, dir, mid, lod).0 >= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return toward(a, b + dir * (0.5 * (lo + hi)), dir);
        }
        prev = t;
    }
    dir
}

/// `plane_warp` (one step) for a batch of queries, returning fetch vectors bit for bit equal
/// to the per-lookup function's. Queries advance in lockstep groups of [`LANES`] through
/// the same stages (encode, depth fetch, plane, encode, depth fetch, projection), with the
/// per-lookup function's early exits as selects, so the processor overlaps the lanes'
/// dependency chains: one lookup alone is latency-bound (three dependent fetches).
/// Answers the first `min(queries.len(), out.len())` queries; give slices of equal length.
pub fn warp1_batch(p: &WarpProbe, queries: &[(Vec3, Vec3)], lod: f32, out: &mut [Vec3]) {
    let n = queries.len().min(out.len());
    fill_in_lanes(
        &mut out[..n],
        |k| warp1_lanes(p, group_at(queries, k), lod),
        |k| plane_warp(p, queries[k].0, queries[k].1, lod, 1, false),
    );
}

/// [`LANES`] lookups of `plane_warp` with one step.
#[inline]
#[must_use]
pub fn warp1_lanes(p: &WarpProbe, q: &[(Vec3, Vec3); LANES], lod: f32) -> [Vec3; LANES] {
    let a = p.position;
    let w1 = p.inv_dist_lanes(&encode_lanes(&q.map(|(_, dir)| dir)), lod);
    // explicit loops: `std::array::from_fn` is not reliably inlined here
    let (mut ab, mut dir_ab, mut v) = ([Vec3::ZERO; LANES], [0.0f32; LANES], [Vec3::ZERO; LANES]);
    for k in 0..LANES {
        let (b, dir) = q[k];
        ab[k] = a - b;
        dir_ab[k] = dir.dot(ab[k]);
        v[k] = first_plane(dir, ab[k], dir_ab[k], w1[k]);
    }
    let w = p.inv_dist_lanes(&encode_lanes(&v), lod);
    let mut out = [Vec3::ZERO; LANES];
    for k in 0..LANES {
        let (b, dir) = q[k];
        let lambda = v[k].length() * w[k];
        let f = project_on_ray(dir, ab[k], dir_ab[k], v[k], lambda);
        let usable = b != a && w1[k] != 0.0 && lambda > 0.0;
        out[k] = if usable { fetch_vector(Vec3::ZERO, f, dir) } else { dir };
    }
    out
}
