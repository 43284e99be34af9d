//! The fitted-grid file and the runtime sampler: equality with the fitter's own evaluation,
//! the committed grid under fits/ keeps loading with the same answers, every malformed input
//! is an error naming file and field (never a panic, including under byte-level fuzzing), and
//! the sampler's documented edge cases.

mod common;
use common::*;
use glam::{Vec2, Vec3};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use warpfit::eval::{self, EvalSettings};
use warpfit::gridfile::{GRID_VERSION_WRITTEN, MANIFEST_FILE};
use warpfit::jobs::run::{self as job, StoreOptions};
use warpfit::report::folder::RunFolder;
use warpfit::runtime::{FittedGrid, IrradianceBlend, LoadError, Precision, SpecularRead};
use warpfit::warp::Method;
use warpfit::warp::corrective::Blend;

fn tiny() -> PathBuf {
    repo().join("fits/tiny")
}

/// Fixed queries spread over the tiny room (inside, on a wall, outside the grid).
fn tiny_queries() -> Vec<(Vec3, Vec3, f32)> {
    let mut q = Vec::new();
    for k in 0..24u32 {
        let mut s = warpfit::sampling::Sampler::new(11, 0, k);
        let p = Vec3::new(s.next_1d() * 4.4 - 2.2, s.next_1d() * 2.6, s.next_1d() * 4.4 - 2.2);
        let d = warpfit::sampling::uniform_sphere(s.next_2d());
        q.push((p, d, [0.0, 0.15, 0.5, 1.0][k as usize % 4]));
    }
    q
}

#[test]
fn the_committed_fit_keeps_loading_with_the_same_answers() {
    // A format change that breaks this grid must bump GRID_VERSION knowingly and re-fit
    // fits/tiny (`warpfit fit --scene data/scenes/tiny.toml --out fits/tiny --train-positions 8
    // --train-dirs 64`, then WARPFIT_BLESS=1 cargo test --test runtime), keeping the grid of
    // the older versions still read beside it: fits/tiny_v5 (probe A alone) and fits/tiny_v4
    // (one map per cell) never change. fits/tiny_probes is the same room with a second
    // probe (`data/scenes/tiny_probes.toml`, fitted the same way).
    let grids = [
        (tiny(), GRID_VERSION_WRITTEN, true),
        (repo().join("fits/tiny_probes"), GRID_VERSION_WRITTEN, true),
        (repo().join("fits/tiny_v5"), 5, false),
        (repo().join("fits/tiny_v4"), 4, false),
    ];
    for (dir, version, bless) in grids {
        let g = FittedGrid::load(&dir).unwrap_or_else(|e| panic!("{} loads: {e}", dir.display()));
        assert_eq!(g.manifest().version, version, "{}", dir.display());
        assert_eq!(g.correctives().has_rough_maps(), version >= 5, "{}: rough maps", dir.display());
        let several = dir.ends_with("tiny_probes");
        assert_eq!(g.warp().probe_count(), if several { 2 } else { 1 }, "{}: probes", dir.display());
        assert_eq!(!g.correctives().probe_maps.is_empty(), several, "{}: probe maps", dir.display());
        // the manifest states the blend the runtime applies
        let rule = g.manifest().correctives.as_ref().and_then(|c| c.rough_maps.clone());
        assert_eq!(rule, (version >= 5).then(warpfit::gridfile::rough_map_encoding), "{}", dir.display());
        let got: Vec<[f32; 6]> = tiny_queries()
            .iter()
            .map(|&(p, d, r)| {
                let s = g.specular(p, d, r);
                let e = g.irradiance(p, d);
                [s.x, s.y, s.z, e.x, e.y, e.z]
            })
            .collect();
        let expected_path = dir.join("expected_samples.json");
        if bless && std::env::var("WARPFIT_BLESS").is_ok() {
            std::fs::write(&expected_path, serde_json::to_vec_pretty(&got).unwrap()).unwrap();
        }
        let expected: Vec<[f32; 6]> = serde_json::from_slice(&std::fs::read(&expected_path).unwrap()).unwrap();
        assert_eq!(got.len(), expected.len());
        for (k, (a, b)) in got.iter().zip(&expected).enumerate() {
            for c in 0..6 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-6 * b[c].abs().max(1e-3),
                    "{}: query {k} component {c}: {} vs {}",
                    dir.display(),
                    a[c],
                    b[c]
                );
            }
        }
        assert!(got.iter().flatten().all(|x| x.is_finite() && *x >= 0.0));
    }
}

/// A small torture grid, written f32 and f16.
struct Fixture {
    torture: SmallTorture,
    f32_dir: TestDir,
    f16_dir: TestDir,
}

impl std::ops::Deref for Fixture {
    type Target = SmallTorture;
    fn deref(&self) -> &SmallTorture {
        &self.torture
    }
}

fn fixture() -> &'static Fixture {
    static F: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let f32_dir = fixture_dir("runtime-f32");
        let torture = SmallTorture::fit_into(&f32_dir);
        let f16_dir = fixture_dir("runtime-f16");
        let f16 = StoreOptions { precision: Precision::F16, ..Default::default() };
        job::write_grid(torture.baked(), &torture.warp, &torture.fit, f16, &RunFolder::new(&f16_dir)).unwrap();
        Fixture { torture, f32_dir, f16_dir }
    })
}

