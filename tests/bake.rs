//! Bakes: closed-form distances, inside-geometry flags, bit-identical results at any thread
//! count, and files that read back exactly.

mod common;
use common::*;
use glam::{Vec3, Vec3A};
use warpfit::bake::{self, Bake};
use warpfit::bakefile;
use warpfit::octa;
use warpfit::progress::Progress;
use warpfit::scene::Scene;
use warpfit::trace::{Tracer, bvh::intersect_sphere};

/// The torture scene at test resolution.
fn small_torture() -> Scene {
    let mut s = load("torture");
    s.config.probe.resolution = 64;
    s.config.probe.samples_per_texel = 2;
    s.config.probe.ggx_samples = 16;
    s.config.grid.counts = [6, 3, 6];
    s.config.grid.depth_resolution = 8;
    s.config.grid.depth_samples = 2;
    s
}

fn bake_with_threads(scene: &Scene, threads: usize) -> Bake {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let tracer = Tracer::new(scene);
        bake::bake(scene, &tracer, &Progress::quiet())
    })
}

/// The small torture baked on 2 threads and written into a fresh folder `name`.
fn written_bake(name: &str) -> (Bake, TestDir) {
    let scene = small_torture();
    let baked = bake_with_threads(&scene, 2);
    let dir = tmp_dir(name);
    bakefile::write_bake(&dir, &scene, &baked).unwrap();
    (baked, dir)
}

#[test]
fn bake_is_bit_identical_at_any_thread_count() {
    let scene = small_torture();
    let a = bake_with_threads(&scene, 1);
    let b = bake_with_threads(&scene, 2);
    let c = bake_with_threads(&scene, 3);
    assert!(a.probe == b.probe && a.probe == c.probe, "probe differs between thread counts");
    assert!(a.grid == b.grid && a.grid == c.grid, "grid differs between thread counts");
    // and so are the encoded files
    let p = std::path::Path::new("probe.exr");
    let ea =
        warpfit::gridfile::exr::encode(p, warpfit::gridfile::probe_layers(&a.probe.radiance, &a.probe.depth), |_| {
            false
        })
        .unwrap();
    let eb =
        warpfit::gridfile::exr::encode(p, warpfit::gridfile::probe_layers(&b.probe.radiance, &b.probe.depth), |_| {
            false
        })
        .unwrap();
    assert!(ea == eb, "probe.exr bytes differ");
}

#[test]
fn bake_folder_reads_back_exactly() {
    let (baked, dir) = written_bake("roundtrip");
    for f in ["probe.exr", "grid.exr", "manifest.json"] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind");
    let (manifest, probe, grid) = bakefile::read_bake(&dir).unwrap();
    assert_eq!(probe, baked.probe);
    assert_eq!(grid, baked.grid);
    assert_eq!(manifest.probe.radiance_mips.len(), probe.radiance.levels.len());
    assert_eq!(manifest.probe.radiance_mips[0].perceptual_roughness, 0.0);
    assert_eq!(manifest.probe.radiance_mips.last().unwrap().perceptual_roughness, 1.0);
    assert!(manifest.conventions.octahedral.contains("sign(0)=+1"));
    // the sky is visible through the skylight: some probe distances are +inf and survive
    assert!(probe.distance().texels.iter().any(|d| d.is_infinite()));
}

#[test]
fn foreign_and_damaged_bakes_are_errors() {
    let (_, dir) = written_bake("damaged");
    // truncated EXR
    let probe = std::fs::read(dir.join("probe.exr")).unwrap();
    std::fs::write(dir.join("probe.exr"), &probe[..probe.len() / 2]).unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("probe.exr"), "{e}");
    // one byte of the grid changed, its size kept: the checksum read through the file
    std::fs::write(dir.join("probe.exr"), &probe).unwrap();
    let mut grid = std::fs::read(dir.join("grid.exr")).unwrap();
    let k = grid.len() / 2;
    grid[k] ^= 0x40;
    std::fs::write(dir.join("grid.exr"), &grid).unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("grid.exr") && e.contains("checksum"), "{e}");
    // a JSON file where the EXR should be
    std::fs::copy(dir.join("manifest.json"), dir.join("probe.exr")).unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("probe.exr"), "{e}");
    // wrong version
    let m = std::fs::read_to_string(dir.join("manifest.json")).unwrap();
    std::fs::write(
        dir.join("manifest.json"),
        m.replace(&format!("\"version\": {}", bakefile::manifest::BAKE_VERSION), "\"version\": 99"),
    )
    .unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("manifest.json") && e.contains("99"), "{e}");
    // not JSON at all
    std::fs::write(dir.join("manifest.json"), "{ nope").unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("manifest.json"), "{e}");
}

