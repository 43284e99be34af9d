//! `warpfit-bake`, the bake folder: `probe.exr`, `grid.exr` and `manifest.json` (the job
//! that writes it adds PNG previews).
//!
//! `probe.exr` has the fitted grid's probe layout (`gridfile::probe_layers`):
//! `radiance_mip{m}` (R, G, B; GGX-prefiltered, roughness in the manifest) and
//! `distance_mip{m}` (Z; distance, +inf on miss; mip 0 = texel-centre distances).
//! `grid.exr` layers: `irradiance` (R, G, B) and `depth_moments` (mean, mean_sq, hit) atlases;
//! cell (x, y, z) occupies tile column x, tile row y + ny·z, tiles of the map's resolution.

pub mod manifest;

use crate::bake::grid::hit_fraction;
use crate::bake::{Bake, GridGeometry, ProbeGrid, SpecularProbe};
use crate::files::{FileError, write_json};
use crate::gridfile::exr::{self, ExrLayer, Samples};
use crate::gridfile::read::{Expected, Listing, Rule, check_listed_payload, scan_listed_payload};
use crate::gridfile::schema::{
    LayerEntry, MAX_CELLS, MAX_PROBE_RESOLUTION, MAX_RADIANCE, MAX_TILE_RESOLUTION, PER_CELL_BYTES, Payload, Precision,
    SCAN_ABOVE_BYTES, tile_major,
};
use crate::gridfile::{distance_layer, probe_layers, radiance_layer};
use crate::octa::{CONVENTION, OctMap, OctMips};
use crate::scene::Scene;
use glam::{UVec3, Vec3};
use manifest::*;
use std::path::Path;

pub const PROBE_FILE: &str = "probe.exr";
pub const GRID_FILE: &str = "grid.exr";
pub const MANIFEST_FILE: &str = "manifest.json";

/// A channel of per-cell maps (cell-major, `res²` texels each) laid out as the atlas (see
/// the module docs), each sample read from `per_cell` when the encoder asks for it: the
/// atlas is never built. Tile column x, row y + ny·z is cell x + nx·(y + ny·z).
fn atlas_channel<'a, T: Copy + Sync>(
    g: &GridGeometry,
    res: u32,
    per_cell: &'a [T],
    value: impl Fn(T) -> f32 + Sync + 'a,
) -> Samples<'a> {
    let nx = g.counts.x;
    Samples::Computed(Box::new(move |k| value(per_cell[tile_major(k, res, nx)])))
}

/// The layers of `grid.exr`: the grid's per-cell maps as atlases, read in place.
pub fn grid_layers(g: &ProbeGrid) -> Vec<ExrLayer<Samples<'_>>> {
    let geo = &g.geometry;
    let (ir, dr) = (g.irradiance_resolution, g.depth_resolution);
    let (nx, rows) = (geo.counts.x as usize, (geo.counts.y * geo.counts.z) as usize);
    let irr = |f: fn(Vec3) -> f32| atlas_channel(geo, ir, &g.irradiance, f);
    let depth = |v| atlas_channel(geo, dr, v, |x: f32| x);
    vec![
        ExrLayer {
            name: "irradiance".into(),
            width: nx * ir as usize,
            height: rows * ir as usize,
            channels: vec![("R".into(), irr(|v| v.x)), ("G".into(), irr(|v| v.y)), ("B".into(), irr(|v| v.z))],
        },
        ExrLayer {
            name: "depth_moments".into(),
            width: nx * dr as usize,
            height: rows * dr as usize,
            channels: vec![
                ("mean".into(), depth(&g.depth_mean)),
                ("mean_sq".into(), depth(&g.depth_mean_sq)),
                ("hit".into(), atlas_channel(geo, dr, &g.hits, move |h| hit_fraction(h, g.depth_samples))),
            ],
        },
    ]
}

/// The file of the scene's probe `k` ≥ 1 (probe A's is [`PROBE_FILE`]).
#[must_use]
pub fn other_file(k: usize) -> String {
    format!("probe_{k}.exr")
}