#[test]
fn runtime_equals_the_fitters_evaluation_on_the_validation_set() {
    let f = fixture();
    let g = FittedGrid::load(&f.f32_dir).unwrap();
    let settings = EvalSettings { positions: 48, dirs_per_position: 32, reference_spp: 2, ..EvalSettings::default() };
    let set = eval::validation_set(&f.scene, &f.tracer, &f.grid, &[f.probe.position], &settings, None);
    assert!(f.fit.correctives.stored_cells() > 0, "the test needs stored maps");
    let mut worst = 0.0f32;
    for k in 0..set.dirs.len() {
        let (b, d) = (set.position_of(k), set.dirs[k]);
        let fitter = f.warp.probe.radiance(f.fit.correctives.fetch_vector(Blend::Cell, &f.warp, b, d));
        let runtime = g.specular(b, d, 0.0);
        let rel = (runtime - fitter).abs().max_element() / fitter.abs().max_element().max(1e-6);
        worst = worst.max(rel);
    }
    assert!(worst <= 1e-5, "worst relative difference {worst}");

    // f16 radiance: measured, small against the fit's own error
    let h = FittedGrid::load(&f.f16_dir).unwrap();
    let est32: Vec<Vec3> = (0..set.dirs.len()).map(|k| g.specular(set.position_of(k), set.dirs[k], 0.0)).collect();
    let est16: Vec<Vec3> = (0..set.dirs.len()).map(|k| h.specular(set.position_of(k), set.dirs[k], 0.0)).collect();
    let e32 = eval::error_stats(&est32, &set.reference, 1.0).rel_rmse;
    let e16 = eval::error_stats(&est16, &set.reference, 1.0).rel_rmse;
    assert!((e16 - e32).abs() < 1e-3 * e32, "f16 changes rel RMSE {e32} → {e16}");
    let p32 = std::fs::metadata(f.f32_dir.join("probe.exr")).unwrap().len();
    let p16 = std::fs::metadata(f.f16_dir.join("probe.exr")).unwrap().len();
    assert!(p16 < p32, "f16 probe {p16} bytes vs f32 {p32}");
}

#[test]
fn the_fits_per_query_error_is_the_error_through_the_runtime() {
    // The objective the fit minimises and the lookup the runtime answers share one fetch
    // function and one rough lookup: for mirror and rough queries in stored cells, the fit's
    // per-query error under the stored map equals the error of `FittedGrid::specular`
    // against the same reference. (The irradiance blend of rough lookups is fitted after
    // the maps, on top of them: the maps' objective is probe A's part, the grid read
    // without the blend.)
    let f = fixture();
    let g = FittedGrid::load(&f.f32_dir).unwrap();
    let probe_only = g.roughness().cloned().map(|c| {
        let fit = warpfit::roughness::RoughnessFit { irradiance_weight: Vec::new(), ..c.into() };
        warpfit::roughness::RoughnessCorrection::try_from(fit).unwrap()
    });
    let g = g.with_roughness(probe_only);
    let c = &f.fit.correctives;
    let geo = c.geometry;
    let n2 = (c.map_res * c.map_res) as usize;
    let mut compared = 0;
    for cell in (0..geo.cell_count()).filter(|&k| c.stores_map(k)) {
        let slot = c.slot_of(cell).unwrap() as usize;
        let lo = geo.min + geo.cell_coords(cell).as_vec3() * geo.cell_size();
        let queries: Vec<warpfit::fit::objective::Sample> = (0..64u32)
            .map(|k| {
                let mut s = warpfit::sampling::Sampler::new(31, cell as u64, k);
                let b = lo + Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * geo.cell_size();
                let dir = warpfit::sampling::uniform_sphere(s.next_2d());
                let reference = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
                // mirror, the map's band, the blend of map and rough map, the rough map's
                let roughness = [0.0, 0.25, 0.5, 0.625, 0.75, 1.0][k as usize % 6];
                warpfit::fit::objective::Sample::new(b, dir, roughness, reference)
            })
            .collect();
        let map = c.maps[slot * n2..(slot + 1) * n2].to_vec();
        let rough = c.rough_maps.get(slot * n2..(slot + 1) * n2).unwrap_or(&[]).to_vec();
        let glossy = warpfit::warp::glossy::Glossy { warp: &f.warp, correction: f.fit.roughness.as_ref() };
        let ctx = warpfit::fit::objective::CellContext {
            glossy,
            exposure: 1.0,
            proxy: c.fallback,
            origin: geo.cell_centre(cell),
            res: c.map_res,
            probe_map: &[],
        };
        let start = vec![0.0; n2];
        let problem = warpfit::fit::objective::CellProblem::new(ctx, start, queries.clone());
        for (q, fit_err) in queries.iter().zip(problem.query_errors(&map, &rough)) {
            let d = g.specular(q.b, q.dir, q.roughness) - q.reference;
            let runtime_err = ((d.x.abs() + d.y.abs() + d.z.abs()) / 3.0) as f64;
            assert_eq!(fit_err.to_bits(), runtime_err.to_bits(), "cell {cell} query {q:?}");
            compared += 1;
        }
    }
    assert!(compared >= 64, "no stored cell to compare");
    assert!(c.has_rough_maps(), "the standard fit stores rough maps: the test covers them");
}

#[test]
fn roughness_selects_blurrier_mips_and_the_correction_applies() {
    // probe A's part alone (the blended tier mixes the cell's irradiance into rough lookups)
    let g = FittedGrid::load(tiny()).unwrap().with_read(warpfit::runtime::SpecularRead::ProbeOnly);
    let a = g.warp().probe.position;
    // at the probe (k = 1 everywhere) roughness r reads mip r·(mips−1) exactly
    let d = Vec3::new(0.3, 0.2, -0.9).normalize();
    let last = (g.warp().probe.radiance.levels.len() - 1) as f32;
    let (got, want) = (g.specular(a, d, 1.0), g.warp().probe.radiance.sample_lod(d, last));
    assert!((got - want).abs().max_element() <= 1e-4 * want.max_element(), "{got} vs {want}");
    assert_eq!(g.specular(a, d, 0.0), g.warp().probe.radiance(d));
    // the correction: a shading point nearer the hit than the probe (k > 1) reads a sharper mip
    let lut = g.roughness().expect("tiny stores the correction");
    assert!(lut.corrected_alpha(0.25, 4.0) < 0.25);
    assert!(lut.corrected_alpha(0.25, 0.25) > 0.25);
    assert!((lut.corrected_alpha(0.25, 1.0) - 0.25).abs() < 0.02);
    // the runtime lookup is the stored correction's own
    let stored = g.manifest().roughness.as_ref().unwrap();
    for a in [0.0, 0.01, 0.1, 0.33, 0.7, 1.0, 2.0] {
        for k in [0.01, 0.2, 0.9, 1.0, 1.7, 5.0, 100.0] {
            let (x, y) = (lut.corrected_alpha(a, k), stored.corrected_alpha(a, k));
            assert!((x - y).abs() <= 1e-5, "α {a} k {k}: {x} vs {y}");
        }
    }
}

