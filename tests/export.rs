//! The engine export: every KTX2 file opens in an independent reader (the `ktx2` crate)
//! with the format, size, mips and data written, and plain bilinear inside a guttered tile
//! (what a GPU does with clamp-free addressing) equals the CPU sampler's seam-aware
//! bilinear of the tile.

mod common;

use glam::{Vec2, Vec3};
use std::path::Path;
use warpfit::export::{self, AtlasLayout};
use warpfit::octa::{self, OctMap};
use warpfit::runtime::FittedGrid;
use warpfit::sampling::Sampler;

fn tiny() -> FittedGrid {
    FittedGrid::load(common::repo().join("fits/tiny")).unwrap()
}

/// The file as the `ktx2` crate reads it: (vkFormat, width, height, levels' bytes).
fn read(path: &Path) -> (u32, u32, u32, Vec<Vec<u8>>) {
    let bytes = std::fs::read(path).unwrap();
    let r = ktx2::Reader::new(bytes.as_slice()).unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
    let h = r.header();
    assert_eq!(h.face_count, 1);
    assert_eq!(h.layer_count, 0);
    assert!(h.supercompression_scheme.is_none());
    let dfd = r.dfd_blocks().next().expect("a data format descriptor");
    let basic = ktx2::DfdBlockBasic::parse(dfd.data).unwrap();
    assert_eq!(basic.header.color_model, Some(ktx2::ColorModel::RGBSDA));
    for s in basic.sample_information() {
        assert!(s.channel_type_qualifiers.contains(ktx2::ChannelTypeQualifiers::FLOAT), "float samples");
    }
    assert!(
        r.key_value_data().any(|(k, v)| k == "KTXwriter" && String::from_utf8_lossy(v).starts_with("warpfit")),
        "KTXwriter key"
    );
    let levels: Vec<Vec<u8>> = r.levels().map(|l| l.data.to_vec()).collect();
    (h.format.map_or(0, |f| f.value()), h.pixel_width, h.pixel_height, levels)
}

fn f32s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
}

fn f16s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(2).map(|c| half::f16::from_bits(u16::from_le_bytes(c.try_into().unwrap())).to_f32()).collect()
}

