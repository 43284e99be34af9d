//! Several specular probes: placement, the fit's per-texel choice, the grid format and the
//! runtime reading them.

mod common;

use common::*;
use warpfit::bake::placement;
use warpfit::eval::methods::face_blend;
use warpfit::jobs::run::{self as job, Output, StoreOptions};
use warpfit::progress::Progress;
use warpfit::report::folder::RunFolder;
use warpfit::runtime::FittedGrid;
use warpfit::scene::Scene;
use warpfit::trace::{Renderer, Tracer};
use warpfit::warp::corrective::Blend;
use warpfit_runtime::glam::Vec3;

/// Two closed rooms side by side (x < 0 warm, x > 0 cool), a door between them in the
/// wall at x = 0; probe A in the warm room. `probes`: the scene's `[probes]` table body.
fn two_rooms(probes: &str) -> Scene {
    let text = format!(
        r#"
seed = 3
[probe]
position = [-2.0, 1.2, 0.0]
resolution = 32
samples_per_texel = 2
ggx_samples = 8
[probes]
{probes}
[grid]
min = [-3.9, 0.1, -1.9]
max = [3.9, 2.4, 1.9]
counts = [6, 2, 3]
irradiance_resolution = 4
depth_resolution = 8
depth_samples = 1
[sky]
zenith = [0.0, 0.0, 0.0]
horizon = [0.0, 0.0, 0.0]
ground = [0.0, 0.0, 0.0]
[[sphere_lights]]
position = [-2.0, 2.2, 1.0]
radius = 0.1
radiance = [40.0, 30.0, 20.0]
[[sphere_lights]]
position = [2.0, 2.2, -1.0]
radius = 0.1
radiance = [20.0, 30.0, 40.0]
[[geometry]]
type = "room"
min = [-4.0, 0.0, -2.0]
max = [4.0, 2.5, 2.0]
material = {{ albedo = [0.7, 0.7, 0.7] }}
[[geometry]]
type = "box"
min = [-0.1, 0.0, -2.0]
max = [0.1, 2.5, -0.4]
material = {{ albedo = [0.8, 0.4, 0.3] }}
[[geometry]]
type = "box"
min = [-0.1, 0.0, 0.4]
max = [0.1, 2.5, 2.0]
material = {{ albedo = [0.3, 0.4, 0.8] }}
[[geometry]]
type = "box"
min = [-0.1, 1.9, -0.4]
max = [0.1, 2.5, 0.4]
material = {{ albedo = [0.7, 0.7, 0.7] }}
"#
    );
    Scene::parse(&text, &repo().join("tests/fixtures/two_rooms.toml")).expect("the two rooms parse")
}

#[test]
fn placement_adds_a_probe_for_the_room_probe_a_cannot_see_and_none_for_a_closed_room() {
    let scene = two_rooms("auto = true\nmax = 4");
    let tracer = Tracer::new(&scene);
    let renderer = Renderer::new(&scene, &tracer);
    let settings = warpfit::bake::grid_settings(&scene);
    let p = placement::place(&renderer, &settings);
    assert!(p.placed >= 1 && p.positions.len() <= 4, "{p:?}");
    assert!(p.hidden_probe_a > 0.3, "probe A sees one room of two: {p:?}");
    assert!(p.hidden < 0.5 * p.hidden_probe_a, "the placed probes see the other room: {p:?}");
    assert!(p.positions[1..].iter().any(|q| q.x > 0.1), "a probe stands in the other room: {p:?}");
    // the same at any thread count
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    assert_eq!(one.install(|| placement::place(&renderer, &settings)), p);
    // without auto nothing is placed, and the hidden share is measured all the same
    let fixed = two_rooms("positions = [[2.0, 1.2, 0.0]]");
    let tracer = Tracer::new(&fixed);
    let q = placement::place(&Renderer::new(&fixed, &tracer), &warpfit::bake::grid_settings(&fixed));
    assert_eq!((q.placed, q.positions.len()), (0, 2));
    assert!(q.hidden < q.hidden_probe_a, "{q:?}");
    // a closed room whose probe sees every wall places nothing
    let room = parse(
        "[probes]\nauto = true\n[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\n[[sphere_lights]]\nposition = [0.0, 1.5, 0.0]\nradius = 0.1\nradiance = [9.0, 9.0, 9.0]",
    )
    .unwrap();
    let tracer = Tracer::new(&room);
    let r = placement::place(&Renderer::new(&room, &tracer), &warpfit::bake::grid_settings(&room));
    assert_eq!(r.positions.len(), 1, "{r:?}");
}

