//! Reading a fitted grid folder, distrustfully: the manifest and its format and version,
//! each payload's size and checksum before it is decoded, EXR headers against the manifest
//! before any pixel is, then every layer's presence, size and values. Every failure is a
//! [`FileError`] naming the file and the field. Produces plain data ([`GridData`]); the
//! runtime sampler is assembled from it.

use super::exr::{self, ExrLayer as Layer};
use super::schema::*;
use crate::files::FileError;
use crate::grid::GridGeometry;
use crate::octa::{self, OctMap, OctMips};
use crate::roughness::RoughnessCorrection;
use crate::warp::corrective::{Correctives, NO_MAP};
use crate::warp::proxy::{BoxProxy, Kdop};
use crate::warp::{MAX_RELAX_TEXELS, Method, Proxies, Warp, WarpProbe};
use glam::{Quat, UVec3, Vec3};
use std::path::Path;

/// A fitted grid as read from its folder, validated.
pub struct GridData {
    pub manifest: GridManifest,
    /// Probe A (inverse-distance and radiance mips), the proxies and the warp options.
    pub warp: Warp,
    pub correctives: Correctives,
    pub irradiance: IrradianceGrid,
    pub roughness: Option<RoughnessCorrection>,
}

/// Irradiance and distance moments of the stored (not inside geometry) cells; sampled by
/// the runtime (`runtime::irradiance`).
#[derive(Clone, Debug, PartialEq)]
pub struct IrradianceGrid {
    pub geometry: GridGeometry,
    pub resolution: u32,
    pub depth_resolution: u32,
    /// Per grid cell: slot in the arrays below ([`NO_MAP`] = not stored).
    pub slot: Vec<u32>,
    /// `slot · resolution² + texel`.
    pub irradiance: Vec<Vec3>,
    /// `slot · depth_resolution² + texel`: mean and mean square of the hit distance.
    pub depth_mean: Vec<f32>,
    pub depth_mean_sq: Vec<f32>,
    /// The fitted corrections of the cells that store one (empty: none).
    pub correction: IrradianceCorrection,
    /// Per grid cell: its probe's offset from the cell centre (relocation); empty when every
    /// probe sits at its centre.
    pub probe_offset: Vec<Vec3>,
}

/// Per-cell corrections of the blended irradiance, fitted against traced references at
/// surface points in the cell: a small octahedral map of scales over the normal, applied to
/// what the blend of the eight cells around a point gives when the point lies in the cell.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IrradianceCorrection {
    /// N of each N×N map of scales.
    pub resolution: u32,
    /// Per grid cell: slot of its map ([`NO_MAP`]: no correction); empty when none.
    pub slot: Vec<u32>,
    /// `slot · N² + texel`: the scale.
    pub scale: Vec<f32>,
    /// How far the runtime's blend moves a point along its normal before weighing the
    /// cells, as a fraction of the smallest cell extent (DDGI's surface bias, Majercik et
    /// al. 2021); 0 = not moved. Chosen by the fit on the scene's surface points.
    pub surface_bias: f32,
}

impl IrradianceCorrection {
    /// The scale for cell `cell` at unit normal `n` (1 where the cell stores none).
    #[inline]
    #[must_use]
    pub fn scale(&self, cell: usize, n: Vec3) -> f32 {
        if self.slot.get(cell).is_none_or(|&s| s == NO_MAP) {
            return 1.0;
        }
        self.scale_taps(cell, &octa::bilinear_taps(self.resolution, octa::encode(n)))
    }

    /// [`IrradianceCorrection::scale`] with the normal's taps in the map given.
    #[inline]
    #[must_use]
    pub fn scale_taps(&self, cell: usize, taps: &[(u32, f32); 4]) -> f32 {
        match self.slot.get(cell) {
            Some(&s) if s != NO_MAP => {
                let base = s as usize * (self.resolution * self.resolution) as usize;
                taps.iter().map(|&(t, w)| self.scale[base + t as usize] * w).sum()
            }
            _ => 1.0,
        }
    }

    /// Cells that store a correction.
    #[must_use]
    pub fn stored_cells(&self) -> usize {
        self.slot.iter().filter(|&&s| s != NO_MAP).count()
    }
}

impl IrradianceGrid {
    /// The grid from dense per-cell arrays (`cell · res² + texel`, as the bake holds them),
    /// storing the cells `stored` accepts, in cell order (as the grid file does).
    #[must_use]
    pub fn from_cells(
        geometry: GridGeometry,
        (resolution, depth_resolution): (u32, u32),
        (irradiance, depth_mean, depth_mean_sq, probe_offset): (&[Vec3], &[f32], &[f32], &[Vec3]),
        stored: impl Fn(usize) -> bool,
    ) -> IrradianceGrid {
        let (n2, d2) = ((resolution * resolution) as usize, (depth_resolution * depth_resolution) as usize);
        let mut g = IrradianceGrid {
            geometry,
            resolution,
            depth_resolution,
            slot: vec![NO_MAP; geometry.cell_count()],
            irradiance: Vec::new(),
            depth_mean: Vec::new(),
            depth_mean_sq: Vec::new(),
            correction: IrradianceCorrection::default(),
            probe_offset: if probe_offset.iter().any(|o| *o != Vec3::ZERO) {
                probe_offset.to_vec()
            } else {
                Vec::new()
            },
        };
        for cell in (0..geometry.cell_count()).filter(|&c| stored(c)) {
            g.slot[cell] = (g.irradiance.len() / n2) as u32;
            g.irradiance.extend_from_slice(&irradiance[cell * n2..(cell + 1) * n2]);
            g.depth_mean.extend_from_slice(&depth_mean[cell * d2..(cell + 1) * d2]);
            g.depth_mean_sq.extend_from_slice(&depth_mean_sq[cell * d2..(cell + 1) * d2]);
        }
        g
    }
}

fn invalid(path: &Path, field: impl Into<String>, message: impl Into<String>) -> FileError {
    FileError::invalid(path, field, message)
}

/// Reads and checks `manifest.json`: a regular file of bounded size, its format and
/// version, and its checksum over its canonical form (an edited manifest is refused).
pub fn read_manifest(dir: &Path) -> Result<GridManifest, FileError> {
    let path = dir.join(MANIFEST_FILE);
    let bytes = crate::files::read_regular(&path, MAX_MANIFEST_BYTES)?;
    // the format and version first, the rest skipped (no tree of the document is built)
    #[derive(serde::Deserialize)]
    struct Header {
        #[serde(default)]
        format: serde_json::Value,
        #[serde(default)]
        version: serde_json::Value,
    }
    let json = |e: serde_json::Error| FileError::Json { path: path.clone(), message: e.to_string() };
    let h: Header = serde_json::from_slice(&bytes).map_err(json)?;
    let found = h.format.as_str().unwrap_or("").to_string();
    let version = h.version.as_u64().unwrap_or(0);
    if found != GRID_FORMAT || !(GRID_VERSION_OLDEST as u64..=GRID_VERSION as u64).contains(&version) {
        return Err(FileError::Version { path, found, version, expected: GRID_FORMAT, supported: GRID_VERSION });
    }
    let m: GridManifest = serde_json::from_slice(&bytes).map_err(json)?;
    drop(bytes);
    let found = m.canonical_checksum();
    if found != m.manifest_checksum {
        return Err(FileError::Checksum { path, expected: m.manifest_checksum.clone(), found });
    }
    Ok(m)
}

