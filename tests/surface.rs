//! Surface probes (seed 003) against closed forms: a constant sky over a floor is the sky
//! at every point, direction and roughness; a ceiling plane's distance is `h / cos θ`; the
//! warped lookup at a probe is the seed's lookup; probes under a box take their neighbours'
//! light; bakes are bit-identical at any thread count; bad entries are named; the surface
//! table of an evaluation has every row at every bucket.

mod common;
use common::*;
use glam::Vec3;
use warpfit::bake::surface::bake_surface_atlas;
use warpfit::progress::Progress;
use warpfit::scene::Scene;
use warpfit::trace::{Renderer, Tracer};
use warpfit::warp::surface::SurfaceAtlas;

fn scene(top: &str, body: &str) -> Scene {
    Scene::parse(&format!("{top}\n{HEADER}\n{body}"), &repo().join("tests/fixtures/inline.toml")).unwrap()
}

/// A 2 × 2 floor at y = 0 facing up, 4 × 4 probes of 8² texels.
const FLOOR_PROBES: &str = r#"
[[surface_probes]]
corner = [-1.0, 0.0, -1.0]
edge_u = [0.0, 0.0, 2.0]
edge_v = [2.0, 0.0, 0.0]
counts = [4, 4]
resolution = 8
samples_per_texel = 2
"#;

const FLOOR: &str = r#"
[[geometry]]
type = "quad"
corner = [-1.0, 0.0, -1.0]
edge_u = [0.0, 0.0, 2.0]
edge_v = [2.0, 0.0, 0.0]
"#;

fn atlas(s: &Scene) -> SurfaceAtlas {
    let tracer = Tracer::new(s);
    let spec = s.surface_probes()[0];
    bake_surface_atlas(&Renderer::new(s, &tracer), &spec, 0, 1, &Progress::quiet()).0
}

fn queries() -> Vec<(Vec3, Vec3)> {
    (0..64u32)
        .map(|k| {
            let mut s = warpfit::sampling::Sampler::new(4, 2, k);
            let p = Vec3::new(s.next_1d() * 2.0 - 1.0, 1e-3, s.next_1d() * 2.0 - 1.0);
            (p, warpfit::sampling::cosine_hemisphere(s.next_2d(), Vec3::Y))
        })
        .collect()
}

#[test]
fn a_constant_sky_over_a_floor_is_the_sky_everywhere() {
    let s = scene("bounces = 0", &format!("[sky]\ncolor = [0.5, 1.0, 2.0]\n{FLOOR}{FLOOR_PROBES}"));
    let a = atlas(&s);
    assert!((a.normal() - Vec3::Y).length() < 1e-6);
    let sky = Vec3::new(0.5, 1.0, 2.0);
    for (p, d) in queries() {
        for r in [0.0, 0.125, 0.3, 0.5, 1.0] {
            for l in [a.radiance(p, d, r), a.radiance_warped(p, d, r)] {
                assert!((l - sky).abs().max_element() < 1e-5, "{l} at {p} {d} r {r}");
            }
        }
    }
}

#[test]
fn a_ceiling_plane_is_at_h_over_cos_theta() {
    // floor at 0, an unlit ceiling at h = 0.5 seen from every probe
    let ceiling = r#"
[[geometry]]
type = "quad"
corner = [-50.0, 0.5, -50.0]
edge_u = [100.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 100.0]
"#;
    let s = scene("bounces = 0", &format!("{FLOOR}{ceiling}{FLOOR_PROBES}"));
    let a = atlas(&s);
    let n = a.patch.resolution;
    for (t, &w) in a.inv_distance.iter().enumerate().take((n * n) as usize) {
        let d = warpfit::octa::hemi::texel_dir(n, t as u32 % n, t as u32 / n);
        let h = 0.5 - a.patch.offset;
        let want = d.z / h; // world up is the tangent frame's z
        assert!((w - want).abs() <= 1e-4 * want.max(1e-3), "texel {t}: {w} vs {want}");
    }
}

