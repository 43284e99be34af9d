//! Writing a fitted grid folder from plain data: `probe.exr`, `correctives.exr` (only if
//! some cell stores a shift map), `irradiance.exr` and `manifest.json`, each written
//! atomically. The manifest is written last and carries every payload's checksum, so an
//! interrupted rewrite is reported as a checksum mismatch on load, never read as a silently
//! mixed grid. Knows nothing of how the data was fitted: the fit hands over [`Provenance`].

use super::exr::{self, ExrLayer, F16_MAX, IntoLayer, Samples};
use super::schema::*;
use crate::files::FileError;
use crate::grid::GridGeometry;
use crate::octa::{self, OctMap, OctMips};
use crate::roughness::RoughnessCorrection;
use crate::warp::Warp;
use crate::warp::corrective::{Blend, Correctives};
use glam::Vec3;
use std::path::Path;

/// What the fit that made the correctives says about them, recorded in the manifest.
#[derive(Clone, Debug, Default)]
pub struct Provenance {
    /// The fit settings (any serialisable record).
    pub fit_settings: serde_json::Value,
    /// Summary of the fit's held-out errors.
    pub residuals: serde_json::Value,
    /// Active cells that store no map (level 0: the fallback method is as good).
    pub level0_cells: usize,
}

/// The probe as stored: position, GGX radiance mips with their perceptual roughness, and the
/// distance mips (+inf = sky).
#[derive(Clone, Copy)]
pub struct ProbeData<'a> {
    pub position: Vec3,
    pub radiance: &'a OctMips<Vec3>,
    pub mip_roughness: &'a [f32],
    pub distance: &'a OctMips<f32>,
}

/// The grid's per-cell irradiance and distance moments (`cell · res² + texel`), and which
/// cells are inside geometry (stored nowhere).
#[derive(Clone, Copy)]
pub struct IrradianceSource<'a> {
    pub resolution: u32,
    pub depth_resolution: u32,
    pub irradiance: &'a [Vec3],
    pub depth_mean: &'a [f32],
    pub depth_mean_sq: &'a [f32],
    pub inside: &'a [bool],
    /// The fitted corrections of the blended irradiance (cells without one: none stored).
    pub correction: &'a crate::gridfile::IrradianceCorrection,
}

/// Everything a fitted grid folder holds.
pub struct GridContents<'a> {
    pub scene: &'a str,
    pub geometry: GridGeometry,
    pub probe: ProbeData<'a>,
    /// The other specular probes, after probe A (empty: probe A alone).
    pub others: Vec<ProbeData<'a>>,
    /// The proxies and warp options of the fallback method (the probe comes from `probe`).
    pub warp: &'a Warp,
    pub correctives: &'a Correctives,
    pub blend: Blend,
    pub irradiance: IrradianceSource<'a>,
    pub roughness: Option<&'a RoughnessCorrection>,
    /// Per cell: its probe's offset from the cell centre (relocation).
    pub probe_offset: &'a [Vec3],
    pub precision: Precision,
    pub provenance: Provenance,
}

/// Per-cell tiles (`cell · res² + texel` in `src`) of the listed cells as an atlas channel
/// (tile k = `cells[k]`), each sample read from `src` through `value` when the encoder asks
/// for it, so the atlas is never built; tiles past the last are `value(T::default())`.
fn packed<'a, T: Copy + Default + Sync>(
    src: &'a [T],
    cells: &'a [u32],
    res: u32,
    columns: u32,
    value: impl Fn(T) -> f32 + Sync + 'a,
) -> Samples<'a> {
    let n2 = (res * res) as usize;
    Samples::Computed(Box::new(move |i| {
        let (k, t) = atlas_texel(i, res, columns);
        value(cells.get(k).map_or_else(T::default, |&cell| src[cell as usize * n2 + t]))
    }))
}

/// A layer of per-cell tiles: `channels` name and [`packed`] samples.
fn packed_layer<'a>(
    name: &str,
    count: usize,
    res: u32,
    columns: u32,
    channels: Vec<(&str, Samples<'a>)>,
) -> ExrLayer<Samples<'a>> {
    let (width, height) = atlas_size(count, res, columns);
    let channels = channels.into_iter().map(|(n, s)| (n.to_string(), s)).collect();
    ExrLayer { name: name.into(), width, height, channels }
}