/// A layer a payload must hold, derived from the manifest's structure (not from the
/// payload's own listing, which a damaged manifest could inflate).
pub struct Expected {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: &'static [&'static str],
    /// An atlas of square tiles (tile resolution, columns): its channels are delivered tile
    /// by tile (texel t of tile k at `k·res² + t`, the padding tiles last), placed as they
    /// are decoded, so no atlas-then-gather copy is held.
    pub tiles: Option<(u32, u32)>,
    /// What the writer can store in each channel (one per `channels`): a value outside it
    /// is damage, refused before the grid answers.
    pub rules: Vec<Rule>,
}

/// The values a writer can produce in a channel, and how many of its samples (in placed
/// order) hold data; the rest is an atlas's padding, not checked.
#[derive(Clone, Debug)]
pub struct Rule {
    pub min: f32,
    pub max: f32,
    /// `min` itself is not a value (a scale is > 0).
    pub min_open: bool,
    /// +inf is a value (a distance to the sky).
    pub infinite: bool,
    /// Whole numbers only (a probe index).
    pub whole: bool,
    /// Samples that hold data, in placed order.
    pub valid: usize,
    /// The rule in words, for the error.
    pub what: String,
}

impl Rule {
    /// Finite values in `[min, max]`, `valid` of them, described as `what`.
    #[must_use]
    pub fn within(min: f32, max: f32, valid: usize, what: impl Into<String>) -> Rule {
        Rule { min, max, min_open: false, infinite: false, whole: false, valid, what: what.into() }
    }

    /// Radiance: finite, in `[0, MAX_RADIANCE]`.
    #[must_use]
    pub fn radiance(valid: usize) -> Rule {
        Rule::within(0.0, MAX_RADIANCE, valid, format!("in [0, {MAX_RADIANCE:e}]"))
    }

    /// Whether `v` keeps the rule (NaN never does).
    #[inline]
    #[must_use]
    pub fn ok(&self, v: f32) -> bool {
        let low = if self.min_open { v > self.min } else { v >= self.min };
        let high = v <= self.max || (self.infinite && v == f32::INFINITY);
        low && high && (!self.whole || v.fract() == 0.0)
    }

    /// Checks `values` (in placed order, padding beyond [`Rule::valid`] skipped); names the
    /// first offender as `field` of `path`.
    pub fn check(&self, path: &Path, field: &str, values: impl IntoIterator<Item = f32>) -> Result<(), FileError> {
        match values.into_iter().take(self.valid).enumerate().find(|&(_, v)| !self.ok(v)) {
            Some((k, v)) => Err(self.refusal(path, field, k, v)),
            None => Ok(()),
        }
    }

    fn refusal(&self, path: &Path, field: &str, k: usize, v: f32) -> FileError {
        invalid(path, field, format!("sample {k} is {v}: expected {}", self.what))
    }
}

impl Expected {
    /// A plain (not atlas) layer of `n × n` texels, each channel under `rule`.
    #[must_use]
    pub fn square(name: String, n: u32, channels: &'static [&'static str], rule: &Rule) -> Expected {
        let (width, height) = (n as usize, n as usize);
        let rules = channels.iter().map(|_| Rule { valid: width * height, ..rule.clone() }).collect();
        Expected { name, width, height, channels, tiles: None, rules }
    }

    /// An atlas of `tiles` maps of `res²` texels in `columns`, its channels under `rules`
    /// (their `valid` set to the tiles' texels).
    #[must_use]
    pub fn atlas(
        name: &str,
        (tiles, res, columns): (usize, u32, u32),
        channels: &'static [&'static str],
        rules: &[Rule],
    ) -> Expected {
        let (width, height) = atlas_size(tiles, res, columns);
        let valid = tiles * (res * res) as usize;
        let rules = rules.iter().map(|r| Rule { valid, ..r.clone() }).collect();
        Expected { name: name.into(), width, height, channels, tiles: Some((res, columns)), rules }
    }

    /// Bytes its channels decode to, as f32.
    #[must_use]
    pub fn decoded_bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * self.channels.len() as u64 * 4
    }
}

/// The layers of every payload, from the manifest's structural fields; checks the structure
/// on the way (resolutions, mip chains, layer names, sorted unique cells, atlas columns) and
/// that everything decodes within [`MAX_DECODED_BYTES`].
fn expected_payloads(
    m: &GridManifest,
    mp: &Path,
    cells: usize,
    bounds: &ValueBounds,
) -> Result<Vec<(&'static str, Vec<Expected>)>, FileError> {
    let mut out = vec![(PROBE_FILE, expected_probe(&m.probe, "probe", mp, bounds)?)];
    if m.other_probes.len() >= MAX_PROBES {
        return Err(invalid(
            mp,
            "other_probes",
            format!("{} probes, at most {MAX_PROBES} in all", m.other_probes.len() + 1),
        ));
    }
    if !m.other_probes.is_empty() && m.version < 6 {
        return Err(invalid(mp, "other_probes", "several probes need format version 6"));
    }
    if m.warp.blend == crate::warp::corrective::Blend::Faces && m.version < 7 {
        return Err(invalid(mp, "warp.blend", "the faces blend needs format version 7"));
    }
    check_cell_probes(m, mp, cells)?;
    for (k, p) in m.other_probes.iter().enumerate() {
        let field = format!("other_probes[{k}]");
        let same = p.resolution == m.probe.resolution
            && p.distance_mips == m.probe.distance_mips
            && p.radiance_mips.len() == m.probe.radiance_mips.len()
            && p.radiance_mips.iter().zip(&m.probe.radiance_mips).all(|(a, b)| a == b);
        if !same {
            return Err(invalid(mp, field, "must have probe A's resolution and mip chains"));
        }
        out.push((PROBE_FILES[k + 1], expected_probe(p, &field, mp, bounds)?));
    }
    if let Some(c) = &m.correctives {
        let probes = m.other_probes.len() + 1;
        out.push((CORRECTIVES_FILE, expected_correctives(c, (m.version, probes), mp, cells, bounds)?));
    }
    if let Some(layers) = expected_irradiance(&m.irradiance, mp, cells, bounds)? {
        out.push((IRRADIANCE_FILE, layers));
    }
    check_listing(m, mp, &out)?;
    Ok(out)
}