/// A probe's entry in the bake manifest, its layers in `file`.
fn probe_manifest(scene: &Scene, p: &SpecularProbe, file: String) -> ProbeManifest {
    ProbeManifest {
        file,
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
    }
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
        probe: probe_manifest(scene, p, PROBE_FILE.into()),
        others: bake.others.iter().enumerate().map(|(k, o)| probe_manifest(scene, o, other_file(k + 1))).collect(),
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
    let probes = std::iter::once(&bake.probe).chain(&bake.others);
    let names = std::iter::once(PROBE_FILE.to_string()).chain((1..=bake.others.len()).map(other_file));
    for (file, p) in names.zip(probes) {
        let layers: Vec<ExrLayer<Samples>> =
            probe_layers(&p.radiance, &p.depth).into_iter().map(crate::gridfile::exr::IntoLayer::into_layer).collect();
        let path = dir.join(&file);
        let (bytes, checksum) = exr::write_payload(&path, layers, |_| false)?;
        files.push(FileEntry { file, bytes, checksum });
    }
    // the grid's layers read in place
    let path = dir.join(GRID_FILE);
    let (bytes, checksum) = exr::write_payload(&path, grid_layers(&bake.grid), |_| false)?;
    files.push(FileEntry { file: GRID_FILE.into(), bytes, checksum });
    write_json(&dir.join(MANIFEST_FILE), &BakeManifest { files, ..build_manifest(scene, bake) })
}

/// A payload of the bake, checked against the manifest's size and checksum, decoded with
/// each channel's samples where `route` sends them.
fn read_payload(
    dir: &Path,
    m: &BakeManifest,
    file: &str,
    route: impl Fn(&str, &str, usize, usize) -> exr::Destination + 'static,
) -> Result<Vec<ExrLayer>, FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let entry = m
        .files
        .iter()
        .find(|f| f.file == file)
        .ok_or_else(|| FileError::invalid(&mpath, "files", format!("no entry for {file}")))?;
    let path = dir.join(file);
    let f = crate::files::open_listed(&path, entry.bytes, &entry.checksum)?;
    exr::decode_routed(&path, f, route)
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
    check_radiance(&v, path, &l.name)?;
    Ok(v)
}

/// Radiance as the bake writes it: finite, in [0, `MAX_RADIANCE`].
fn check_radiance(v: &[Vec3], path: &Path, layer: &str) -> Result<(), FileError> {
    match v.iter().position(|x| !(x.is_finite() && x.min_element() >= 0.0 && x.max_element() <= MAX_RADIANCE)) {
        Some(k) => Err(FileError::invalid(
            path,
            layer,
            format!("texel {k} is {}: expected radiance in [0, {MAX_RADIANCE:e}]", v[k]),
        )),
        None => Ok(()),
    }
}

/// The layers a probe of the bake must hold (`p`, the manifest's section `field`), from its
/// structure, checked on the way.
fn expected_probe(p: &ProbeManifest, field: &str, mpath: &Path) -> Result<Vec<Expected>, FileError> {
    let bad = |f: String, m: &str| FileError::invalid(mpath, f, m);
    if !(1..=MAX_PROBE_RESOLUTION).contains(&p.resolution) {
        return Err(bad(format!("{field}.resolution"), "out of range"));
    }
    if p.radiance_mips.is_empty() || p.distance_mips.is_empty() {
        return Err(bad(field.into(), "no mips listed"));
    }
    let distance = Rule { infinite: true, ..Rule::within(0.0, f32::MAX, 0, "a distance ≥ 0 or +inf") };
    let mut out = Vec::new();
    for (k, mip) in p.radiance_mips.iter().enumerate() {
        let n = p.resolution.checked_shr(k as u32).unwrap_or(0);
        if mip.resolution != n || n == 0 || mip.layer != radiance_layer(k) {
            return Err(bad(format!("{field}.radiance_mips[{k}]"), "not this format's mip chain"));
        }
        out.push(Expected::square(mip.layer.clone(), n, &["R", "G", "B"], &Rule::radiance(0)));
    }
    for (k, name) in p.distance_mips.iter().enumerate() {
        let n = p.resolution.checked_shr(k as u32).unwrap_or(0);
        if n == 0 || *name != distance_layer(k) {
            return Err(bad(format!("{field}.distance_mips[{k}]"), "not this format's mip chain"));
        }
        out.push(Expected::square(name.clone(), n, &["Z"], &distance));
    }
    Ok(out)
}