#[test]
fn a_multi_probe_grid_reads_the_probe_each_texel_chose_and_beats_probe_a_alone() {
    let scene = two_rooms("auto = true\nmax = 3");
    let tracer = Tracer::new(&scene);
    let quiet = Progress::quiet();
    let bake = warpfit::bake::bake(&scene, &tracer, &quiet);
    assert!(!bake.others.is_empty(), "the two rooms place a second probe");
    let dir = tmp_dir("probes-grid");
    let settings = warpfit::fit::FitSettings::quick();
    let fit_into = |b: job::Baked, sub: &str| {
        let folder = RunFolder::new(dir.join(sub));
        let warp = b.warp(warpfit::warp::WarpOptions::standard());
        let out = Output { folder: &folder, command: "test", progress: &quiet };
        job::fit(b, &warp, &settings, StoreOptions::default(), warpfit::fit::MapSets::Stored, out).unwrap();
        FittedGrid::load(dir.join(sub)).unwrap()
    };
    let several = fit_into(bake.baked(&scene, &tracer), "several");
    let alone = fit_into(job::Baked { others: &[], ..bake.baked(&scene, &tracer) }, "alone");
    assert_eq!(several.warp().probe_count(), 1 + bake.others.len());
    let c = several.correctives();
    let version = if c.cell_probes.is_empty() { warpfit::gridfile::GRID_VERSION_WRITTEN } else { 8 };
    assert_eq!(several.manifest().version, version);
    assert_eq!(c.probe_maps.len(), c.maps.len(), "a probe index per stored texel");
    assert!(c.probe_maps.iter().any(|&p| p > 0), "some texels read another probe than A");
    assert!(alone.correctives().probe_maps.is_empty() && alone.warp().probe_count() == 1);

    // held-out queries in the cool room (x > 0), which probe A does not see
    let (mut b, mut d, mut r) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..256u32 {
        let mut s = warpfit::sampling::Sampler::new(9, 0xB0B, k);
        let p = Vec3::new(0.5 + 3.0 * s.next_1d(), 0.3 + 1.8 * s.next_1d(), -1.6 + 3.2 * s.next_1d());
        b.push(p);
        d.push(warpfit::sampling::uniform_sphere(s.next_2d()));
        r.push([0.0, 0.0, 0.5, 1.0][k as usize % 4]);
    }
    // the batch API answers bit for bit as one lookup at a time
    let mut batch = vec![Vec3::ZERO; b.len()];
    several.specular_batch(&b, &d, &r, &mut batch).unwrap();
    for k in 0..b.len() {
        let one = several.specular(b[k], d[k], r[k]);
        assert_eq!(one.to_array().map(f32::to_bits), batch[k].to_array().map(f32::to_bits), "query {k}");
        assert!(one.is_finite() && one.min_element() >= 0.0);
    }
    // against the truth: mirror references traced along the queries
    let renderer = Renderer::new(&scene, &tracer);
    let (refs, _) = warpfit::trace::trace_batch(&renderer, &b, &d, 9, 0x5EF, 64);
    let exposure = several.warp().probe.key_exposure();
    let tm = |v: Vec3| warpfit::tonemap::reinhard(v, exposure);
    let error = |g: &FittedGrid| -> f32 {
        (0..b.len()).map(|k| (tm(g.specular(b[k], d[k], 0.0)) - tm(refs[k].radiance)).abs().element_sum()).sum::<f32>()
    };
    let (e_several, e_alone) = (error(&several), error(&alone));
    assert!(e_several < 0.7 * e_alone, "several probes {e_several} against probe A alone {e_alone}");
    // the fit judged the rough lookups' irradiance blend on what the grid reads (each
    // texel's probe, not probe A alone): at low roughness the blended read is not worse
    // than the probes alone against lobe references
    let lobes: Vec<Vec3> = (0..b.len())
        .map(|k| {
            let (x, y) = warpfit::perceptual::lobe_halves(&renderer, (b[k], d[k], 0.125), 32, (9, 0x5F0 + k as u64));
            (x + y) * 0.5
        })
        .collect();
    let rough_error = |read: warpfit::runtime::SpecularRead| -> f32 {
        (0..b.len())
            .map(|k| (tm(several.specular_as(read, b[k], d[k], 0.125)) - tm(lobes[k])).abs().element_sum())
            .sum::<f32>()
    };
    let (blended, alone) =
        (rough_error(warpfit::runtime::SpecularRead::Blended), rough_error(warpfit::runtime::SpecularRead::ProbeOnly));
    assert!(blended <= 1.05 * alone, "blended {blended} against the probes alone {alone}");

    // `fitted-faces`: inside a cell, the containing cell's lookup bit for bit; across the
    // cell face of the warm room where the containing cell's lookup jumps most (x = −2.6 or
    // −1.3), continuous
    let shading = warpfit::warp::glossy::Glossy { warp: several.warp(), correction: None };
    let rule = warpfit::warp::glossy::MipRule::Plain;
    let (c, warp) = (several.correctives(), several.warp());
    let cell = |p: Vec3, dir: Vec3| shading.radiance(rule, p, dir, c.fetch(Blend::Cell, warp, p, dir, 0.0), 0.0);
    let faces = |p: Vec3, dir: Vec3| face_blend(shading, rule, c, (p, dir, 0.0));
    let jumps = |x: f32| {
        let (mut jump_cell, mut jump_faces) = (0.0f32, 0.0f32);
        for k in 0..256u32 {
            let mut s = warpfit::sampling::Sampler::new(9, 0xFACE, k);
            let dir = warpfit::sampling::uniform_sphere(s.next_2d());
            let (y, z) = (0.4 + 0.5 * s.next_1d(), -0.3 + 0.6 * s.next_1d());
            let centre = c.geometry.cell_centre(c.geometry.cell_index(c.geometry.cell_of(Vec3::new(x - 0.65, y, z))));
            assert_eq!(faces(centre, dir).to_array().map(f32::to_bits), cell(centre, dir).to_array().map(f32::to_bits));
            let (below, above) = (Vec3::new(x - 1e-4, y, z), Vec3::new(x + 1e-4, y, z));
            jump_cell = jump_cell.max((tm(cell(below, dir)) - tm(cell(above, dir))).abs().max_element());
            jump_faces = jump_faces.max((tm(faces(below, dir)) - tm(faces(above, dir))).abs().max_element());
        }
        (jump_cell, jump_faces)
    };
    let (jump_cell, jump_faces) = [jumps(-2.6), jumps(-1.3)].into_iter().max_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
    assert!(jump_cell > 0.05 && jump_faces < 0.25 * jump_cell && jump_faces < 0.02, "{jump_cell} {jump_faces}");
}