#[test]
fn hit_counts_are_read_back_as_counts() {
    let (baked, dir) = written_bake("hits");
    assert!(baked.grid.hits.contains(&1), "some texel has one of its two rays hit");
    let m = std::fs::read_to_string(dir.join("manifest.json")).unwrap();
    assert!(m.contains("\"depth_samples\": 2"), "{m}");
    // the stored fractions are halves: not counts of 3 rays
    std::fs::write(dir.join("manifest.json"), m.replace("\"depth_samples\": 2", "\"depth_samples\": 3")).unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("grid.exr") && e.contains("depth_moments.hit") && e.contains("3 rays"), "{e}");
    // a count a byte cannot hold
    std::fs::write(dir.join("manifest.json"), m.replace("\"depth_samples\": 2", "\"depth_samples\": 256")).unwrap();
    let e = bakefile::read_bake(&dir).unwrap_err().to_string();
    assert!(e.contains("manifest.json") && e.contains("grid.depth_samples"), "{e}");
    std::fs::write(dir.join("manifest.json"), &m).unwrap();
    let (_, _, grid) = bakefile::read_bake(&dir).unwrap();
    assert_eq!(grid.hits, baked.grid.hits);
    assert_eq!(warpfit::bake::grid::hit_fraction(grid.hits[0], grid.depth_samples), f32::from(grid.hits[0]) / 2.0);
}

#[test]
fn hit_counts_left_for_later_read_back_the_same_from_the_same_bake_only() {
    let (baked, dir) = written_bake("hits-later");
    let (m, _, mut grid) = bakefile::read_bake_with(&dir, bakefile::Hits::Later).unwrap();
    assert!(grid.hits.is_empty() && !grid.holds_hits());
    assert!(baked.grid.holds_hits());
    grid.hits = bakefile::read_hits(&dir, &m.key, &grid).unwrap();
    assert_eq!(grid, baked.grid, "the grid read in two steps is the grid read at once");
    // a bake replaced in between (another key), or its grid file damaged: errors naming the file
    let e = bakefile::read_hits(&dir, "fnv1a64:0000000000000000", &grid).unwrap_err().to_string();
    assert!(e.contains("manifest.json") && e.contains("changed"), "{e}");
    let mut bytes = std::fs::read(dir.join("grid.exr")).unwrap();
    let k = bytes.len() / 3;
    bytes[k] ^= 0x10;
    std::fs::write(dir.join("grid.exr"), &bytes).unwrap();
    let e = bakefile::read_hits(&dir, &m.key, &grid).unwrap_err().to_string();
    assert!(e.contains("grid.exr") && e.contains("checksum"), "{e}");
}

#[test]
fn sphere_probe_distances_are_closed_form() {
    let scene = load("sphere");
    let tracer = Tracer::new(&scene);
    let baked = bake::bake(&scene, &tracer, &Progress::quiet());
    let centre = Vec3::new(0.0, 1.0, 0.0);
    let light = scene.lights.sphere_lights[0];
    let dist = baked.probe.distance();
    let n = dist.res;
    let mut light_texels = 0;
    for j in 0..n {
        for i in 0..n {
            let d = octa::texel_dir(n, i, j);
            let to_light = intersect_sphere(
                Vec3A::from(centre),
                Vec3A::from(d),
                Vec3A::from(light.position),
                light.radius,
                0.0,
                f32::INFINITY,
            );
            let want = to_light.min(2.0);
            light_texels += (to_light < 2.0) as u32;
            let got = dist.get(i, j);
            assert!((got - want).abs() / want < 1e-5, "texel ({i},{j}): {got} vs {want}");
        }
    }
    assert!(light_texels > 0, "the light should cover some texels");
    assert!(baked.grid.inside.iter().all(|x| !x), "no cell of the sphere is inside geometry");
}

