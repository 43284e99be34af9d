//! `warpfit-bake`, the bake folder: `probe.exr`, `grid.exr` and `manifest.json` (the job
//! that writes it adds PNG previews).
//!
//! `probe.exr` has the fitted grid's probe layout (`gridfile::probe_layers`):
//! `radiance_mip{m}` (R, G, B; GGX-prefiltered, roughness in the manifest) and
//! `distance_mip{m}` (Z; distance, +inf on miss; mip 0 = texel-centre distances).
//! `grid.exr` layers: `irradiance` (R, G, B) and `depth_moments` (mean, mean_sq, hit) atlases;
//! cell (x, y, z) occupies tile column x, tile row y + ny·z, tiles of the map's resolution.

pub mod manifest;

use crate::bake::{Bake, GridGeometry, ProbeGrid, SpecularProbe};
use crate::files::{FileError, write_json};
use crate::gridfile::exr::{self, ExrLayer};
use crate::gridfile::{distance_layer, probe_layers, radiance_layer, rgb_channels};
use crate::octa::{CONVENTION, OctMap, OctMips};
use crate::scene::Scene;
use glam::{UVec3, Vec3};
use manifest::*;
use std::path::Path;

pub const PROBE_FILE: &str = "probe.exr";
pub const GRID_FILE: &str = "grid.exr";
pub const MANIFEST_FILE: &str = "manifest.json";

/// Rearranges cell-major per-cell maps into an atlas (row-major, see module docs).
fn to_atlas<T: Copy + Default>(g: &GridGeometry, res: u32, per_cell: &[T]) -> (usize, usize, Vec<T>) {
    let (nx, ny, nz) = (g.counts.x as usize, g.counts.y as usize, g.counts.z as usize);
    let r = res as usize;
    let (w, h) = (nx * r, ny * nz * r);
    let mut atlas = vec![T::default(); w * h];
    for cell in 0..g.cell_count() {
        let c = g.cell_coords(cell);
        let (tx, ty) = (c.x as usize, c.y as usize + ny * c.z as usize);
        for j in 0..r {
            for i in 0..r {
                atlas[(ty * r + j) * w + tx * r + i] = per_cell[cell * r * r + j * r + i];
            }
        }
    }
    (w, h, atlas)
}

fn from_atlas<T: Copy + Default>(g: &GridGeometry, res: u32, atlas: &[T]) -> Vec<T> {
    let ny = g.counts.y as usize;
    let r = res as usize;
    let w = g.counts.x as usize * r;
    let mut out = vec![T::default(); g.cell_count() * r * r];
    for cell in 0..g.cell_count() {
        let c = g.cell_coords(cell);
        let (tx, ty) = (c.x as usize, c.y as usize + ny * c.z as usize);
        for j in 0..r {
            for i in 0..r {
                out[cell * r * r + j * r + i] = atlas[(ty * r + j) * w + tx * r + i];
            }
        }
    }
    out
}

pub fn grid_layers(g: &ProbeGrid) -> Vec<ExrLayer> {
    let (w, h, irr) = to_atlas(&g.geometry, g.irradiance_resolution, &g.irradiance);
    let (dw, dh, mean) = to_atlas(&g.geometry, g.depth_resolution, &g.depth_mean);
    let (_, _, mean_sq) = to_atlas(&g.geometry, g.depth_resolution, &g.depth_mean_sq);
    let (_, _, hit) = to_atlas(&g.geometry, g.depth_resolution, &g.hit_fraction);
    vec![
        ExrLayer { name: "irradiance".into(), width: w, height: h, channels: rgb_channels(&irr) },
        ExrLayer {
            name: "depth_moments".into(),
            width: dw,
            height: dh,
            channels: vec![("mean".into(), mean), ("mean_sq".into(), mean_sq), ("hit".into(), hit)],
        },
    ]
}