/// Encodes `layers` into `file` in `dir` and returns its manifest entry.
fn payload<'a, L: IntoLayer<'a>>(
    dir: &Path,
    file: &str,
    layers: impl IntoIterator<Item = L>,
    precision: Precision,
) -> Result<Payload, FileError> {
    let path = dir.join(file);
    let layers: Vec<ExrLayer<Samples>> = layers.into_iter().map(IntoLayer::into_layer).collect();
    // f16 only where every value fits: a sun brighter than 65504 keeps its layer in f32
    // rather than saturating (the manifest records each layer's actual precision).
    let fits_f16 = |l: &ExrLayer<Samples>| {
        l.channels.iter().all(|(_, s)| (0..l.width * l.height).all(|i| s.get(i).abs() <= F16_MAX))
    };
    let kept: Vec<String> = layers
        .iter()
        .filter(|l| precision == Precision::F16 && may_be_half(&l.name) && !fits_f16(l))
        .map(|l| l.name.clone())
        .collect();
    if !kept.is_empty() {
        tracing::warn!("{}: layers {kept:?} exceed the f16 range (65504); stored as f32", path.display());
    }
    let half = |name: &str| precision == Precision::F16 && may_be_half(name) && !kept.iter().any(|k| k == name);
    let entries: Vec<LayerEntry> =
        layers.iter().map(|l| LayerEntry::of(l, if half(&l.name) { Precision::F16 } else { Precision::F32 })).collect();
    let (bytes, checksum) = exr::write_payload(&path, layers, half)?;
    Ok(Payload { file: file.into(), bytes, checksum, layers: entries })
}

/// How `irradiance.exr`'s layers read, in words (the manifest's `irradiance.encoding`).
const IRRADIANCE_ENCODING: &str = "per stored cell: irradiance (R, G, B) on an octahedral map of normals; distance moments (mean, mean_sq; misses count as the bake's far distance) on an octahedral map of directions; per corrected cell: a map of scales (S) over the normal, multiplying the blended irradiance of points in the cell";

/// Writes the fitted grid folder and returns its manifest.
pub fn write(dir: &Path, g: &GridContents) -> Result<GridManifest, FileError> {
    let geo = g.geometry;
    let (mut payloads, mut left_out) = (Vec::new(), Vec::new());
    // every value inside the bounds the reader enforces (real data never reaches them)
    let bounds = ValueBounds::of_diagonal((geo.max - geo.min).length());
    let probe = write_probe(dir, PROBE_FILE, &g.probe, g.precision, &bounds, &mut payloads)?;
    let mut other_probes = Vec::with_capacity(g.others.len());
    for (k, p) in g.others.iter().enumerate() {
        let file = PROBE_FILES.get(k + 1).ok_or_else(|| {
            FileError::invalid(dir, "other_probes", format!("{} probes, at most {MAX_PROBES}", g.others.len() + 1))
        })?;
        other_probes.push(write_probe(dir, file, p, g.precision, &bounds, &mut payloads)?);
    }
    // files of probes a previous grid in this folder had and this one has not
    for file in PROBE_FILES.iter().skip(g.others.len() + 1) {
        let _ = std::fs::remove_file(dir.join(file));
    }
    let correctives = write_correctives(dir, g, &bounds, &mut payloads, &mut left_out)?;
    let irradiance = write_irradiance(dir, g, &bounds, &mut payloads, &mut left_out)?;
    if g.roughness.is_none() {
        left_out.push(LeftOut {
            what: "roughness correction table".into(),
            reason: if g.probe.radiance.levels.len() < 2 {
                "the probe has no rough mips".into()
            } else {
                "disabled for this fit".into()
            },
            bytes_saved: 0,
        });
    }

    // the cells without a map that read a probe other than A
    let c = g.correctives;
    let cell_probes: Vec<(u32, u8)> = (0..c.geometry.cell_count())
        .filter(|&cell| !c.stores_map(cell) && c.cell_probe(cell) != 0)
        .map(|cell| (cell as u32, c.cell_probe(cell)))
        .collect();
    let manifest = GridManifest {
        format: GRID_FORMAT.into(),
        // the oldest version that reads the grid
        version: if !cell_probes.is_empty() {
            GRID_VERSION
        } else if g.blend == Blend::Faces {
            7
        } else {
            GRID_VERSION_WRITTEN
        },
        octahedral_convention: octa::CONVENTION.into(),
        units: "scene units (positions, distances); radiance in the scene's linear RGB units".into(),
        up_axis: "+Y".into(),
        scene: g.scene.into(),
        grid: GridSection {
            min: geo.min.to_array(),
            max: geo.max.to_array(),
            counts: geo.counts.to_array(),
            relocated: crate::grid::relocated_cells(g.probe_offset),
        },
        probe,
        other_probes,
        cell_probes,
        warp: warp_section(g),
        correctives,
        irradiance,
        roughness: g.roughness.cloned(),
        payloads,
        left_out,
        fit_settings: g.provenance.fit_settings.clone(),
        residuals: g.provenance.residuals.clone(),
        manifest_checksum: String::new(),
    };
    let manifest = GridManifest { manifest_checksum: manifest.canonical_checksum(), ..manifest };
    crate::files::write_json(&dir.join(MANIFEST_FILE), &manifest)?;
    Ok(manifest)
}