/// The cells without a map that read another probe ([`GridManifest::cell_probes`]): version
/// 8, sorted unique cells in range that store no map, probes other than A that the grid has.
fn check_cell_probes(m: &GridManifest, mp: &Path, cells: usize) -> Result<(), FileError> {
    const FIELD: &str = "cell_probes";
    if m.cell_probes.is_empty() {
        return Ok(());
    }
    if m.version < 8 {
        return Err(invalid(mp, FIELD, "cells reading another probe without a map need format version 8"));
    }
    let list: Vec<u32> = m.cell_probes.iter().map(|&(c, _)| c).collect();
    cells_ok(&list, FIELD, cells, mp)?;
    let probes = m.other_probes.len() + 1;
    if let Some(&(c, p)) = m.cell_probes.iter().find(|&&(_, p)| p == 0 || usize::from(p) >= probes) {
        return Err(invalid(
            mp,
            FIELD,
            format!("cell {c} reads probe {p}: not a probe other than A of the grid's {probes}"),
        ));
    }
    let stored = m.correctives.as_ref().map_or(&[][..], |c| c.stored_cells.as_slice());
    if let Some(&(c, _)) = m.cell_probes.iter().find(|&&(c, _)| stored.binary_search(&c).is_ok()) {
        return Err(invalid(mp, FIELD, format!("cell {c} stores a map: its texels say which probe it reads")));
    }
    Ok(())
}

/// Per cell, the probe it reads without a map ([`check_cell_probes`]); empty when every
/// such cell reads probe A.
fn cell_probes(m: &GridManifest, cells: usize) -> Vec<u8> {
    if m.cell_probes.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0u8; cells];
    for &(c, p) in &m.cell_probes {
        out[c as usize] = p;
    }
    out
}

/// Whether `r` is a tile resolution a reader accepts.
fn tile_ok(r: u32) -> bool {
    (2..=MAX_TILE_RESOLUTION).contains(&r) && r.is_multiple_of(2)
}

/// A manifest's list of cells: sorted, unique, within the grid's `cells`.
fn cells_ok(list: &[u32], field: &str, cells: usize, mp: &Path) -> Result<(), FileError> {
    if let Some(w) = list.windows(2).find(|w| w[0] >= w[1]) {
        return Err(invalid(mp, field, format!("cells must be sorted and unique ({} then {})", w[0], w[1])));
    }
    if let Some(&c) = list.last().filter(|&&c| c as usize >= cells) {
        return Err(invalid(mp, field, format!("cell {c} out of range (the grid has {cells})")));
    }
    Ok(())
}

/// An atlas's column count for `n` tiles: at least one, at most one a tile.
fn columns_ok(n: usize, columns: u32, field: &str, mp: &Path) -> Result<(), FileError> {
    if columns == 0 || columns as usize > n.max(1) {
        return Err(invalid(mp, field, format!("{columns} columns for {n} tiles")));
    }
    Ok(())
}

/// A probe file's layers (`p`, the manifest's section `field`): the radiance chain
/// (halving, named, roughness increasing in [0, 1]) and the distance chain.
fn expected_probe(p: &ProbeSection, field: &str, mp: &Path, bounds: &ValueBounds) -> Result<Vec<Expected>, FileError> {
    if !(2..=MAX_PROBE_RESOLUTION).contains(&p.resolution) || !p.resolution.is_multiple_of(2) {
        return Err(invalid(
            mp,
            format!("{field}.resolution"),
            format!("{} is not an even size in 2..={MAX_PROBE_RESOLUTION}", p.resolution),
        ));
    }
    if p.radiance_mips.is_empty() || p.distance_mips.is_empty() {
        return Err(invalid(mp, field, "needs at least one radiance and one distance mip"));
    }
    let dmax = bounds.max_distance;
    let distance =
        Rule { infinite: true, ..Rule::within(0.0, dmax, 0, format!("a distance in [0, {dmax:e}] or +inf")) };
    let mut probe = Vec::new();
    for (k, mip) in p.radiance_mips.iter().enumerate() {
        let n = p.resolution.checked_shr(k as u32).unwrap_or(0);
        if mip.resolution != n || n == 0 {
            return Err(invalid(mp, format!("{field}.radiance_mips[{k}].resolution"), "must halve at every mip"));
        }
        if mip.layer != radiance_layer(k) {
            return Err(invalid(
                mp,
                format!("{field}.radiance_mips[{k}].layer"),
                format!("must be {}", radiance_layer(k)),
            ));
        }
        if !(0.0..=1.0).contains(&mip.perceptual_roughness)
            || (k > 0 && !(mip.perceptual_roughness > p.radiance_mips[k - 1].perceptual_roughness))
        {
            return Err(invalid(
                mp,
                format!("{field}.radiance_mips[{k}].perceptual_roughness"),
                "must lie in [0, 1] and increase from mip to mip",
            ));
        }
        probe.push(Expected::square(mip.layer.clone(), n, &["R", "G", "B"], &Rule::radiance(0)));
    }
    for (k, name) in p.distance_mips.iter().enumerate() {
        let n = p.resolution.checked_shr(k as u32).unwrap_or(0);
        if n == 0 {
            return Err(invalid(mp, format!("{field}.distance_mips"), "more mips than the resolution allows"));
        }
        if *name != distance_layer(k) {
            return Err(invalid(mp, format!("{field}.distance_mips[{k}]"), format!("must be {}", distance_layer(k))));
        }
        probe.push(Expected::square(name.clone(), n, &["Z"], &distance));
    }
    Ok(probe)
}

/// `correctives.exr`'s layers: the shift maps, from version 5 the rough maps, from version 6
/// the probe maps (a grid of `probes` probes).
fn expected_correctives(
    c: &CorrectiveSection,
    (version, probes): (u32, usize),
    mp: &Path,
    cells: usize,
    bounds: &ValueBounds,
) -> Result<Vec<Expected>, FileError> {
    if !tile_ok(c.map_res) {
        return Err(invalid(mp, "correctives.map_res", format!("must be an even size in 2..={MAX_TILE_RESOLUTION}")));
    }
    if c.stored_cells.is_empty() {
        return Err(invalid(
            mp,
            "correctives.stored_cells",
            "empty: the section is left out when no cell stores a map",
        ));
    }
    cells_ok(&c.stored_cells, "correctives.stored_cells", cells, mp)?;
    columns_ok(c.stored_cells.len(), c.atlas_columns, "correctives.atlas_columns", mp)?;
    if c.rough_maps.is_some() && version < 5 {
        return Err(invalid(mp, "correctives.rough_maps", "rough maps need format version 5"));
    }
    let dmax = bounds.max_distance;
    let shift = Rule::within(-dmax, dmax, 0, format!("a shift in [-{dmax:e}, {dmax:e}]"));
    let atlas = (c.stored_cells.len(), c.map_res, c.atlas_columns);
    let mut layers = vec![Expected::atlas("shift_maps", atlas, &["D"], std::slice::from_ref(&shift))];
    if c.rough_maps.is_some() {
        layers.push(Expected::atlas("rough_shift_maps", atlas, &["D"], std::slice::from_ref(&shift)));
    }
    if c.probe_maps.is_some() {
        if version < 6 {
            return Err(invalid(mp, "correctives.probe_maps", "probe maps need format version 6"));
        }
        if probes < 2 {
            return Err(invalid(mp, "correctives.probe_maps", "present, but the grid has one probe"));
        }
        let index =
            Rule { whole: true, ..Rule::within(0.0, (probes - 1) as f32, 0, format!("a probe index in 0..{probes}")) };
        layers.push(Expected::atlas("probe_maps", atlas, &["P"], &[index]));
    }
    Ok(layers)
}