#[test]
fn documented_edge_cases_stay_finite() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<FittedGrid>();
    let tiny = FittedGrid::load(tiny()).unwrap();
    // with the containing cell's lookup, and with the faces blend
    for g in [tiny.clone(), tiny.with_lookup(|_, blend, _| *blend = Blend::Faces)] {
        edge_cases_stay_finite(&g);
    }
}

fn edge_cases_stay_finite(g: &FittedGrid) {
    let a = g.warp().probe.position;
    // zero / non-finite direction: black
    assert_eq!(g.specular(a, Vec3::ZERO, 0.0), Vec3::ZERO);
    assert_eq!(g.specular(a, Vec3::NAN, 0.0), Vec3::ZERO);
    assert_eq!(g.irradiance(a, Vec3::ZERO), Vec3::ZERO);
    // non-finite position: the probe's own view
    let d = Vec3::new(0.1, -0.3, 0.8).normalize();
    assert_eq!(g.specular(Vec3::NAN, d, 0.0), g.specular(a, d, 0.0));
    // the direction need not be unit length
    assert_eq!(g.specular(a, d * 7.0, 0.0), g.specular(a, d, 0.0));
    // far outside the grid, huge and tiny values, NaN roughness
    for p in [Vec3::splat(1e6), Vec3::splat(-1e30), Vec3::new(0.0, 1e-30, 0.0), Vec3::new(2.0, 1.2, 0.0)] {
        for r in [0.0, 0.5, 1.0, f32::NAN, -3.0, 9.0] {
            for d in [Vec3::X, -Vec3::Z, Vec3::new(1.0, 1.0, 0.0), Vec3::new(1e-30, 1.0, 0.0)] {
                let s = g.specular(p, d, r);
                assert!(s.is_finite() && s.cmpge(Vec3::ZERO).all(), "{p} {d} {r}: {s}");
                let e = g.irradiance(p, d);
                assert!(e.is_finite() && e.cmpge(Vec3::ZERO).all(), "{p} {d}: {e}");
            }
        }
    }
    // batch versions agree with single calls and reject mismatched slices
    let q = tiny_queries();
    let (p, d, r): (Vec<Vec3>, Vec<Vec3>, Vec<f32>) =
        (q.iter().map(|x| x.0).collect(), q.iter().map(|x| x.1).collect(), q.iter().map(|x| x.2).collect());
    let mut out = vec![Vec3::ZERO; q.len()];
    g.specular_batch(&p, &d, &r, &mut out).unwrap();
    for k in 0..q.len() {
        assert_eq!(out[k], g.specular(p[k], d[k], r[k]));
    }
    g.irradiance_batch(&p, &d, &mut out).unwrap();
    assert_eq!(out[3], g.irradiance(p[3], d[3]));
    assert!(g.specular_batch(&p[1..], &d, &r, &mut out).is_err());
}

#[test]
fn specular_batch_is_bitwise_the_single_call() {
    // Mirror groups take the lane sampler; groups with a rough, black or degenerate query
    // shade per lane; the tail shorter than a group calls `specular`. All must agree bit
    // for bit with `specular`, on the committed grid and on a lit torture grid.
    let grids = [FittedGrid::load(tiny()).unwrap(), FittedGrid::load(&fixture().f32_dir).unwrap()];
    let faces = |g: &FittedGrid| g.clone().with_lookup(|_, blend, _| *blend = Blend::Faces);
    // the faces blend's aims are found side by side, for every proxy; one by one with UV
    // relaxation
    let variants = |g: &FittedGrid| {
        let proxies = [Method::Box, Method::Kdop, Method::Warp1]
            .map(|m| g.clone().with_lookup(|_, blend, c| (*blend, c.fallback) = (Blend::Faces, m)));
        let relaxed = g.clone().with_lookup(|w, blend, _| (*blend, w.options.relax_texels) = (Blend::Faces, 1.0));
        proxies.into_iter().chain([relaxed])
    };
    let grids = grids
        .iter()
        .flat_map(|g| [g.clone(), faces(g)].into_iter().chain(variants(g)))
        .chain([faces(&load_tiny_probes())]);
    for g in grids.flat_map(|g| SpecularRead::ALL.map(|read| g.clone().with_read(read))) {
        let lanes = warpfit::octa::LANES;
        let n = lanes * 5 + 3;
        let geo = &g.irradiance_grid().geometry;
        let (mut p, mut d, mut r) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..n as u32 {
            let mut s = warpfit::sampling::Sampler::new(23, 0, k);
            let t = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 1.2 - 0.1;
            p.push(geo.min + (geo.max - geo.min) * t);
            d.push(warpfit::sampling::uniform_sphere(s.next_2d()) * (0.5 + s.next_1d()));
            // groups 0 and 1 mirror only; group 2 mirror with one rough lane; the rest mixed
            r.push(match k as usize / lanes {
                0 | 1 => 0.0,
                2 if k as usize % lanes == 5 => 0.3,
                2 => 0.0,
                _ => [0.0, 0.2, 0.7, 1.0][k as usize % 4],
            });
        }
        // degenerate queries inside a mirror group and in mixed groups
        let a = g.warp().probe.position;
        (p[1], p[2], d[3], d[4]) = (a, Vec3::NAN, Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0));
        (p[lanes * 3 + 1], d[lanes * 3 + 2], r[lanes * 3 + 3]) = (Vec3::splat(1e6), Vec3::INFINITY, f32::NAN);
        let mut out = vec![Vec3::ZERO; n];
        g.specular_batch(&p, &d, &r, &mut out).unwrap();
        let mut lit = 0;
        for k in 0..n {
            let single = g.specular(p[k], d[k], r[k]);
            assert_eq!(out[k].to_array().map(f32::to_bits), single.to_array().map(f32::to_bits), "query {k}");
            lit += (single.max_element() > 0.0) as usize;
        }
        assert!(lit > n / 4, "too few lit queries ({lit} of {n}) for the comparison to mean much");
    }
}