/// Writes probe `p` into `file` (the GGX chain and the distance chain, within the reader's
/// bounds) and returns its manifest section.
fn write_probe(
    dir: &Path,
    file: &str,
    p: &ProbeData,
    precision: Precision,
    bounds: &ValueBounds,
    payloads: &mut Vec<Payload>,
) -> Result<ProbeSection, FileError> {
    let radiance = OctMips {
        levels: p
            .radiance
            .levels
            .iter()
            .map(|l| OctMap { res: l.res, texels: l.texels.iter().map(|v| v.min(Vec3::splat(MAX_RADIANCE))).collect() })
            .collect(),
    };
    let distance = OctMips {
        levels: p
            .distance
            .levels
            .iter()
            .map(|l| OctMap {
                res: l.res,
                texels: l.texels.iter().map(|&d| if d.is_finite() { d.min(bounds.max_distance) } else { d }).collect(),
            })
            .collect(),
    };

    // probe: GGX chain and distance chain
    let layers = probe_layers(&radiance, &distance);
    let radiance_mips = p
        .radiance
        .levels
        .iter()
        .enumerate()
        .map(|(m, level)| RadianceMip {
            layer: radiance_layer(m),
            resolution: level.res,
            perceptual_roughness: p.mip_roughness[m],
        })
        .collect();
    let distance_mips = (0..p.distance.levels.len()).map(distance_layer).collect();
    payloads.push(payload(dir, file, layers, precision)?);

    Ok(ProbeSection {
        position: p.position.to_array(),
        resolution: p.radiance.levels[0].res,
        radiance_mips,
        distance_mips,
    })
}

/// Writes `correctives.exr` (the shift maps of level-2 cells in cell order, tile k = k-th
/// stored cell, and their rough maps) unless no cell stores one; returns its section.
fn write_correctives(
    dir: &Path,
    g: &GridContents,
    bounds: &ValueBounds,
    payloads: &mut Vec<Payload>,
    left_out: &mut Vec<LeftOut>,
) -> Result<Option<CorrectiveSection>, FileError> {
    let c = g.correctives;
    let cells = g.geometry.cell_count();
    let stored: Vec<(u32, u32)> = (0..cells).filter_map(|cell| c.slot_of(cell).map(|s| (s, cell as u32))).collect();
    let stored_cells: Vec<u32> = stored.iter().map(|(_, cell)| *cell).collect();
    let shifts_per_cell = (c.map_res * c.map_res) as u64 * if c.has_rough_maps() { 2 } else { 1 };
    let level0 = g.provenance.level0_cells as u64;
    left_out.push(LeftOut {
        what: format!("shift maps of {level0} level-0 cells"),
        reason: format!(
            "the proxy `{}` alone is as good on held-out queries (within the selection margin)",
            c.fallback.name()
        ),
        bytes_saved: level0 * shifts_per_cell * 4,
    });
    Ok(if stored_cells.is_empty() {
        let _ = std::fs::remove_file(dir.join(CORRECTIVES_FILE));
        left_out.push(LeftOut {
            what: CORRECTIVES_FILE.into(),
            reason: "no cell stores a shift map".into(),
            bytes_saved: 0,
        });
        None
    } else {
        let columns = atlas_columns(stored_cells.len());
        let slots: Vec<u32> = stored.iter().map(|(slot, _)| *slot).collect();
        let dmax = bounds.max_distance;
        let clamp = move |x: f32| if x.is_nan() { 0.0 } else { x.clamp(-dmax, dmax) };
        let shift = packed(&c.maps, &slots, c.map_res, columns, clamp);
        let mut layers = vec![packed_layer("shift_maps", slots.len(), c.map_res, columns, vec![("D", shift)])];
        if c.has_rough_maps() {
            let rough = packed(&c.rough_maps, &slots, c.map_res, columns, clamp);
            layers.push(packed_layer("rough_shift_maps", slots.len(), c.map_res, columns, vec![("D", rough)]));
        }
        let probe_maps = !c.probe_maps.is_empty();
        if probe_maps {
            let index = packed(&c.probe_maps, &slots, c.map_res, columns, f32::from);
            layers.push(packed_layer("probe_maps", slots.len(), c.map_res, columns, vec![("P", index)]));
        }
        payloads.push(payload(dir, CORRECTIVES_FILE, layers, g.precision)?);
        Some(CorrectiveSection {
            map_res: c.map_res,
            stored_cells,
            atlas_columns: columns,
            encoding: SHIFT_MAP_ENCODING.into(),
            rough_maps: c.has_rough_maps().then(rough_map_encoding),
            probe_maps: probe_maps.then(|| PROBE_MAP_ENCODING.into()),
        })
    })
}