#[test]
fn several_probes_are_refused_when_a_file_or_field_is_wrong() {
    let scene = two_rooms("positions = [[2.0, 1.2, 0.0]]");
    let tracer = Tracer::new(&scene);
    let quiet = Progress::quiet();
    let bake = warpfit::bake::bake(&scene, &tracer, &quiet);
    let dir = tmp_dir("probes-bad");
    let folder = RunFolder::new(&*dir);
    let b = bake.baked(&scene, &tracer);
    let warp = b.warp(warpfit::warp::WarpOptions::standard());
    let out = Output { folder: &folder, command: "test", progress: &quiet };
    job::fit(
        b,
        &warp,
        &warpfit::fit::FitSettings::quick(),
        StoreOptions::default(),
        warpfit::fit::MapSets::Stored,
        out,
    )
    .unwrap();
    FittedGrid::load(&*dir).unwrap();
    let manifest_path = dir.join("manifest.json");
    let original = std::fs::read_to_string(&manifest_path).unwrap();
    let edit = |f: &dyn Fn(&mut warpfit::gridfile::GridManifest)| {
        let mut m: warpfit::gridfile::GridManifest = serde_json::from_str(&original).unwrap();
        f(&mut m);
        m.manifest_checksum = m.canonical_checksum();
        std::fs::write(&manifest_path, serde_json::to_string(&m).unwrap()).unwrap();
        FittedGrid::load(&*dir).unwrap_err().to_string()
    };
    let e = edit(&|m| m.other_probes[0].resolution /= 2);
    assert!(e.contains("other_probes[0]") && e.contains("probe A's resolution"), "{e}");
    let e = edit(&|m| m.version = 5);
    assert!(e.contains("other_probes") && e.contains("version 6"), "{e}");
    // the cells without a map that read probe 1: a value the writer cannot produce, named
    let stored = serde_json::from_str::<warpfit::gridfile::GridManifest>(&original)
        .unwrap()
        .correctives
        .map_or_else(Vec::new, |c| c.stored_cells);
    let cells: u32 = scene.config.grid.counts.iter().product();
    let unmapped: Vec<u32> = (0..cells).filter(|c| stored.binary_search(c).is_err()).take(2).collect();
    let (a, b) = (unmapped[0], unmapped[1]);
    for (cell_probes, version, says) in [
        (vec![(a, 1u8)], 7, "version 8"),
        (vec![(a, 0)], 8, "not a probe other than A"),
        (vec![(a, 2)], 8, "not a probe other than A"),
        (vec![(b, 1), (a, 1)], 8, "sorted and unique"),
        (vec![(cells, 1)], 8, "out of range"),
    ] {
        let e = edit(&|m| (m.cell_probes, m.version) = (cell_probes.clone(), version));
        assert!(e.contains("cell_probes") && e.contains(says), "{e}");
    }
    if let Some(&c) = stored.first() {
        let e = edit(&|m| (m.cell_probes, m.version) = (vec![(c, 1)], 8));
        assert!(e.contains("cell_probes") && e.contains("stores a map"), "{e}");
    }
    std::fs::write(&manifest_path, &original).unwrap();
    std::fs::remove_file(dir.join("probe_1.exr")).unwrap();
    let e = FittedGrid::load(&*dir).unwrap_err().to_string();
    assert!(e.contains("probe_1.exr"), "{e}");
}