pub fn build_manifest(scene: &Scene, bake: &Bake) -> BakeManifest {
    let p = &bake.probe;
    let g = &bake.grid;
    let (lo, hi) = scene.bounds();
    BakeManifest {
        format: BAKE_FORMAT.into(),
        version: BAKE_VERSION,
        generator: format!("warpfit {}", env!("CARGO_PKG_VERSION")),
        conventions: Conventions {
            octahedral: CONVENTION.into(),
            up_axis: "+Y".into(),
            handedness: "right".into(),
            units: "scene units (metres in the built-in scenes)".into(),
            distance: "Euclidean distance from the probe/cell centre along the texel direction; \
                       +inf in EXR depth layers where the ray missed; the grid's moments count a \
                       miss as far_distance"
                .into(),
            radiance: "linear RGB, view-independent (Lambertian) outgoing radiance".into(),
        },
        scene: SceneSummary {
            name: scene.name.clone(),
            file: scene.source.display().to_string(),
            triangles: scene.triangles.len(),
            spheres: scene.spheres.len(),
            degenerate_triangles_skipped: scene.degenerate_skipped,
            bounds_min: lo.to_array(),
            bounds_max: hi.to_array(),
        },
        probe: ProbeManifest {
            file: PROBE_FILE.into(),
            position: p.position.to_array(),
            resolution: p.resolution(),
            samples_per_texel: scene.config.probe.samples_per_texel,
            ggx_samples: scene.config.probe.ggx_samples,
            radiance_mips: p
                .radiance
                .levels
                .iter()
                .enumerate()
                .map(|(m, l)| MipInfo {
                    level: m as u32,
                    layer: radiance_layer(m),
                    resolution: l.res,
                    perceptual_roughness: p.roughness[m],
                    alpha: p.roughness[m] * p.roughness[m],
                })
                .collect(),
            distance_mips: (0..p.depth.levels.len()).map(distance_layer).collect(),
            depth_mip_filter: "solid-angle-weighted 2x2 mean of inverse distance (1/inf = 0)".into(),
        },
        grid: GridManifest {
            file: GRID_FILE.into(),
            min: g.geometry.min.to_array(),
            max: g.geometry.max.to_array(),
            counts: g.geometry.counts.to_array(),
            cell_size: g.geometry.cell_size().to_array(),
            cell_index: "x + nx*(y + ny*z); probe at the cell centre plus its relocation offset".into(),
            irradiance_resolution: g.irradiance_resolution,
            depth_resolution: g.depth_resolution,
            depth_samples: g.depth_samples,
            atlas_layout: "cell (x,y,z) at tile column x, tile row y + ny*z; tile = one octahedral map".into(),
            far_distance: g.far_distance,
            active_cells: g.active_cells(),
            inside_cells: g.inside.iter().enumerate().filter(|(_, x)| **x).map(|(k, _)| k as u32).collect(),
            relocated: crate::grid::relocated_cells(&g.probe_offset),
        },
        stats: bake.stats.clone(),
        settings: scene.config.clone(),
        key: scene.content_key(),
        inputs: scene.inputs.iter().map(|(p, c)| (p.display().to_string(), c.clone())).collect(),
        files: Vec::new(),
    }
}

/// Writes the bake folder (each file atomically; the manifest last, with the payloads'
/// sizes and checksums). Callers write it inside a staged run folder, so a bake is swapped in
/// whole or not at all.
pub fn write_bake(dir: &Path, scene: &Scene, bake: &Bake) -> Result<(), FileError> {
    std::fs::create_dir_all(dir).map_err(FileError::io(dir))?;
    let mut files = Vec::new();
    for file in [PROBE_FILE, GRID_FILE] {
        // one payload's layers at a time
        let layers = if file == PROBE_FILE {
            probe_layers(&bake.probe.radiance, &bake.probe.depth)
        } else {
            grid_layers(&bake.grid)
        };
        let path = dir.join(file);
        let (bytes, checksum) = exr::write_payload(&path, layers, |_| false)?;
        files.push(FileEntry { file: file.into(), bytes, checksum });
    }
    write_json(&dir.join(MANIFEST_FILE), &BakeManifest { files, ..build_manifest(scene, bake) })
}