/// The layers `grid.exr` must hold, from the manifest's grid section, checked on the way.
fn expected_grid(m: &BakeManifest, mpath: &Path) -> Result<(Vec<Expected>, u64), FileError> {
    let g = &m.grid;
    let cells = g.counts.iter().try_fold(1u64, |a, &c| (c > 0).then(|| a * c as u64));
    let Some(cells) = cells.filter(|&n| n <= MAX_CELLS) else {
        return Err(FileError::invalid(mpath, "grid.counts", format!("each ≥ 1, at most {MAX_CELLS} cells")));
    };
    let (ir, dr) = (g.irradiance_resolution, g.depth_resolution);
    if !(1..=MAX_TILE_RESOLUTION).contains(&ir) || !(1..=MAX_TILE_RESOLUTION).contains(&dr) {
        return Err(FileError::invalid(mpath, "grid", format!("map resolutions must be in 1..={MAX_TILE_RESOLUTION}")));
    }
    let atlas = |res| (cells as usize, res, g.counts[0]);
    let moment = Rule::within(0.0, f32::MAX, 0, "finite and ≥ 0");
    let radiance = Rule::radiance(0);
    let layers = vec![
        Expected::atlas("irradiance", atlas(ir), &["R", "G", "B"], &[radiance.clone(), radiance.clone(), radiance]),
        Expected::atlas(
            "depth_moments",
            atlas(dr),
            &["mean", "mean_sq", "hit"],
            &[moment.clone(), moment, Rule::within(0.0, 1.0, 0, "a fraction in [0, 1]")],
        ),
    ];
    Ok((layers, cells))
}

/// Every payload of bake `m` in `dir` checked before any is decoded: its size, checksum and
/// EXR headers against the layers its manifest's structure gives; a bake that would need
/// more than `SCAN_ABOVE_BYTES` in memory also has its values streamed through their rules,
/// so a damaged bake is refused at a bounded cost instead of after it is decoded.
fn check_payloads(dir: &Path, m: &BakeManifest) -> Result<(), FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let mut expected = vec![(m.probe.file.clone(), expected_probe(&m.probe, "probe", &mpath)?)];
    for (k, p) in m.others.iter().enumerate() {
        expected.push((p.file.clone(), expected_probe(p, &format!("others[{k}]"), &mpath)?));
    }
    let (grid, cells) = expected_grid(m, &mpath)?;
    expected.push((GRID_FILE.into(), grid));
    // the bake's listing with the layers its structure gives, all f32 as the bake writes them
    let listing: Vec<Payload> = m
        .files
        .iter()
        .map(|f| Payload {
            file: f.file.clone(),
            bytes: f.bytes,
            checksum: f.checksum.clone(),
            layers: expected
                .iter()
                .filter(|(file, _)| *file == f.file)
                .flat_map(|(_, layers)| layers)
                .map(|l| LayerEntry {
                    name: l.name.clone(),
                    width: l.width as u32,
                    height: l.height as u32,
                    channels: l.channels.iter().map(|c| c.to_string()).collect(),
                    precision: Precision::F32,
                })
                .collect(),
        })
        .collect();
    let bytes: u64 = expected.iter().flat_map(|(_, l)| l).map(Expected::decoded_bytes).sum();
    let scan = bytes + cells * PER_CELL_BYTES > SCAN_ABOVE_BYTES;
    let listed = Listing { dir, manifest: &mpath, payloads: &listing };
    for (file, layers) in &expected {
        if scan {
            scan_listed_payload(listed, file, layers)?;
        } else {
            check_listed_payload(listed, file, layers)?;
        }
    }
    Ok(())
}

/// Each texel's hit count, and the first texel whose fraction is no count (with it).
type Counts = (Vec<u8>, Option<(usize, f32)>);

/// The hit fractions of a bake's distance texels decoded straight into counts (a byte
/// each, in the grid's placed order): a fraction that is not exactly a count of `samples`
/// rays (as the bake writes them) is an error naming the first such texel.
struct HitSink {
    counts: std::sync::Arc<std::sync::Mutex<Counts>>,
    samples: u32,
    place: exr::Placement,
}

impl HitSink {
    fn new(len: usize, samples: u32, place: exr::Placement) -> HitSink {
        HitSink { counts: std::sync::Arc::new(std::sync::Mutex::new((vec![0; len], None))), samples, place }
    }