/// `irradiance.exr`'s layers (none when no cell stores irradiance): irradiance, distance
/// moments and the diffuse corrections' scales.
fn expected_irradiance(
    ir: &IrradianceSection,
    mp: &Path,
    cells: usize,
    bounds: &ValueBounds,
) -> Result<Option<Vec<Expected>>, FileError> {
    if !tile_ok(ir.resolution) || !tile_ok(ir.depth_resolution) {
        return Err(invalid(mp, "irradiance", format!("resolutions must be even sizes in 2..={MAX_TILE_RESOLUTION}")));
    }
    cells_ok(&ir.stored_cells, "irradiance.stored_cells", cells, mp)?;
    if !ir.stored_cells.is_empty() {
        let n = ir.stored_cells.len();
        columns_ok(n, ir.atlas_columns, "irradiance.atlas_columns", mp)?;
        let dmax = bounds.max_distance;
        let d2 = dmax * dmax;
        let moments = [
            Rule::within(0.0, dmax, 0, format!("in [0, {dmax:e}]")),
            Rule::within(0.0, d2, 0, format!("in [0, {d2:e}]")),
        ];
        let mut layers = vec![
            Expected::atlas(
                "irradiance",
                (n, ir.resolution, ir.atlas_columns),
                &["R", "G", "B"],
                &[Rule::radiance(0), Rule::radiance(0), Rule::radiance(0)],
            ),
            Expected::atlas(
                "depth_moments",
                (n, ir.depth_resolution, ir.atlas_columns),
                &["mean", "mean_sq"],
                &moments,
            ),
        ];
        if !ir.corrected_cells.is_empty() {
            if !tile_ok(ir.correction_resolution) {
                return Err(invalid(
                    mp,
                    "irradiance.correction_resolution",
                    format!("must be an even size in 2..={MAX_TILE_RESOLUTION}"),
                ));
            }
            cells_ok(&ir.corrected_cells, "irradiance.corrected_cells", cells, mp)?;
            if let Some(c) = ir.corrected_cells.iter().find(|c| ir.stored_cells.binary_search(c).is_err()) {
                return Err(invalid(mp, "irradiance.corrected_cells", format!("cell {c} stores no irradiance")));
            }
            columns_ok(ir.corrected_cells.len(), ir.correction_columns, "irradiance.correction_columns", mp)?;
            let k = ir.corrected_cells.len();
            let scale = Rule { min_open: true, ..Rule::within(0.0, 100.0, 0, "a scale in (0, 100]") };
            layers.push(Expected::atlas(
                "irradiance_scale",
                (k, ir.correction_resolution, ir.correction_columns),
                &["S"],
                &[scale],
            ));
        }
        Ok(Some(layers))
    } else if !ir.corrected_cells.is_empty() {
        Err(invalid(mp, "irradiance.corrected_cells", "no cell stores irradiance"))
    } else {
        Ok(None)
    }
}

/// The decoded size within [`MAX_DECODED_BYTES`], and the manifest's own payload listing
/// exactly the layers the structure says.
fn check_listing(m: &GridManifest, mp: &Path, out: &[(&'static str, Vec<Expected>)]) -> Result<(), FileError> {
    let decoded: u64 = out.iter().flat_map(|(_, layers)| layers).map(Expected::decoded_bytes).sum();
    if decoded > MAX_DECODED_BYTES {
        return Err(invalid(
            mp,
            "payloads",
            format!("the grid would decode to {decoded} bytes, more than the {MAX_DECODED_BYTES} this loader accepts"),
        ));
    }
    // the manifest's own listing must be exactly this
    let files: Vec<&str> = out.iter().map(|(f, _)| *f).collect();
    if let Some(extra) = m.payloads.iter().find(|p| !files.contains(&p.file.as_str())) {
        return Err(invalid(mp, "payloads", format!("unexpected payload {:?}", extra.file)));
    }
    for (file, layers) in out {
        let entries: Vec<&Payload> = m.payloads.iter().filter(|p| p.file == *file).collect();
        let [entry] = entries.as_slice() else {
            return Err(invalid(mp, "payloads", format!("{} entries for {file}, expected one", entries.len())));
        };
        if entry.layers.len() != layers.len() {
            return Err(invalid(
                mp,
                format!("payloads.{file}"),
                format!("{} layers, expected {}", entry.layers.len(), layers.len()),
            ));
        }
        for l in layers {
            let listed = entry
                .layers
                .iter()
                .find(|x| x.name == l.name)
                .ok_or_else(|| invalid(mp, format!("payloads.{file}"), format!("layer {} missing", l.name)))?;
            let channels: Vec<&str> = listed.channels.iter().map(String::as_str).collect();
            if (listed.width as usize, listed.height as usize) != (l.width, l.height) || channels != l.channels {
                return Err(invalid(
                    mp,
                    format!("payloads.{file}.{}", l.name),
                    format!(
                        "lists {}x{} {:?}, the structure says {}x{} {:?}",
                        listed.width, listed.height, channels, l.width, l.height, l.channels
                    ),
                ));
            }
            if listed.precision == Precision::F16 && !may_be_half(&l.name) {
                return Err(invalid(
                    mp,
                    format!("payloads.{file}.{}.precision", l.name),
                    "f16, but only radiance layers are ever stored as f16",
                ));
            }
        }
    }
    Ok(())
}

/// Reads a payload: a regular file whose size (from its metadata) and checksum match the
/// manifest, whose EXR headers match the expected layers, then decoded.
fn read_payload(dir: &Path, m: &GridManifest, file: &str, expected: &[Expected]) -> Result<Vec<Layer>, FileError> {
    Ok(read_listed_payload_rgb(listing(dir, &dir.join(MANIFEST_FILE), m), file, expected, None)?.0)
}

/// The payloads of grid folder `dir` as its manifest `m` (read from `mpath`) lists them.
fn listing<'a>(dir: &'a Path, mpath: &'a Path, m: &'a GridManifest) -> Listing<'a> {
    Listing { dir, manifest: mpath, payloads: &m.payloads }
}