#[test]
fn cells_inside_solid_geometry_are_flagged() {
    // A solid box filling the lower half of the grid: cells with centre y < 1 are inside.
    let scene = parse("[[geometry]]\ntype = \"room\"\nmin = [-3.0, -3.0, -3.0]\nmax = [3.0, 3.0, 3.0]\n[[geometry]]\ntype = \"box\"\nmin = [-2.0, -1.0, -2.0]\nmax = [2.0, 1.0, 2.0]\n").unwrap();
    let tracer = Tracer::new(&scene);
    let baked = bake::bake(&scene, &tracer, &Progress::quiet());
    let g = &baked.grid;
    for cell in 0..g.geometry.cell_count() {
        let c = g.geometry.cell_centre(cell);
        assert_eq!(g.inside[cell], c.y < 1.0, "cell {cell} at {c}");
    }
    assert_eq!(g.active_cells(), 4);
}

#[test]
fn irradiance_of_uniform_sky_is_pi_times_radiance() {
    // No geometry near the probe: a constant sky L gives E(n) = π L for every normal.
    let scene = parse("[sky]\ncolor = [1.0, 0.5, 0.25]\n[[geometry]]\ntype = \"sphere\"\ncenter = [50.0, 50.0, 50.0]\nradius = 0.001\n").unwrap();
    let tracer = Tracer::new(&scene);
    let baked = bake::bake(&scene, &tracer, &Progress::quiet());
    let want = Vec3::new(1.0, 0.5, 0.25) * std::f32::consts::PI;
    for e in &baked.grid.irradiance {
        assert!((*e - want).length() < 1e-5 * want.length(), "{e} vs {want}");
    }
}

/// A scene inside an inward sphere of albedo `albedo` (0: black walls), with a lamp and
/// a black sky when `lamp`: what the emitted-part tests bake.
fn lamp_room(albedo: f32, lamp: bool) -> Scene {
    let lights = "[sky]\nzenith = [0.0, 0.0, 0.0]\nhorizon = [0.0, 0.0, 0.0]\nground = [0.0, 0.0, 0.0]\n[[sphere_lights]]\nposition = [0.0, 1.0, 2.0]\nradius = 0.5\nradiance = [40.0, 40.0, 40.0]\n";
    let room = format!(
        "[[geometry]]\ntype = \"sphere\"\ncenter = [0.0, 1.0, 0.0]\nradius = 6.0\ninward = true\nmaterial = {{ albedo = [{albedo}, {albedo}, {albedo}] }}\n"
    );
    let body = if lamp { format!("{lights}{room}") } else { room };
    Scene::parse(&format!("bounces = 0\n{HEADER}\n{body}"), &fixture("emitted.toml")).unwrap()
}

