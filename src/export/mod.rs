//! `warpfit export`: a fitted grid in the layout engines load. KTX2 textures (`ktx2`) and
//! a JSON sidecar (`export.json`):
//!
//! - `probe_radiance.ktx2` (RGBA16F, every GGX mip; alpha 1) and `probe_inv_distance.ktx2`
//!   (R32F, every mip; 1/distance, 0 = sky: what the warps read), a grid's probes side by
//!   side (probe k's mip m from column k · its width at m; one probe: the plain square);
//! - `correctives.ktx2` (R32F: the shift maps, then the rough maps, then the probe maps), `irradiance.ktx2` (RGBA16F), `moments.ktx2` (RG32F: mean
//!   and mean square of the hit distance) and `irradiance_scale.ktx2` (R32F): atlases of
//!   per-cell octahedral tiles, each with a one-texel gutter filled by the octahedral seam
//!   rule (`octa::wrap_texel`, as DDGI fills its borders: an edge texel's neighbour across
//!   the edge is the mirrored texel of the same edge, a corner's the opposite corner). Plain
//!   hardware bilinear inside a tile's gutter box then blends exactly the 2×2 texels and
//!   weights the CPU's seam-aware bilinear blends (`tests/export.rs` checks it).
//!
//! `roughness_lookup.ktx2` (R32F) is the roughness correction's table exactly as the
//! runtime interpolates it, its coordinates in the sidecar, with the nodes of the rough
//! lookups' irradiance blend (`irradiance_blend`).
//!
//! The sidecar holds what a shader needs besides the textures: the grid, the sparse
//! cell → tile tables, the atlas layout and the uv formula, and the grid's own manifest
//! (fallback method, proxies, roughness correction, conventions).
//!
//! The reference shader (`shaders/warpfit.wgsl`, with naga's HLSL and GLSL translations) is
//! written beside them, with its two buffers (`shader`): `warpfit_params.bin` and
//! `warpfit_cells.bin`. Radiance beyond half-float range (65504) is exported as RGBA32F
//! instead of RGBA16F, so a bright emitter is never turned into infinity.

pub mod ktx2;
pub mod shader;

use crate::files::{FileError, write_atomic, write_json};
use crate::octa::wrap_texel;
use crate::runtime::FittedGrid;
use crate::warp::corrective::NO_MAP;
use glam::Vec3;
use ktx2::{Format, Level};
use serde::Serialize;
use std::path::Path;

/// Where one kind of tile lives in its atlas.
#[derive(Clone, Debug, Serialize)]
pub struct AtlasLayout {
    pub file: String,
    pub format: String,
    /// N of each N×N tile (without the gutter).
    pub tile_resolution: u32,
    /// Texels of gutter on each side of a tile.
    pub gutter: u32,
    /// Tiles per atlas row; tile `s` sits in column `s % columns`, row `s / columns`.
    pub columns: u32,
    pub width: u32,
    pub height: u32,
    /// Per grid cell (`x + nx·(y + ny·z)`): its tile, or −1 (none).
    pub cell_tile: Vec<i64>,
    /// The corrective atlas with rough maps: a cell's rough map is tile `cell_tile` + this
    /// (see the grid manifest's `correctives.rough_maps` for how a lookup blends the two).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rough_tile_offset: Option<u32>,
    /// The corrective atlas of a grid of several probes: a cell's probe map (probe indices
    /// as floats) is tile `cell_tile` + this (the grid manifest's `correctives.probe_maps`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probe_tile_offset: Option<u32>,
}