/// A payload of the bake, checked against the manifest's size and checksum, decoded.
fn read_payload(dir: &Path, m: &BakeManifest, file: &str) -> Result<Vec<ExrLayer>, FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let entry = m
        .files
        .iter()
        .find(|f| f.file == file)
        .ok_or_else(|| FileError::invalid(&mpath, "files", format!("no entry for {file}")))?;
    let path = dir.join(file);
    let bytes = crate::files::read_regular(&path, entry.bytes)?;
    if bytes.len() as u64 != entry.bytes {
        return Err(FileError::invalid(
            &path,
            "size",
            format!("{} bytes, the manifest says {}", bytes.len(), entry.bytes),
        ));
    }
    let found = crate::files::checksum(&bytes);
    if found != entry.checksum {
        return Err(FileError::Checksum { path, expected: entry.checksum.clone(), found });
    }
    exr::decode(&path, &bytes)
}

fn find<'a>(layers: &'a [ExrLayer], path: &Path, name: &str, res: (usize, usize)) -> Result<&'a ExrLayer, FileError> {
    let l = layers.iter().find(|l| l.name == name).ok_or_else(|| FileError::invalid(path, name, "layer missing"))?;
    if (l.width, l.height) != res {
        return Err(FileError::Invalid {
            path: path.to_path_buf(),
            field: name.into(),
            message: format!("size {}x{}, expected {}x{}", l.width, l.height, res.0, res.1),
        });
    }
    Ok(l)
}

fn channel<'a>(l: &'a ExrLayer, path: &Path, name: &str) -> Result<&'a [f32], FileError> {
    l.channel(name).ok_or_else(|| FileError::Invalid {
        path: path.to_path_buf(),
        field: format!("{}.{name}", l.name),
        message: "channel missing".into(),
    })
}

fn finite_rgb(l: &ExrLayer, path: &Path) -> Result<Vec<Vec3>, FileError> {
    let (r, g, b) = (channel(l, path, "R")?, channel(l, path, "G")?, channel(l, path, "B")?);
    let v: Vec<Vec3> = (0..r.len()).map(|k| Vec3::new(r[k], g[k], b[k])).collect();
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(FileError::Invalid {
            path: path.to_path_buf(),
            field: l.name.clone(),
            message: format!("texel {k} is not finite"),
        });
    }
    Ok(v)
}

/// The content key a bake folder's manifest records, if it has a readable one.
#[must_use]
pub fn manifest_key(dir: &Path) -> Option<String> {
    let bytes = crate::files::read_regular(&dir.join(MANIFEST_FILE), crate::files::MAX_JSON_BYTES).ok()?;
    let v: serde_json::Value = serde_json::from_slice(&bytes).ok()?;
    v.get("key").and_then(|k| k.as_str()).map(str::to_string)
}

