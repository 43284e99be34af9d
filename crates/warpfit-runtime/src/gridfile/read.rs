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
use crate::warp::{Method, Proxies, Warp, WarpProbe};
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
    let value: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| FileError::Json { path: path.clone(), message: e.to_string() })?;
    let found = value.get("format").and_then(|v| v.as_str()).unwrap_or("").to_string();
    let version = value.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
    if found != GRID_FORMAT || !(GRID_VERSION_OLDEST as u64..=GRID_VERSION as u64).contains(&version) {
        return Err(FileError::Version { path, found, version, expected: GRID_FORMAT, supported: GRID_VERSION });
    }
    let m: GridManifest =
        serde_json::from_value(value).map_err(|e| FileError::Json { path: path.clone(), message: e.to_string() })?;
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
}

/// The layers of every payload, from the manifest's structural fields; checks the structure
/// on the way (resolutions, mip chains, layer names, sorted unique cells, atlas columns) and
/// that everything decodes within [`MAX_DECODED_BYTES`].
fn expected_payloads(
    m: &GridManifest,
    mp: &Path,
    cells: usize,
) -> Result<Vec<(&'static str, Vec<Expected>)>, FileError> {
    let mut out = vec![(PROBE_FILE, expected_probe(&m.probe, "probe", mp)?)];
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
    for (k, p) in m.other_probes.iter().enumerate() {
        let field = format!("other_probes[{k}]");
        let same = p.resolution == m.probe.resolution
            && p.distance_mips == m.probe.distance_mips
            && p.radiance_mips.len() == m.probe.radiance_mips.len()
            && p.radiance_mips.iter().zip(&m.probe.radiance_mips).all(|(a, b)| a == b);
        if !same {
            return Err(invalid(mp, field, "must have probe A's resolution and mip chains"));
        }
        out.push((PROBE_FILES[k + 1], expected_probe(p, &field, mp)?));
    }
    if let Some(c) = &m.correctives {
        out.push((CORRECTIVES_FILE, expected_correctives(c, m.version, mp, cells)?));
    }
    if let Some(layers) = expected_irradiance(&m.irradiance, mp, cells)? {
        out.push((IRRADIANCE_FILE, layers));
    }
    check_listing(m, mp, &out)?;
    Ok(out)
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
fn expected_probe(p: &ProbeSection, field: &str, mp: &Path) -> Result<Vec<Expected>, FileError> {
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
        probe.push(Expected {
            name: mip.layer.clone(),
            width: n as usize,
            height: n as usize,
            channels: &["R", "G", "B"],
            tiles: None,
        });
    }
    for (k, name) in p.distance_mips.iter().enumerate() {
        let n = p.resolution.checked_shr(k as u32).unwrap_or(0);
        if n == 0 {
            return Err(invalid(mp, format!("{field}.distance_mips"), "more mips than the resolution allows"));
        }
        if *name != distance_layer(k) {
            return Err(invalid(mp, format!("{field}.distance_mips[{k}]"), format!("must be {}", distance_layer(k))));
        }
        probe.push(Expected {
            name: name.clone(),
            width: n as usize,
            height: n as usize,
            channels: &["Z"],
            tiles: None,
        });
    }
    Ok(probe)
}

/// `correctives.exr`'s layers: the shift maps and, from version 5, the rough maps.
fn expected_correctives(
    c: &CorrectiveSection,
    version: u32,
    mp: &Path,
    cells: usize,
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
    let (w, h) = atlas_size(c.stored_cells.len(), c.map_res, c.atlas_columns);
    let layer = |name: &str| Expected {
        name: name.into(),
        width: w,
        height: h,
        channels: &["D"],
        tiles: Some((c.map_res, c.atlas_columns)),
    };
    let mut layers = vec![layer("shift_maps")];
    if c.rough_maps.is_some() {
        layers.push(layer("rough_shift_maps"));
    }
    if c.probe_maps.is_some() {
        if version < 6 {
            return Err(invalid(mp, "correctives.probe_maps", "probe maps need format version 6"));
        }
        layers.push(Expected { channels: &["P"], ..layer("probe_maps") });
    }
    Ok(layers)
}