/// `export.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Sidecar {
    pub format: &'static str,
    pub version: u32,
    /// How to sample a tile with hardware bilinear (clamp-free addressing).
    pub uv_rule: &'static str,
    pub probe_radiance: String,
    pub probe_inv_distance: String,
    pub probe_mips: u32,
    /// Every specular probe's position, probe A first: the probe textures hold them side by
    /// side, probe k's mip m from column k · (the probe's width at m), each probe's
    /// octahedral seam wrap inside its own square.
    pub probe_positions: Vec<[f32; 3]>,
    pub correctives: Option<AtlasLayout>,
    pub irradiance: AtlasLayout,
    pub moments: AtlasLayout,
    pub irradiance_scale: Option<AtlasLayout>,
    /// The roughness correction as the runtime interpolates it (`roughness_lookup.ktx2`:
    /// R32F, `nodes × nodes`, row = roughness node): absent when the grid stores none.
    pub roughness_lookup: Option<crate::roughness::LookupTable>,
    /// Rough lookups' irradiance blend as the runtime applies it: (perceptual roughness,
    /// weight) nodes by increasing roughness, the weight linear in r between them (the
    /// first node's below, the last one's beyond; 0 at r = 0); a lookup is
    /// `probe·(1 − w) + E(dir)/π·w` with E the `irradiance` tile of the cell containing the
    /// point, where that cell has one. Empty: probe A alone (a grid fitted without the
    /// blend, or exported to read probe A alone: `SpecularRead::ProbeOnly`).
    pub irradiance_blend: Vec<[f32; 2]>,
    /// The reference shader and its buffers.
    pub shader: ShaderSection,
    /// The fitted grid's manifest: grid, conventions, fallback, proxies, roughness table.
    pub grid_manifest: crate::gridfile::GridManifest,
    /// Surface-probe atlases (seed 003) exported beside the grid.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub surfaces: Vec<SurfaceSection>,
}

/// A surface-probe atlas in engine layout: `radiance` a 2-D array texture (layer m = mip m
/// of every tile, prefiltered for `surface.roughness[m]`), `inv_distance` a 2-D texture,
/// both `counts[0]·N × counts[1]·N` with probe (i, j)'s tile at column i, row j, no gutter.
#[derive(Clone, Debug, Serialize)]
pub struct SurfaceSection {
    pub radiance: String,
    pub radiance_format: String,
    pub inv_distance: String,
    /// The atlas's `SurfaceParams` for the reference shader's `surface_specular` (group 2
    /// of `warpfit.wgsl`), little-endian bytes uploaded as a uniform buffer.
    pub params: String,
    pub width: u32,
    pub height: u32,
    pub uv_rule: &'static str,
    /// The patch, the tiles' convention and each layer's roughness (as in the atlas's
    /// `manifest.json`).
    pub surface: crate::gridfile::surface::SurfaceDescription,
}

/// Writes surface atlas `k` into `dir` and returns its section.
fn export_surface(
    dir: &Path,
    k: usize,
    atlas: &crate::warp::surface::SurfaceAtlas,
) -> Result<SurfaceSection, FileError> {
    let p = &atlas.patch;
    let (width, height) = (p.counts[0] * p.resolution, p.counts[1] * p.resolution);
    let format = colour_format(atlas.radiance.iter().flatten().copied());
    let mut values = Vec::new();
    for level in &atlas.radiance {
        let image = atlas.packed(level);
        values.extend(image.iter().flat_map(|v| [v.x, v.y, v.z, 1.0]));
    }
    let radiance = format!("surface{k}_radiance.ktx2");
    let layers = atlas.radiance.len() as u32;
    write_atomic(&dir.join(&radiance), &ktx2::encode_array(format, layers, &[Level { width, height, values }]))?;
    let inv_distance = format!("surface{k}_inv_distance.ktx2");
    let inv = Level { width, height, values: atlas.packed(&atlas.inv_distance) };
    write_atomic(&dir.join(&inv_distance), &ktx2::encode(Format::R32F, &[inv]))?;
    let params = format!("surface{k}_params.bin");
    write_atomic(&dir.join(&params), &shader::surface_params(atlas))?;
    Ok(SurfaceSection {
        radiance,
        radiance_format: format.name().into(),
        inv_distance,
        params,
        width,
        height,
        surface: crate::gridfile::surface::SurfaceDescription::of(atlas),
        uv_rule: "for hemi-octahedral uv in [0,1]² of probe (i, j): texel coordinate x = i·N + clamp(u·N, 0.5, N − 0.5) (y likewise with j), bilinear at (x, y) / (width, height): the clamp keeps the lookup inside its tile, as the CPU's edge clamp does; the four nearest probes blend bilinearly by the point's (s, t) on the patch",
    })
}

