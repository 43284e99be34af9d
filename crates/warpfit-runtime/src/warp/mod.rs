//! Warps: given a query position B and a direction, where to fetch probe A. Every technique
//! of the source articles is here as a baseline, plus the oracle bound.
//!
//! Each method is a pure function returning the unit direction towards which probe A is
//! fetched. Conventions shared by all of them:
//! - the probe's depth is read as *inverse* distance `w = 1/d` (bilinear, seam-aware,
//!   from the chosen depth mip); sky is `w = 0`, so no infinity ever enters arithmetic;
//! - a query exactly at the probe (`B == A`) returns the query direction unchanged: the
//!   probe's own data is exact there;
//! - when a construction degenerates (sky, a plane parallel to the ray, a point behind B),
//!   the method falls back to the query direction, which is what a miss to the sky needs;
//! - results are always finite, non-zero vectors (`fetch_vector`); `fetch_dir` normalises.

pub mod corrective;
pub mod depth;
pub mod glossy;
pub mod proxy;
pub mod surface;

use crate::octa::{self, LANES, OctMap, OctMips, UvLanes};
use glam::Vec3;

/// The probe data warps read: position, inverse-distance mips and radiance mips with the
/// perceptual roughness each radiance mip was prefiltered for.
#[derive(Clone, Debug)]
pub struct WarpProbe {
    pub position: Vec3,
    /// 1/distance per depth mip (0 where the probe saw sky).
    pub inv_depth: OctMips<f32>,
    pub radiance: OctMips<Vec3>,
    /// Perceptual roughness of each radiance mip (increasing; mip 0 = 0, the mirror image).
    mip_roughness: Vec<f32>,
    /// `n − 1` for a chain of n mips at r = m / (n − 1), the chain every bake writes
    /// (`lod_of_roughness` is then r · (n − 1)); `None` for any other.
    uniform_lods: Option<f32>,
    /// Largest finite distance the probe saw (bounds ray marching).
    pub max_distance: f32,
}

impl WarpProbe {
    /// From distance mips (+inf = sky; mip 0 = texel-centre distances), radiance mips and
    /// their perceptual roughness.
    pub fn from_distance_mips(
        position: Vec3,
        distance: &OctMips<f32>,
        radiance: OctMips<Vec3>,
        mip_roughness: Vec<f32>,
    ) -> Self {
        let inv_depth = OctMips {
            levels: distance
                .levels
                .iter()
                .map(|l| OctMap::new(l.res, l.texels.iter().map(|&d| octa::inverse_distance(d)).collect()))
                .collect(),
        };
        let max_distance = distance
            .levels
            .first()
            .map_or(0.0, |l| l.texels.iter().copied().filter(|d| d.is_finite()).fold(0.0f32, f32::max));
        let n = mip_roughness.len();
        let uniform = n >= 2 && (0..n).all(|m| mip_roughness[m] == m as f32 / (n - 1) as f32);
        let uniform_lods = uniform.then_some((n - 1) as f32);
        WarpProbe { position, inv_depth, radiance, mip_roughness, uniform_lods, max_distance }
    }

    /// Perceptual roughness of each radiance mip (increasing; mip 0 = 0, the mirror image).
    #[must_use]
    pub fn mip_roughness(&self) -> &[f32] {
        &self.mip_roughness
    }

    /// The exposure every tone-mapped error of this probe's scene is measured at: the key of
    /// its mirror image (`tonemap::key_exposure`), shared by the fit, eval and the sweep.
    #[must_use]
    pub fn key_exposure(&self) -> f32 {
        self.radiance.levels.first().map_or(1.0, |l| crate::tonemap::key_exposure(&l.texels))
    }

    /// Inverse distance seen by the probe towards `dir` at depth mip `lod`.
    #[inline]
    #[must_use]
    pub fn inv_dist(&self, dir: Vec3, lod: f32) -> f32 {
        usable_inverse(self.inv_depth.sample_lod(dir, lod))
    }

    /// `inv_dist` for [`LANES`] lookups given their octahedral uv, bit for bit the same.
    #[inline]
    #[must_use]
    pub fn inv_dist_lanes(&self, uv: &UvLanes, lod: f32) -> [f32; LANES] {
        let mut w = self.inv_depth.sample_lod_uv_lanes(uv, lod);
        for k in 0..LANES {
            w[k] = usable_inverse(w[k]);
        }
        w
    }