/// `irradiance.exr`'s layers (none when no cell stores irradiance): irradiance, distance
/// moments and the diffuse corrections' scales.
fn expected_irradiance(ir: &IrradianceSection, mp: &Path, cells: usize) -> Result<Option<Vec<Expected>>, FileError> {
    if !tile_ok(ir.resolution) || !tile_ok(ir.depth_resolution) {
        return Err(invalid(mp, "irradiance", format!("resolutions must be even sizes in 2..={MAX_TILE_RESOLUTION}")));
    }
    cells_ok(&ir.stored_cells, "irradiance.stored_cells", cells, mp)?;
    if !ir.stored_cells.is_empty() {
        let n = ir.stored_cells.len();
        columns_ok(n, ir.atlas_columns, "irradiance.atlas_columns", mp)?;
        let (w, h) = atlas_size(n, ir.resolution, ir.atlas_columns);
        let (dw, dh) = atlas_size(n, ir.depth_resolution, ir.atlas_columns);
        let mut layers = vec![
            Expected {
                name: "irradiance".into(),
                width: w,
                height: h,
                channels: &["R", "G", "B"],
                tiles: Some((ir.resolution, ir.atlas_columns)),
            },
            Expected {
                name: "depth_moments".into(),
                width: dw,
                height: dh,
                channels: &["mean", "mean_sq"],
                tiles: Some((ir.depth_resolution, ir.atlas_columns)),
            },
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
            let (sw, sh) = atlas_size(ir.corrected_cells.len(), ir.correction_resolution, ir.correction_columns);
            layers.push(Expected {
                name: "irradiance_scale".into(),
                width: sw,
                height: sh,
                channels: &["S"],
                tiles: Some((ir.correction_resolution, ir.correction_columns)),
            });
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
    let decoded: u64 = out
        .iter()
        .flat_map(|(_, layers)| layers)
        .map(|l| l.width as u64 * l.height as u64 * l.channels.len() as u64 * 4)
        .sum();
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
        }
    }
    Ok(())
}

/// Reads a payload: a regular file whose size (from its metadata) and checksum match the
/// manifest, whose EXR headers match the expected layers, then decoded.
fn read_payload(dir: &Path, m: &GridManifest, file: &str, expected: &[Expected]) -> Result<Vec<Layer>, FileError> {
    Ok(read_listed_payload_rgb(dir, &dir.join(MANIFEST_FILE), &m.payloads, file, expected, None)?.0)
}

/// Reads payload `file` of `dir` as `payloads` (from the manifest at `mpath`) lists it:
/// size, checksum and EXR headers checked against the listing and `expected` before a byte
/// is decoded, then the layers' sizes and channels.
pub fn read_listed_payload(
    dir: &Path,
    mpath: &Path,
    payloads: &[Payload],
    file: &str,
    expected: &[Expected],
) -> Result<Vec<Layer>, FileError> {
    Ok(read_listed_payload_rgb(dir, mpath, payloads, file, expected, None)?.0)
}