    fn sink(&self) -> exr::Sink {
        let (counts, samples, place) = (self.counts.clone(), self.samples, self.place.clone());
        Box::new(move |start: usize, line: &[f32]| {
            let mut guard = counts.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let (counts, bad) = &mut *guard;
            let last = counts.len().saturating_sub(1);
            for (i, &f) in line.iter().enumerate() {
                let k = place(start + i).min(last);
                match hit_count(f, samples) {
                    Some(h) => counts[k] = h,
                    None if bad.is_none_or(|(b, _)| k < b) => *bad = Some((k, f)),
                    None => {}
                }
            }
        })
    }

    fn take(self, path: &Path) -> Result<Vec<u8>, FileError> {
        let (counts, bad) = std::mem::take(&mut *self.counts.lock().unwrap_or_else(std::sync::PoisonError::into_inner));
        match bad {
            Some((k, f)) => Err(FileError::invalid(
                path,
                "depth_moments.hit",
                format!("texel {k}: {f} is not a count of {} rays", self.samples),
            )),
            None => Ok(counts),
        }
    }
}

/// The sink of a bake's hit fractions, placed in the grid's cell-major order.
fn hit_sink(m: &BakeManifest, geometry: GridGeometry) -> HitSink {
    let (dr, nx) = (m.grid.depth_resolution, geometry.counts.x);
    let len = geometry.cell_count() * (dr * dr) as usize;
    HitSink::new(len, m.grid.depth_samples, std::sync::Arc::new(move |k| tile_major(k, dr, nx)))
}

/// The hit counts of `grid`, a bake with content key `key` that [`read_bake_with`] read from
/// `dir` without them: the grid file is read again (checked against its manifest, which
/// must still be that bake's) and only its `hit` channel kept.
pub fn read_hits(dir: &Path, key: &str, grid: &ProbeGrid) -> Result<Vec<u8>, FileError> {
    let m = &read_manifest(dir)?;
    let same = m.key == key
        && m.grid.counts == grid.geometry.counts.to_array()
        && m.grid.depth_resolution == grid.depth_resolution
        && m.grid.depth_samples == grid.depth_samples;
    if !same {
        return Err(FileError::invalid(
            &dir.join(MANIFEST_FILE),
            "key",
            format!("the bake changed since it was read (key {}, expected {key}): run again", m.key),
        ));
    }
    let gpath = dir.join(GRID_FILE);
    let hits = hit_sink(m, grid.geometry);
    let sink = std::cell::RefCell::new(Some(hits.sink()));
    let route = move |layer: &str, channel: &str, _: usize, _: usize| -> exr::Destination {
        let taken = (layer == "depth_moments" && channel == "hit").then(|| sink.borrow_mut().take()).flatten();
        exr::Destination::Sink(taken.unwrap_or_else(|| Box::new(|_: usize, _: &[f32]| {})))
    };
    let layers = read_payload(dir, m, GRID_FILE, route)?;
    let (d, c) = (grid.depth_resolution as usize, grid.geometry.counts);
    channel(find(&layers, &gpath, "depth_moments", (c.x as usize * d, (c.y * c.z) as usize * d))?, &gpath, "hit")?;
    hits.take(&gpath)
}

/// The hit count whose fraction of `samples` rays is exactly `f`, if there is one.
fn hit_count(f: f32, samples: u32) -> Option<u8> {
    let n = (f * samples as f32).round();
    (0.0..=samples as f32)
        .contains(&n)
        .then_some(n as u8)
        .filter(|&h| hit_fraction(h, samples).to_bits() == f.to_bits())
}

/// The content key a bake folder's manifest records, if it has a readable one.
#[must_use]
pub fn manifest_key(dir: &Path) -> Option<String> {
    let bytes = crate::files::read_regular(&dir.join(MANIFEST_FILE), crate::files::MAX_JSON_BYTES).ok()?;
    let v: serde_json::Value = serde_json::from_slice(&bytes).ok()?;
    v.get("key").and_then(|k| k.as_str()).map(str::to_string)
}

/// A bake folder's manifest, its format and version checked.
fn read_manifest(dir: &Path) -> Result<BakeManifest, FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let bytes = crate::files::read_regular(&mpath, crate::files::MAX_JSON_BYTES)?;
    let probe_format: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| FileError::Json { path: mpath.clone(), message: e.to_string() })?;
    let found = probe_format.get("format").and_then(|v| v.as_str()).unwrap_or("").to_string();
    let version = probe_format.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
    if found != BAKE_FORMAT || version != BAKE_VERSION as u64 {
        return Err(FileError::Version { path: mpath, found, version, expected: BAKE_FORMAT, supported: BAKE_VERSION });
    }
    serde_json::from_value(probe_format).map_err(|e| FileError::Json { path: mpath, message: e.to_string() })
}