/// Probe A's emitted chain (what the evaluation takes out of every lookup to measure the
/// light apart from the emitters) is the bake's own rays' emitted part: all of the probe
/// where the lamp is all it sees, none where it sees a lit wall, nothing without emitters.
#[test]
fn the_emitted_chain_is_the_probes_lamp_and_nothing_else() {
    let emitted_of = |scene: &Scene| {
        let tracer = Tracer::new(scene);
        let renderer = warpfit::trace::Renderer::new(scene, &tracer);
        let baked = bake::bake(scene, &tracer, &Progress::quiet());
        let settings = bake::probe_settings(scene);
        let (emitted, rays) = bake::probe::emitted_mips(&renderer, &settings, &Progress::quiet());
        (baked.probe.radiance, emitted, rays)
    };

    // black walls and sky: every bit of the probe is the lamp, mips included
    let scene = lamp_room(0.0, true);
    let (radiance, emitted, rays) = emitted_of(&scene);
    assert!(rays > 0);
    assert_eq!(emitted.levels.len(), radiance.levels.len());
    for (e, r) in emitted.levels.iter().zip(&radiance.levels) {
        assert_eq!(e.res, r.res);
        assert!(e.texels == r.texels, "the emitted chain is the probe itself where only the lamp shines");
    }
    assert!(emitted.levels[0].texels.iter().any(|l| l.x > 0.0), "the lamp covers some texels");

    // lit walls: the walls' texels carry light but no emitted part; the lamp's carry both
    let scene = lamp_room(0.5, true);
    let (radiance, emitted, _) = emitted_of(&scene);
    let (r0, e0) = (&radiance.levels[0], &emitted.levels[0]);
    let (mut walls, mut lamp_texels) = (0, 0);
    for j in 0..r0.res {
        for i in 0..r0.res {
            let (r, e) = (r0.get(i, j), e0.get(i, j));
            assert!(e.cmple(r + Vec3::splat(1e-4)).all(), "texel ({i},{j}): emitted {e} above radiance {r}");
            let d = octa::texel_dir(r0.res, i, j);
            if d.z < -0.5 {
                walls += 1;
                assert!(r.x > 0.0 && e == Vec3::ZERO, "texel ({i},{j}) sees a lit wall: {r}, {e}");
            }
            // (one ray per texel: a texel with an emitted part is one whose ray met the lamp)
            if e != Vec3::ZERO {
                lamp_texels += 1;
                assert!(d.z > 0.5 && r == e, "texel ({i},{j}) sees the lamp: {r}, {e}");
            }
        }
    }
    assert!(walls > 10 && lamp_texels > 0, "walls {walls}, lamp texels {lamp_texels}");

    // nothing that emits: zeros, and no ray traced for them
    let scene = lamp_room(0.5, false);
    let (radiance, emitted, rays) = emitted_of(&scene);
    assert_eq!(rays, 0);
    assert_eq!(emitted.levels.len(), radiance.levels.len());
    assert!(emitted.levels.iter().all(|l| l.texels.iter().all(|&x| x == Vec3::ZERO)));
}

#[test]
fn the_emitted_irradiance_is_the_grids_lamp_and_nothing_else() {
    let emitted_of = |scene: &Scene| {
        let tracer = Tracer::new(scene);
        let renderer = warpfit::trace::Renderer::new(scene, &tracer);
        let baked = bake::bake(scene, &tracer, &Progress::quiet());
        let (emitted, rays) = bake::grid::emitted_irradiance(&renderer, &bake::grid_settings(scene), &baked.grid);
        (baked.grid, emitted, rays)
    };
    let i2 = |grid: &bake::grid::ProbeGrid| (grid.irradiance_resolution * grid.irradiance_resolution) as usize;

    // black walls and sky: every cell's irradiance is the lamp's, bit for bit
    let (grid, emitted, rays) = emitted_of(&lamp_room(0.0, true));
    assert!(rays > 0);
    assert_eq!(emitted.len(), grid.irradiance.len());
    let outside: Vec<usize> = (0..grid.inside.len()).filter(|&c| !grid.inside[c]).collect();
    assert!(!outside.is_empty());
    for &c in &outside {
        let span = c * i2(&grid)..(c + 1) * i2(&grid);
        assert!(emitted[span.clone()] == grid.irradiance[span], "cell {c}: the emitted part is all of it");
    }
    assert!(emitted.iter().any(|e| e.x > 0.0), "the lamp lights some texels");

    // lit walls: the walls add irradiance the emitted part does not hold
    let (grid, emitted, _) = emitted_of(&lamp_room(0.5, true));
    let (mut below, mut lit) = (0, 0);
    for &c in &outside {
        let span = c * i2(&grid)..(c + 1) * i2(&grid);
        for (t, (&e, &r)) in emitted[span.clone()].iter().zip(&grid.irradiance[span]).enumerate() {
            assert!(e.cmple(r + Vec3::splat(1e-4)).all(), "cell {c} texel {t}: emitted {e} above irradiance {r}");
            below += usize::from(e.x < r.x - 1e-3);
            lit += usize::from(e.x > 0.0);
        }
    }
    assert!(below > 0 && lit > 0, "texels below the irradiance {below}, lit by the lamp {lit}");

    // nothing that emits: zeros, and no ray traced for them
    let (grid, emitted, rays) = emitted_of(&lamp_room(0.5, false));
    assert_eq!(rays, 0);
    assert_eq!(emitted.len(), grid.irradiance.len());
    assert!(emitted.iter().all(|&e| e == Vec3::ZERO));
}