fn load_tiny_probes() -> FittedGrid {
    FittedGrid::load(repo().join("fits/tiny_probes")).unwrap()
}

#[test]
fn the_faces_blend_reads_the_containing_cell_inside_it_and_nothing_jumps_at_a_face() {
    // `Blend::Faces`: bit for bit the containing cell's lookup away from its faces; across
    // a face between linked cells, where the containing cell's lookup jumps (a shift map against its neighbour's,
    // or another probe, or the irradiance a rough lookup blends in), the blend changes by no
    // more than its neighbours a step apart do; in both read tiers.
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    let grids = [FittedGrid::load(&fixture().f32_dir).unwrap(), load_tiny_probes()];
    for cell_grid in grids.iter().flat_map(|g| SpecularRead::ALL.map(|read| g.clone().with_read(read))) {
        let faces = cell_grid.clone().with_lookup(|_, blend, _| *blend = Blend::Faces);
        let geo = cell_grid.correctives().geometry;
        let size = geo.cell_size();
        let (mut inside, mut crossings, mut jumps) = (0, 0, 0);
        for cell in (0..geo.cell_count()).filter(|&c| cell_grid.correctives().stores_map(c)) {
            let lo = geo.min + geo.cell_coords(cell).as_vec3() * size;
            for k in 0..8u32 {
                let mut s = warpfit::sampling::Sampler::new(41, cell as u64, k);
                let d = warpfit::sampling::uniform_sphere(s.next_2d());
                let r = [0.0, 0.0, 0.3, 0.8][k as usize % 4];
                // away from every face: the containing cell's lookup
                let t = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 0.7 + 0.15;
                let b = lo + t * size;
                assert_eq!(bits(faces.specular(b, d, r)), bits(cell_grid.specular(b, d, r)), "cell {cell} at {t}");
                inside += 1;
                // across the face beyond this cell on each axis (away from its edges, and where
                // the two cells link: the blend does not reach through walls), two steps of
                // 1e-4 cells
                for axis in 0..3 {
                    let mut at = lo + (0.4 + 0.2 * t) * size;
                    at[axis] = lo[axis] + size[axis];
                    let o = glam::IVec3::from(std::array::from_fn::<i32, 3, _>(|x| (x == axis) as i32));
                    let linked = faces.irradiance_sh().links[cell] & warpfit::runtime::link_bit(o) != 0;
                    if at[axis] >= geo.max[axis] - 0.01 * size[axis] || !linked {
                        continue;
                    }
                    let step =
                        Vec3::from(std::array::from_fn::<f32, 3, _>(|x| if x == axis { 1e-4 * size[x] } else { 0.0 }));
                    let (cell_a, cell_b) = (cell_grid.specular(at - step, d, r), cell_grid.specular(at + step, d, r));
                    let [f0, f1, f2] = [at - step * 3.0, at - step, at + step].map(|p| faces.specular(p, d, r));
                    let scale = f1.max_element().max(1e-3);
                    // across the face no more than two steps on one side (with room for rounding)
                    let across = (f2 - f1).abs().max_element();
                    let beside = (f1 - f0).abs().max_element();
                    assert!(
                        across <= beside + 1e-3 * scale,
                        "cell {cell} axis {axis} r {r}: jump {across} beside {beside} ({f1})"
                    );
                    crossings += 1;
                    jumps += ((cell_b - cell_a).abs().max_element() > 1e-2 * scale) as usize;
                }
            }
        }
        assert!(inside > 0 && crossings > 20, "{inside} inside, {crossings} crossings");
        assert!(jumps * 10 > crossings, "the containing cell's lookup jumps at only {jumps} of {crossings} faces");
    }
}

#[test]
fn a_grid_fitted_with_the_faces_blend_is_written_at_version_7_and_read_as_it() {
    // `--blend faces` stores `Faces` in the manifest at format version 7 (every other grid
    // stays at 6, so older readers keep reading it); the loaded grid answers as the same
    // grid switched to the faces blend, and a version-6 manifest naming it is refused
    let f = fixture();
    let dir = tmp_dir("runtime-faces");
    let faces = StoreOptions { blend: Blend::Faces, ..Default::default() };
    job::write_grid(f.baked(), &f.warp, &f.fit, faces, &RunFolder::new(&dir)).unwrap();
    let g = FittedGrid::load(&dir).unwrap();
    assert_eq!((g.manifest().version, g.blend()), (7, Blend::Faces));
    let cell = FittedGrid::load(&f.f32_dir).unwrap();
    assert_eq!((cell.manifest().version, cell.blend()), (GRID_VERSION_WRITTEN, Blend::Cell));
    let switched = cell.with_lookup(|_, blend, _| *blend = Blend::Faces);
    for (p, d, r) in tiny_queries().into_iter().map(|(p, d, r)| (p * 4.0, d, r)) {
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        assert_eq!(bits(g.specular(p, d, r)), bits(switched.specular(p, d, r)));
    }
    edit_manifest(&dir, |m| m["version"] = 6.into());
    let e = load_err(&dir);
    assert!(e.contains("manifest.json") && e.contains("warp.blend") && e.contains("version 7"), "{e}");
}

