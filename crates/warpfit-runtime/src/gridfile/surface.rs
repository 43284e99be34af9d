//! `warpfit-surface`: a surface-probe atlas (seed 003) as a folder a game loads beside the
//! fitted grid: `manifest.json` (format, version, the hemi-octahedral convention, the patch,
//! each mip's roughness, the payload's size and checksum) and `atlas.exr`.
//!
//! `atlas.exr` holds the tiles packed as the seed packs them, probe (i, j) at tile column i,
//! row j of a `counts[0]·N × counts[1]·N` image: layers `radiance_mip{m}` (R, G, B; every mip
//! at the tile's resolution) and `inv_distance` (W: 1/distance of each mip-0 texel-centre
//! ray, 0 = sky). All f32, so a written atlas loads back bit for bit.
//!
//! The reader trusts nothing: sizes, checksum and headers are checked before decoding, the
//! patch and roughness before anything is built, every sample after.

use super::read::{Expected, Listing, Rule, read_listed_payload, scan_listed_payload};
use super::schema::{MAX_TILE_RESOLUTION, Payload, SCAN_ABOVE_BYTES};
use crate::files::FileError;
use crate::octa::hemi;
use crate::warp::surface::{SurfaceAtlas, SurfacePatch};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const SURFACE_FORMAT: &str = "warpfit-surface";
pub const SURFACE_VERSION: u32 = 1;
pub const SURFACE_MANIFEST: &str = "manifest.json";
pub const SURFACE_ATLAS_FILE: &str = "atlas.exr";
/// Largest probe count along one edge, and mips, a reader accepts.
pub const MAX_SURFACE_PROBES: u32 = 256;
pub const MAX_SURFACE_MIPS: usize = 16;

/// Where an atlas sits and how its tiles read: what the manifest and the engine export
/// (`export.json` → `surfaces`) both describe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceDescription {
    /// [`hemi::CONVENTION`]: the tile mapping the atlas was written with.
    pub convention: String,
    /// The patch `corner + s·edge_u + t·edge_v`, facing `edge_u × edge_v`; the tangent frame
    /// of every tile is (edge_u normalised, normal × that, normal).
    pub corner: [f32; 3],
    pub edge_u: [f32; 3],
    pub edge_v: [f32; 3],
    pub counts: [u32; 2],
    pub resolution: u32,
    /// Height of the probes above the patch (scene units).
    pub offset: f32,
    /// Perceptual roughness of each radiance mip (GGX α = r²).
    pub roughness: Vec<f32>,
}

impl SurfaceDescription {
    /// The description of `atlas`.
    #[must_use]
    pub fn of(atlas: &SurfaceAtlas) -> SurfaceDescription {
        let p = &atlas.patch;
        SurfaceDescription {
            convention: hemi::CONVENTION.into(),
            corner: p.corner.to_array(),
            edge_u: p.edge_u.to_array(),
            edge_v: p.edge_v.to_array(),
            counts: p.counts,
            resolution: p.resolution,
            offset: p.offset,
            roughness: atlas.roughness.clone(),
        }
    }
}

/// `manifest.json` of a surface-probe atlas.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceManifest {
    pub format: String,
    pub version: u32,
    pub surface: SurfaceDescription,
    pub payload: Payload,
}

pub fn radiance_layer(m: usize) -> String {
    format!("radiance_mip{m}")
}

/// The inverse of `SurfaceAtlas::packed`: an atlas image back to tiles.
fn unpack<T: Copy + Default>(image: &[T], counts: [u32; 2], n: u32) -> Vec<T> {
    let (n, cu) = (n as usize, counts[0] as usize);
    let w = cu * n;
    let mut out = vec![T::default(); image.len()];
    for (k, tile) in out.chunks_mut(n * n).enumerate() {
        let (i, j) = (k % cu, k / cu);
        for (t, v) in tile.iter_mut().enumerate() {
            *v = image[(j * n + t / n) * w + i * n + t % n];
        }
    }
    out
}

fn invalid(path: &Path, field: &str, message: impl Into<String>) -> FileError {
    FileError::invalid(path, field, message)
}