/// A scene of `geometry` (TOML `[[geometry]]` tables) under a sky, its grid the 12 m cube
/// or the 36 × 12 × 36 m slab the brick plans cover.
fn brick_scene(geometry: &str) -> Scene {
    let text = format!(
        r#"
seed = 1
[probe]
position = [1.0, 1.0, 1.0]
[grid]
min = [0.0, 0.0, 0.0]
max = [12.0, 12.0, 12.0]
counts = [12, 12, 12]
[sky]
zenith = [0.3, 0.5, 1.0]
horizon = [0.8, 0.9, 1.0]
ground = [0.2, 0.2, 0.2]
{geometry}
"#
    );
    Scene::parse(&text, std::path::Path::new("bricks.toml")).unwrap()
}

fn brick_plan(scene: &Scene, max: Vec3, rule: bake::bricks::Rule, threads: usize) -> bake::bricks::BrickPlan {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let tracer = Tracer::new(scene);
        bake::bricks::plan(scene, &tracer, (Vec3::ZERO, max), 1.0, 2, rule, 0.25)
    })
}

#[test]
fn sparse_bricks_keep_the_cells_by_surfaces_and_drop_a_solid_core() {
    // a 12 m room round a solid 7 m cube: of the 27 bricks of 4 m, the middle one lies in
    // the cube more than a cell from its faces, every other touches a wall or the cube
    let scene = brick_scene(
        r#"
[[geometry]]
type = "room"
min = [0.0, 0.0, 0.0]
max = [12.0, 12.0, 12.0]
[[geometry]]
type = "box"
min = [2.5, 2.5, 2.5]
max = [9.5, 9.5, 9.5]
"#,
    );
    for rule in [bake::bricks::Rule::NearGeometry, bake::bricks::Rule::CHECK] {
        let p = brick_plan(&scene, Vec3::splat(12.0), rule, 2);
        assert_eq!((p.kept.clone(), p.solid.clone()), (vec![26, 0], vec![1, 0]), "{rule:?}");
        assert_eq!((p.cells(), p.uniform_cells), (26 * 64, 12 * 12 * 12));
        assert_eq!(p, brick_plan(&scene, Vec3::splat(12.0), rule, 1), "{rule:?} at 1 thread");
    }
}

#[test]
fn open_ground_splits_by_the_geometry_rule_and_stays_coarse_by_the_distance_rule() {
    // a ground slab far wider than the volume, under the sky: the near-geometry rule splits
    // every 12 m brick (its bottom touches the ground) and keeps all 27 children; the
    // seen-distance rule sees the sky in half the directions and keeps the 9 coarse bricks
    let scene = brick_scene(
        r#"
[[geometry]]
type = "box"
min = [-1000.0, -1.0, -1000.0]
max = [1000.0, 0.0, 1000.0]
"#,
    );
    let max = Vec3::new(36.0, 12.0, 36.0);
    let near = brick_plan(&scene, max, bake::bricks::Rule::NearGeometry, 2);
    assert_eq!((near.kept, near.solid), (vec![243, 0], vec![0, 0]));
    let seen = brick_plan(&scene, max, bake::bricks::Rule::CHECK, 2);
    assert_eq!((seen.kept, seen.solid), (vec![0, 9], vec![0, 0]));
    assert_eq!(seen.uniform_cells, 36 * 12 * 36);
}

#[test]
fn a_brick_plan_of_a_degenerate_box_or_cell_is_empty() {
    let scene = brick_scene("[[geometry]]\ntype = \"box\"\nmin = [1.0, 1.0, 1.0]\nmax = [2.0, 2.0, 2.0]\n");
    let tracer = Tracer::new(&scene);
    for (max, finest, levels) in [
        (Vec3::ZERO, 1.0, 2),
        (Vec3::splat(f32::NAN), 1.0, 2),
        (Vec3::ONE, 0.0, 2),
        (Vec3::ONE, f32::INFINITY, 2),
        (Vec3::ONE, 1.0, 0),
        (Vec3::ONE, 1.0, 5),
    ] {
        let p = bake::bricks::plan(&scene, &tracer, (Vec3::ZERO, max), finest, levels, bake::bricks::Rule::CHECK, 0.25);
        assert_eq!(p.cells() + p.uniform_cells, 0, "{max} {finest} {levels}");
    }
}
