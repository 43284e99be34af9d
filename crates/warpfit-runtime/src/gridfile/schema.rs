//! `manifest.json` of a fitted grid: what the folder holds, how to read it, and what the fit
//! measured. Plain serde types the writer and the reader share, the layout of the atlases,
//! and the names of the probe's layers.

use super::exr::ExrLayer;
use crate::octa::OctMips;
use crate::roughness::RoughnessCorrection;
use crate::warp::WarpOptions;
use crate::warp::corrective::Blend;
use serde::{Deserialize, Serialize};

pub const GRID_FORMAT: &str = "warpfit-grid";
/// Bumped on any change an older reader cannot read correctly.
/// 2: a rough lookup in a cell with a map takes its distance ratio from the map's hit
/// estimate (no depth fetch), and the stored roughness correction is fitted for that.
/// 3: the manifest's own checksum, structural limits, and the fitted irradiance corrections.
/// 4: the maps shift the proxy's surface (`shift_maps`, scene units) instead of holding
/// inverse distances from the cell's origin; the fallback is the proxy (box, kdop, warp1).
/// 5: a stored cell may keep a second map for rough lookups (`rough_shift_maps`); a version-4
/// grid is read as one with none.
/// 6: several specular probes (`other_probes`, files [`PROBE_FILES`]) and, per stored
/// texel, the probe a lookup reads (`correctives.exr` layer `probe_maps`); a version-5 grid
/// is read as one with probe A alone.
/// 7: the faces blend (`warp.blend` = `Faces`: near a cell face the near cells' lookups
/// blend). A grid is written at the oldest version that reads it, and at least 6: version 7
/// only with the faces blend, so a reader of version 6 keeps reading every other grid.
/// 8: a cell without a map may read a probe other than probe A (`cell_probes`); written
/// only when some cell does.
pub const GRID_VERSION: u32 = 8;
/// The version every grid is written at unless it needs a newer one ([`GRID_VERSION`]).
pub const GRID_VERSION_WRITTEN: u32 = 6;
/// The oldest version this build reads.
pub const GRID_VERSION_OLDEST: u32 = 4;
pub const MANIFEST_FILE: &str = "manifest.json";
pub const PROBE_FILE: &str = "probe.exr";
/// The most specular probes a grid holds (a probe index fits 4 bits).
pub const MAX_PROBES: usize = 16;
/// The file of each probe: probe A's [`PROBE_FILE`], then `probe_1.exr`, ….
pub const PROBE_FILES: [&str; MAX_PROBES] = [
    PROBE_FILE,
    "probe_1.exr",
    "probe_2.exr",
    "probe_3.exr",
    "probe_4.exr",
    "probe_5.exr",
    "probe_6.exr",
    "probe_7.exr",
    "probe_8.exr",
    "probe_9.exr",
    "probe_10.exr",
    "probe_11.exr",
    "probe_12.exr",
    "probe_13.exr",
    "probe_14.exr",
    "probe_15.exr",
];
pub const CORRECTIVES_FILE: &str = "correctives.exr";
pub const IRRADIANCE_FILE: &str = "irradiance.exr";

/// Storage precision of a radiance layer. Distances and shift maps are always f32: f16's
/// range (6.5e4) and precision cannot hold the distances of a level scaled by 1e4.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    F32,
    F16,
}