/// A folder's payloads as its manifest lists them: the folder, the manifest's path (for
/// errors) and its payload entries.
#[derive(Clone, Copy, Debug)]
pub struct Listing<'a> {
    /// The folder the payload files are in.
    pub dir: &'a Path,
    /// The manifest's path, named in errors about its entries.
    pub manifest: &'a Path,
    /// The manifest's payload entries (name, size, checksum, layers).
    pub payloads: &'a [Payload],
}

/// Reads payload `file` as `listing` lists it: size, checksum and EXR headers checked
/// against the listing and `expected` before a byte is decoded, then the layers' sizes and
/// channels.
pub fn read_listed_payload(listing: Listing, file: &str, expected: &[Expected]) -> Result<Vec<Layer>, FileError> {
    Ok(read_listed_payload_rgb(listing, file, expected, None)?.0)
}

/// [`read_listed_payload`], the R, G and B channels of layer `rgb` (when named) decoded
/// straight into triples in the layer's placed order (its channels come back empty): a big
/// grid's irradiance is never held as three channels and a copy.
pub fn read_listed_payload_rgb(
    listing: Listing,
    file: &str,
    expected: &[Expected],
    rgb: Option<&str>,
) -> Result<(Vec<Layer>, Vec<Vec3>), FileError> {
    let (path, f) = open_checked(listing, file, expected)?;
    // (name, size, tiles) of the atlas layers
    let atlases: Vec<_> =
        expected.iter().filter_map(|l| Some((l.name.clone(), (l.width, l.height), l.tiles?))).collect();
    let place = move |name: &str, w: usize, h: usize| -> Option<exr::Placement> {
        let &(_, _, (res, columns)) = atlases.iter().find(|(n, size, _)| n == name && *size == (w, h))?;
        Some(placement(Some((res, columns))))
    };
    // the triples' layer as the manifest lists it (its headers were checked against it)
    let triples = rgb.and_then(|name| expected.iter().find(|l| l.name == name)).map(|l| {
        let identity: exr::Placement = std::sync::Arc::new(|i| i);
        let at = place(&l.name, l.width, l.height).unwrap_or(identity);
        (l.name.clone(), exr::RgbSink::new(l.width * l.height, at))
    });
    let sinks = triples.as_ref().map(|(name, sink)| sink.sinks(name)).unwrap_or_default();
    let layers = exr::decode_routed(&path, f, exr::route_to_sinks(sinks, place))?;
    let triples = triples.map(|(_, sink)| sink.take()).unwrap_or_default();
    for l in expected {
        let got = layers
            .iter()
            .find(|x| x.name == l.name)
            .ok_or_else(|| invalid(&path, &l.name, "layer listed in the manifest is missing"))?;
        if (got.width, got.height) != (l.width, l.height) {
            return Err(invalid(
                &path,
                &l.name,
                format!("size {}x{}, the manifest says {}x{}", got.width, got.height, l.width, l.height),
            ));
        }
        for c in l.channels {
            if !got.channels.iter().any(|(n, _)| n == c) {
                return Err(invalid(&path, format!("{}.{c}", l.name), "channel missing"));
            }
        }
    }
    // every value within what the writer stores
    for l in expected {
        for (c, rule) in l.channels.iter().zip(&l.rules) {
            let field = format!("{}.{c}", l.name);
            match ["R", "G", "B"].iter().position(|x| x == c).filter(|_| rgb == Some(l.name.as_str())) {
                Some(k) => rule.check(&path, &field, triples.iter().map(|t| t[k]))?,
                None => rule.check(
                    &path,
                    &field,
                    layer(&layers, &path, &l.name, (l.width, l.height))
                        .and_then(|x| channel(x, &path, c))?
                        .iter()
                        .copied(),
                )?,
            }
        }
    }
    Ok((layers, triples))
}

/// Where an expected layer's samples go: tile-major for an atlas of `(res, columns)`,
/// row-major otherwise.
fn placement(tiles: Option<(u32, u32)>) -> exr::Placement {
    match tiles {
        Some((res, columns)) => std::sync::Arc::new(move |i| tile_major(i, res, columns)),
        None => std::sync::Arc::new(|i| i),
    }
}

/// Checks payload `file` as `listing` lists it: its size, checksum and EXR headers against
/// `expected`, decoding nothing.
pub fn check_listed_payload(listing: Listing, file: &str, expected: &[Expected]) -> Result<(), FileError> {
    open_checked(listing, file, expected).map(|_| ())
}

/// Payload `file` opened as `payloads` lists it: size and checksum read through the file
/// in pieces (its bytes are never held whole), then its EXR headers checked against
/// `expected` and the listing before a byte is decoded (a damaged header can claim a layer
/// of any size, and decoding would try to allocate it).
fn open_checked(
    listing: Listing,
    file: &str,
    expected: &[Expected],
) -> Result<(std::path::PathBuf, std::fs::File), FileError> {
    let entry = listing
        .payloads
        .iter()
        .find(|p| p.file == file)
        .ok_or_else(|| invalid(listing.manifest, "payloads", format!("no entry for {file}")))?;
    let path = listing.dir.join(file);
    let mut f = crate::files::open_listed(&path, entry.bytes, &entry.checksum)?;
    check_headers(&path, &mut f, expected, &entry.layers)?;
    Ok((path, f))
}

/// Streams payload `file`'s values through `expected`'s rules, holding no array of them:
/// a grid too big to decode on trust ([`SCAN_ABOVE_BYTES`]) is checked this way first, so
/// a damaged one is refused before any of its arrays is allocated.
pub fn scan_listed_payload(listing: Listing, file: &str, expected: &[Expected]) -> Result<(), FileError> {
    use std::sync::{Arc, Mutex, PoisonError};
    let (path, f) = open_checked(listing, file, expected)?;
    let failure: Arc<Mutex<Option<FileError>>> = Arc::default();
    /// One channel's rule and where its samples go.
    #[derive(Clone)]
    struct Channel {
        layer: String,
        name: &'static str,
        size: (usize, usize),
        rule: Rule,
        tiles: Option<(u32, u32)>,
    }
    let channels: Vec<Channel> = expected
        .iter()
        .flat_map(|l| {
            l.channels.iter().zip(&l.rules).map(|(&name, rule)| Channel {
                layer: l.name.clone(),
                name,
                size: (l.width, l.height),
                rule: rule.clone(),
                tiles: l.tiles,
            })
        })
        .collect();
    let (found, p) = (failure.clone(), path.clone());
    let route = move |layer: &str, channel: &str, w: usize, h: usize| {
        let Some(Channel { rule, tiles, .. }) =
            channels.iter().find(|c| c.layer == layer && c.name == channel && c.size == (w, h)).cloned()
        else {
            // the headers were checked against `expected`: no such channel is decoded
            return exr::Destination::Sink(Box::new(|_, _| {}));
        };
        let (found, p, place) = (found.clone(), p.clone(), placement(tiles));
        let field = format!("{layer}.{channel}");
        exr::Destination::Sink(Box::new(move |start: usize, line: &[f32]| {
            let mut found = found.lock().unwrap_or_else(PoisonError::into_inner);
            if found.is_some() {
                return;
            }
            let bad = line
                .iter()
                .enumerate()
                .map(|(i, &v)| (place(start + i), v))
                .find(|&(at, v)| at < rule.valid && !rule.ok(v));
            if let Some((at, v)) = bad {
                *found = Some(rule.refusal(&p, &field, at, v));
            }
        }))
    };
    let decoded = exr::decode_routed(&path, f, route);
    if let Some(e) = failure.lock().unwrap_or_else(PoisonError::into_inner).take() {
        return Err(e);
    }
    decoded.map(|_| ())
}