/// A probe of the bake (`p`, an entry of manifest `m`), its values checked.
fn read_probe(dir: &Path, m: &BakeManifest, p: &ProbeManifest) -> Result<SpecularProbe, FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let ppath = dir.join(&p.file);
    let layers = read_payload(dir, m, &p.file, |_, _, _, _| exr::Destination::Own(None))?;
    let mut radiance = Vec::new();
    for mip in &p.radiance_mips {
        let n = mip.resolution as usize;
        let l = find(&layers, &ppath, &mip.layer, (n, n))?;
        radiance.push(OctMap::new(mip.resolution, finite_rgb(l, &ppath)?));
    }
    let mut depth = Vec::new();
    for (k, name) in p.distance_mips.iter().enumerate() {
        let n = (p.resolution >> k) as usize;
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
    let position = Vec3::from_array(p.position);
    if !position.is_finite() {
        return Err(FileError::invalid(&mpath, "probe.position", "not finite"));
    }
    Ok(SpecularProbe {
        position,
        roughness: p.radiance_mips.iter().map(|x| x.perceptual_roughness).collect(),
        radiance: OctMips { levels: radiance },
        depth: OctMips { levels: depth },
    })
}

/// The other probes of the bake in `dir` whose manifest [`read_bake_with`] gave as `m`:
/// each file named as the format names it, with probe A's resolution and mip chain.
pub fn read_others(dir: &Path, m: &BakeManifest) -> Result<Vec<SpecularProbe>, FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    if m.others.len() >= crate::scene::config::MAX_PROBES as usize {
        return Err(FileError::invalid(
            &mpath,
            "others",
            format!("{} probes, at most {} in all", m.others.len() + 1, crate::scene::config::MAX_PROBES),
        ));
    }
    m.others
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let field = format!("others[{k}]");
            if p.file != other_file(k + 1) {
                return Err(FileError::invalid(
                    &mpath,
                    format!("{field}.file"),
                    format!("must be {}", other_file(k + 1)),
                ));
            }
            if p.resolution != m.probe.resolution || p.radiance_mips.len() != m.probe.radiance_mips.len() {
                return Err(FileError::invalid(&mpath, field, "does not have probe A's resolution and mips"));
            }
            read_probe(dir, m, p)
        })
        .collect()
}

/// Whether bake `m` (read from `dir`) has the structure `scene` asks for: probe A's
/// resolution, the grid's counts, map resolutions and depth samples. Its key says it was
/// made from this scene; this catches a manifest edited without its key.
pub fn agrees_with_scene(dir: &Path, m: &BakeManifest, scene: &Scene) -> Result<(), FileError> {
    let (p, g) = (&scene.config.probe, &scene.config.grid);
    let found = (
        m.probe.resolution,
        m.grid.counts,
        m.grid.irradiance_resolution,
        m.grid.depth_resolution,
        m.grid.depth_samples,
    );
    let asked = (p.resolution, g.counts, g.irradiance_resolution, g.depth_resolution, g.depth_samples);
    if found != asked {
        return Err(FileError::invalid(
            &dir.join(MANIFEST_FILE),
            "probe/grid",
            format!(
                "records (probe resolution, counts, irradiance, depth resolution, depth samples) {found:?}, the scene asks {asked:?}"
            ),
        ));
    }
    Ok(())
}

/// When a bake's hit counts are read ([`ProbeGrid::hits`]): only a fit's cells stage reads
/// them, so a fit of a big level can leave them on disk until then.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hits {
    /// With the rest of the grid.
    WithGrid,
    /// Not now: the grid's `hits` stay empty until [`read_hits`] reads them.
    Later,
}

/// Reads a bake folder back, validating versions, sizes and values.
pub fn read_bake(dir: &Path) -> Result<(BakeManifest, SpecularProbe, ProbeGrid), FileError> {
    read_bake_with(dir, Hits::WithGrid)
}