#[test]
fn a_lookup_reads_the_map_of_its_roughness() {
    // Up to ROUGH_MAP_FROM a lookup reads the cell's map alone, from ROUGH_MAP_TO its rough
    // map alone (the same answers as correctives holding only that map), and between them
    // a blend of the two (`warp::corrective::sample_maps`, tested there).
    use warpfit::warp::corrective::{Correctives, ROUGH_MAP_FROM, ROUGH_MAP_TO};
    let f = fixture();
    let c = &f.fit.correctives;
    assert!(c.has_rough_maps() && c.stored_cells() > 0, "the standard fit stores rough maps");
    let only = |maps: &Vec<f32>| Correctives::new(c.geometry, c.map_res, c.slot.clone(), maps.clone(), c.fallback);
    let (mirror, rough) = (only(&c.maps), only(&c.rough_maps));
    let geo = c.geometry;
    let (mut differ, mut compared) = (0, 0);
    for cell in (0..geo.cell_count()).filter(|&k| c.stores_map(k)) {
        for k in 0..16u32 {
            let mut s = warpfit::sampling::Sampler::new(37, cell as u64, k);
            let lo = geo.min + geo.cell_coords(cell).as_vec3() * geo.cell_size();
            let b = lo + Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * geo.cell_size();
            let d = warpfit::sampling::uniform_sphere(s.next_2d());
            let bits = |a: warpfit::warp::glossy::Aim| (a.v.to_array().map(f32::to_bits), a.k.map(f32::to_bits));
            let at = |g: &Correctives, r: f32| bits(g.fetch(Blend::Cell, &f.warp, b, d, r));
            for r in [0.0, 0.25, ROUGH_MAP_FROM] {
                assert_eq!(at(c, r), at(&mirror, r), "cell {cell} r {r}: the map's");
            }
            for r in [ROUGH_MAP_TO, 0.9, 1.0] {
                assert_eq!(at(c, r), at(&rough, r), "cell {cell} r {r}: the rough map's");
            }
            // in the band, a shifted surface between the two maps' surfaces: the aimed point's
            // distance along the ray lies between theirs
            let mid = 0.5 * (ROUGH_MAP_FROM + ROUGH_MAP_TO);
            let along =
                |g: &Correctives| (f.warp.probe.position + g.fetch(Blend::Cell, &f.warp, b, d, mid).v - b).dot(d);
            let [m, q, x] = [&mirror, &rough, c].map(along);
            if at(&mirror, mid) != at(&rough, mid) {
                differ += 1;
                let slack = 1e-4 * m.abs().max(q.abs());
                assert!(x >= m.min(q) - slack && x <= m.max(q) + slack, "cell {cell}: {x} not between {m} and {q}");
            }
            compared += 1;
        }
    }
    assert!(compared > 0 && differ * 4 > compared, "the maps differ in only {differ} of {compared} lookups");
}

#[test]
fn irradiance_at_a_cell_centre_is_that_cells_bake() {
    let g = FittedGrid::load(tiny()).unwrap();
    let ig = &g.irradiance_grid();
    let res = ig.resolution;
    assert!(ig.correction.stored_cells() > 0, "the witness grid stores a diffuse correction");
    for cell in 0..ig.geometry.cell_count() {
        let Some(slot) = (ig.slot[cell] != u32::MAX).then_some(ig.slot[cell] as usize) else { continue };
        let c = ig.geometry.cell_centre(cell);
        for t in [0u32, 5, 9] {
            let n = warpfit::octa::texel_dir(res, t % res, t / res);
            let want = ig.irradiance[slot * (res * res) as usize + t as usize];
            let got = ig.irradiance_blend(c, n, IrradianceBlend::Chebyshev);
            assert!(
                (got - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-3),
                "cell {cell}: {got} vs {want}"
            );
            // the runtime's answer is the blend with each cell's fitted correction: at a cell
            // centre, the cell's own
            let k = ig.correction.scale(cell, n);
            assert!(k > 0.0 && k.is_finite());
            let corrected = g.irradiance(c, n);
            assert!(
                (corrected - got * k).abs().max_element() <= 1e-5 * corrected.max_element().max(1e-3),
                "cell {cell}: {corrected} vs {}",
                got * k
            );
        }
    }
}

// ---- malformed input ---------------------------------------------------------------------

/// Copies fits/tiny's grid files to a fresh folder.
fn copy_tiny(tag: &str) -> TestDir {
    let dir = tmp_dir(tag);
    for f in ["manifest.json", "probe.exr", "correctives.exr", "irradiance.exr"] {
        std::fs::copy(tiny().join(f), dir.join(f)).unwrap();
    }
    dir
}

/// Edits the manifest and re-seals its checksum (where it still parses), so the loader's
/// deeper rules are what the edit meets; [`edit_manifest_unsealed`] leaves the seal alone.
fn edit_manifest(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    edit_manifest_unsealed(dir, edit);
    let p = dir.join(MANIFEST_FILE);
    if let Ok(mut m) = serde_json::from_slice::<warpfit::gridfile::GridManifest>(&std::fs::read(&p).unwrap()) {
        m.manifest_checksum = m.canonical_checksum();
        std::fs::write(&p, serde_json::to_vec_pretty(&m).unwrap()).unwrap();
    }
}

fn edit_manifest_unsealed(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let p = dir.join(MANIFEST_FILE);
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&p, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
}

/// Re-records size and checksum of `file` in the manifest (so the loader gets past them).
fn reseal(dir: &Path, file: &str) {
    let bytes = std::fs::read(dir.join(file)).unwrap();
    edit_manifest(dir, |v| {
        for p in v["payloads"].as_array_mut().unwrap() {
            if p["file"] == file {
                p["bytes"] = bytes.len().into();
                p["checksum"] = warpfit::files::checksum(&bytes).into();
            }
        }
    });
}