#[test]
fn the_warped_lookup_at_a_probe_is_the_seed_lookup() {
    let s = load("cornell");
    let text = format!(
        "{}\n[[surface_probes]]\ncorner = [0.05, 0.0, 0.05]\nedge_u = [0.0, 0.0, 0.45]\nedge_v = [0.45, 0.0, 0.0]\ncounts = [3, 3]\nresolution = 8\nsamples_per_texel = 1\n",
        std::fs::read_to_string(scene_file("cornell")).unwrap()
    );
    let s2 = Scene::parse(&text, &scene_file("cornell")).unwrap();
    assert_eq!(s.content_key(), s2.content_key(), "surface probes are not part of the bake's key");
    let a = atlas(&s2);
    // at a probe (to the rounding of its surface coordinates, which leaves its neighbours
    // weights of order 1e-6) the warp changes nothing; between probes it does
    for (i, j) in [(0, 0), (1, 1), (2, 1)] {
        let p = a.probe_position(i, j);
        for (_, d) in queries() {
            for r in [0.0, 0.5] {
                let (l, w) = (a.radiance(p, d, r), a.radiance_warped(p, d, r));
                assert!((l - w).abs().max_element() <= 1e-4 * l.max_element().max(1e-6), "{l} vs {w}");
            }
        }
    }
    let between = (a.probe_position(0, 0) + a.probe_position(1, 1)) * 0.5;
    let moved =
        queries().iter().filter(|(_, d)| a.radiance(between, *d, 0.0) != a.radiance_warped(between, *d, 0.0)).count();
    assert!(moved > 32, "the warp moved {moved} of 64 lookups");
}

#[test]
fn degenerate_queries_are_finite_and_never_negative() {
    let s = scene("", &format!("[sky]\ncolor = [0.5, 1.0, 2.0]\n{FLOOR}{FLOOR_PROBES}"));
    let a = atlas(&s);
    let positions = [Vec3::ZERO, Vec3::NAN, Vec3::splat(f32::INFINITY), Vec3::splat(1e30), Vec3::new(5.0, -3.0, 9.0)];
    let dirs = [Vec3::ZERO, Vec3::NAN, -Vec3::Y, Vec3::X, Vec3::splat(1e-30), Vec3::splat(f32::MAX)];
    for p in positions {
        for d in dirs {
            for r in [f32::NAN, -1.0, 0.0, 0.7, 2.0, f32::INFINITY] {
                for l in [a.radiance(p, d, r), a.radiance_warped(p, d, r)] {
                    assert!(l.is_finite() && l.cmpge(Vec3::ZERO).all(), "{l} at {p} {d} {r}");
                }
            }
        }
    }
}

#[test]
fn probes_inside_geometry_take_their_neighbours_light() {
    // a box standing on the floor swallows the probes under it
    let block = "[[geometry]]\ntype = \"box\"\nmin = [-0.45, 0.0, -0.45]\nmax = [0.45, 0.6, 0.45]\n";
    let s = scene("", &format!("[sky]\ncolor = [1.0, 1.0, 1.0]\n{FLOOR}{block}{FLOOR_PROBES}"));
    let a = atlas(&s);
    let texels = (a.patch.resolution * a.patch.resolution) as usize;
    for (k, tile) in a.radiance[0].chunks(texels).enumerate() {
        let mean = tile.iter().copied().sum::<Vec3>() / texels as f32;
        assert!(mean.min_element() > 0.05, "probe {k} is black: {mean}");
    }
}

#[test]
fn the_bake_is_identical_at_any_thread_count() {
    let text = format!(
        "{}\n[[surface_probes]]\ncorner = [0.05, 0.0, 0.05]\nedge_u = [0.0, 0.0, 0.45]\nedge_v = [0.45, 0.0, 0.0]\ncounts = [3, 2]\nresolution = 6\nsamples_per_texel = 2\n",
        std::fs::read_to_string(scene_file("cornell")).unwrap()
    );
    let s = Scene::parse(&text, &scene_file("cornell")).unwrap();
    let bits = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let a = pool.install(|| atlas(&s));
        let mut out: Vec<u32> = a.radiance.iter().flatten().flat_map(|v| v.to_array().map(f32::to_bits)).collect();
        out.extend(a.inv_distance.iter().map(|w| w.to_bits()));
        out
    };
    assert_eq!(bits(1), bits(3));
}

#[test]
fn bad_surface_probe_entries_are_named() {
    let cases = [
        ("edge_v = [0.0, 0.0, 4.0]", "surface_probes[0]"),
        ("edge_v = [0.0, 0.0, 0.0]", "surface_probes[0]"),
        ("counts = [0, 4]", "surface_probes[0].counts"),
        ("resolution = 7", "surface_probes[0].resolution"),
        ("samples_per_texel = 0", "surface_probes[0].samples_per_texel"),
        ("corner = [1e30, 0.0, 0.0]", "surface_probes[0].corner"),
    ];
    for (line, field) in cases {
        let key = line.split(' ').next().unwrap();
        let entry: String = FLOOR_PROBES
            .lines()
            .map(|l| if l.starts_with(&format!("{key} ")) { line.to_string() } else { l.to_string() })
            .collect::<Vec<_>>()
            .join("\n");
        let entry = if entry.contains(line) { entry } else { format!("{entry}\n{line}") };
        let err = parse(&format!("{FLOOR}{entry}")).err().unwrap_or_else(|| panic!("{line} accepted")).to_string();
        assert!(err.contains(field), "{line}: {err}");
    }
}