impl Precision {
    #[must_use]
    pub fn bytes(self) -> u64 {
        match self {
            Precision::F32 => 4,
            Precision::F16 => 2,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridManifest {
    pub format: String,
    pub version: u32,
    /// The octahedral mapping every map in the folder uses (`octa::CONVENTION`).
    pub octahedral_convention: String,
    pub units: String,
    pub up_axis: String,
    pub scene: String,
    pub grid: GridSection,
    pub probe: ProbeSection,
    /// The other specular probes, after probe A (probe k in `PROBE_FILES[k]`, with probe
    /// A's layout, resolution and mip chain); absent: probe A alone.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub other_probes: Vec<ProbeSection>,
    /// The cells without a shift map that read a probe other than probe A through the proxy
    /// (version 8): (cell index, probe index ≥ 1), cells increasing; every other cell
    /// without a map reads probe A.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cell_probes: Vec<(u32, u8)>,
    pub warp: WarpSection,
    /// Absent when no cell stores a shift map.
    pub correctives: Option<CorrectiveSection>,
    pub irradiance: IrradianceSection,
    /// GGX distance-ratio roughness correction; absent when the probe has no rough mips or
    /// the fit was asked for none.
    pub roughness: Option<RoughnessCorrection>,
    pub payloads: Vec<Payload>,
    /// What the fit did not store, why, and the bytes that saved.
    pub left_out: Vec<LeftOut>,
    /// The fit settings and the per-level residual summary, as the fitter wrote them.
    pub fit_settings: serde_json::Value,
    pub residuals: serde_json::Value,
    /// `fnv1a64:` checksum of this manifest's canonical form ([`GridManifest::canonical_checksum`]):
    /// an edited manifest is refused instead of serving other answers.
    pub manifest_checksum: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSection {
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub counts: [u32; 3],
    /// Cells whose probe is off its centre (relocated away from geometry), sorted, with the
    /// offset from the centre (within half a cell): the origin of the cell's irradiance and
    /// distance moments (and of the shift map the fit started from).
    pub relocated: Vec<(u32, [f32; 3])>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSection {
    pub position: [f32; 3],
    pub resolution: u32,
    /// `probe.exr` layers of the GGX chain (R, G, B), level 0 = mirror.
    pub radiance_mips: Vec<RadianceMip>,
    /// `probe.exr` layers of the distance chain (Z; +inf = sky), level 0 = texel centres.
    pub distance_mips: Vec<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadianceMip {
    pub layer: String,
    pub resolution: u32,
    pub perceptual_roughness: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarpSection {
    /// The proxy every lookup reads through and the maps shift (`box`, `kdop` or `warp1`:
    /// the probe's own depth as seed 000's warp reads it), as it is in cells without a map.
    pub fallback: String,
    pub options: WarpOptions,
    pub blend: Blend,
    pub box_proxy: BoxSection,
    /// 18-DOP planes `normal · x ≤ offset`; `null` offset = open side.
    pub kdop: Vec<KdopPlane>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSection {
    pub centre: [f32; 3],
    /// Local → world rotation quaternion (x, y, z, w).
    pub rotation: [f32; 4],
    pub half_extents: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KdopPlane {
    pub normal: [f32; 3],
    pub offset: Option<f32>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CorrectiveSection {
    /// N of each N×N shift map.
    pub map_res: u32,
    /// Grid cell index of each stored map, in atlas tile order.
    pub stored_cells: Vec<u32>,
    /// `correctives.exr` layer `shift_maps`, channel `D`: tiles in rows of `atlas_columns`.
    pub atlas_columns: u32,
    /// [`SHIFT_MAP_ENCODING`].
    pub encoding: String,
    /// Present when `correctives.exr` also holds layer `rough_shift_maps` (channel `D`, the
    /// same tiles): each stored cell's map for rough lookups, read as this says
    /// ([`rough_map_encoding`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rough_maps: Option<String>,
    /// Present when `correctives.exr` also holds layer `probe_maps` (channel `P`, the same
    /// tiles): which probe each stored texel's lookups read, as [`PROBE_MAP_ENCODING`] says.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe_maps: Option<String>,
}

/// What a probe map's texels mean (the manifest's `correctives.probe_maps`).
pub const PROBE_MAP_ENCODING: &str = "per stored cell, an N×N octahedral map of probe indices (0 = probe A, k = other_probes[k-1]), integers stored as floats: a lookup along dir reads the probe of the texel with the greatest bilinear weight (the first of equals, in the order texel (i0,j0), (i0+1,j0), (i0,j0+1), (i0+1,j0+1)) and fetches it towards the point the shift map aims at";

/// How a lookup reads the rough maps (the manifest's `correctives.rough_maps`).
/// Written from the runtime's own band (`warp::corrective::ROUGH_MAP_FROM`, `ROUGH_MAP_TO`),
/// so the words cannot drift from what `sample_maps` does.
#[must_use]
pub fn rough_map_encoding() -> String {
    use crate::warp::corrective::{ROUGH_MAP_FROM as FROM, ROUGH_MAP_TO as TO};
    format!(
        "with rough_maps, a lookup of perceptual roughness r shifts by the shift_maps value for r <= {FROM}, by the rough_shift_maps value for r >= {TO}, and by shift + (rough_shift - shift) * (r - {FROM}) / {} between (each map sampled bilinearly as shift_maps)",
        TO - FROM
    )
}

/// What a shift map's texels mean (the manifest's `correctives.encoding`).
pub const SHIFT_MAP_ENCODING: &str = "per stored cell, an N×N octahedral map of shifts (scene units) of the proxy's surface along the lookup direction: a lookup from B along dir aims at t_proxy(B, dir) + bilinear shift(dir), where t_proxy is the distance to the proxy (warp.fallback) from B; negative = nearer";

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IrradianceSection {
    pub resolution: u32,
    pub depth_resolution: u32,
    /// Grid cell index of each stored cell (cells inside geometry are left out).
    pub stored_cells: Vec<u32>,
    pub atlas_columns: u32,
    /// `irradiance.exr` layers `irradiance` (R, G, B) and `depth_moments` (mean, mean_sq).
    pub encoding: String,
    /// Cells that store a fitted correction of the blended irradiance (sorted), the N of
    /// its N×N map of scales, and the columns of the `irradiance_scale` atlas (channel S).
    pub corrected_cells: Vec<u32>,
    pub correction_resolution: u32,
    pub correction_columns: u32,
    /// The blend's surface bias, a fraction of the smallest cell extent
    /// (`runtime::IrradianceBlend::Biased`); absent = 0, as grids written before it.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub surface_bias: f32,
}

/// Whether `x` is 0 (serde's `skip_serializing_if` for fields added with a default of 0:
/// manifests written before them keep their canonical form and checksum).
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Payload {
    pub file: String,
    pub bytes: u64,
    /// `fnv1a64:` + 16 hex digits of the file's bytes.
    pub checksum: String,
    pub layers: Vec<LayerEntry>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerEntry {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub channels: Vec<String>,
    pub precision: Precision,
}

impl LayerEntry {
    /// The manifest's entry of `layer` stored at `precision`.
    #[must_use]
    pub fn of<S>(layer: &super::exr::ExrLayer<S>, precision: Precision) -> LayerEntry {
        LayerEntry {
            name: layer.name.clone(),
            width: layer.width as u32,
            height: layer.height as u32,
            channels: layer.channel_names().map(String::from).collect(),
            precision,
        }
    }

    /// Uncompressed bytes of the layer's samples.
    #[must_use]
    pub fn raw_bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * self.channels.len() as u64 * self.precision.bytes()
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeftOut {
    pub what: String,
    pub reason: String,
    pub bytes_saved: u64,
}

/// Layer name of radiance mip `m` (GGX chain), in the grid's and the bake's `probe.exr`.
#[must_use]
pub fn radiance_layer(m: usize) -> String {
    format!("radiance_mip{m}")
}

/// Whether layer `layer` may be stored as f16: radiance only (probe mips and the cells'
/// irradiance); distances, shifts, probe indices, moments and scales are always f32. The
/// writer stores f16 nowhere else and the reader refuses it anywhere else.
#[must_use]
pub fn may_be_half(layer: &str) -> bool {
    layer.starts_with("radiance_mip") || layer == "irradiance"
}

/// Layer name of distance mip `m`, in the grid's and the bake's `probe.exr`.
#[must_use]
pub fn distance_layer(m: usize) -> String {
    format!("distance_mip{m}")
}

/// The probe's layers: radiance mips (R, G, B) then distance mips (Z; +inf = sky). The one
/// layout of `probe.exr`, in the fitted grid and in the bake folder.
#[must_use]
pub fn probe_layers(radiance: &OctMips<glam::Vec3>, distance: &OctMips<f32>) -> Vec<ExrLayer> {
    let mut layers = Vec::new();
    for (m, level) in radiance.levels.iter().enumerate() {
        let n = level.res as usize;
        layers.push(ExrLayer { name: radiance_layer(m), width: n, height: n, channels: rgb_channels(&level.texels) });
    }
    for (m, level) in distance.levels.iter().enumerate() {
        let n = level.res as usize;
        let channels = vec![("Z".into(), level.texels.clone())];
        layers.push(ExrLayer { name: distance_layer(m), width: n, height: n, channels });
    }
    layers
}

/// R, G, B channels of `v`.
#[must_use]
pub fn rgb_channels(v: &[glam::Vec3]) -> Vec<(String, Vec<f32>)> {
    vec![
        ("R".into(), v.iter().map(|x| x.x).collect()),
        ("G".into(), v.iter().map(|x| x.y).collect()),
        ("B".into(), v.iter().map(|x| x.z).collect()),
    ]
}

/// Tiles of `res × res` in rows of `columns`: the atlas size for `count` tiles.
#[must_use]
pub fn atlas_size(count: usize, res: u32, columns: u32) -> (usize, usize) {
    let cols = columns.max(1) as usize;
    let rows = count.div_ceil(cols).max(1);
    (cols * res as usize, rows * res as usize)
}

/// Columns of a near-square atlas of `count` tiles.
#[must_use]
pub fn atlas_columns(count: usize) -> u32 {
    ((count as f64).sqrt().ceil() as u32).max(1)
}

/// Linear index in the atlas of texel `t` (row-major in its tile) of tile `k`.
#[inline]
#[must_use]
pub fn atlas_index(k: usize, t: usize, res: u32, columns: u32) -> usize {
    let (r, cols) = (res as usize, columns.max(1) as usize);
    let (tx, ty) = (k % cols, k / cols);
    let (i, j) = (t % r, t / r);
    (ty * r + j) * (cols * r) + tx * r + i
}

/// Tile and texel of the atlas's linear index `i`: the inverse of [`atlas_index`] (the
/// tile may lie past the last one where the atlas's last row is not full).
#[inline]
#[must_use]
pub fn atlas_texel(i: usize, res: u32, columns: u32) -> (usize, usize) {
    let (r, cols) = (res as usize, columns.max(1) as usize);
    let (x, y) = (i % (cols * r), i / (cols * r));
    ((y / r) * cols + x / r, (y % r) * r + x % r)
}

/// Where the atlas's linear index `i` lands with its tiles laid end to end (texel t of tile
/// k at `k·res² + t`, the padding tiles last): the order per-cell maps are held in.
#[inline]
#[must_use]
pub fn tile_major(i: usize, res: u32, columns: u32) -> usize {
    let (k, t) = atlas_texel(i, res, columns);
    k * (res * res) as usize + t
}

/// Bounds every stored value must keep (the writer clamps to them, the reader refuses
/// beyond them): a hit nearer the cell centre or probe than a millionth of the grid's
/// diagonal, a distance or moment beyond a million diagonals, and radiance above 1e12 are
/// damage, not data.
pub const DISTANCE_RANGE_DIAGONALS: f32 = 1e6;
pub const MAX_RADIANCE: f32 = 1e12;
/// Largest probe resolution (radiance mip 0 of 4096² RGB f32 decodes to 201 MB).
pub const MAX_PROBE_RESOLUTION: u32 = 4096;
/// Largest map, irradiance or moment tile side.
pub const MAX_TILE_RESOLUTION: u32 = 64;
/// Most grid cells.
pub const MAX_CELLS: u64 = 1 << 24;
/// Most bytes all payloads of a grid may decode to: a file that would need more is refused
/// before anything is decoded.
pub const MAX_DECODED_BYTES: u64 = 4 << 30;
/// A grid that would need more than this many bytes in memory (its payloads decoded, plus
/// [`PER_CELL_BYTES`] per cell) has every payload's values streamed through their rules
/// before anything is decoded into memory: a damaged grid is refused at a bounded cost.
pub const SCAN_ABOVE_BYTES: u64 = 32 << 20;
/// Bytes the reader holds per grid cell whatever the cell stores (slots and offsets).
pub const PER_CELL_BYTES: u64 = 24;
/// Largest manifest file.
pub const MAX_MANIFEST_BYTES: u64 = 256 << 20;

/// The value bounds of a grid whose diagonal is `diagonal` (see the constants above).
#[derive(Clone, Copy, Debug)]
pub struct ValueBounds {
    /// Largest finite distance or mean distance.
    pub max_distance: f32,
    /// Largest inverse distance.
    pub max_inverse_distance: f32,
}

impl ValueBounds {
    #[must_use]
    pub fn of_diagonal(diagonal: f32) -> ValueBounds {
        let d = if diagonal.is_finite() && diagonal > 0.0 { diagonal } else { 1.0 };
        ValueBounds {
            max_distance: (d * DISTANCE_RANGE_DIAGONALS).min(1e18),
            max_inverse_distance: (DISTANCE_RANGE_DIAGONALS / d).min(1e18),
        }
    }
}

impl GridManifest {
    /// Checksum of the manifest with an empty `manifest_checksum`, serialised compactly: the
    /// value the writer stores and the reader recomputes (independent of whitespace).
    #[must_use]
    pub fn canonical_checksum(&self) -> String {
        let mut m = self.clone();
        m.manifest_checksum.clear();
        crate::files::checksum(&serde_json::to_vec(&m).unwrap_or_default())
    }

    /// Human-readable summary: what the grid holds, the bytes of each layer, the fit's
    /// residuals and what was left out (`warpfit inspect`).
    #[must_use]
    pub fn describe(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let c = self.grid.counts;
        let cells = c[0] as u64 * c[1] as u64 * c[2] as u64;
        let _ =
            writeln!(s, "{} fitted grid of scene {:?} ({} v{})", GRID_FORMAT, self.scene, self.format, self.version);
        let _ = writeln!(
            s,
            "grid: {}×{}×{} cells over {:?}..{:?} ({}, up {})",
            c[0], c[1], c[2], self.grid.min, self.grid.max, self.units, self.up_axis
        );
        let _ = writeln!(
            s,
            "probe: at {:?}, {}² radiance, {} GGX mips (roughness {}), {} distance mips",
            self.probe.position,
            self.probe.resolution,
            self.probe.radiance_mips.len(),
            self.probe
                .radiance_mips
                .iter()
                .map(|m| format!("{:.2}", m.perceptual_roughness))
                .collect::<Vec<_>>()
                .join("/"),
            self.probe.distance_mips.len()
        );
        let stored = self.correctives.as_ref().map_or(0, |c| c.stored_cells.len());
        let map_res = self.correctives.as_ref().map_or(0, |c| c.map_res);
        let rough = self.correctives.as_ref().is_some_and(|c| c.rough_maps.is_some());
        let _ = writeln!(
            s,
            "correctives: {stored} of {cells} cells store a {map_res}×{map_res} shift map of the proxy `{}`{}; the others read it as it is (depth mip {}); a lookup reads {}",
            self.warp.fallback,
            if rough { " and one for rough lookups" } else { "" },
            self.warp.options.depth_lod,
            match self.warp.blend {
                Blend::Cell => "the containing cell",
                Blend::Trilinear => "the shifts of the eight cells around it, trilinear",
                Blend::Faces =>
                    "the containing cell, and within an eighth of a cell of a face the near cells it links to, blended",
            }
        );
        let _ = writeln!(
            s,
            "irradiance: {} cells stored, {} with a fitted diffuse correction; {} cell probes relocated off their centre",
            self.irradiance.stored_cells.len(),
            self.irradiance.corrected_cells.len(),
            self.grid.relocated.len()
        );
        match &self.roughness {
            Some(r) => {
                let _ = writeln!(
                    s,
                    "roughness correction: {} ({}×{} table, held-out RMS in α' {:.4}; analytic c0 {:.4} c1 {:.4}, {:.4})",
                    format!("{:?}", r.chosen).to_lowercase(),
                    r.alphas.len(),
                    r.ratios.len(),
                    r.heldout_rms_table,
                    r.c0,
                    r.c1,
                    r.heldout_rms_analytic
                );
                let nodes = r.irradiance_nodes();
                if nodes.is_empty() {
                    let _ = writeln!(s, "rough lookups: probe A alone (no irradiance blend)");
                } else {
                    let w: Vec<String> = nodes.iter().map(|(r, w)| format!("{w:.3} at r {r:.3}")).collect();
                    let cells = match self.warp.blend {
                        Blend::Faces => "the containing cell's irradiance (near a face, the linked near cells')",
                        _ => "the containing cell's irradiance",
                    };
                    let _ = writeln!(s, "rough lookups blend {cells} / π: {}", w.join(", "));
                }
            }
            None => {
                let _ = writeln!(s, "roughness correction: none");
            }
        }
        let _ = writeln!(
            s,
            "\nlayers:\n  {:<18} {:<16} {:>10} {:>9} {:>12}",
            "file", "layer", "size", "precision", "raw bytes"
        );
        let mut total_file = 0;
        for p in &self.payloads {
            total_file += p.bytes;
            for l in &p.layers {
                let _ = writeln!(
                    s,
                    "  {:<18} {:<16} {:>10} {:>9} {:>12}",
                    p.file,
                    l.name,
                    format!("{}×{}", l.width, l.height),
                    format!("{:?}", l.precision).to_lowercase(),
                    l.raw_bytes()
                );
            }
            let _ = writeln!(s, "  {:<18} {:<16} {:>10} {:>9} {:>12} (on disk, ZIP)", p.file, "", "", "", p.bytes);
        }
        let _ = writeln!(s, "  total on disk: {}", crate::files::human_bytes(total_file));
        if let Some(c) = &self.correctives {
            let _ = writeln!(
                s,
                "  bytes per stored cell: {} ({}) + {} (irradiance and moments)",
                c.map_res as u64 * c.map_res as u64 * 4 * if c.rough_maps.is_some() { 2 } else { 1 },
                if c.rough_maps.is_some() { "shift map and rough map" } else { "shift map" },
                {
                    let ir = self.irradiance.resolution as u64;
                    let dr = self.irradiance.depth_resolution as u64;
                    let radiance = self
                        .payloads
                        .iter()
                        .flat_map(|p| &p.layers)
                        .find(|l| l.name == "irradiance")
                        .map_or(4, |l| l.precision.bytes());
                    ir * ir * 3 * radiance + dr * dr * 2 * 4
                }
            );
        }
        let _ = writeln!(s, "\nleft out:");
        let mut saved = 0;
        for l in &self.left_out {
            saved += l.bytes_saved;
            let _ = writeln!(s, "  {} — {} (saves {})", l.what, l.reason, crate::files::human_bytes(l.bytes_saved));
        }
        let _ = writeln!(s, "  total saved: {} (uncompressed)", crate::files::human_bytes(saved));
        if let Some(r) = self.residuals.as_object() {
            let _ = writeln!(s, "\nfit residuals (mean held-out relative error per active cell):");
            for key in [
                "mean_check_err_warp1",
                "mean_check_err_fallback",
                "mean_check_err_celldepth",
                "mean_check_err_stored",
                "cells_level0",
                "cells_level2",
                "fit_seconds",
            ] {
                if let Some(v) = r.get(key) {
                    let _ = writeln!(s, "  {key}: {v}");
                }
            }
        }
        s
    }
}