/// Checks the EXR headers of the open payload `f` against `expected`, and rewinds it.
fn check_headers(
    path: &Path,
    f: &mut std::fs::File,
    expected: &[Expected],
    listing: &[LayerEntry],
) -> Result<(), FileError> {
    let meta = ::exr::meta::MetaData::read_from_buffered(std::io::BufReader::new(&mut *f), false)
        .map_err(|e| FileError::Exr { path: path.to_path_buf(), message: e.to_string() })?;
    std::io::Seek::rewind(f).map_err(FileError::io(path))?;
    if meta.headers.len() != expected.len() {
        return Err(invalid(
            path,
            "layers",
            format!("{} layers, the manifest says {}", meta.headers.len(), expected.len()),
        ));
    }
    let mut seen = Vec::new();
    for h in &meta.headers {
        let name = h.own_attributes.layer_name.as_ref().map(|n| n.to_string()).unwrap_or_default();
        let listed = expected
            .iter()
            .find(|l| l.name == name)
            .ok_or_else(|| invalid(path, &name, "layer in the file is not listed in the manifest"))?;
        if seen.contains(&name) {
            return Err(invalid(path, &name, "layer appears twice"));
        }
        seen.push(name.clone());
        let (w, h_) = (h.layer_size.0, h.layer_size.1);
        if (w, h_) != (listed.width, listed.height) {
            return Err(invalid(
                path,
                &name,
                format!("header says {w}x{h_}, the manifest says {}x{}", listed.width, listed.height),
            ));
        }
        if h.deep || h.channels.list.len() != listed.channels.len() {
            return Err(invalid(
                path,
                &name,
                format!("deep data or not {} channels: not a warpfit layer", listed.channels.len()),
            ));
        }
        let precision = listing.iter().find(|x| x.name == name).map(|x| x.precision);
        let sample = match precision {
            Some(Precision::F16) => ::exr::meta::attribute::SampleType::F16,
            _ => ::exr::meta::attribute::SampleType::F32,
        };
        if let Some(c) = h.channels.list.iter().find(|c| c.sample_type != sample) {
            return Err(invalid(
                path,
                format!("{name}.{}", c.name),
                format!("stored as {:?}, the manifest says {precision:?}", c.sample_type),
            ));
        }
    }
    Ok(())
}

fn layer<'a>(layers: &'a [Layer], path: &Path, name: &str, size: (usize, usize)) -> Result<&'a Layer, FileError> {
    let l = layers.iter().find(|l| l.name == name).ok_or_else(|| invalid(path, name, "layer missing"))?;
    if (l.width, l.height) != size {
        return Err(invalid(path, name, format!("size {}x{}, expected {}x{}", l.width, l.height, size.0, size.1)));
    }
    Ok(l)
}

fn channel<'a>(l: &'a Layer, path: &Path, name: &str) -> Result<&'a [f32], FileError> {
    l.channels
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| v.as_slice())
        .ok_or_else(|| invalid(path, format!("{}.{name}", l.name), "channel missing"))
}

/// The RGB samples of a layer (their values were checked against its rules).
fn rgb(l: &Layer, path: &Path) -> Result<Vec<Vec3>, FileError> {
    let (r, g, b) = (channel(l, path, "R")?, channel(l, path, "G")?, channel(l, path, "B")?);
    Ok((0..r.len().min(g.len()).min(b.len())).map(|k| Vec3::new(r[k], g[k], b[k])).collect())
}

/// Channel `name` of layer `layer` (of `size`), moved out of the decoded layers.
fn take_channel(
    layers: &mut [Layer],
    path: &Path,
    layer_name: &str,
    size: (usize, usize),
    name: &str,
) -> Result<Vec<f32>, FileError> {
    layer(layers, path, layer_name, size)?;
    let l =
        layers.iter_mut().find(|l| l.name == layer_name).ok_or_else(|| invalid(path, layer_name, "layer missing"))?;
    l.channels
        .iter_mut()
        .find(|(n, _)| n == name)
        .map(|(_, v)| std::mem::take(v))
        .ok_or_else(|| invalid(path, format!("{layer_name}.{name}"), "channel missing"))
}

fn finite3(v: [f32; 3], path: &Path, field: &str) -> Result<Vec3, FileError> {
    let v = Vec3::from_array(v);
    if v.is_finite() { Ok(v) } else { Err(invalid(path, field, "not finite")) }
}

/// Sparse cell list → per-cell slot (`u32::MAX` = not stored), validated.
fn slots(cells: &[u32], count: usize, path: &Path, field: &str) -> Result<Vec<u32>, FileError> {
    let mut slot = vec![NO_MAP; count];
    for (k, &c) in cells.iter().enumerate() {
        let s = slot.get_mut(c as usize).ok_or_else(|| invalid(path, field, format!("cell {c} out of range")))?;
        if *s != NO_MAP {
            return Err(invalid(path, field, format!("cell {c} listed twice")));
        }
        *s = k as u32;
    }
    Ok(slot)
}