/// [`read_bake`], the grid's hit counts read now or left for [`read_hits`].
pub fn read_bake_with(dir: &Path, when: Hits) -> Result<(BakeManifest, SpecularProbe, ProbeGrid), FileError> {
    let mpath = dir.join(MANIFEST_FILE);
    let m = read_manifest(dir)?;
    if m.probe.file != PROBE_FILE || m.grid.file != GRID_FILE {
        return Err(FileError::invalid(&mpath, "probe.file/grid.file", "not this format's file names"));
    }
    if let Some((k, p)) = m.others.iter().enumerate().find(|(k, p)| p.file != other_file(k + 1)) {
        return Err(FileError::invalid(
            &mpath,
            format!("others[{k}].file"),
            format!("{}: must be {}", p.file, other_file(k + 1)),
        ));
    }
    check_payloads(dir, &m)?;
    let probe = read_probe(dir, &m, &m.probe)?;
    let gpath = dir.join(GRID_FILE);
    let geometry = GridGeometry {
        min: Vec3::from_array(m.grid.min),
        max: Vec3::from_array(m.grid.max),
        counts: UVec3::from_array(m.grid.counts),
    };
    let max = crate::scene::MAX_DEPTH_SAMPLES;
    if !(1..=max).contains(&m.grid.depth_samples) {
        return Err(FileError::Invalid {
            path: mpath.clone(),
            field: "grid.depth_samples".into(),
            message: format!("must be in 1..={max}, got {}", m.grid.depth_samples),
        });
    }
    let (ir, dr) = (m.grid.irradiance_resolution, m.grid.depth_resolution);
    let c = geometry.counts;
    let irr_size = ((c.x * ir) as usize, (c.y * c.z * ir) as usize);
    let dep_size = ((c.x * dr) as usize, (c.y * c.z * dr) as usize);
    // the atlases' tiles arrive as per-cell maps, cell-major, as they are decoded, the
    // irradiance as triples and the hit fractions as counts: a big grid's bake is read with
    // one copy of it in memory, in the grid's own form
    let nx = c.x;
    let place = move |layer: &str, w: usize, h: usize| -> Option<exr::Placement> {
        let (r, size) = match layer {
            "irradiance" => (ir, irr_size),
            "depth_moments" => (dr, dep_size),
            _ => return None,
        };
        (size == (w, h)).then(|| -> exr::Placement { std::sync::Arc::new(move |k| tile_major(k, r, nx)) })
    };
    let irradiance = exr::RgbSink::new(irr_size.0 * irr_size.1, std::sync::Arc::new(move |k| tile_major(k, ir, nx)));
    let hits = (when == Hits::WithGrid).then(|| hit_sink(&m, geometry));
    let mut sinks = irradiance.sinks("irradiance");
    let hit_channel = match &hits {
        Some(h) => h.sink(),
        None => Box::new(|_: usize, _: &[f32]| {}),
    };
    sinks.push(("depth_moments".into(), "hit".into(), hit_channel));
    let mut layers = read_payload(dir, &m, GRID_FILE, exr::route_to_sinks(sinks, place))?;
    find(&layers, &gpath, "depth_moments", dep_size)?;
    for c in ["R", "G", "B"] {
        channel(find(&layers, &gpath, "irradiance", irr_size)?, &gpath, c)?;
    }
    channel(find(&layers, &gpath, "depth_moments", dep_size)?, &gpath, "hit")?;
    let irradiance = irradiance.take();
    check_radiance(&irradiance, &gpath, "irradiance")?;
    let hits = match hits {
        Some(h) => h.take(&gpath)?,
        None => Vec::new(),
    };
    layers.retain(|l| l.name != "irradiance");
    let mut moment = |name: &str| -> Result<Vec<f32>, FileError> {
        let l = layers.iter_mut().find(|l| l.name == "depth_moments");
        let c = l.and_then(|l| l.channels.iter_mut().find(|(n, _)| n == name)).ok_or_else(|| FileError::Invalid {
            path: gpath.clone(),
            field: format!("depth_moments.{name}"),
            message: "channel missing".into(),
        })?;
        Ok(std::mem::take(&mut c.1))
    };
    let depth_mean = moment("mean")?;
    let depth_mean_sq = moment("mean_sq")?;
    for (name, v) in [("mean", &depth_mean), ("mean_sq", &depth_mean_sq)] {
        if let Some(k) = v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(FileError::invalid(
                &gpath,
                format!("depth_moments.{name}"),
                format!("texel {k} is {}: expected finite and ≥ 0", v[k]),
            ));
        }
    }
    drop(layers);
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
        hits,
        inside,
        probe_offset,
        far_distance: m.grid.far_distance,
    };
    Ok((m, probe, grid))
}