#[test]
fn every_texture_opens_in_an_independent_reader_with_the_data_written() {
    let grid = tiny();
    let dir = common::tmp_dir("export-read");
    let s = export::export(&grid, &dir).unwrap();
    let p = &grid.warp().probe;

    let (format, w, h, levels) = read(&dir.join(&s.probe_radiance));
    assert_eq!(
        (format, w, h, levels.len()),
        (97, p.radiance.levels[0].res, p.radiance.levels[0].res, p.radiance.levels.len())
    );
    for (m, bytes) in p.radiance.levels.iter().zip(&levels) {
        let v = f16s(bytes);
        assert_eq!(v.len(), m.texels.len() * 4);
        for (k, t) in m.texels.iter().enumerate() {
            for c in 0..3 {
                let want = half::f16::from_f32(t[c]).to_f32();
                assert_eq!(v[4 * k + c], want);
            }
            assert_eq!(v[4 * k + 3], 1.0);
        }
    }
    let (format, _, _, levels) = read(&dir.join(&s.probe_inv_distance));
    assert_eq!(format, 100);
    for (m, bytes) in p.inv_depth.levels.iter().zip(&levels) {
        assert_eq!(f32s(bytes), m.texels, "inverse distances bit for bit");
    }
    let layouts: Vec<&AtlasLayout> =
        [s.correctives.as_ref(), Some(&s.irradiance), Some(&s.moments), s.irradiance_scale.as_ref()]
            .into_iter()
            .flatten()
            .collect();
    assert_eq!(layouts.len(), 4, "tiny stores maps and corrections");
    for l in layouts {
        let (format, w, h, levels) = read(&dir.join(&l.file));
        assert_eq!((w, h, levels.len()), (l.width, l.height, 1), "{}", l.file);
        assert_eq!(
            format,
            match l.format.as_str() {
                "RGBA16F" => 97,
                "R32F" => 100,
                _ => 103,
            }
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Plain bilinear (no wrap) in a guttered tile of `n` at octahedral `uv`: what a GPU does
/// at the sidecar's texel coordinate.
fn plain_bilinear(tile: &[f32], n: u32, uv: Vec2) -> f32 {
    let t = (n + 2) as usize;
    let x = 1.0 + uv.x.clamp(0.0, 1.0) * n as f32 - 0.5;
    let y = 1.0 + uv.y.clamp(0.0, 1.0) * n as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as usize, y0 as usize);
    let at = |i: usize, j: usize| tile[j * t + i];
    (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy) + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
}

#[test]
fn hardware_bilinear_in_a_guttered_tile_equals_the_seam_aware_bilinear() {
    let n = 8u32;
    let tiles = 5;
    // tiles of random values, so every seam texel matters
    let tile = |s: usize| -> Vec<[f32; 1]> {
        (0..n * n).map(|k| [Sampler::new(7, s as u64, k).next_1d() * 10.0 - 3.0]).collect()
    };
    let (columns, w, _, atlas) = export::guttered_atlas::<1>(n, tiles, tile);
    let mut worst = 0.0f32;
    for s in 0..tiles {
        let cpu = OctMap::new(n, tile(s).iter().map(|v| v[0]).collect());
        let t = (n + 2) as usize;
        let (x0, y0) = ((s as u32 % columns) as usize * t, (s as u32 / columns) as usize * t);
        let guttered: Vec<f32> = (0..t * t).map(|k| atlas[(y0 + k / t) * w as usize + x0 + k % t]).collect();
        for q in 0..4000u32 {
            // directions everywhere, and uv on and beyond the edges and corners
            let mut smp = Sampler::new(11, s as u64, q);
            let uv = if q % 4 == 0 {
                Vec2::new(smp.next_1d() * 1.2 - 0.1, smp.next_1d() * 1.2 - 0.1)
            } else {
                octa::encode(warpfit::sampling::uniform_sphere(smp.next_2d()))
            };
            let a = cpu.bilinear_uv(uv);
            let b = plain_bilinear(&guttered, n, uv);
            worst = worst.max((a - b).abs());
        }
    }
    // the same four texels and weights; the sums are the same floats up to the rounding of
    // the weights (the gutter's +1 shifts where x's bits fall)
    assert!(worst < 1e-5, "largest difference {worst}");
}

#[test]
fn exported_irradiance_tiles_are_the_grid_s_tiles_in_their_atlas_slots() {
    let grid = tiny();
    let dir = common::tmp_dir("export-irr");
    let s = export::export(&grid, &dir).unwrap();
    let (_, w, _, levels) = read(&dir.join(&s.irradiance.file));
    let v = f16s(&levels[0]);
    let ir = &grid.irradiance_grid();
    let n = s.irradiance.tile_resolution;
    for (cell, &tile) in s.irradiance.cell_tile.iter().enumerate() {
        if tile < 0 {
            continue;
        }
        assert_eq!(tile as u32, ir.slot[cell]);
        let t = tile as u32;
        let (x0, y0) = ((t % s.irradiance.columns) * (n + 2), (t / s.irradiance.columns) * (n + 2));
        for k in 0..n * n {
            let (i, j) = (k % n, k / n);
            let at = (((y0 + 1 + j) * w + x0 + 1 + i) * 4) as usize;
            let e: Vec3 = ir.irradiance[(t * n * n + k) as usize];
            assert_eq!(v[at], half::f16::from_f32(e.x).to_f32());
            assert_eq!(v[at + 2], half::f16::from_f32(e.z).to_f32());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_exported_roughness_table_interpolated_by_its_rule_is_the_runtime_s_correction() {
    let grid = tiny();
    let correction = grid.roughness().expect("tiny stores a roughness correction");
    let dir = common::tmp_dir("export-rough");
    let s = export::export(&grid, &dir).unwrap();
    let t = s.roughness_lookup.expect("exported");
    let (format, w, h, levels) = read(&dir.join("roughness_lookup.ktx2"));
    assert_eq!((format, w, h), (100, t.nodes, t.nodes));
    let values = f32s(&levels[0]);
    let n = t.nodes as usize;
    let last = (n - 1) as f32;
    // the sidecar's rule, written out as a shader would
    let lookup = |r: f32, k: f32| -> f32 {
        let fr = if r.is_finite() { (r * last).clamp(0.0, last) } else { 0.0 };
        let k = if k.is_finite() && k > 0.0 { k.clamp(t.k_min, t.k_max) } else { 1.0f32.clamp(t.k_min, t.k_max) };
        let fx = ((warpfit::roughness::pseudo_log2(k) - t.x0) * t.inv_dx).clamp(0.0, last);
        let (i, j) = ((fr as usize).min(n - 2), (fx as usize).min(n - 2));
        let (a, b) = (fr - i as f32, fx - j as f32);
        let at = |i: usize, j: usize| values[i * n + j];
        (at(i, j) * (1.0 - b) + at(i, j + 1) * b) * (1.0 - a) + (at(i + 1, j) * (1.0 - b) + at(i + 1, j + 1) * b) * a
    };
    for q in 0..5000u32 {
        let mut smp = Sampler::new(5, 1, q);
        let r = smp.next_1d();
        let k = warpfit::roughness::pseudo_exp2(smp.next_1d() * 12.0 - 6.0);
        assert_eq!(lookup(r, k).to_bits(), correction.corrected_roughness(r, k).to_bits(), "r {r}, k {k}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn radiance_beyond_half_float_range_is_exported_as_rgba32f_unchanged() {
    // a sun-like texel of 1e6 would become infinity in a half float
    let grid = tiny();
    let mut radiance = grid.warp().probe.radiance.clone();
    radiance.levels[0].texels[5] = Vec3::new(1e6, 2e5, 3e4);
    let grid = grid.with_radiance(radiance);
    let dir = common::tmp_dir("export-rgba32f");
    export::export(&grid, &dir).unwrap();
    let (format, _, _, levels) = read(&dir.join("probe_radiance.ktx2"));
    assert_eq!(format, 109, "VK_FORMAT_R32G32B32A32_SFLOAT");
    let p = &grid.warp().probe;
    for (m, bytes) in p.radiance.levels.iter().zip(&levels) {
        let v = f32s(bytes);
        for (k, t) in m.texels.iter().enumerate() {
            assert_eq!([v[4 * k], v[4 * k + 1], v[4 * k + 2], v[4 * k + 3]], [t.x, t.y, t.z, 1.0]);
        }
    }
    // the irradiance, in range, stays half float
    let (format, ..) = read(&dir.join("irradiance.ktx2"));
    assert_eq!(format, 97);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn surface_atlases_export_as_array_textures_in_the_seeds_layout() {
    use warpfit::warp::surface::{SurfaceAtlas, SurfacePatch};
    let patch = SurfacePatch {
        corner: Vec3::new(-1.0, 0.0, -1.0),
        edge_u: Vec3::new(0.0, 0.0, 2.0),
        edge_v: Vec3::new(3.0, 0.0, 0.0),
        counts: [3, 2],
        resolution: 4,
        offset: 1e-4,
    };
    let texels = 3 * 2 * 16;
    let value = |m: usize, t: usize| Vec3::new(t as f32, m as f32, 0.5 + t as f32 * 0.25);
    let radiance: Vec<Vec<Vec3>> = (0..3).map(|m| (0..texels).map(|t| value(m, t)).collect()).collect();
    let inv: Vec<f32> = (0..texels).map(|t| 1.0 / (1.0 + t as f32)).collect();
    let atlas = SurfaceAtlas::new(patch, radiance, vec![0.0, 0.5, 1.0], inv.clone());
    let dir = common::tmp_dir("export-surface");
    let s = export::export_with_surfaces(&tiny(), std::slice::from_ref(&atlas), &dir).unwrap();
    assert_eq!(s.surfaces.len(), 1);
    let sec = &s.surfaces[0];
    assert_eq!((sec.width, sec.height, sec.surface.counts, sec.surface.resolution), (12, 8, [3, 2], 4));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("export.json")).unwrap()).unwrap();
    assert_eq!(json["surfaces"][0]["radiance"], "surface0_radiance.ktx2");
    // the radiance: one level, a layer per mip, probe (i, j)'s texel (x, y) at (i·4 + x, j·4 + y)
    let bytes = std::fs::read(dir.join(&sec.radiance)).unwrap();
    let r = ktx2::Reader::new(bytes.as_slice()).unwrap();
    assert_eq!((r.header().layer_count, r.header().level_count, r.header().pixel_width), (3, 1, 12));
    let data = f16s(r.levels().next().unwrap().data);
    assert_eq!(data.len(), 3 * 12 * 8 * 4);
    for m in 0..3 {
        for (probe, (i, j)) in [(0usize, (0usize, 0usize)), (4, (1, 1)), (5, (2, 1))] {
            for (x, y) in [(0usize, 0usize), (3, 1), (2, 3)] {
                let want = value(m, probe * 16 + y * 4 + x);
                let at = ((m * 8 + j * 4 + y) * 12 + i * 4 + x) * 4;
                let got = Vec3::new(data[at], data[at + 1], data[at + 2]);
                assert!(
                    (got - want).abs().max_element() <= want.max_element() * 1e-3,
                    "mip {m} probe {probe}: {got} vs {want}"
                );
            }
        }
    }
    let bytes = std::fs::read(dir.join(&sec.inv_distance)).unwrap();
    let r = ktx2::Reader::new(bytes.as_slice()).unwrap();
    let w = f32s(r.levels().next().unwrap().data);
    // probe (2, 1), texel (3, 1): image row 4 + 1, column 8 + 3
    assert_eq!(w[(4 + 1) * 12 + 8 + 3], inv[5 * 16 + 4 + 3]);
}
