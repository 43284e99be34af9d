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
/// multiple of the fetch direction): the octahedral lookup does not need it normalised, and
/// skipping the normalisations shortens the dependent chain of divisions.
#[inline]
pub fn plane_warp(p: &WarpProbe, b: Vec3, dir: Vec3, lod: f32, steps: u32, new_plane: bool) -> Vec3 {
    let a = p.position;
    if b == a {
        return dir;
    }
    let w1 = p.inv_dist(dir, lod);
    if w1 == 0.0 {
        return dir; // the probe sees sky along Dir: treat the hit as infinitely far
    }
    // Plane perpendicular to Dir at S1 = A + Dir/w1; |Dir| = 1, so no division.
    let mut t = (dir.dot(a - b) + 1.0 / w1).max(0.0);
    let mut normal = dir;
    for step in 0..steps.max(1) {
        let v = b + dir * t - a; // A → I, unnormalised
        let w = p.inv_dist(v, lod);
        let len_w = v.length() * w;
        if !(len_w > 0.0) {
            return dir; // sky towards I (or I at A)
        }
        let s = a + v * (1.0 / len_w); // S = A + dir(A→I) · distance
        if step + 1 < steps {
            if new_plane {
                normal = v;
            }
            let denom = normal.dot(dir);
            if denom.abs() > 1e-4 * normal.length() {
                t = (normal.dot(s - b) / denom).max(0.0);
            }
        } else {
            // project S on the ray from B
            t = dir.dot(s - b).max(0.0);
        }
    }
    fetch_vector(a, b + dir * t, dir)
}

/// `to − from` when usable as a fetch vector, else `fallback`.
#[inline]
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

/// `plane_warp` (one step) for a batch of queries, returning fetch vectors. Identical results
/// to the per-lookup function; the queries advance in lockstep groups of 8 so the processor
/// overlaps their independent dependency chains (one lookup alone is latency-bound: three
/// dependent texture reads and a chain of divisions).
pub fn warp1_batch(p: &WarpProbe, queries: &[(Vec3, Vec3)], lod: f32, out: &mut [Vec3]) {
    const LANES: usize = 8;
    let a = p.position;
    for (qs, os) in queries.chunks(LANES).zip(out.chunks_mut(LANES)) {
        let n = qs.len();
        let mut w1 = [0.0f32; LANES];
        for i in 0..n {
            w1[i] = p.inv_dist(qs[i].1, lod);
        }
        let mut v = [Vec3::ZERO; LANES];
        for i in 0..n {
            let (b, dir) = qs[i];
            let t = if w1[i] > 0.0 { (dir.dot(a - b) + 1.0 / w1[i]).max(0.0) } else { 0.0 };
            v[i] = b + dir * t - a;
        }
        let mut w = [0.0f32; LANES];
        for i in 0..n {
            w[i] = if w1[i] > 0.0 { p.inv_dist(v[i], lod) } else { 0.0 };
        }
        for i in 0..n {
            let (b, dir) = qs[i];
            let len_w = v[i].length() * w[i];
            os[i] = if b == a || !(w1[i] > 0.0) || !(len_w > 0.0) {
                dir
            } else {
                let s = a + v[i] * (1.0 / len_w);
                let t = dir.dot(s - b).max(0.0);
                fetch_vector(a, b + dir * t, dir)
            };
        }
    }
}