/// [`export`] with surface-probe atlases (`runtime::load_surface_atlases`) beside the grid.
pub fn export_with_surfaces(
    grid: &FittedGrid,
    surfaces: &[crate::warp::surface::SurfaceAtlas],
    dir: &Path,
) -> Result<Sidecar, FileError> {
    let mut sidecar = export(grid, dir)?;
    sidecar.surfaces = surfaces.iter().enumerate().map(|(k, a)| export_surface(dir, k, a)).collect::<Result<_, _>>()?;
    write_json(&dir.join(SIDECAR), &sidecar)?;
    Ok(sidecar)
}

/// The reference shader's files in the export folder.
#[derive(Clone, Debug, Serialize)]
pub struct ShaderSection {
    /// The WGSL source and its translations.
    pub sources: Vec<String>,
    /// The uniform buffer `Params` (binding 7), little-endian, `shader::PARAMS_BYTES` long.
    pub params: String,
    /// The storage buffer `array<Cell>` (binding 8), one `shader::CELL_BYTES` entry per cell.
    pub cells: String,
    pub bindings: &'static str,
    /// The grid's values of the shader's specialisation constants (WGSL `override`s):
    /// set them when building a pipeline for this grid alone; leave them unset (255) for a
    /// pipeline that reads every setting from `params`.
    pub constants: std::collections::BTreeMap<&'static str, u32>,
}

pub const SIDECAR: &str = "export.json";

/// Largest finite half float.
const F16_MAX: f32 = 65504.0;

/// RGBA16F when every value fits a half float, else RGBA32F.
fn colour_format(values: impl IntoIterator<Item = Vec3>) -> Format {
    if values.into_iter().all(|v| v.max_element() <= F16_MAX) { Format::Rgba16F } else { Format::Rgba32F }
}

/// An atlas of guttered tiles: tile `s` holds `tile(s)` (N² texels of `C` channels each,
/// row-major), its border filled by the seam rule.
pub fn guttered_atlas<const C: usize>(
    n: u32,
    tiles: usize,
    tile: impl Fn(usize) -> Vec<[f32; C]>,
) -> (u32, u32, u32, Vec<f32>) {
    let columns = (tiles as f64).sqrt().ceil().max(1.0) as u32;
    let rows = (tiles as u32).div_ceil(columns).max(1);
    let t = n + 2;
    let (w, h) = (columns * t, rows * t);
    let mut out = vec![0.0f32; (w * h) as usize * C];
    for s in 0..tiles {
        let texels = tile(s);
        let (x0, y0) = ((s as u32 % columns) * t, (s as u32 / columns) * t);
        for bj in -1..=n as i64 {
            for bi in -1..=n as i64 {
                let (i, j) = wrap_texel(n, bi, bj);
                let v = texels[(j * n + i) as usize];
                let at = ((y0 as i64 + bj + 1) * w as i64 + x0 as i64 + bi + 1) as usize * C;
                out[at..at + C].copy_from_slice(&v);
            }
        }
    }
    (columns, w, h, out)
}

fn cell_tiles(slot: &[u32]) -> Vec<i64> {
    slot.iter().map(|&s| if s == NO_MAP { -1 } else { s as i64 }).collect()
}

/// Writes one atlas and returns its layout.
fn write_atlas<const C: usize>(
    dir: &Path,
    file: &str,
    format: Format,
    n: u32,
    slot: &[u32],
    tiles: usize,
    tile: impl Fn(usize) -> Vec<[f32; C]>,
) -> Result<AtlasLayout, FileError> {
    let (columns, width, height, values) = guttered_atlas::<C>(n, tiles, tile);
    write_atomic(&dir.join(file), &ktx2::encode(format, &[Level { width, height, values }]))?;
    Ok(AtlasLayout {
        file: file.into(),
        format: format.name().into(),
        tile_resolution: n,
        gutter: 1,
        columns,
        width,
        height,
        cell_tile: cell_tiles(slot),
        rough_tile_offset: None,
        probe_tile_offset: None,
    })
}