#[test]
fn the_probes_table_is_validated_with_named_errors() {
    for (body, field) in [
        ("[probes]\nmax = 0", "probes.max"),
        ("[probes]\nmax = 17", "probes.max"),
        ("[probes]\nmax = 1\npositions = [[0.0, 1.0, 0.5]]", "probes.positions"),
        ("[probes]\nmin_gain = 0.0", "probes.min_gain"),
        ("[probes]\nmin_gain = 1.5", "probes.min_gain"),
        ("[probes]\nautomatic = true", "automatic"),
    ] {
        let e = parse(body).unwrap_err().to_string();
        assert!(e.contains(field), "{body}: {e}");
    }
    let ok = "[probes]\npositions = [[0.0, 1.0, 0.5]]\nauto = true\nmax = 4\nmin_gain = 0.05\n[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]";
    let s = parse(ok).unwrap();
    assert_eq!(s.config.probes.positions.len(), 1);
    // a scene without the table has probe A alone, and writes no table back
    let plain = parse("[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]").unwrap();
    assert!(plain.config.probes.is_single() && !plain.config.probes.auto);
}

#[test]
fn the_export_lays_several_probes_side_by_side_and_names_them() {
    let grid = FittedGrid::load(repo().join("fits/tiny_probes")).unwrap();
    let dir = tmp_dir("probes-export");
    let sidecar = warpfit::export::export(&grid, &dir).unwrap();
    assert_eq!(sidecar.probe_positions.len(), 2);
    assert_eq!(sidecar.probe_positions[1], grid.warp().others[0].position.to_array());
    let c = sidecar.correctives.as_ref().unwrap();
    let stored = grid.correctives().stored_cells() as u32;
    assert_eq!(c.probe_tile_offset, Some(2 * stored), "after the maps and the rough maps");
    // the probe textures: two squares side by side at every mip
    let bytes = std::fs::read(dir.join("probe_inv_distance.ktx2")).unwrap();
    let reader = ktx2::Reader::new(&bytes).unwrap();
    let h = reader.header();
    let n = grid.warp().probe.inv_depth.levels[0].res;
    assert_eq!((h.pixel_width, h.pixel_height), (2 * n, n));
}

