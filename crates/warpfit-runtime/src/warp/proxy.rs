//! Proxy-geometry parallax correction (seed 001, Lagarde 2012): intersect the ray from B
//! with a convex proxy from inside, then fetch A towards the intersection.
//!
//! - `BoxProxy`: an oriented box (centre, rotation, half extents); by default the scene's
//!   bounds.
//! - `Kdop`: an 18-DOP (the 3 axes and 6 face diagonals, both signs) whose planes touch the
//!   farthest point probe A saw in each direction (Black Ops 3 style fit to the probe's
//!   depth samples).
//!
//! Fallback (documented): when B lies outside the proxy, or the ray does not leave it
//! (degenerate), the query direction is returned unchanged, i.e. no correction. Seed 001
//! returns black there; a direction keeps the lookup finite and plausible.

use crate::octa;
use glam::{Mat3, Quat, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct BoxProxy {
    pub centre: Vec3,
    pub rotation: Quat,
    pub half_extents: Vec3,
    /// Inverse rotation, precomputed for lookups.
    world_to_local: Mat3,
    /// The rotation is the identity (the scene-bounds box): lookups skip it.
    axis_aligned: bool,
}

impl BoxProxy {
    /// Axis-aligned box [lo, hi].
    #[must_use]
    pub fn aabb(lo: Vec3, hi: Vec3) -> Self {
        Self::oriented((lo + hi) * 0.5, Quat::IDENTITY, (hi - lo) * 0.5)
    }

    /// Oriented box: centre, rotation (local → world) and half extents.
    #[must_use]
    pub fn oriented(centre: Vec3, rotation: Quat, half_extents: Vec3) -> Self {
        let rotation = rotation.normalize();
        let world_to_local = Mat3::from_quat(rotation.conjugate());
        BoxProxy {
            centre,
            rotation,
            half_extents: half_extents.abs().max(Vec3::splat(f32::MIN_POSITIVE)),
            world_to_local,
            axis_aligned: world_to_local == Mat3::IDENTITY,
        }
    }

    /// The rotation from world to box-local coordinates (the inverse of `rotation`).
    #[must_use]
    pub fn world_to_local(&self) -> Mat3 {
        self.world_to_local
    }

    /// Distance along `dir` from `b` (inside) to the box's boundary, if `b` is inside.
    #[inline]
    #[must_use]
    pub fn exit_distance(&self, b: Vec3, dir: Vec3) -> Option<f32> {
        let inv = self.world_to_local;
        // the identity's product is the vector itself for finite input (which a lookup's
        // is), and the lane form takes the same path
        let local = |v: Vec3| if self.axis_aligned { v } else { inv * v };
        let o = local(b - self.centre);
        if o.abs().cmpgt(self.half_extents).any() {
            return None;
        }
        let d = local(dir);
        let mut t = f32::INFINITY;
        for k in 0..3 {
            // selects, not branches: the signs of a random direction are unpredictable
            let face = if d[k] > 0.0 { self.half_extents[k] } else { -self.half_extents[k] };
            let t_face = (face - o[k]) / d[k];
            t = t.min(if d[k] != 0.0 { t_face } else { f32::INFINITY }); // parallel: no exit
        }
        t.is_finite().then_some(t.max(0.0))
    }

    /// [`exit_distance`](Self::exit_distance) for [`LANES`](crate::octa::LANES) queries given
    /// as components ([`octa::soa`]), with the same operations in the same order (the matrix
    /// products as glam forms them): each lane's distance and whether it has one (`Some`),
    /// bit for bit the scalar values, the lanes side by side.
    #[inline(always)]
    #[must_use]
    pub fn exit_distance_soa(
        &self,
        b: &octa::Soa3,
        dir: &octa::Soa3,
    ) -> ([f32; crate::octa::LANES], [bool; crate::octa::LANES]) {
        const L: usize = crate::octa::LANES;
        let m = self.world_to_local;
        let (h, c) = (self.half_extents.to_array(), self.centre.to_array());
        let aligned = self.axis_aligned;
        // the box-local components, as `world_to_local * v` forms them (identity: v itself)
        let local = |v: [&[f32; L]; 3], k: usize, l: usize| -> f32 {
            if aligned {
                v[k][l]
            } else {
                ((m.x_axis[k] * v[0][l]) + (m.y_axis[k] * v[1][l])) + (m.z_axis[k] * v[2][l])
            }
        };
        let mut bc = [[0.0f32; L]; 3];
        for k in 0..3 {
            for l in 0..L {
                bc[k][l] = b[k][l] - c[k];
            }
        }
        let (mut o, mut d) = ([[0.0f32; L]; 3], [[0.0f32; L]; 3]);
        for k in 0..3 {
            for l in 0..L {
                o[k][l] = local([&bc[0], &bc[1], &bc[2]], k, l);
                d[k][l] = local([&dir[0], &dir[1], &dir[2]], k, l);
            }
        }
        let (mut out, mut ok) = ([0.0f32; L], [false; L]);
        for l in 0..L {
            // (bitwise `|` and `&`: no short circuits, so the loop vectorises)
            let outside = (o[0][l].abs() > h[0]) | (o[1][l].abs() > h[1]) | (o[2][l].abs() > h[2]);
            let mut t = f32::INFINITY;
            for k in 0..3 {
                let face = if d[k][l] > 0.0 { h[k] } else { -h[k] };
                let t_face = (face - o[k][l]) / d[k][l];
                t = t.min(if d[k][l] != 0.0 { t_face } else { f32::INFINITY });
            }
            // `o.abs().cmpgt(h)` is false for NaN, as here
            ok[l] = !outside & t.is_finite();
            out[l] = t.max(0.0);
        }
        (out, ok)
    }

    /// Fetch vector of probe A at `a` for the query (`b`, `dir`): towards where the ray
    /// leaves the proxy ([`towards_exit`]).
    #[inline]
    #[must_use]
    pub fn fetch_dir(&self, a: Vec3, b: Vec3, dir: Vec3) -> Vec3 {
        towards_exit(a, b, dir, || self.exit_distance(b, dir))
    }
}

/// 18-DOP: planes `n_k · x ≤ h_k`.
#[derive(Clone, Debug, PartialEq)]
pub struct Kdop {
    pub normals: Vec<Vec3>,
    /// Plane offsets; +inf when the probe saw nothing in that direction (open side).
    pub offsets: Vec<f32>,
}

/// The 18 plane normals: ±x, ±y, ±z and ±(x±y), ±(y±z), ±(x±z), normalised.
#[must_use]
pub fn kdop18_normals() -> Vec<Vec3> {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let base = [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::new(s, s, 0.0),
        Vec3::new(s, -s, 0.0),
        Vec3::new(0.0, s, s),
        Vec3::new(0.0, s, -s),
        Vec3::new(s, 0.0, s),
        Vec3::new(s, 0.0, -s),
    ];
    base.iter().flat_map(|&n| [n, -n]).collect()
}

impl Kdop {
    /// Fits the planes to the probe's depth samples (texel-centre hit points).
    #[must_use]
    pub fn fit(a: Vec3, distance: &octa::OctMap<f32>) -> Self {
        let normals = kdop18_normals();
        let mut offsets = vec![f32::NEG_INFINITY; normals.len()];
        let mut open = vec![false; normals.len()];
        for j in 0..distance.res {
            for i in 0..distance.res {
                let d = distance.get(i, j);
                let dir = octa::texel_dir(distance.res, i, j);
                if !d.is_finite() {
                    // sky: any plane this direction leans towards is open
                    for (k, n) in normals.iter().enumerate() {
                        if n.dot(dir) > 0.9 {
                            open[k] = true;
                        }
                    }
                    continue;
                }
                let p = a + dir * d;
                for (k, n) in normals.iter().enumerate() {
                    offsets[k] = offsets[k].max(n.dot(p));
                }
            }
        }
        for (o, open) in offsets.iter_mut().zip(open) {
            if open || !o.is_finite() {
                *o = f32::INFINITY;
            }
        }
        Kdop { normals, offsets }
    }

    /// Distance along `dir` from `b` (inside) to the proxy's boundary: `None` when `b` is
    /// outside it, `+inf` when the ray leaves through an open side.
    #[inline]
    #[must_use]
    pub fn exit_distance(&self, b: Vec3, dir: Vec3) -> Option<f32> {
        let mut t = f32::INFINITY;
        for (n, &h) in self.normals.iter().zip(&self.offsets) {
            let nb = n.dot(b);
            if nb > h {
                return None; // B outside the proxy
            }
            let nd = n.dot(dir);
            if nd > 0.0 && h.is_finite() {
                t = t.min((h - nb) / nd);
            }
        }
        Some(t)
    }

    /// Fetch vector of probe A at `a` for the query (`b`, `dir`): towards where the ray
    /// leaves the proxy ([`towards_exit`]).
    #[inline]
    #[must_use]
    pub fn fetch_dir(&self, a: Vec3, b: Vec3, dir: Vec3) -> Vec3 {
        towards_exit(a, b, dir, || self.exit_distance(b, dir))
    }
}

/// A proxy method's fetch vector: from probe A at `a` towards the point where the ray from
/// `b` along `dir` leaves the proxy (`exit`, called only when `b` is not at A); the query
/// direction itself at A, from outside the proxy or through an open side (no finite exit).
#[inline]
fn towards_exit(a: Vec3, b: Vec3, dir: Vec3, exit: impl FnOnce() -> Option<f32>) -> Vec3 {
    if a == b {
        return dir;
    }
    match exit() {
        Some(t) if t.is_finite() => super::depth::fetch_vector(a, b + dir * t, dir),
        _ => dir,
    }
}