    /// Mirror (roughness 0) radiance of the probe towards `dir`.
    #[inline]
    #[must_use]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        self.radiance.levels[0].bilinear(dir)
    }

    /// `radiance` for a batch of fetch vectors, bit for bit the same values, [`LANES`] at a
    /// time. Answers the first `min(vectors.len(), out.len())`; give slices of equal length.
    pub fn radiance_batch(&self, vectors: &[Vec3], out: &mut [Vec3]) {
        let n = vectors.len().min(out.len());
        octa::fill_in_lanes(
            &mut out[..n],
            |k| self.radiance_lanes(octa::group_at(vectors, k)),
            |k| self.radiance(vectors[k]),
        );
    }

    /// `radiance` for [`LANES`] fetch vectors, bit for bit the same.
    #[inline]
    #[must_use]
    pub fn radiance_lanes(&self, dirs: &[Vec3; LANES]) -> [Vec3; LANES] {
        self.radiance.levels[0].bilinear_uv_lanes(&crate::octa::encode_lanes(dirs))
    }
}

/// A sampled inverse distance as the warps use it: finite and positive, else 0 (sky).
/// Written as two compares so that loops over lanes vectorise.
#[inline(always)]
fn usable_inverse(w: f32) -> f32 {
    if w > 0.0 && w < f32::INFINITY { w } else { 0.0 }
}

/// Unit direction from `from` to `to`, or `fallback` when they coincide or overflow.
#[inline]
#[must_use]
pub fn toward(from: Vec3, to: Vec3, fallback: Vec3) -> Vec3 {
    let v = to - from;
    let l2 = v.length_squared();
    if l2 > 0.0 && l2.is_finite() { v / l2.sqrt() } else { fallback }
}

/// Largest UV relaxation the fit chooses ([`WarpOptions::relax_texels`]), in probe texels;
/// a grid file asking for more is refused.
pub const MAX_RELAX_TEXELS: f32 = 3.0;

/// Tunable options shared by the depth-based methods.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WarpOptions {
    /// Depth mip (blur) the warp reads; fractional values blend mips.
    pub depth_lod: f32,
    /// UV relaxation: the fetch direction is averaged over a 4-tap stencil of query
    /// directions this many probe texels around the query (0 = off).
    pub relax_texels: f32,
    /// Iterations of `secant`.
    pub secant_steps: u32,
    /// Linear steps of `raymarch` before binary refinement.
    pub march_steps: u32,
}

impl WarpOptions {
    /// Depth mip 2 (a 4×-downsampled, inverse-distance-filtered depth): the seed's "blurry
    /// depth" advice, better than mip 0 in the eval sweep, and cache-resident.
    #[must_use]
    pub const fn standard() -> Self {
        WarpOptions { depth_lod: 2.0, relax_texels: 0.0, secant_steps: 6, march_steps: 64 }
    }
}

impl Default for WarpOptions {
    fn default() -> Self {
        Self::standard()
    }
}

/// The per-lookup methods (reprojection and the oracle need more context; see
/// `reproject` and `eval`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Method {
    None,
    Box,
    Kdop,
    Warp1,
    Warp2Fixed,
    Warp2New,
    Secant,
    Raymarch,
    Reproject,
    Oracle,
}

impl Method {
    pub const ALL: [Method; 10] = [
        Method::None,
        Method::Box,
        Method::Kdop,
        Method::Warp1,
        Method::Warp2Fixed,
        Method::Warp2New,
        Method::Secant,
        Method::Raymarch,
        Method::Reproject,
        Method::Oracle,
    ];

