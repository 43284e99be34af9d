//! Seed 003, "Baked Surface Reflections": many reflection probes attached to one surface,
//! each a hemi-octahedral tile in the surface's tangent space, packed into one atlas. A
//! lookup at a point on the surface finds the point's place among the probes (the surface's
//! (s, t) coordinates), brings the reflection direction into tangent space, and blends the
//! four nearest probes bilinearly, each read bilinearly inside its tile, as the seed does.
//!
//! Beside the seed's lookup, `radiance_warped` applies each of the four probes' own depth
//! first (seed 000's one-step plane warp from that probe, `warp::depth`), the unfitted
//! parallax correction a surface probe can afford.
//!
//! Plain data: the atlas is baked by `bake::surface` and judged by `eval::surface`; this
//! module only samples it. Rough lookups read the tile mips (GGX-prefiltered, r = m/(M−1)),
//! linear in r between mips, as the probe's chain is read.

use crate::octa::{self, hemi};
use glam::Vec3;

/// Where an atlas sits: the parallelogram `corner + s·edge_u + t·edge_v` (s, t in [0, 1]),
/// facing along `edge_u × edge_v`, its probe counts and tile size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePatch {
    pub corner: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    /// Probes along edge_u and edge_v (each ≥ 1); probe (i, j) is tile `j·counts[0] + i`.
    pub counts: [u32; 2],
    /// N of each N×N hemi-octahedral tile (even, ≥ 2).
    pub resolution: u32,
    /// Height of the probes above the surface, along the normal (scene units).
    pub offset: f32,
}

/// A baked surface-probe atlas (seed 003): a grid of hemispherical probes just above a large
/// glossy surface (a floor), for glossy reflections on that surface, loaded with
/// [`load_surface_atlas`](crate::load_surface_atlas).
#[derive(Clone, Debug)]
pub struct SurfaceAtlas {
    #[doc(hidden)]
    pub patch: SurfacePatch,
    /// Radiance per mip, each `probes × N²` texels, tile after tile; mip 0 is the mirror
    /// image, mip m is GGX-prefiltered for `roughness[m]`.
    #[doc(hidden)]
    pub radiance: Vec<Vec<Vec3>>,
    /// Perceptual roughness of each radiance mip (0 first, increasing, 1 last).
    #[doc(hidden)]
    pub roughness: Vec<f32>,
    /// 1/distance of each mip-0 texel-centre ray (0 where the probe saw sky).
    #[doc(hidden)]
    pub inv_distance: Vec<f32>,
    /// `patch.frame()`, kept for the lookups.
    frame: SurfaceFrame,
}

/// A patch's tangent frame (edge_u normalised, normal × that, the normal) and the dual
/// basis of its edges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceFrame {
    pub tangent: Vec3,
    pub bitangent: Vec3,
    pub normal: Vec3,
    /// `s = dual_u · (p − corner)`, `t = dual_v · (p − corner)`.
    pub dual_u: Vec3,
    pub dual_v: Vec3,
}

impl SurfaceFrame {
    /// World direction of a tangent-space direction.
    #[must_use]
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        self.tangent * local.x + self.bitangent * local.y + self.normal * local.z
    }

    /// Tangent-space direction of a world direction.
    #[must_use]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.tangent), v.dot(self.bitangent), v.dot(self.normal))
    }
}

impl SurfacePatch {
    /// The patch's frame (zero vectors for degenerate edges: lookups stay finite).
    #[must_use]
    pub fn frame(&self) -> SurfaceFrame {
        let (u, v) = (self.edge_u, self.edge_v);
        let normal = u.cross(v).normalize_or_zero();
        let tangent = u.normalize_or_zero();
        let bitangent = normal.cross(tangent);
        let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
        let det = uu * vv - uv * uv;
        let inv = if det > 0.0 && det.is_finite() { 1.0 / det } else { 0.0 };
        SurfaceFrame { tangent, bitangent, normal, dual_u: (u * vv - v * uv) * inv, dual_v: (v * uu - u * uv) * inv }
    }

    /// Number of probes.
    #[must_use]
    pub fn probes(&self) -> usize {
        self.counts[0] as usize * self.counts[1] as usize
    }

    /// World position of probe (i, j) given the patch's `frame`: the centre of its patch,
    /// `offset` off the surface.
    #[must_use]
    pub fn probe_position(&self, frame: &SurfaceFrame, i: u32, j: u32) -> Vec3 {
        let s = (i as f32 + 0.5) / self.counts[0] as f32;
        let t = (j as f32 + 0.5) / self.counts[1] as f32;
        self.corner + self.edge_u * s + self.edge_v * t + frame.normal * self.offset
    }
}