/// Reads a bake folder back, validating versions, sizes and values.
pub fn read_bake(dir: &Path) -> Result<(BakeManifest, SpecularProbe, ProbeGrid), FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let bytes = crate::files::read_regular(&mpath, crate::files::MAX_JSON_BYTES)?;
    let probe_format: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| FileError::Json { path: mpath.clone(), message: e.to_string() })?;
    let found = probe_format.get("format").and_then(|v| v.as_str()).unwrap_or("").to_string();
    let version = probe_format.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
    if found != BAKE_FORMAT || version != BAKE_VERSION as u64 {
        return Err(FileError::Version { path: mpath, found, version, expected: BAKE_FORMAT, supported: BAKE_VERSION });
    }
    let m: BakeManifest = serde_json::from_value(probe_format)
        .map_err(|e| FileError::Json { path: mpath.clone(), message: e.to_string() })?;

    if m.probe.file != PROBE_FILE || m.grid.file != GRID_FILE {
        return Err(FileError::invalid(&mpath, "probe.file/grid.file", "not this format's file names"));
    }
    let ppath = dir.join(PROBE_FILE);
    let layers = read_payload(dir, &m, PROBE_FILE)?;
    let mut radiance = Vec::new();
    for mip in &m.probe.radiance_mips {
        let n = mip.resolution as usize;
        let l = find(&layers, &ppath, &mip.layer, (n, n))?;
        radiance.push(OctMap::new(mip.resolution, finite_rgb(l, &ppath)?));
    }
    let mut depth = Vec::new();
    for (k, name) in m.probe.distance_mips.iter().enumerate() {
        let n = (m.probe.resolution >> k) as usize;
        let l = find(&layers, &ppath, name, (n, n))?;
        let z = channel(l, &ppath, "Z")?;
        if let Some(t) = z.iter().position(|d| d.is_nan() || *d < 0.0) {
            return Err(FileError::Invalid {
                path: ppath.clone(),
                field: name.clone(),
                message: format!("texel {t} is NaN or negative"),
            });
        }
        depth.push(OctMap::new(n as u32, z.to_vec()));
    }
    if radiance.is_empty() || depth.is_empty() {
        return Err(FileError::Invalid { path: mpath, field: "probe".into(), message: "no mips listed".into() });
    }
    let probe = SpecularProbe {
        position: Vec3::from_array(m.probe.position),
        roughness: m.probe.radiance_mips.iter().map(|x| x.perceptual_roughness).collect(),
        radiance: OctMips { levels: radiance },
        depth: OctMips { levels: depth },
    };

    drop(layers);
    let gpath = dir.join(GRID_FILE);
    let mut layers = read_payload(dir, &m, GRID_FILE)?;
    let geometry = GridGeometry {
        min: Vec3::from_array(m.grid.min),
        max: Vec3::from_array(m.grid.max),
        counts: UVec3::from_array(m.grid.counts),
    };
    let (ir, dr) = (m.grid.irradiance_resolution, m.grid.depth_resolution);
    let c = geometry.counts;
    let irr_size = ((c.x * ir) as usize, (c.y * c.z * ir) as usize);
    let dep_size = ((c.x * dr) as usize, (c.y * c.z * dr) as usize);
    find(&layers, &gpath, "depth_moments", dep_size)?;
    let irr = finite_rgb(find(&layers, &gpath, "irradiance", irr_size)?, &gpath)?;
    // each layer and channel is dropped once converted: a big grid's bake is read with
    // about one copy of it in memory, not three
    layers.retain(|l| l.name != "irradiance");
    let irradiance = from_atlas(&geometry, ir, &irr);
    drop(irr);
    let mut moment = |name: &str| -> Result<Vec<f32>, FileError> {
        let l = layers.iter_mut().find(|l| l.name == "depth_moments");
        let c = l.and_then(|l| l.channels.iter_mut().find(|(n, _)| n == name)).ok_or_else(|| FileError::Invalid {
            path: gpath.clone(),
            field: format!("depth_moments.{name}"),
            message: "channel missing".into(),
        })?;
        let atlas = std::mem::take(&mut c.1);
        Ok(from_atlas(&geometry, dr, &atlas))
    };
    let depth_mean = moment("mean")?;
    let depth_mean_sq = moment("mean_sq")?;
    let hit_fraction = moment("hit")?;
    let mut inside = vec![false; geometry.cell_count()];
    for &k in &m.grid.inside_cells {
        *inside.get_mut(k as usize).ok_or_else(|| FileError::Invalid {
            path: mpath.clone(),
            field: "grid.inside_cells".into(),
            message: format!("cell {k} out of range"),
        })? = true;
    }
    let mut probe_offset = vec![Vec3::ZERO; geometry.cell_count()];
    let half = geometry.cell_size() * 0.5;
    for &(k, o) in &m.grid.relocated {
        let o = Vec3::from_array(o);
        let bad = |message: String| FileError::Invalid { path: mpath.clone(), field: "grid.relocated".into(), message };
        if !(o.is_finite() && o.abs().cmple(half).all()) {
            return Err(bad(format!("cell {k}: offset {o} is not finite or leaves its cell")));
        }
        *probe_offset.get_mut(k as usize).ok_or_else(|| bad(format!("cell {k} out of range")))? = o;
    }
    let grid = ProbeGrid {
        geometry,
        irradiance_resolution: ir,
        depth_resolution: dr,
        depth_samples: m.grid.depth_samples,
        irradiance,
        depth_mean,
        depth_mean_sq,
        hit_fraction,
        inside,
        probe_offset,
        far_distance: m.grid.far_distance,
    };
    Ok((m, probe, grid))
}