/// Writes `irradiance.exr` (irradiance, distance moments and diffuse corrections of the
/// cells not inside geometry) and returns its section.
fn write_irradiance(
    dir: &Path,
    g: &GridContents,
    bounds: &ValueBounds,
    payloads: &mut Vec<Payload>,
    left_out: &mut Vec<LeftOut>,
) -> Result<IrradianceSection, FileError> {
    let cells = g.geometry.cell_count();
    let src = &g.irradiance;
    let active: Vec<u32> = (0..cells as u32).filter(|&k| !src.inside[k as usize]).collect();
    let inside = (cells - active.len()) as u64;
    let (ir, dr) = (src.resolution, src.depth_resolution);
    let per_cell = (ir * ir) as u64 * 3 * g.precision.bytes() + (dr * dr) as u64 * 2 * 4;
    left_out.push(LeftOut {
        what: format!("irradiance and distance moments of {inside} cells inside geometry"),
        reason: "their centre is inside geometry: nothing is ever shaded from there".into(),
        bytes_saved: inside * per_cell,
    });
    left_out.push(LeftOut {
        what: "hit-fraction channel of the distance moments".into(),
        reason: "not read at runtime (misses are already in the moments as the far distance)".into(),
        bytes_saved: active.len() as u64 * (dr * dr) as u64 * 4,
    });
    let columns = atlas_columns(active.len());
    // fitted irradiance corrections of stored cells, in cell order
    let corrected: Vec<u32> = active
        .iter()
        .copied()
        .filter(|&c| src.correction.slot.get(c as usize).is_some_and(|&s| s != crate::warp::corrective::NO_MAP))
        .collect();
    let correction_columns = atlas_columns(corrected.len());
    let uncorrected = active.len() - corrected.len();
    left_out.push(LeftOut {
        what: format!("irradiance corrections of {uncorrected} cells"),
        reason: "the blend of the grid is as good on held-out surface points (within 5%), or the cell holds too few surfaces to fit".into(),
        bytes_saved: uncorrected as u64 * (src.correction.resolution * src.correction.resolution) as u64 * 4,
    });
    if !active.is_empty() {
        // the tiles are read from the grid's arrays as the encoder goes: nothing is copied
        let slots: Vec<u32> = corrected.iter().map(|&c| src.correction.slot[c as usize]).collect();
        let dmax = bounds.max_distance;
        let e = |f: fn(Vec3) -> f32| {
            packed(src.irradiance, &active, ir, columns, move |v| f(v.min(Vec3::splat(MAX_RADIANCE))))
        };
        let mut layers = vec![
            packed_layer(
                "irradiance",
                active.len(),
                ir,
                columns,
                vec![("R", e(|v| v.x)), ("G", e(|v| v.y)), ("B", e(|v| v.z))],
            ),
            packed_layer(
                "depth_moments",
                active.len(),
                dr,
                columns,
                vec![
                    ("mean", packed(src.depth_mean, &active, dr, columns, move |x| x.min(dmax))),
                    ("mean_sq", packed(src.depth_mean_sq, &active, dr, columns, move |x| x.min(dmax * dmax))),
                ],
            ),
        ];
        if !corrected.is_empty() {
            let cr = src.correction.resolution;
            let scale = packed(&src.correction.scale, &slots, cr, correction_columns, |x| x);
            layers.push(packed_layer("irradiance_scale", slots.len(), cr, correction_columns, vec![("S", scale)]));
        }
        payloads.push(payload(dir, IRRADIANCE_FILE, layers, g.precision)?);
    }

    Ok(IrradianceSection {
        resolution: ir,
        depth_resolution: dr,
        stored_cells: active,
        atlas_columns: columns,
        encoding: IRRADIANCE_ENCODING.into(),
        corrected_cells: corrected,
        correction_resolution: src.correction.resolution.max(2),
        correction_columns,
        surface_bias: src.correction.surface_bias,
    })
}

/// The manifest's warp section: the proxy, the options, the blend and the proxies' shapes.
fn warp_section(g: &GridContents) -> WarpSection {
    let aabb = &g.warp.proxies.aabb;
    let kdop = &g.warp.proxies.kdop;
    WarpSection {
        fallback: g.correctives.fallback.name().into(),
        options: g.warp.options,
        blend: g.blend,
        box_proxy: BoxSection {
            centre: aabb.centre.to_array(),
            rotation: aabb.rotation.to_array(),
            half_extents: aabb.half_extents.to_array(),
        },
        kdop: kdop
            .normals
            .iter()
            .zip(&kdop.offsets)
            .map(|(n, h)| KdopPlane { normal: n.to_array(), offset: h.is_finite().then_some(*h) })
            .collect(),
    }
}