#[test]
fn a_cell_without_a_map_reads_its_own_probe_through_the_proxy_on_every_path() {
    // the committed two-probe grid with every map dropped, each cell reading probe 1
    let grid = FittedGrid::load(repo().join("fits/tiny_probes")).unwrap();
    let cells = grid.correctives().geometry.cell_count();
    let unmapped = |probe: u8, blend: Blend| {
        grid.clone().with_lookup(|_, b, c| {
            *b = blend;
            c.slot = vec![warpfit::warp::corrective::NO_MAP; cells];
            c.cell_probes = vec![probe; cells];
        })
    };
    let (one, faces, probe_a) = (unmapped(1, Blend::Cell), unmapped(1, Blend::Faces), unmapped(0, Blend::Cell));
    let (warp, c) = (one.warp(), one.correctives());
    let shading = warpfit::warp::glossy::Glossy { warp, correction: None };
    let (lo, hi) = grid.bounds();
    let (mut b, mut d) = (Vec::new(), Vec::new());
    for k in 0..64u32 {
        let mut s = warpfit::sampling::Sampler::new(5, 0xCE11, k);
        b.push(lo + (hi - lo) * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()));
        d.push(warpfit::sampling::uniform_sphere(s.next_2d()));
    }
    let mut batch = vec![Vec3::ZERO; b.len()];
    one.specular_batch(&b, &d, &vec![0.0; b.len()], &mut batch).unwrap();
    let mut differs = 0;
    for k in 0..b.len() {
        // the aim: probe 1 fetched towards the proxy's surface, unshifted
        let aim = c.fetch(Blend::Cell, warp, b[k], d[k], 0.0);
        assert_eq!(aim.probe, 1, "query {k}");
        let t = warp.base_distance(c.fallback, b[k], d[k]);
        let expected = warpfit::warp::corrective::shifted_aim(warp.probe_at(1).position, t, 0.0, b[k], d[k]);
        assert_eq!(aim.v.to_array().map(f32::to_bits), expected.v.to_array().map(f32::to_bits), "query {k}");
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let single = one.specular(b[k], d[k], 0.0);
        assert_eq!(bits(single), bits(batch[k]), "batch, query {k}");
        let centre = c.geometry.cell_centre(c.cell_at(b[k]));
        assert_eq!(bits(one.specular(centre, d[k], 0.0)), bits(faces.specular(centre, d[k], 0.0)), "faces, query {k}");
        let rule = warpfit::warp::glossy::MipRule::Plain;
        assert!(shading.radiance(rule, b[k], d[k], aim, 0.0).is_finite());
        if bits(single) != bits(probe_a.specular(b[k], d[k], 0.0)) {
            differs += 1;
        }
    }
    assert!(differs > b.len() / 4, "reading probe 1 differs from probe A on {differs} of {} queries", b.len());
}