#[test]
fn an_evaluation_judges_every_row_at_every_bucket() {
    use warpfit::jobs::run::{self as job, Output};
    let dir = tmp_dir("surface-eval");
    let fixture = SmallTorture::fit_into(&dir);
    // the same bake with a floor of surface probes (not part of the bake)
    let mut scene = fixture.scene.clone();
    scene.config.surface_probes.push(warpfit::scene::config::SurfaceProbesConfig {
        corner: [-5.0, 0.0, -5.0],
        edge_u: [0.0, 0.0, 10.0],
        edge_v: [10.0, 0.0, 0.0],
        counts: [4, 4],
        resolution: 6,
        samples_per_texel: 1,
    });
    let baked = job::Baked { scene: &scene, ..fixture.baked() };
    let settings = warpfit::eval::EvalSettings::quick();
    let folder = warpfit::report::folder::RunFolder::new(&dir);
    let out = Output { folder: &folder, command: "test", progress: &Progress::quiet() };
    let methods = [warpfit::warp::Method::None, warpfit::warp::Method::Box, warpfit::warp::Method::Warp1];
    let report = job::evaluate(baked, &fixture.warp, &settings, &methods, Some(&fixture.fit), out).unwrap();
    // the runtime in every bucket; its probe-only tier in every rough one, where it is the
    // stored maps with the stored correction, which the `fitted/corrected` row reads too
    for &r in &warpfit::eval::ROUGHNESS_BUCKETS {
        let row = |name: &str| report.methods.iter().find(|m| m.roughness == r && m.name == name);
        assert!(row("runtime").is_some(), "r {r}: no runtime row");
        let tier = row("runtime-probe-only");
        assert_eq!(tier.is_some(), r > 0.0, "r {r}: the probe-only row belongs to the rough buckets");
        if let Some(tier) = tier {
            let fitted = report
                .methods
                .iter()
                .find(|m| m.roughness == r && m.label() == "fitted/corrected")
                .expect("the fitted row");
            assert!((tier.tm_rmse - fitted.tm_rmse).abs() <= 1e-9 * fitted.tm_rmse, "r {r}: {tier:?} vs {fitted:?}");
            assert!(tier.flip.is_some_and(f64::is_finite), "{tier:?}");
        }
    }
    assert_eq!(report.surface.len(), 1);
    let sr = &report.surface[0];
    assert!(sr.points > 0 && sr.bytes > 0 && sr.camera.is_some());
    let buckets: Vec<f32> = sr.buckets.iter().map(|b| b.roughness).collect();
    assert_eq!(buckets, warpfit::eval::ROUGHNESS_BUCKETS.to_vec());
    let names: std::collections::BTreeSet<&str> = sr.rows.iter().map(|r| r.name.as_str()).collect();
    for want in ["surface atlas (seed 003)", "surface atlas + warp1 per probe", "none", "box", "warp1", "runtime"] {
        assert!(names.contains(want), "{want} missing from {names:?}");
    }
    assert_eq!(sr.rows.len(), names.len() * buckets.len());
    for r in &sr.rows {
        assert!(r.tm_rmse.is_finite() && r.rel_rmse.is_finite() && r.ns_per_lookup > 0.0, "{r:?}");
        assert!(r.flip.is_some_and(f64::is_finite), "{r:?}");
    }
    for f in ["surface_atlas0.png", "flip_surface0_r0.000.png", "flip_surface0_r0.500.png"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let md = std::fs::read_to_string(dir.join("eval.md")).unwrap();
    assert!(md.contains("## Surface probes 0 (seed 003)"));
    // the atlas as a game loads it
    let loaded = warpfit::runtime::load_surface_atlas(&dir.join("surface0")).unwrap();
    assert_eq!(loaded.patch.counts, [4, 4]);
}

/// A small lit atlas written to a fresh folder (`surface0` in the scratch folder, which
/// lives as long as the returned guard).
fn written(tag: &str) -> (SurfaceAtlas, std::path::PathBuf, TestDir) {
    let s = scene("", &format!("[sky]\nzenith = [0.2, 0.4, 1.0]\nhorizon = [1.0, 0.9, 0.8]\n{FLOOR}{FLOOR_PROBES}"));
    let a = atlas(&s);
    let scratch = tmp_dir(tag);
    let dir = scratch.join("surface0");
    warpfit::gridfile::surface::write(&dir, &a).unwrap();
    (a, dir, scratch)
}

#[test]
fn a_written_atlas_loads_back_bit_for_bit() {
    let (a, dir, _scratch) = written("surface-file");
    let b = warpfit::runtime::load_surface_atlas(&dir).unwrap();
    assert_eq!(a.patch, b.patch);
    assert_eq!(a.roughness, b.roughness);
    let bits = |x: &SurfaceAtlas| -> Vec<u32> {
        let mut v: Vec<u32> = x.radiance.iter().flatten().flat_map(|c| c.to_array().map(f32::to_bits)).collect();
        v.extend(x.inv_distance.iter().map(|w| w.to_bits()));
        v
    };
    assert_eq!(bits(&a), bits(&b));
    for (p, d) in queries() {
        assert_eq!(a.radiance_warped(p, d, 0.3).to_array(), b.radiance_warped(p, d, 0.3).to_array());
    }
}

#[test]
fn damaged_or_foreign_atlas_files_are_named_errors() {
    let (_, dir, _scratch) = written("surface-damaged");
    let manifest = std::fs::read_to_string(dir.join("manifest.json")).unwrap();
    let exr = std::fs::read(dir.join("atlas.exr")).unwrap();
    let check = |what: &str, want: &str, setup: &dyn Fn()| {
        setup();
        let err =
            warpfit::runtime::load_surface_atlas(&dir).err().unwrap_or_else(|| panic!("{what}: loaded")).to_string();
        assert!(err.contains(want), "{what}: {err}");
        std::fs::write(dir.join("manifest.json"), &manifest).unwrap();
        std::fs::write(dir.join("atlas.exr"), &exr).unwrap();
    };
    let edit = |pointer: &str, to: serde_json::Value| {
        let mut v: serde_json::Value = serde_json::from_str(&manifest).unwrap();
        *v.pointer_mut(pointer).unwrap_or_else(|| panic!("{pointer}")) = to;
        std::fs::write(dir.join("manifest.json"), serde_json::to_string_pretty(&v).unwrap()).unwrap();
    };
    check("truncated atlas", "atlas.exr", &|| std::fs::write(dir.join("atlas.exr"), &exr[..exr.len() / 2]).unwrap());
    check("flipped byte", "atlas.exr", &|| {
        let mut e = exr.clone();
        let k = e.len() - 100;
        e[k] ^= 0x40;
        std::fs::write(dir.join("atlas.exr"), e).unwrap();
    });
    check("newer version", "manifest.json", &|| edit("/version", 2.into()));
    check("foreign format", "manifest.json", &|| edit("/format", "warpfit-grid".into()));
    check("parallel edges", "edge_u", &|| edit("/surface/edge_v", serde_json::json!([0.0, 0.0, 4.0])));
    check("odd resolution", "resolution", &|| edit("/surface/resolution", 7.into()));
    check("fewer mips than the file", "7 layers, the manifest says 3", &|| {
        edit("/surface/roughness", serde_json::json!([0.0, 0.5]))
    });
    check("roughness not from 0", "roughness", &|| {
        edit("/surface/roughness", serde_json::json!([0.1, 0.2, 0.4, 0.6, 0.8, 1.0]))
    });
    check("no manifest", "manifest.json", &|| std::fs::remove_file(dir.join("manifest.json")).unwrap());
}

#[test]
fn check_warns_of_a_patch_in_the_air_or_facing_into_its_floor() {
    let room = "[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\n";
    let warnings = |probes: &str| {
        let s = scene("", &format!("[sky]\ncolor = [1.0, 1.0, 1.0]\n{room}{probes}"));
        // the patch's warnings (this closed room lit from outside also gets the light check's)
        let all = warpfit::jobs::check::check(&s, &Tracer::new(&s)).warnings;
        all.into_iter()
            .filter(|w| !w.contains("the grid's cells") && !w.contains("coarse for this level"))
            .collect::<Vec<_>>()
    };
    assert!(warnings(FLOOR_PROBES).is_empty(), "{:?}", warnings(FLOOR_PROBES));
    let flipped = FLOOR_PROBES.replace(
        "edge_u = [0.0, 0.0, 2.0]\nedge_v = [2.0, 0.0, 0.0]",
        "edge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 2.0]",
    );
    let w = warnings(&flipped);
    assert!(w.iter().any(|m| m.contains("surface_probes[0]") && m.contains("swap edge_u and edge_v")), "{w:?}");
    let lifted = FLOOR_PROBES.replace("corner = [-1.0, 0.0, -1.0]", "corner = [-1.0, 0.7, -1.0]");
    let w = warnings(&lifted);
    assert!(w.iter().any(|m| m.contains("surface_probes[0] lies on geometry at only 0")), "{w:?}");
}