/// Reads the atlas folder `dir` (`surface{k}/` beside a fitted grid), checking everything
/// (versions, sizes, checksum, every value) before anything is built.
///
/// ```
/// use std::path::Path;
/// let err = warpfit_runtime::load_surface_atlas(Path::new("fits/none/surface0")).unwrap_err();
/// assert!(err.to_string().contains("surface0"));
/// ```
pub fn read(dir: &Path) -> Result<SurfaceAtlas, FileError> {
    let mpath = dir.join(SURFACE_MANIFEST);
    let bytes = crate::files::read_regular(&mpath, 1 << 20)?;
    let value: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| FileError::Json { path: mpath.clone(), message: e.to_string() })?;
    let found = value.get("format").and_then(|v| v.as_str()).unwrap_or("").to_string();
    let version = value.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
    if found != SURFACE_FORMAT || version != SURFACE_VERSION as u64 {
        return Err(FileError::Version {
            path: mpath,
            found,
            version,
            expected: SURFACE_FORMAT,
            supported: SURFACE_VERSION,
        });
    }
    let manifest: SurfaceManifest =
        serde_json::from_value(value).map_err(|e| FileError::Json { path: mpath.clone(), message: e.to_string() })?;
    let (m, mp) = (&manifest.surface, mpath.as_path());
    if m.convention != hemi::CONVENTION {
        return Err(invalid(mp, "convention", "differs from this reader's hemi-octahedral mapping"));
    }
    let vec3 = |v: [f32; 3], field: &str| {
        let ok = v.iter().all(|x| x.is_finite() && x.abs() <= 1e12);
        if ok { Ok(Vec3::from_array(v)) } else { Err(invalid(mp, field, format!("must be finite, got {v:?}"))) }
    };
    let (corner, edge_u, edge_v) = (vec3(m.corner, "corner")?, vec3(m.edge_u, "edge_u")?, vec3(m.edge_v, "edge_v")?);
    let scale = |v: Vec3| v / v.abs().max_element().max(f32::MIN_POSITIVE);
    let (u, v) = (scale(edge_u), scale(edge_v));
    if !(u.cross(v).length() > 1e-3 * u.length() * v.length()) {
        return Err(invalid(mp, "edge_u", "edge_u and edge_v must be non-zero and not parallel"));
    }
    if m.counts.iter().any(|c| !(1..=MAX_SURFACE_PROBES).contains(c)) {
        return Err(invalid(mp, "counts", format!("each must be in 1..={MAX_SURFACE_PROBES}, got {:?}", m.counts)));
    }
    let n = m.resolution;
    if !(2..=MAX_TILE_RESOLUTION).contains(&n) || !n.is_multiple_of(2) {
        return Err(invalid(mp, "resolution", format!("must be even in 2..={MAX_TILE_RESOLUTION}, got {n}")));
    }
    if !(m.offset.is_finite() && m.offset >= 0.0) {
        return Err(invalid(mp, "offset", format!("must be finite and ≥ 0, got {}", m.offset)));
    }
    let r = &m.roughness;
    let increasing = r.windows(2).all(|w| w[1] > w[0]);
    if r.is_empty() || r.len() > MAX_SURFACE_MIPS || r[0] != 0.0 || !increasing || r.iter().any(|x| !(*x <= 1.0)) {
        return Err(invalid(
            mp,
            "roughness",
            format!("must rise from 0 to at most 1 over 1..={MAX_SURFACE_MIPS} mips, got {r:?}"),
        ));
    }
    let (w, h) = ((m.counts[0] * n) as usize, (m.counts[1] * n) as usize);
    let plain = |name: String, channels: &'static [&'static str], rule: Rule| Expected {
        name,
        width: w,
        height: h,
        channels,
        tiles: None,
        rules: channels.iter().map(|_| Rule { valid: w * h, ..rule.clone() }).collect(),
    };
    let mut expected: Vec<Expected> =
        (0..r.len()).map(|k| plain(radiance_layer(k), &["R", "G", "B"], Rule::radiance(0))).collect();
    expected.push(plain("inv_distance".into(), &["W"], Rule::within(0.0, f32::MAX, 0, "finite and ≥ 0")));
    let listing = Listing { dir, manifest: mp, payloads: std::slice::from_ref(&manifest.payload) };
    if expected.iter().map(Expected::decoded_bytes).sum::<u64>() > SCAN_ABOVE_BYTES {
        scan_listed_payload(listing, SURFACE_ATLAS_FILE, &expected)?;
    }
    let layers = read_listed_payload(listing, SURFACE_ATLAS_FILE, &expected)?;
    let path = dir.join(SURFACE_ATLAS_FILE);
    let channel = |layer: &str, c: &str| -> Result<&[f32], FileError> {
        layers
            .iter()
            .find(|l| l.name == layer)
            .and_then(|l| l.channel(c))
            .ok_or_else(|| invalid(&path, &format!("{layer}.{c}"), "missing"))
    };
    let mut radiance = Vec::with_capacity(r.len());
    for k in 0..r.len() {
        let name = radiance_layer(k);
        let (rr, gg, bb) = (channel(&name, "R")?, channel(&name, "G")?, channel(&name, "B")?);
        let image: Vec<Vec3> = (0..w * h).map(|t| Vec3::new(rr[t], gg[t], bb[t])).collect();
        radiance.push(unpack(&image, m.counts, n));
    }
    let inv = channel("inv_distance", "W")?;
    let patch = SurfacePatch { corner, edge_u, edge_v, counts: m.counts, resolution: n, offset: m.offset };
    Ok(SurfaceAtlas::new(patch, radiance, m.roughness.clone(), unpack(inv, m.counts, n)))
}

/// Every atlas a run wrote into the grid folder `dir`: `surface0/`, `surface1/`, … up to the
/// first index without a folder (none for a scene without `[[surface_probes]]`).
///
/// ```
/// # let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny"));
/// let atlases = warpfit_runtime::load_surface_atlases(dir)?; // e.g. "fits/mylevel"
/// assert!(atlases.is_empty()); // tiny has no surface probes
/// # Ok::<(), warpfit_runtime::LoadError>(())
/// ```
pub fn read_all(dir: &Path) -> Result<Vec<SurfaceAtlas>, FileError> {
    let mut out = Vec::new();
    while dir.join(format!("surface{}", out.len())).is_dir() {
        out.push(read(&dir.join(format!("surface{}", out.len())))?);
    }
    Ok(out)
}