/// Reads and validates the fitted grid in `dir`.
pub fn read(dir: &Path) -> Result<GridData, FileError> {
    let m = read_manifest(dir)?;
    let mpath = dir.join(MANIFEST_FILE);
    let mp = mpath.as_path();
    if m.octahedral_convention != octa::CONVENTION {
        return Err(invalid(mp, "octahedral_convention", "differs from this reader's octahedral mapping"));
    }
    let (geometry, cells) = read_geometry(&m, mp)?;
    check_relocated(&m, mp, &geometry, cells)?;
    let bounds = ValueBounds::of_diagonal((geometry.max - geometry.min).length());
    let expected = expected_payloads(&m, mp, cells, &bounds)?;
    let (fallback, proxies) = read_proxies(&m, mp, &bounds)?;
    // Every manifest rule has held. A grid too big to decode on trust has its payloads'
    // values streamed through their rules first, so a damaged one is refused before any
    // array of it is allocated; a small one is checked as it is decoded.
    let per_cell = cells as u64 * PER_CELL_BYTES;
    if expected.iter().flat_map(|(_, l)| l).map(Expected::decoded_bytes).sum::<u64>() + per_cell > SCAN_ABOVE_BYTES {
        for (file, layers) in &expected {
            scan_listed_payload(listing(dir, mp, &m), file, layers)?;
        }
    }
    let probe = read_probe(dir, (&m, mp), (PROBE_FILE, &m.probe, "probe"), expected_of(&expected, PROBE_FILE))?;
    let mut others = Vec::with_capacity(m.other_probes.len());
    for (k, p) in m.other_probes.iter().enumerate() {
        let (file, field) = (PROBE_FILES[k + 1], format!("other_probes[{k}]"));
        others.push(read_probe(dir, (&m, mp), (file, p, &field), expected_of(&expected, file))?);
    }
    let correctives =
        read_correctives(dir, (&m, mp), expected_of(&expected, CORRECTIVES_FILE), (geometry, cells), fallback)?
            .with_cell_probes(cell_probes(&m, cells));
    let irradiance = read_irradiance(
        dir,
        (&m, mp),
        expected_of(&expected, IRRADIANCE_FILE),
        (geometry, cells),
        relocated_offsets(&m, cells),
    )?;
    let roughness = m.roughness.clone();
    let options = m.warp.options;
    Ok(GridData {
        warp: Warp { probe, others: others.into(), proxies, options },
        correctives,
        irradiance,
        roughness,
        manifest: m,
    })
}