/// The mip levels of every probe's chain `chain` side by side (probe k's texels of mip m
/// from column k · its width at m), each texel's channels from `texel`.
fn side_by_side<T, const C: usize>(
    probes: &[&crate::warp::WarpProbe],
    chain: impl Fn(&crate::warp::WarpProbe) -> &crate::octa::OctMips<T>,
    texel: impl Fn(&T) -> [f32; C],
) -> Vec<Level> {
    let levels = probes.first().map_or(0, |q| chain(q).levels.len());
    (0..levels)
        .map(|m| {
            let n = chain(probes[0]).levels[m].res;
            let mut values = Vec::with_capacity(probes.len() * (n * n) as usize * C);
            for j in 0..n as usize {
                for q in probes {
                    let row = &chain(q).levels[m].texels[j * n as usize..(j + 1) * n as usize];
                    values.extend(row.iter().flat_map(&texel));
                }
            }
            Level { width: n * probes.len() as u32, height: n, values }
        })
        .collect()
}

/// Exports the fitted grid `grid` into `dir` (created; files written atomically).
pub fn export(grid: &FittedGrid, dir: &Path) -> Result<Sidecar, FileError> {
    std::fs::create_dir_all(dir).map_err(FileError::io(dir))?;
    let w = grid.warp();
    let p = &w.probe;
    let probes: Vec<&crate::warp::WarpProbe> = (0..w.probe_count()).map(|k| w.probe_at(k)).collect();
    let rgba = |v: Vec3| [v.x, v.y, v.z, 1.0];
    // the probes side by side: probe k's mip m from column k · (its width at m)
    let radiance: Vec<Level> = side_by_side(&probes, |q| &q.radiance, |v: &Vec3| rgba(*v));
    let radiance_format =
        colour_format(probes.iter().flat_map(|q| q.radiance.levels.iter().flat_map(|l| l.texels.iter().copied())));
    write_atomic(&dir.join("probe_radiance.ktx2"), &ktx2::encode(radiance_format, &radiance))?;
    let inv: Vec<Level> = side_by_side(&probes, |q| &q.inv_depth, |w: &f32| [*w]);
    write_atomic(&dir.join("probe_inv_distance.ktx2"), &ktx2::encode(Format::R32F, &inv))?;

    let c = &grid.correctives();
    let (n, n2) = (c.map_res, (c.map_res * c.map_res) as usize);
    let stored = c.maps.len() / n2.max(1);
    // rough maps, if any, follow the maps in the same atlas (a cell's rough tile is its
    // tile + `rough_tile_offset`), then the probe maps (+ `probe_tile_offset`)
    let rough_tiles = if c.has_rough_maps() { stored } else { 0 };
    let probe_tiles = if c.probe_maps.is_empty() { 0 } else { stored };
    let correctives = (stored > 0)
        .then(|| {
            write_atlas::<1>(
                dir,
                "correctives.ktx2",
                Format::R32F,
                n,
                &c.slot,
                stored + rough_tiles + probe_tiles,
                |s| {
                    if s >= stored + rough_tiles {
                        let s = s - stored - rough_tiles;
                        return c.probe_maps[s * n2..(s + 1) * n2].iter().map(|&x| [f32::from(x)]).collect();
                    }
                    let (maps, s) = if s < stored { (&c.maps, s) } else { (&c.rough_maps, s - stored) };
                    maps[s * n2..(s + 1) * n2].iter().map(|&x| [x]).collect()
                },
            )
            .map(|l| AtlasLayout {
                rough_tile_offset: c.has_rough_maps().then_some(stored as u32),
                probe_tile_offset: (probe_tiles > 0).then_some((stored + rough_tiles) as u32),
                ..l
            })
        })
        .transpose()?;

    let ir = &grid.irradiance_grid();
    let (ires, i2) = (ir.resolution, (ir.resolution * ir.resolution) as usize);
    let (dres, d2) = (ir.depth_resolution, (ir.depth_resolution * ir.depth_resolution) as usize);
    let cells = ir.irradiance.len() / i2.max(1);
    let irradiance_format = colour_format(ir.irradiance.iter().copied());
    let irradiance = write_atlas::<4>(dir, "irradiance.ktx2", irradiance_format, ires, &ir.slot, cells, |s| {
        ir.irradiance[s * i2..(s + 1) * i2].iter().map(|&v| rgba(v)).collect()
    })?;
    let moments = write_atlas::<2>(dir, "moments.ktx2", Format::Rg32F, dres, &ir.slot, cells, |s| {
        (s * d2..(s + 1) * d2).map(|k| [ir.depth_mean[k], ir.depth_mean_sq[k]]).collect()
    })?;
    let cr = &ir.correction;
    let c2 = (cr.resolution * cr.resolution) as usize;
    let corrected = cr.scale.len() / c2.max(1);
    let irradiance_scale = (corrected > 0)
        .then(|| {
            write_atlas::<1>(dir, "irradiance_scale.ktx2", Format::R32F, cr.resolution, &cr.slot, corrected, |s| {
                cr.scale[s * c2..(s + 1) * c2].iter().map(|&x| [x]).collect()
            })
        })
        .transpose()?;
    let roughness_lookup = grid.roughness().map(|r| r.lookup_table());
    if let Some(t) = &roughness_lookup {
        let level = Level { width: t.nodes, height: t.nodes, values: t.values.clone() };
        write_atomic(&dir.join("roughness_lookup.ktx2"), &ktx2::encode(Format::R32F, &[level]))?;
    }
    let shape = |l: Option<&AtlasLayout>| {
        l.map_or(Default::default(), |l| shader::AtlasShape { tile_resolution: l.tile_resolution, columns: l.columns })
    };
    let atlases = shader::Atlases {
        corrective: shape(correctives.as_ref()),
        irradiance: shape(Some(&irradiance)),
        moments: shape(Some(&moments)),
        scale: shape(irradiance_scale.as_ref()),
    };
    let unsupported = |e: shader::Unsupported| {
        FileError::invalid(dir, "shader", format!("the grid cannot be exported for the shader: {}", e.0))
    };
    let probe_tile_offset = correctives.as_ref().and_then(|l| l.probe_tile_offset).unwrap_or(0);
    let params = shader::params(grid, &atlases, probe_tile_offset).map_err(unsupported)?;
    let constants = shader::constants(grid).map_err(unsupported)?;
    write_atomic(&dir.join("warpfit_params.bin"), &params)?;
    write_atomic(&dir.join("warpfit_cells.bin"), &shader::cells(grid))?;
    for (name, text) in shader::SHADER_FILES {
        write_atomic(&dir.join(name), text.as_bytes())?;
    }
    let shader = ShaderSection {
        sources: shader::SHADER_FILES.iter().map(|(name, _)| name.to_string()).collect(),
        params: "warpfit_params.bin".into(),
        cells: "warpfit_cells.bin".into(),
        constants: constants.into_iter().collect(),
        bindings: "group 0: 0 probe_radiance, 1 probe_inv_distance, 2 correctives, 3 irradiance, 4 moments, 5 irradiance_scale, 6 roughness_lookup (absent files: bind a 1×1 texture), 7 params (uniform), 8 cells (storage); group 1: the query kernels' queries and results",
    };
    let sidecar = Sidecar {
        format: "warpfit-export",
        version: 1,
        uv_rule: "for octahedral uv in [0,1]² of tile s: texel coordinate x = (s % columns)·(N+2) + 1 + clamp(u,0,1)·N (same for y with s / columns), sampled with plain bilinear at (x, y) / (width, height); the gutter makes it equal to the seam-aware bilinear",
        probe_radiance: "probe_radiance.ktx2".into(),
        probe_inv_distance: "probe_inv_distance.ktx2".into(),
        probe_mips: p.radiance.levels.len() as u32,
        probe_positions: probes.iter().map(|q| q.position.to_array()).collect(),
        correctives,
        irradiance,
        moments,
        irradiance_scale,
        roughness_lookup,
        irradiance_blend: grid.irradiance_blend_nodes().iter().map(|&(r, w)| [r, w]).collect(),
        shader,
        grid_manifest: grid.manifest().clone(),
        surfaces: Vec::new(),
    };
    write_json(&dir.join(SIDECAR), &sidecar)?;
    Ok(sidecar)
}