/// [`read_listed_payload`], the R, G and B channels of layer `rgb` (when named) decoded
/// straight into triples in the layer's placed order (its channels come back empty): a big
/// grid's irradiance is never held as three channels and a copy.
pub fn read_listed_payload_rgb(
    dir: &Path,
    mpath: &Path,
    payloads: &[Payload],
    file: &str,
    expected: &[Expected],
    rgb: Option<&str>,
) -> Result<(Vec<Layer>, Vec<Vec3>), FileError> {
    let entry = payloads
        .iter()
        .find(|p| p.file == file)
        .ok_or_else(|| invalid(mpath, "payloads", format!("no entry for {file}")))?;
    let path = dir.join(file);
    // size and checksum read through the file in pieces: its bytes are never held whole
    let mut f = crate::files::open_listed(&path, entry.bytes, &entry.checksum)?;
    // Check the headers against the expected layers before decoding: a damaged header can
    // claim a layer of any size, and decoding would try to allocate it.
    check_headers(&path, &mut f, expected)?;
    // (name, size, tiles) of the atlas layers
    let atlases: Vec<_> =
        expected.iter().filter_map(|l| Some((l.name.clone(), (l.width, l.height), l.tiles?))).collect();
    let place = move |name: &str, w: usize, h: usize| -> Option<exr::Placement> {
        let &(_, _, (res, columns)) = atlases.iter().find(|(n, size, _)| n == name && *size == (w, h))?;
        Some(std::sync::Arc::new(move |i| tile_major(i, res, columns)))
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
    Ok((layers, triples))
}

/// Checks the EXR headers of the open payload `f` against `expected`, and rewinds it.
fn check_headers(path: &Path, f: &mut std::fs::File, expected: &[Expected]) -> Result<(), FileError> {
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

/// Checks every value with `ok`; names the first offender.
fn check(path: &Path, field: &str, values: &[f32], what: &str, ok: impl Fn(f32) -> bool) -> Result<(), FileError> {
    match values.iter().position(|&v| !ok(v)) {
        Some(k) => Err(invalid(path, field, format!("sample {k} is {}: expected {what}", values[k]))),
        None => Ok(()),
    }
}

/// The RGB samples of a layer (every sample checked).
fn rgb(l: &Layer, path: &Path) -> Result<Vec<Vec3>, FileError> {
    let (r, g, b) = (channel(l, path, "R")?, channel(l, path, "G")?, channel(l, path, "B")?);
    let v: Vec<Vec3> = (0..r.len().min(g.len()).min(b.len())).map(|k| Vec3::new(r[k], g[k], b[k])).collect();
    check_rgb(path, &l.name, &v)?;
    Ok(v)
}

/// Checks every component of layer `layer`'s triples: R first, then G, then B, each
/// failure naming the channel and the sample.
fn check_rgb(path: &Path, layer: &str, v: &[Vec3]) -> Result<(), FileError> {
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        if let Some(k) = v.iter().position(|x| !(0.0..=MAX_RADIANCE).contains(&x[c])) {
            return Err(invalid(
                path,
                format!("{layer}.{name}"),
                format!("sample {k} is {}: expected in [0, {MAX_RADIANCE:e}]", v[k][c]),
            ));
        }
    }
    Ok(())
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
    let probe_offset = read_relocated(&m, mp, &geometry, cells)?;
    let bounds = ValueBounds::of_diagonal((geometry.max - geometry.min).length());
    let expected = expected_payloads(&m, mp, cells)?;
    let probe =
        read_probe(dir, (&m, mp), (PROBE_FILE, &m.probe, "probe"), expected_of(&expected, PROBE_FILE), &bounds)?;
    let mut others = Vec::with_capacity(m.other_probes.len());
    for (k, p) in m.other_probes.iter().enumerate() {
        let (file, field) = (PROBE_FILES[k + 1], format!("other_probes[{k}]"));
        others.push(read_probe(dir, (&m, mp), (file, p, &field), expected_of(&expected, file), &bounds)?);
    }
    let (fallback, proxies) = read_proxies(&m, mp)?;
    let correctives = read_correctives(
        dir,
        (&m, mp),
        expected_of(&expected, CORRECTIVES_FILE),
        (geometry, cells),
        fallback,
        &bounds,
    )?;
    let irradiance = read_irradiance(
        dir,
        (&m, mp),
        expected_of(&expected, IRRADIANCE_FILE),
        (geometry, cells),
        probe_offset,
        &bounds,
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

/// The relocated cell probes' offsets (empty when none moved): sorted, unique, in range,
/// within half a cell of their centre.
fn read_relocated(m: &GridManifest, mp: &Path, geometry: &GridGeometry, cells: usize) -> Result<Vec<Vec3>, FileError> {
    let mut probe_offset = Vec::new();
    if !m.grid.relocated.is_empty() {
        probe_offset = vec![Vec3::ZERO; cells];
        let half = geometry.cell_size() * 0.5;
        let mut last = None;
        for &(c, o) in &m.grid.relocated {
            let o = Vec3::from_array(o);
            if last.is_some_and(|l| c <= l) {
                return Err(invalid(mp, "grid.relocated", "cells must be sorted and unique"));
            }
            last = Some(c);
            let slot = probe_offset
                .get_mut(c as usize)
                .ok_or_else(|| invalid(mp, "grid.relocated", format!("cell {c} out of range")))?;
            if !(o.is_finite() && o.abs().cmple(half).all() && o != Vec3::ZERO) {
                return Err(invalid(
                    mp,
                    "grid.relocated",
                    format!("cell {c}: offset {o} is zero, not finite or leaves its cell"),
                ));
            }
            *slot = o;
        }
    }
    Ok(probe_offset)
}

/// A probe from its file (probe A's `probe.exr`, `file` with manifest section `p` named
/// `field`): the radiance chain and the distance chain, values checked.
fn read_probe(
    dir: &Path,
    (m, mp): (&GridManifest, &Path),
    (file, p, field): (&str, &ProbeSection, &str),
    expected: &[Expected],
    bounds: &ValueBounds,
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
        let dmax = bounds.max_distance;
        check(&ppath, &format!("{name}.Z"), z, &format!("a distance in [0, {dmax:e}] or +inf"), |d| {
            d >= 0.0 && (d <= dmax || d == f32::INFINITY)
        })?;
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
fn read_proxies(m: &GridManifest, mp: &Path) -> Result<(Method, Proxies), FileError> {
    let w = &m.warp;
    let fallback = match Method::parse(&w.fallback) {
        Some(f @ (Method::Box | Method::Kdop | Method::Warp1)) => f,
        _ => return Err(invalid(mp, "warp.fallback", format!("{:?} is not a proxy (box, kdop or warp1)", w.fallback))),
    };
    let o = &w.options;
    if !(o.depth_lod.is_finite() && o.depth_lod >= 0.0 && o.relax_texels.is_finite() && o.relax_texels >= 0.0)
        || o.secant_steps > 64
        || o.march_steps > 4096
    {
        return Err(invalid(mp, "warp.options", "depth_lod and relax_texels must be finite and ≥ 0, steps bounded"));
    }
    let b = &w.box_proxy;
    let rotation = Quat::from_array(b.rotation);
    if !rotation.is_finite() || rotation.length() < 1e-3 {
        return Err(invalid(mp, "warp.box_proxy.rotation", "not a finite non-zero quaternion"));
    }
    let aabb = BoxProxy::oriented(
        finite3(b.centre, mp, "warp.box_proxy.centre")?,
        rotation,
        finite3(b.half_extents, mp, "warp.box_proxy.half_extents")?,
    );
    let mut kdop = Kdop { normals: Vec::new(), offsets: Vec::new() };
    for (k, plane) in w.kdop.iter().enumerate() {
        let n = finite3(plane.normal, mp, &format!("warp.kdop[{k}].normal"))?;
        let h = match plane.offset {
            Some(h) if h.is_finite() => h,
            Some(_) => return Err(invalid(mp, format!("warp.kdop[{k}].offset"), "not finite")),
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
    bounds: &ValueBounds,
) -> Result<Correctives, FileError> {
    let (map_res, slot, maps, rough_maps, probe_maps) = match &m.correctives {
        None => (8, vec![NO_MAP; cells], Vec::new(), Vec::new(), Vec::new()),
        Some(c) => {
            let slot = slots(&c.stored_cells, cells, mp, "correctives.stored_cells")?;
            let cpath = dir.join(CORRECTIVES_FILE);
            let mut layers = read_payload(dir, m, CORRECTIVES_FILE, expected)?;
            let size = atlas_size(c.stored_cells.len(), c.map_res, c.atlas_columns);
            let dmax = bounds.max_distance;
            let mut take = |layer: &str| -> Result<Vec<f32>, FileError> {
                let mut maps = take_channel(&mut layers, &cpath, layer, size, "D")?;
                check(&cpath, &format!("{layer}.D"), &maps, &format!("a shift in [-{dmax:e}, {dmax:e}]"), |x| {
                    (-dmax..=dmax).contains(&x)
                })?;
                maps.truncate(c.stored_cells.len() * (c.map_res * c.map_res) as usize);
                Ok(maps)
            };
            let maps = take("shift_maps")?;
            let rough_maps = if c.rough_maps.is_some() { take("rough_shift_maps")? } else { Vec::new() };
            let probe_maps = if c.probe_maps.is_some() {
                let probes = m.other_probes.len() + 1;
                if probes < 2 {
                    return Err(invalid(mp, "correctives.probe_maps", "present, but the grid has one probe"));
                }
                let mut p = take_channel(&mut layers, &cpath, "probe_maps", size, "P")?;
                let what = format!("a probe index in 0..{probes}");
                check(&cpath, "probe_maps.P", &p, &what, |x| x >= 0.0 && x < probes as f32 && x.fract() == 0.0)?;
                p.truncate(c.stored_cells.len() * (c.map_res * c.map_res) as usize);
                p.into_iter().map(|x| x as u8).collect()
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
    bounds: &ValueBounds,
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
            read_listed_payload_rgb(dir, mp, &m.payloads, IRRADIANCE_FILE, expected, Some("irradiance"))?;
        let n = ir.stored_cells.len();
        let (r2, dr2) =
            ((ir.resolution * ir.resolution) as usize, (ir.depth_resolution * ir.depth_resolution) as usize);
        let size = atlas_size(n, ir.resolution, ir.atlas_columns);
        layer(&layers, &ipath, "irradiance", size)?;
        check_rgb(&ipath, "irradiance", &e)?;
        e.truncate(n * r2);
        layers.retain(|l| l.name != "irradiance");
        let dsize = atlas_size(n, ir.depth_resolution, ir.atlas_columns);
        let mut mean = take_channel(&mut layers, &ipath, "depth_moments", dsize, "mean")?;
        let mut mean_sq = take_channel(&mut layers, &ipath, "depth_moments", dsize, "mean_sq")?;
        let dmax = bounds.max_distance;
        check(&ipath, "depth_moments.mean", &mean, &format!("in [0, {dmax:e}]"), |x| (0.0..=dmax).contains(&x))?;
        let d2 = dmax * dmax;
        check(&ipath, "depth_moments.mean_sq", &mean_sq, &format!("in [0, {d2:e}]"), |x| (0.0..=d2).contains(&x))?;
        if !ir.corrected_cells.is_empty() {
            let cr = ir.correction_resolution;
            let k = ir.corrected_cells.len();
            let ssize = atlas_size(k, cr, ir.correction_columns);
            let mut scale = take_channel(&mut layers, &ipath, "irradiance_scale", ssize, "S")?;
            // the atlas's unused tail tiles are padding: only the cells' tiles are checked
            scale.truncate(k * (cr * cr) as usize);
            check(&ipath, "irradiance_scale.S", &scale, "a scale in (0, 100]", |x| x > 0.0 && x <= 100.0)?;
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