/// The layers `expected_payloads` lists for `file` (none when it lists no such file).
fn expected_of<'a>(expected: &'a [(&'static str, Vec<Expected>)], file: &str) -> &'a [Expected] {
    expected.iter().find(|(f, _)| *f == file).map(|(_, l)| l.as_slice()).unwrap_or(&[])
}

/// The grid's geometry and cell count, checked.
fn read_geometry(m: &GridManifest, mp: &Path) -> Result<(GridGeometry, usize), FileError> {
    // grid
    let geometry = GridGeometry {
        min: finite3(m.grid.min, mp, "grid.min")?,
        max: finite3(m.grid.max, mp, "grid.max")?,
        counts: UVec3::from_array(m.grid.counts),
    };
    if !(geometry.max.cmpgt(geometry.min).all()) {
        return Err(invalid(mp, "grid", "max must exceed min on every axis"));
    }
    let cells = m.grid.counts.iter().try_fold(1u64, |a, &c| (c > 0).then(|| a * c as u64));
    let cells = match cells {
        Some(n) if n <= MAX_CELLS => n as usize,
        _ => {
            return Err(invalid(mp, "grid.counts", format!("each count must be ≥ 1 and the grid ≤ {MAX_CELLS} cells")));
        }
    };
    Ok((geometry, cells))
}

/// The relocated cell probes' offsets: sorted, unique, in range, within half a cell of
/// their centre (checked before anything the size of the grid is allocated).
fn check_relocated(m: &GridManifest, mp: &Path, geometry: &GridGeometry, cells: usize) -> Result<(), FileError> {
    let half = geometry.cell_size() * 0.5;
    let mut last = None;
    for &(c, o) in &m.grid.relocated {
        let o = Vec3::from_array(o);
        if last.is_some_and(|l| c <= l) {
            return Err(invalid(mp, "grid.relocated", "cells must be sorted and unique"));
        }
        last = Some(c);
        if c as usize >= cells {
            return Err(invalid(mp, "grid.relocated", format!("cell {c} out of range")));
        }
        if !(o.is_finite() && o.abs().cmple(half).all() && o != Vec3::ZERO) {
            return Err(invalid(
                mp,
                "grid.relocated",
                format!("cell {c}: offset {o} is zero, not finite or leaves its cell"),
            ));
        }
    }
    Ok(())
}

/// Per cell, its probe's offset from the centre ([`check_relocated`]); empty when none moved.
fn relocated_offsets(m: &GridManifest, cells: usize) -> Vec<Vec3> {
    let mut probe_offset = Vec::new();
    if !m.grid.relocated.is_empty() {
        probe_offset = vec![Vec3::ZERO; cells];
        for &(c, o) in &m.grid.relocated {
            probe_offset[c as usize] = Vec3::from_array(o);
        }
    }
    probe_offset
}

/// A probe from its file (probe A's `probe.exr`, `file` with manifest section `p` named
/// `field`): the radiance chain and the distance chain, values checked.
fn read_probe(
    dir: &Path,
    (m, mp): (&GridManifest, &Path),
    (file, p, field): (&str, &ProbeSection, &str),
    expected: &[Expected],
) -> Result<WarpProbe, FileError> {
    let ppath = dir.join(file);
    let layers = read_payload(dir, m, file, expected)?;
    let mut radiance = Vec::new();
    let mut roughness_of_mips = Vec::new();
    for mip in &p.radiance_mips {
        let n = mip.resolution as usize;
        let l = layer(&layers, &ppath, &mip.layer, (n, n))?;
        radiance.push(OctMap::new(mip.resolution, rgb(l, &ppath)?));
        roughness_of_mips.push(mip.perceptual_roughness);
    }
    let mut distance = Vec::new();
    for (k, name) in p.distance_mips.iter().enumerate() {
        let n = (p.resolution >> k) as usize;
        let z = channel(layer(&layers, &ppath, name, (n, n))?, &ppath, "Z")?;
        distance.push(OctMap::new(n as u32, z.to_vec()));
    }
    let position = finite3(p.position, mp, &format!("{field}.position"))?;
    Ok(WarpProbe::from_distance_mips(
        position,
        &OctMips { levels: distance },
        OctMips { levels: radiance },
        roughness_of_mips,
    ))
}

/// The fallback proxy and the proxies' shapes, checked.
fn read_proxies(m: &GridManifest, mp: &Path, bounds: &ValueBounds) -> Result<(Method, Proxies), FileError> {
    let w = &m.warp;
    let fallback = match Method::parse(&w.fallback) {
        Some(f @ (Method::Box | Method::Kdop | Method::Warp1)) => f,
        _ => return Err(invalid(mp, "warp.fallback", format!("{:?} is not a proxy (box, kdop or warp1)", w.fallback))),
    };
    let o = &w.options;
    // the sampler clamps the depth mip to the chain; the writer keeps the standard 2 on a
    // shorter chain, and no chain is longer than a 4096² probe's 13 mips
    let last_mip = 16.0;
    if !((0.0..=last_mip).contains(&o.depth_lod) && (0.0..=MAX_RELAX_TEXELS).contains(&o.relax_texels))
        || o.secant_steps > 64
        || o.march_steps > 4096
    {
        return Err(invalid(
            mp,
            "warp.options",
            format!("depth_lod must lie in [0, {last_mip}], relax_texels in [0, {MAX_RELAX_TEXELS}], steps bounded"),
        ));
    }
    // a shape beyond a million diagonals of the grid is damage, as a distance would be
    let far = |v: Vec3| v.abs().max_element() <= bounds.max_distance;
    let b = &w.box_proxy;
    let rotation = Quat::from_array(b.rotation);
    if !rotation.is_finite() || rotation.length() < 1e-3 {
        return Err(invalid(mp, "warp.box_proxy.rotation", "not a finite non-zero quaternion"));
    }
    let (centre, half) =
        (finite3(b.centre, mp, "warp.box_proxy.centre")?, finite3(b.half_extents, mp, "warp.box_proxy.half_extents")?);
    if !(far(centre) && far(half) && half.min_element() >= 0.0) {
        return Err(invalid(
            mp,
            "warp.box_proxy",
            "centre and half extents must lie within the grid's value bounds, extents ≥ 0",
        ));
    }
    let aabb = BoxProxy::oriented(centre, rotation, half);
    let mut kdop = Kdop { normals: Vec::new(), offsets: Vec::new() };
    for (k, plane) in w.kdop.iter().enumerate() {
        let n = finite3(plane.normal, mp, &format!("warp.kdop[{k}].normal"))?;
        if !((n.length() - 1.0).abs() < 1e-3) {
            return Err(invalid(mp, format!("warp.kdop[{k}].normal"), format!("{n} is not a unit vector")));
        }
        let h = match plane.offset {
            Some(h) if h.is_finite() && h.abs() <= bounds.max_distance => h,
            Some(_) => {
                return Err(invalid(mp, format!("warp.kdop[{k}].offset"), "not finite or beyond the value bounds"));
            }
            None => f32::INFINITY,
        };
        kdop.normals.push(n);
        kdop.offsets.push(h);
    }
    Ok((fallback, Proxies { aabb, kdop }))
}

/// The per-cell shift maps and rough maps (their atlas arrives tile by tile: the first
/// tiles are the stored maps), checked.
fn read_correctives(
    dir: &Path,
    (m, mp): (&GridManifest, &Path),
    expected: &[Expected],
    (geometry, cells): (GridGeometry, usize),
    fallback: Method,
) -> Result<Correctives, FileError> {
    let (map_res, slot, maps, rough_maps, probe_maps) = match &m.correctives {
        None => (8, vec![NO_MAP; cells], Vec::new(), Vec::new(), Vec::new()),
        Some(c) => {
            let slot = slots(&c.stored_cells, cells, mp, "correctives.stored_cells")?;
            let cpath = dir.join(CORRECTIVES_FILE);
            let mut layers = read_payload(dir, m, CORRECTIVES_FILE, expected)?;
            let size = atlas_size(c.stored_cells.len(), c.map_res, c.atlas_columns);
            let texels = c.stored_cells.len() * (c.map_res * c.map_res) as usize;
            let mut take = |layer: &str, channel: &str| -> Result<Vec<f32>, FileError> {
                let mut maps = take_channel(&mut layers, &cpath, layer, size, channel)?;
                maps.truncate(texels);
                Ok(maps)
            };
            let maps = take("shift_maps", "D")?;
            let rough_maps = if c.rough_maps.is_some() { take("rough_shift_maps", "D")? } else { Vec::new() };
            let probe_maps = if c.probe_maps.is_some() {
                take("probe_maps", "P")?.into_iter().map(|x| x as u8).collect()
            } else {
                Vec::new()
            };
            (c.map_res, slot, maps, rough_maps, probe_maps)
        }
    };
    Ok(Correctives::new(geometry, map_res, slot, maps, fallback)
        .with_rough_maps(rough_maps)
        .with_probe_maps(probe_maps))
}

/// The cells' irradiance, distance moments and diffuse corrections (atlases arrive tile by
/// tile: the first tiles are the stored cells'), checked.
fn read_irradiance(
    dir: &Path,
    (m, mp): (&GridManifest, &Path),
    expected: &[Expected],
    (geometry, cells): (GridGeometry, usize),
    probe_offset: Vec<Vec3>,
) -> Result<IrradianceGrid, FileError> {
    let ir = &m.irradiance;
    let islot = slots(&ir.stored_cells, cells, mp, "irradiance.stored_cells")?;
    if !(0.0..=1.0).contains(&ir.surface_bias) {
        return Err(invalid(mp, "irradiance.surface_bias", format!("must be in [0, 1], got {}", ir.surface_bias)));
    }
    let mut correction = IrradianceCorrection { surface_bias: ir.surface_bias, ..IrradianceCorrection::default() };
    let (irradiance, depth_mean, depth_mean_sq) = if ir.stored_cells.is_empty() {
        (Vec::new(), Vec::new(), Vec::new())
    } else {
        let ipath = dir.join(IRRADIANCE_FILE);
        let (mut layers, mut e) =
            read_listed_payload_rgb(listing(dir, mp, m), IRRADIANCE_FILE, expected, Some("irradiance"))?;
        let n = ir.stored_cells.len();
        let (r2, dr2) =
            ((ir.resolution * ir.resolution) as usize, (ir.depth_resolution * ir.depth_resolution) as usize);
        let size = atlas_size(n, ir.resolution, ir.atlas_columns);
        layer(&layers, &ipath, "irradiance", size)?;
        e.truncate(n * r2);
        layers.retain(|l| l.name != "irradiance");
        let dsize = atlas_size(n, ir.depth_resolution, ir.atlas_columns);
        let mut mean = take_channel(&mut layers, &ipath, "depth_moments", dsize, "mean")?;
        let mut mean_sq = take_channel(&mut layers, &ipath, "depth_moments", dsize, "mean_sq")?;
        if !ir.corrected_cells.is_empty() {
            let cr = ir.correction_resolution;
            let k = ir.corrected_cells.len();
            let ssize = atlas_size(k, cr, ir.correction_columns);
            let mut scale = take_channel(&mut layers, &ipath, "irradiance_scale", ssize, "S")?;
            // the atlas's unused tail tiles are padding
            scale.truncate(k * (cr * cr) as usize);
            correction = IrradianceCorrection {
                resolution: cr,
                slot: slots(&ir.corrected_cells, cells, mp, "irradiance.corrected_cells")?,
                scale,
                surface_bias: ir.surface_bias,
            };
        }
        e.truncate(n * r2);
        mean.truncate(n * dr2);
        mean_sq.truncate(n * dr2);
        (e, mean, mean_sq)
    };
    Ok(IrradianceGrid {
        geometry,
        resolution: ir.resolution,
        depth_resolution: ir.depth_resolution,
        slot: islot,
        irradiance,
        depth_mean,
        depth_mean_sq,
        correction,
        probe_offset,
    })
}