    /// Methods that answer one lookup on their own (everything but `reproject`, which
    /// needs a per-location pass, and the `oracle`, which traces): the first eight of
    /// [`ALL`](Self::ALL), which lists them first.
    pub const PER_LOOKUP: [Method; 8] = {
        let mut out = [Method::None; 8];
        let mut k = 0;
        while k < out.len() {
            out[k] = Method::ALL[k];
            k += 1;
        }
        out
    };

    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Method::None => "none",
            Method::Box => "box",
            Method::Kdop => "kdop",
            Method::Warp1 => "warp1",
            Method::Warp2Fixed => "warp2-fixed",
            Method::Warp2New => "warp2-new",
            Method::Secant => "secant",
            Method::Raymarch => "raymarch",
            Method::Reproject => "reproject",
            Method::Oracle => "oracle",
        }
    }

    #[must_use]
    pub fn parse(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Reads of probe A one mirror lookup makes, depth and radiance (`None`: `reproject`,
    /// a per-location pass, and the `oracle`, which traces): the projections 1, `warp1` 2,
    /// the two-step warps 3, `secant` and `raymarch` one per step and one more. A count,
    /// not a time: the same on every run and machine (the evaluation's claims budget by it).
    #[must_use]
    pub fn probe_reads(self, o: &WarpOptions) -> Option<u32> {
        match self {
            Method::None | Method::Box | Method::Kdop => Some(1),
            Method::Warp1 => Some(2),
            Method::Warp2Fixed | Method::Warp2New => Some(3),
            Method::Secant => Some(o.secant_steps.saturating_add(1)),
            Method::Raymarch => Some(o.march_steps.saturating_add(1)),
            Method::Reproject | Method::Oracle => None,
        }
    }
}

/// Everything the per-lookup methods need besides the probe.
#[derive(Clone, Debug)]
pub struct Proxies {
    pub aabb: proxy::BoxProxy,
    pub kdop: proxy::Kdop,
}

impl Proxies {
    /// Distance along unit `dir` from `b` to the boundary of proxy `method` (`Box` or
    /// `Kdop`): `None` when `b` is outside it or `method` is not a proxy, `+inf` through an
    /// open side of the k-DOP.
    #[inline]
    #[must_use]
    pub fn exit_distance(&self, method: Method, b: Vec3, dir: Vec3) -> Option<f32> {
        match method {
            Method::Box => self.aabb.exit_distance(b, dir),
            Method::Kdop => self.kdop.exit_distance(b, dir),
            _ => None,
        }
    }
}

/// What every warp reads: probe A, the proxy shapes and the warp options. The evaluation,
/// the fit and the runtime sampler each hold one, so a method answers the same everywhere.
#[derive(Clone, Debug)]
pub struct Warp {
    pub probe: WarpProbe,
    /// The other specular probes after probe A (empty: one probe), shared by clones.
    pub others: std::sync::Arc<[WarpProbe]>,
    pub proxies: Proxies,
    pub options: WarpOptions,
}

impl Warp {
    /// Probe `k`: probe A for 0, else `others[k - 1]` (probe A for an index beyond them).
    #[inline(always)]
    #[must_use]
    pub fn probe_at(&self, k: usize) -> &WarpProbe {
        if k == 0 { &self.probe } else { self.others.get(k - 1).unwrap_or(&self.probe) }
    }

    /// Each lane's read of its own probe (`probe[k]`, as [`Warp::probe_at`]) for [`LANES`]
    /// lanes: `one` on that probe when every lane reads one probe (the usual case, and the
    /// only one with a single probe), else `each` on the lanes' probes; both give each lane
    /// what a lookup of its probe alone gives, bit for bit.
    #[inline(always)]
    pub fn by_probe<T>(
        &self,
        probe: &[u8; LANES],
        one: impl FnOnce(&WarpProbe) -> [T; LANES],
        each: impl FnOnce(&[&WarpProbe; LANES]) -> [T; LANES],
    ) -> [T; LANES] {
        let first = probe[0];
        let mut same = true;
        for k in 0..LANES {
            same &= probe[k] == first;
        }
        if same {
            return one(self.probe_at(first.into()));
        }
        each(&std::array::from_fn(|k| self.probe_at(probe[k].into())))
    }

    /// Every probe's position, probe A first.
    #[must_use]
    pub fn probe_positions(&self) -> Vec<Vec3> {
        std::iter::once(&self.probe).chain(self.others.iter()).map(|p| p.position).collect()
    }

    /// How many probes a lookup can read (probe A and the others).
    #[inline]
    #[must_use]
    pub fn probe_count(&self) -> usize {
        1 + self.others.len()
    }

    /// Distance along unit `dir` from `b` to the surface the grid's maps shift, for base
    /// `method`: the box's or the 18-DOP's exit (`Proxies::exit_distance`), or the point
    /// seed 000's one-step warp aims at (`warp1`, the probe's own depth as the proxy).
    /// `None` where the method makes no correction (B outside a proxy, at the probe, or a
    /// method that aims at no point on the ray); `+inf` for sky.
    #[inline]
    #[must_use]
    pub fn base_distance(&self, method: Method, b: Vec3, dir: Vec3) -> Option<f32> {
        match method {
            Method::Warp1 => depth::warp1_distance(&self.probe, b, dir, self.options.depth_lod),
            m => self.proxies.exit_distance(m, b, dir),
        }
    }

    /// Unit fetch direction of a per-lookup method (`Reproject`/`Oracle` return `dir`).
    #[inline]
    #[must_use]
    pub fn fetch_dir(&self, method: Method, b: Vec3, dir: Vec3) -> Vec3 {
        let v = self.fetch_vector(method, b, dir);
        if v == dir {
            return dir; // the query direction itself, bit for bit (normalising could change it)
        }
        let l2 = v.length_squared();
        if l2 > 0.0 && l2.is_finite() { v / l2.sqrt() } else { dir }
    }

    /// Fetch vector: a positive multiple of the fetch direction (finite, non-zero). Probe
    /// lookups take it as is; normalise it only where a unit vector is needed.
    #[inline]
    #[must_use]
    pub fn fetch_vector(&self, method: Method, b: Vec3, dir: Vec3) -> Vec3 {
        if b == self.probe.position {
            return dir;
        }
        if self.options.relax_texels > 0.0 && !matches!(method, Method::None | Method::Reproject | Method::Oracle) {
            return self.relaxed(method, b, dir);
        }
        self.fetch_vector_plain(method, b, dir)
    }

    /// Mirror radiance the method returns for the query (B, dir).
    #[inline]
    #[must_use]
    pub fn lookup(&self, method: Method, b: Vec3, dir: Vec3) -> Vec3 {
        self.probe.radiance(self.fetch_vector(method, b, dir))
    }

    #[inline]
    fn fetch_vector_plain(&self, method: Method, b: Vec3, dir: Vec3) -> Vec3 {
        let (probe, a, lod) = (&self.probe, self.probe.position, self.options.depth_lod);
        match method {
            Method::None | Method::Reproject | Method::Oracle => dir,
            Method::Box => self.proxies.aabb.fetch_dir(a, b, dir),
            Method::Kdop => self.proxies.kdop.fetch_dir(a, b, dir),
            Method::Warp1 => depth::plane_warp(probe, b, dir, lod, 1, false),
            Method::Warp2Fixed => depth::plane_warp(probe, b, dir, lod, 2, false),
            Method::Warp2New => depth::plane_warp(probe, b, dir, lod, 2, true),
            Method::Secant => depth::secant(probe, b, dir, lod, self.options.secant_steps),
            Method::Raymarch => depth::raymarch(probe, b, dir, lod, self.options.march_steps),
        }
    }

    /// UV relaxation (seed 000: "store the warped UVs, then relax them"): the warped
    /// direction field is box-filtered over a small stencil of neighbouring query directions.
    fn relaxed(&self, method: Method, b: Vec3, dir: Vec3) -> Vec3 {
        self.relaxed_with(self.options.relax_texels, dir, |d| self.fetch_vector_plain(method, b, d))
    }

    /// `fetch`'s direction field box-filtered over a 5-tap stencil `relax_texels` probe
    /// texels around `dir`.
    fn relaxed_with(&self, relax_texels: f32, dir: Vec3, fetch: impl Fn(Vec3) -> Vec3) -> Vec3 {
        let res = self.probe.radiance.levels[0].res as f32;
        // one texel of an N×N octahedral map spans about sqrt(4π/N²) radians
        let angle = relax_texels * (4.0 * std::f32::consts::PI).sqrt() / res;
        let (t, bt) = octa::orthonormal_basis(dir);
        let unit = |v: Vec3| v.normalize_or(dir);
        let mut sum = unit(fetch(dir));
        for off in [t, -t, bt, -bt] {
            let d = (dir + off * angle).normalize();
            sum += unit(fetch(d));
        }
        let l = sum.length();
        if l > 0.0 && l.is_finite() { sum / l } else { dir }
    }

    /// Fetch vector of the level-1 corrective (one origin offset, depth mip and relaxation
    /// strength for a whole cell): seed 000's warp from `b + offset` reading the depth mip
    /// `depth_lod`, relaxed over `relax_texels`.
    #[must_use]
    pub fn level1_vector(&self, l: &Level1, b: Vec3, dir: Vec3) -> Vec3 {
        if b == self.probe.position {
            return dir;
        }
        let from = b + l.offset;
        let plain = |d: Vec3| depth::plane_warp(&self.probe, from, d, l.depth_lod, 1, false);
        if l.relax_texels > 0.0 { self.relaxed_with(l.relax_texels, dir, plain) } else { plain(dir) }
    }
}

/// The level-1 corrective of a cell: the query's origin moved by `offset` (scene units),
/// the depth mip `depth_lod` and the relaxation strength `relax_texels` of its warp.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Level1 {
    pub offset: Vec3,
    pub depth_lod: f32,
    pub relax_texels: f32,
}