fn load_err(dir: &Path) -> String {
    match FittedGrid::load(dir) {
        Ok(_) => panic!("{} should not load", dir.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn every_malformed_input_is_an_error_naming_file_and_field() {
    // missing folder / manifest
    let e = load_err(&repo().join("fits/no-such-fit"));
    assert!(e.contains("manifest.json"), "{e}");

    // wrong version and foreign format
    let d = copy_tiny("bad-version");
    edit_manifest(&d, |v| v["version"] = 99.into());
    let e = load_err(&d);
    assert!(e.contains("manifest.json") && e.contains("version 99"), "{e}");
    let d = copy_tiny("foreign");
    std::fs::write(d.join(MANIFEST_FILE), br#"{"format": "something-else", "version": 1}"#).unwrap();
    assert!(load_err(&d).contains("\"something-else\""));

    // checksum mismatch: one flipped byte in a payload
    let d = copy_tiny("checksum");
    let mut bytes = std::fs::read(d.join("probe.exr")).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 0x40;
    std::fs::write(d.join("probe.exr"), &bytes).unwrap();
    let e = load_err(&d);
    assert!(e.contains("probe.exr") && e.contains("checksum"), "{e}");

    // truncated EXR (resealed, so the EXR decoder itself must notice)
    let d = copy_tiny("truncated");
    let bytes = std::fs::read(d.join("irradiance.exr")).unwrap();
    std::fs::write(d.join("irradiance.exr"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    let e = load_err(&d);
    assert!(e.contains("irradiance.exr") && e.contains("size"), "{e}");
    reseal(&d, "irradiance.exr");
    let e = load_err(&d);
    assert!(e.contains("irradiance.exr"), "{e}");

    // foreign payload (the manifest as EXR)
    let d = copy_tiny("foreign-payload");
    std::fs::copy(d.join(MANIFEST_FILE), d.join("correctives.exr")).unwrap();
    reseal(&d, "correctives.exr");
    let e = load_err(&d);
    assert!(e.contains("correctives.exr") && e.contains("not a readable EXR"), "{e}");

    // wrong sizes
    let d = copy_tiny("sizes");
    edit_manifest(&d, |v| v["correctives"]["map_res"] = 4.into());
    let e = load_err(&d);
    assert!(e.contains("correctives.exr") && e.contains("shift_maps"), "{e}");
    let d = copy_tiny("cells");
    edit_manifest(&d, |v| {
        let cells = v["irradiance"]["stored_cells"].as_array_mut().unwrap();
        *cells.last_mut().unwrap() = 4096.into();
    });
    let e = load_err(&d);
    assert!(e.contains("irradiance.stored_cells") && e.contains("out of range"), "{e}");
    let d = copy_tiny("unsorted");
    edit_manifest(&d, |v| v["irradiance"]["stored_cells"].as_array_mut().unwrap().swap(0, 1));
    let e = load_err(&d);
    assert!(e.contains("irradiance.stored_cells") && e.contains("sorted and unique"), "{e}");
    let d = copy_tiny("grid");
    edit_manifest(&d, |v| v["grid"]["counts"][1] = 0.into());
    assert!(load_err(&d).contains("grid.counts"));

    // NaN values inside a payload (re-encoded, resealed)
    let d = copy_tiny("nan");
    let path = d.join("probe.exr");
    let mut layers = warpfit::gridfile::exr::read(&path).unwrap();
    let l = layers.iter_mut().find(|l| l.name == "radiance_mip1").unwrap();
    l.channels[1].1[7] = f32::NAN;
    warpfit::gridfile::exr::write(&path, &layers).unwrap();
    reseal(&d, "probe.exr");
    let e = load_err(&d);
    assert!(e.contains("probe.exr") && e.contains("radiance_mip1.G") && e.contains("sample 7"), "{e}");

    // unknown fields are refused (a newer writer's manifest is not silently misread)
    let d = copy_tiny("unknown-field");
    edit_manifest(&d, |v| v["warp"]["new_knob"] = 1.into());
    let e = load_err(&d);
    assert!(e.contains("manifest.json") && e.contains("new_knob"), "{e}");

    // payload file names cannot leave the folder
    let d = copy_tiny("escape");
    edit_manifest(&d, |v| v["payloads"][0]["file"] = "../probe.exr".into());
    assert!(matches!(FittedGrid::load(&d), Err(LoadError::Invalid { .. })));
}

/// Loads `dir`, turning a panic into a test failure that names the mutation.
fn load_never_panics(dir: &Path, what: &str) {
    let r = std::panic::catch_unwind(|| FittedGrid::load(dir).map(|g| g.specular(Vec3::ONE, Vec3::X, 0.3)));
    match r {
        Err(_) => panic!("loader panicked on {what}"),
        Ok(Ok(s)) => assert!(s.is_finite(), "{what}: loaded but returned {s}"),
        Ok(Err(e)) => assert!(!e.to_string().is_empty()),
    }
}

proptest! {
    // Byte-level mutation of the real committed grid: random bytes overwritten, inserted or
    // cut, in the manifest or a payload, with the payload's checksum re-sealed half of the
    // time so the EXR decoder and the value checks see the damage too.
    // WARPFIT_FUZZ_CASES=20000 runs a longer campaign.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("WARPFIT_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(96),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]
    #[test]
    fn the_loader_never_panics_on_mutated_grids(
        file in 0usize..4,
        edits in proptest::collection::vec((any::<u32>(), any::<u8>(), 0u8..3), 1..6),
        reseal_it in any::<bool>(),
    ) {
        let name = ["manifest.json", "probe.exr", "correctives.exr", "irradiance.exr"][file];
        let d = copy_tiny("fuzz");
        let mut bytes = std::fs::read(d.join(name)).unwrap();
        for (pos, val, op) in &edits {
            let k = *pos as usize % bytes.len().max(1);
            match op {
                0 => bytes[k] = *val,
                1 => bytes.insert(k, *val),
                _ => bytes.truncate(k.max(1)),
            }
        }
        std::fs::write(d.join(name), &bytes).unwrap();
        if reseal_it && name != "manifest.json" {
            reseal(&d, name);
        }
        load_never_panics(&d, &format!("{name} with {edits:?}"));
    }
}

#[test]
fn corrected_irradiance_is_continuous_across_cell_faces() {
    // the corrections act inside the blend, so a corrected cell shows no seam at its faces
    let g = FittedGrid::load(tiny()).unwrap();
    let ig = &g.irradiance_grid();
    let size = ig.geometry.cell_size();
    let mut faces = 0;
    for cell in (0..ig.geometry.cell_count()).filter(|&c| ig.correction.slot[c] != u32::MAX) {
        let c = ig.geometry.cell_centre(cell);
        for axis in 0..3 {
            let mut face = c;
            face[axis] += 0.5 * size[axis];
            if face[axis] >= ig.geometry.max[axis] {
                continue;
            }
            for n in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z, Vec3::new(0.3, 0.8, -0.5).normalize()] {
                let eps =
                    Vec3::from(std::array::from_fn::<f32, 3, _>(|k| if k == axis { 1e-4 * size[k] } else { 0.0 }));
                let (a, b) = (g.irradiance(face - eps, n), g.irradiance(face + eps, n));
                let scale = a.max_element().max(b.max_element()).max(1e-3);
                assert!((a - b).abs().max_element() <= 2e-3 * scale, "cell {cell} axis {axis} n {n}: {a} vs {b}");
                faces += 1;
            }
        }
    }
    assert!(faces > 0, "the witness grid stores corrections at inner faces");
}

#[test]
fn rough_lookups_blend_the_cells_irradiance_by_the_stored_weight() {
    use warpfit::roughness::{RoughnessCorrection, RoughnessFit};
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    // fits/tiny_v5 was fitted before the blend: it reads probe A alone
    let base = FittedGrid::load(repo().join("fits/tiny_v5")).unwrap();
    let c = base.roughness().cloned().expect("the committed grid has a roughness correction");
    assert!(c.irradiance_nodes().is_empty(), "a grid fitted before the blend reads probe A alone");
    let n = c.alphas.len();
    let mut fit: RoughnessFit = c.into();
    fit.irradiance_weight = (0..n).map(|i| i as f32 / (n - 1) as f32).collect();
    let g = base.clone().with_roughness(Some(RoughnessCorrection::try_from(fit.clone()).unwrap()));
    let corr = g.roughness().unwrap();
    let view = &g.irradiance_sh();
    let mut blended = 0;
    for (p, d, _) in tiny_queries() {
        let d = d.normalize();
        assert_eq!(bits(g.specular(p, d, 0.0)), bits(base.specular(p, d, 0.0)), "mirror lookups are untouched");
        for r in [0.3, 0.7, 1.0] {
            let spec = base.specular(p, d, r);
            let want = match view.read(p, d) {
                Some(e) => warpfit::runtime::mix_irradiance(spec, e, corr.irradiance_weight(r)),
                None => spec,
            };
            assert_eq!(bits(g.specular(p, d, r)), bits(want), "{p} {d} r {r}");
            blended += usize::from(view.read(p, d).is_some() && want != spec);
        }
        // at the roughest row the weight is 1: the cell's irradiance over π alone
        if let Some(e) = view.read(p, d) {
            let got = g.specular(p, d, 1.0);
            assert!((got - e * std::f32::consts::FRAC_1_PI).abs().max_element() <= 1e-6 * (1.0 + e.max_element()));
        }
    }
    assert!(blended > 10, "only {blended} lookups blended");
    // the batch API blends lane by lane, bit for bit the single call
    let qs = tiny_queries();
    let p: Vec<Vec3> = qs.iter().map(|q| q.0).collect();
    let d: Vec<Vec3> = qs.iter().map(|q| q.1).collect();
    let r: Vec<f32> = qs.iter().map(|q| q.2).collect();
    let mut out = vec![Vec3::ZERO; qs.len()];
    g.specular_batch(&p, &d, &r, &mut out).unwrap();
    for k in 0..qs.len() {
        assert_eq!(bits(out[k]), bits(g.specular(p[k], d[k], r[k])), "query {k}");
    }
    // read probe A alone, the blending grid answers what the grid without weights does,
    // single and batched
    let probe_only = g.clone().with_read(SpecularRead::ProbeOnly);
    probe_only.specular_batch(&p, &d, &r, &mut out).unwrap();
    for k in 0..qs.len() {
        let want = bits(base.specular(p[k], d[k], r[k]));
        assert_eq!(bits(probe_only.specular(p[k], d[k], r[k])), want, "query {k}");
        assert_eq!(bits(out[k]), want, "query {k}, batched");
    }

    // weights that are not one per row in [0, 1] are refused
    for bad in [vec![0.5; n - 1], vec![1.5; n], vec![f32::NAN; n], vec![-0.1; n]] {
        let f = RoughnessFit { irradiance_weight: bad.clone(), ..fit.clone() };
        let e = RoughnessCorrection::try_from(f).unwrap_err();
        assert!(e.contains("irradiance_weight"), "{bad:?}: {e}");
    }
}

#[test]
fn the_blends_harmonics_hold_each_cells_irradiance_map() {
    // the nine coefficients a rough lookup reads against the bilinear map they come from,
    // per stored cell at directions between the texels, relative to the cell's mean. Bands
    // 0-2 hold a smooth irradiance within a few percent; the committed grid's maps are
    // 4×4, whose bilinear read is itself coarse, and one bright source nearby costs up to
    // about 10% (the clamped cosine's own band-2 error)
    let g = FittedGrid::load(tiny()).unwrap();
    let (ir, sh) = (&g.irradiance_grid(), &g.irradiance_sh());
    let view = ir.view();
    let mut relative = Vec::new();
    for cell in 0..ir.slot.len() {
        if ir.slot[cell] == warpfit::warp::corrective::NO_MAP {
            continue;
        }
        let centre = ir.geometry.cell_centre(cell);
        let (mut err, mut sum) = (0.0f64, 0.0f64);
        for k in 0..200u32 {
            let (a, b) = ((k as f32 + 0.5) / 200.0, (k as f32 * 0.618_034).fract());
            let d = warpfit::octa::decode(Vec2::new(a, b));
            let (map, harm) = (view.nearest(centre, d).unwrap(), sh.nearest(centre, d).unwrap());
            assert!(harm.is_finite() && harm.min_element() >= 0.0);
            err += (harm - map).length_squared() as f64;
            sum += map.length() as f64;
        }
        relative.push((err / 200.0).sqrt() / (sum / 200.0).max(1e-12));
    }
    relative.sort_by(f64::total_cmp);
    let (median, worst) = (relative[relative.len() / 2], relative[relative.len() - 1]);
    assert!(relative.len() >= 8 && median < 0.15 && worst < 0.3, "median {median}, worst {worst}: {relative:?}");
    // a cell that stores no map reads none through either
    if let Some(cell) = ir.slot.iter().position(|&s| s == warpfit::warp::corrective::NO_MAP) {
        let c = ir.geometry.cell_centre(cell);
        assert!(sh.nearest(c, Vec3::Y).is_none() && view.nearest(c, Vec3::Y).is_none());
    }
}

/// A 4×4×4 grid of unit cells whose irradiance maps are constant per cell, `value(cell
/// coordinates)`, and whose probes see `seen` scene units in every direction.
fn constant_cells(
    value: impl Fn(glam::UVec3) -> f32,
    seen: impl Fn(glam::UVec3) -> f32,
) -> warpfit::runtime::IrradianceSh {
    use warpfit::grid::GridGeometry;
    let geometry = GridGeometry { min: Vec3::ZERO, max: Vec3::splat(4.0), counts: glam::UVec3::splat(4) };
    let (res, dres) = (4u32, 4u32);
    let n = geometry.cell_count();
    let (mut irradiance, mut mean, mut mean_sq) = (Vec::new(), Vec::new(), Vec::new());
    for cell in 0..n {
        let c = geometry.cell_coords(cell);
        irradiance.extend(std::iter::repeat_n(Vec3::splat(value(c)), (res * res) as usize));
        mean.extend(std::iter::repeat_n(seen(c), (dres * dres) as usize));
        mean_sq.extend(std::iter::repeat_n(seen(c) * seen(c), (dres * dres) as usize));
    }
    let slot: Vec<u32> = (0..n as u32).collect();
    let view = warpfit::runtime::IrradianceView {
        geometry,
        resolution: res,
        depth_resolution: dres,
        slot: &slot,
        irradiance: &irradiance,
        depth_mean: &mean,
        depth_mean_sq: &mean_sq,
        probe_offset: &[],
    };
    warpfit::runtime::IrradianceSh::project(&view)
}

#[test]
fn the_blends_read_is_smooth_between_linked_cells_and_stops_at_walls_and_lamps() {
    let up = Vec3::new(0.3, 0.8, -0.52).normalize();
    // a field linear in position, every probe seeing far: every neighbour is linked, the
    // read interpolates the cells (linear inside each tetrahedron of cell centres, so a
    // linear field is read back), is the cell's own value at its centre and is continuous
    // across cell faces, where the containing cell's own harmonics jump
    let linear = |c: glam::UVec3| 1.0 + 0.1 * c.x as f32 + 0.2 * c.y as f32 + 0.05 * c.z as f32;
    let sh = constant_cells(linear, |_| 100.0);
    assert!(sh.links.iter().all(|&l| l.count_ones() >= 8), "corner cells link to their 7 neighbours and themselves");
    let own = |p: Vec3| sh.nearest(p, up).unwrap().x;
    let read = |p: Vec3| sh.read(p, up).unwrap().x;
    // (a constant map projects to band 0 alone, to rounding: E = c₀·Y₀)
    let scale = own(Vec3::splat(0.5)) / linear(glam::UVec3::ZERO);
    for p in [Vec3::new(1.5, 2.5, 0.5), Vec3::new(0.9, 1.2, 2.7), Vec3::new(2.2, 0.6, 1.1), Vec3::new(3.49, 3.1, 0.51)]
    {
        let lattice = (p - 0.5).clamp(Vec3::ZERO, Vec3::splat(3.0));
        let want = 1.0 + 0.1 * lattice.x + 0.2 * lattice.y + 0.05 * lattice.z;
        assert!((read(p) / scale - want).abs() < 1e-4 * want, "{p}: read {} want {want}", read(p) / scale);
    }
    for face in [Vec3::new(2.0, 1.3, 1.7), Vec3::new(0.4, 3.0, 2.2), Vec3::new(1.1, 2.6, 1.0)] {
        let axis = if face.x == 2.0 {
            Vec3::X
        } else if face.y == 3.0 {
            Vec3::Y
        } else {
            Vec3::Z
        };
        let (below, above) = (face - axis * 1e-4, face + axis * 1e-4);
        assert!((read(below) - read(above)).abs() < 1e-3 * read(below), "{face}: {} vs {}", read(below), read(above));
        assert!((own(below) - own(above)).abs() > 0.02 * own(below), "{face}: the cells themselves differ");
    }

    // a wall: the probes of cells with x ≥ 2 see only 0.2 units, so nothing links across
    // x = 2 (nor inside that half): a read never takes a cell behind it
    let walled = constant_cells(linear, |c| if c.x >= 2 { 0.2 } else { 100.0 });
    for p in [Vec3::new(1.9, 1.5, 1.5), Vec3::new(2.1, 1.5, 1.5), Vec3::new(2.6, 0.7, 3.2)] {
        let (r, o) = (walled.read(p, up).unwrap(), walled.nearest(p, up).unwrap());
        if p.x >= 2.0 {
            assert_eq!(r, o, "{p}: a cell that sees nothing reads itself alone");
        } else {
            // x < 2 blends only cells with x < 2: the value of lattice x clamped to ≤ 1
            let want = 1.0 + 0.1 * 1.0 + 0.2 * (p.y - 0.5) + 0.05 * (p.z - 0.5);
            assert!((r.x / scale - want).abs() < 1e-4 * want, "{p}: {} want {want}", r.x / scale);
        }
    }

    // a lamp: one cell 10× brighter than its neighbours links to none of them, so its
    // light stays in its own cell and theirs stays out of it
    let lamp = glam::UVec3::new(1, 1, 1);
    let lit = constant_cells(|c| if c == lamp { 10.0 } else { 1.0 }, |_| 100.0);
    let at = lit.geometry.cell_index(lamp);
    assert_eq!(lit.links[at], 1 << 13, "the lamp's cell links only to itself");
    for p in [Vec3::new(1.05, 1.5, 1.5), Vec3::new(0.95, 1.5, 1.5), Vec3::new(1.5, 2.02, 1.1)] {
        let (r, o) = (lit.read(p, up).unwrap(), lit.nearest(p, up).unwrap());
        assert!((r - o).abs().max_element() <= 1e-6 * o.max_element(), "{p}: {r} vs its own {o}");
    }
    // every read is finite and non-negative, in the grid and outside it
    for p in [Vec3::splat(-1e30), Vec3::splat(1e30), Vec3::new(4.0, 4.0, 4.0), Vec3::ZERO, Vec3::new(-0.0, 2.0, 9.0)] {
        let r = sh.read(p, up).unwrap();
        assert!(r.is_finite() && r.min_element() >= 0.0, "{p}: {r}");
    }
}