impl SurfaceAtlas {
    /// An atlas from its patch and baked layers. Panics unless the layers fit the patch
    /// (the baker's contract, not user input): every mip and the distances hold
    /// `probes × N²` texels, and the roughness runs from 0 with one entry per mip (the
    /// tool's; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn new(patch: SurfacePatch, radiance: Vec<Vec<Vec3>>, roughness: Vec<f32>, inv_distance: Vec<f32>) -> Self {
        let texels = patch.probes() * (patch.resolution * patch.resolution) as usize;
        assert!(patch.counts[0] >= 1 && patch.counts[1] >= 1 && patch.resolution >= 2);
        assert!(!radiance.is_empty() && radiance.len() == roughness.len() && roughness[0] == 0.0);
        assert!(radiance.iter().all(|l| l.len() == texels) && inv_distance.len() == texels);
        SurfaceAtlas { frame: patch.frame(), patch, radiance, roughness, inv_distance }
    }

    /// The patch's tangent frame and dual basis, as the lookups use them (the tool's; not a
    /// supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn frame(&self) -> &SurfaceFrame {
        &self.frame
    }

    /// Unit normal of the surface (`edge_u × edge_v`).
    ///
    /// ```
    /// # use warpfit_runtime::glam::Vec3;
    /// # use warpfit_runtime::warp::surface::SurfacePatch;
    /// # let patch = SurfacePatch { corner: Vec3::ZERO, edge_u: Vec3::X, edge_v: Vec3::NEG_Z, counts: [1, 1], resolution: 2, offset: 0.05 };
    /// # let atlas = warpfit_runtime::SurfaceAtlas::new(patch, vec![vec![Vec3::ONE; 4]], vec![0.0], vec![0.5; 4]);
    /// // `atlas`: one of `warpfit_runtime::load_surface_atlases("fits/mylevel")?`
    /// assert_eq!(atlas.normal(), Vec3::Y);
    /// ```
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        self.frame.normal
    }

    /// Surface coordinates (s, t) of a point (not clamped): (0, 0) at the patch's corner,
    /// (1, 1) at the opposite one.
    ///
    /// ```
    /// # use warpfit_runtime::glam::Vec3;
    /// # use warpfit_runtime::warp::surface::SurfacePatch;
    /// # let patch = SurfacePatch { corner: Vec3::ZERO, edge_u: Vec3::X, edge_v: Vec3::NEG_Z, counts: [1, 1], resolution: 2, offset: 0.05 };
    /// # let atlas = warpfit_runtime::SurfaceAtlas::new(patch, vec![vec![Vec3::ONE; 4]], vec![0.0], vec![0.5; 4]);
    /// // `atlas`: one of `warpfit_runtime::load_surface_atlases("fits/mylevel")?`
    /// assert_eq!(atlas.surface_coordinates(Vec3::new(0.5, 0.0, -0.25)), (0.5, 0.25));
    /// ```
    #[must_use]
    pub fn surface_coordinates(&self, p: Vec3) -> (f32, f32) {
        let d = p - self.patch.corner;
        (self.frame.dual_u.dot(d), self.frame.dual_v.dot(d))
    }

    /// World position of probe (i, j): the centre of its patch, `offset` off the surface
    /// (the tool's; not a supported API).
    #[doc(hidden)]
    #[must_use]
    pub fn probe_position(&self, i: u32, j: u32) -> Vec3 {
        self.patch.probe_position(&self.frame, i, j)
    }

    /// Radiance arriving at `b` (a point on or just off the surface) from unit-or-not
    /// direction `dir` at perceptual roughness `r`: the seed's lookup. Black for a zero or
    /// non-finite direction; a position off the parallelogram reads its nearest probes.
    ///
    /// ```
    /// # use warpfit_runtime::glam::Vec3;
    /// # use warpfit_runtime::warp::surface::SurfacePatch;
    /// # let patch = SurfacePatch { corner: Vec3::ZERO, edge_u: Vec3::X, edge_v: Vec3::NEG_Z, counts: [1, 1], resolution: 2, offset: 0.05 };
    /// # let atlas = warpfit_runtime::SurfaceAtlas::new(patch, vec![vec![Vec3::ONE; 4]], vec![0.0], vec![0.5; 4]);
    /// // `atlas`: one of `warpfit_runtime::load_surface_atlases("fits/mylevel")?`
    /// let c = atlas.radiance(Vec3::new(0.3, 0.0, -0.6), Vec3::new(0.2, 1.0, 0.1), 0.3);
    /// assert!(c.is_finite() && c.min_element() >= 0.0);
    /// ```
    #[must_use]
    pub fn radiance(&self, b: Vec3, dir: Vec3, r: f32) -> Vec3 {
        self.lookup(b, dir, r, false)
    }

    /// As [`Self::radiance`], each of the four probes warped by its own depth first.
    ///
    /// ```
    /// # use warpfit_runtime::glam::Vec3;
    /// # use warpfit_runtime::warp::surface::SurfacePatch;
    /// # let patch = SurfacePatch { corner: Vec3::ZERO, edge_u: Vec3::X, edge_v: Vec3::NEG_Z, counts: [1, 1], resolution: 2, offset: 0.05 };
    /// # let atlas = warpfit_runtime::SurfaceAtlas::new(patch, vec![vec![Vec3::ONE; 4]], vec![0.0], vec![0.5; 4]);
    /// // `atlas`: one of `warpfit_runtime::load_surface_atlases("fits/mylevel")?`
    /// let c = atlas.radiance_warped(Vec3::new(0.3, 0.0, -0.6), Vec3::new(0.2, 1.0, 0.1), 0.3);
    /// assert!(c.is_finite() && c.min_element() >= 0.0);
    /// ```
    #[must_use]
    pub fn radiance_warped(&self, b: Vec3, dir: Vec3, r: f32) -> Vec3 {
        self.lookup(b, dir, r, true)
    }

    fn lookup(&self, b: Vec3, dir: Vec3, r: f32, warped: bool) -> Vec3 {
        let Some(dir) = octa::unit_direction(dir) else { return Vec3::ZERO };
        let (f, p) = (&self.frame, &self.patch);
        let b = if b.is_finite() { b } else { p.corner };
        let d = b - p.corner;
        let axis = |x: f32, n: u32| {
            let x = if x.is_finite() { x } else { 0.5 };
            let c = (x * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
            let i0 = c.floor() as u32;
            (i0, (i0 + 1).min(n - 1), c - i0 as f32)
        };
        let (i0, i1, fx) = axis(f.dual_u.dot(d), p.counts[0]);
        let (j0, j1, fy) = axis(f.dual_v.dot(d), p.counts[1]);
        let last = (self.roughness.len() - 1) as f32;
        let lod = if r.is_finite() { r.clamp(0.0, 1.0) * last } else { 0.0 };
        let m0 = lod.floor() as usize;
        let (m1, fm) = ((m0 + 1).min(self.roughness.len() - 1), lod - m0 as f32);
        let (res, texels) = (p.resolution, (p.resolution * p.resolution) as usize);
        let dir_local = f.to_local(dir);
        // unwarped, every probe reads the same texels of its own tile
        let shared = hemi::taps(res, hemi::encode(dir_local));
        let probe = |i: u32, j: u32| -> Vec3 {
            let tile = (j * p.counts[0] + i) as usize * texels;
            let taps = if warped {
                // seed 000's plane warp from this probe: w1 along Dir, plane ⟂ Dir at the hit,
                // fetch towards where the ray from B crosses it
                let w1 = hemi::gather(&self.inv_distance[tile..tile + texels], shared);
                let ab = f.to_local(self.probe_position(i, j) - b);
                let v = super::depth::first_plane(dir_local, ab, dir_local.dot(ab), w1);
                if w1 > 0.0 && v.is_finite() && v.length_squared() > 0.0 {
                    hemi::taps(res, hemi::encode(v))
                } else {
                    shared
                }
            } else {
                shared
            };
            let a = hemi::gather(&self.radiance[m0][tile..tile + texels], taps);
            if fm > 0.0 { a.lerp(hemi::gather(&self.radiance[m1][tile..tile + texels], taps), fm) } else { a }
        };
        let top = probe(i0, j0).lerp(probe(i1, j0), fx);
        let bottom = probe(i0, j1).lerp(probe(i1, j1), fx);
        let l = top.lerp(bottom, fy);
        if l.is_finite() { l.max(Vec3::ZERO) } else { Vec3::ZERO }
    }

    /// Bytes the atlas takes in engine layout (RGBA16F radiance per texel and mip).
    #[doc(hidden)]
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.radiance.iter().map(|l| l.len() as u64 * 8).sum()
    }

    /// Mip 0 as one image: the tiles side by side as the seed packs them (probe (i, j) at
    /// column i, row j), `(width, height, texels)`.
    #[doc(hidden)]
    #[must_use]
    pub fn atlas_image(&self) -> (u32, u32, Vec<Vec3>) {
        let p = &self.patch;
        (p.counts[0] * p.resolution, p.counts[1] * p.resolution, self.packed(&self.radiance[0]))
    }

    /// A layer of the atlas (`probes × N²` values, tile after tile) packed as one image,
    /// probe (i, j)'s tile at column i, row j, row-major.
    #[doc(hidden)]
    #[must_use]
    pub fn packed<T: Copy + Default>(&self, tiles: &[T]) -> Vec<T> {
        let n = self.patch.resolution as usize;
        let cu = self.patch.counts[0] as usize;
        let w = cu * n;
        let mut out = vec![T::default(); tiles.len()];
        for (k, tile) in tiles.chunks(n * n).enumerate() {
            let (i, j) = (k % cu, k / cu);
            for (t, v) in tile.iter().enumerate() {
                out[(j * n + t / n) * w + i * n + t % n] = *v;
            }
        }
        out
    }
}
