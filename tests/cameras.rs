//! The evaluation's cameras: placed where they see the level, or set by the scene.

mod common;

use common::*;
use warpfit::perceptual::{self, MIN_COVERAGE, RenderSettings};
use warpfit::scene::Scene;
use warpfit::trace::Tracer;
use warpfit_runtime::glam::Vec3;

/// Positions drawn as the evaluation draws its validation positions (every cell a
/// candidate; the inside rule rejects those in geometry).
fn positions(scene: &Scene, tracer: &Tracer) -> Vec<Vec3> {
    let g = warpfit::bake::grid_settings(scene).geometry;
    let active: Vec<usize> = (0..g.cell_count()).collect();
    warpfit::eval::validation::positions(scene, tracer, (&g, &active), 64, 0xE7A1)
}

#[test]
fn every_camera_of_every_built_in_scene_sees_the_level() {
    let mut names: Vec<String> = std::fs::read_dir(repo().join("data/scenes"))
        .unwrap()
        .filter_map(|e| e.ok()?.path().file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    names.sort();
    assert!(names.len() >= 10, "{names:?}");
    for name in names {
        let scene = load(&name);
        let tracer = Tracer::new(&scene);
        let probes = warpfit::bake::placement::fixed_positions(&scene);
        let s = RenderSettings::standard();
        let views = perceptual::views(&scene, &tracer, &positions(&scene, &tracer), &probes, &s);
        let cameras: Vec<_> = views.iter().filter(|v| v.camera).collect();
        assert!(cameras.len() >= s.cameras as usize, "{name}: {} cameras", cameras.len());
        for v in cameras {
            assert!(
                v.coverage() >= MIN_COVERAGE,
                "{name}: {} sees geometry in {:.2} of its pixels",
                v.name,
                v.coverage()
            );
        }
    }
}

/// A floor under an open sky with one wall: most headings see sky.
const OPEN: &str = r#"
[sky]
zenith = [0.3, 0.5, 1.0]
horizon = [0.8, 0.9, 1.0]
ground = [0.2, 0.2, 0.2]
[[geometry]]
type = "box"
min = [-1.0, -0.1, -1.0]
max = [1.0, 0.0, 1.0]
material = { albedo = [0.5, 0.5, 0.5] }
[[geometry]]
type = "box"
min = [-1.0, 0.0, 0.9]
max = [1.0, 2.0, 1.0]
material = { albedo = [0.7, 0.3, 0.3] }
"#;

#[test]
fn an_open_scene_is_seen_looking_at_its_geometry_and_a_scenes_cameras_are_kept() {
    let scene = parse(OPEN).unwrap();
    let tracer = Tracer::new(&scene);
    let s = RenderSettings::standard();
    let views = perceptual::views(&scene, &tracer, &positions(&scene, &tracer), &[], &s);
    for v in views.iter().filter(|v| v.camera) {
        assert!(v.coverage() >= MIN_COVERAGE, "{} {:.2}", v.name, v.coverage());
    }
    // the scene's own cameras, as given, even one that sees mostly sky
    let scene = parse(&format!(
        "{OPEN}\n[[cameras]]\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 1.0, 1.0]\n[[cameras]]\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 2.0, -1.0]\n"
    ))
    .unwrap();
    let poses = perceptual::cameras(&scene, &tracer, &positions(&scene, &tracer), &[], &s);
    assert_eq!(poses.len(), 2);
    assert_eq!(poses[0].eye, Vec3::new(0.0, 1.0, 0.0));
    assert!((poses[0].forward - Vec3::Z).length() < 1e-6);
    let views = perceptual::views(&scene, &tracer, &positions(&scene, &tracer), &[], &s);
    let cams: Vec<f64> = views.iter().filter(|v| v.camera).map(|v| v.coverage()).collect();
    assert_eq!(cams.len(), 2);
    assert!(cams[0] > 0.99 && cams[1] < 0.5, "{cams:?}");
}

#[test]
fn cameras_are_the_same_at_any_thread_count() {
    let scene = load("house");
    let tracer = Tracer::new(&scene);
    let p = positions(&scene, &tracer);
    let at = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| perceptual::cameras(&scene, &tracer, &p, &[], &RenderSettings::standard()))
    };
    assert_eq!(at(1), at(3));
}

#[test]
fn a_bad_camera_is_an_error_naming_it() {
    for (body, field) in [
        ("[[cameras]]\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 1.0, 0.0]\n", "cameras[0].look_at"),
        ("[[cameras]]\nposition = [0.0, nan, 0.0]\nlook_at = [0.0, 1.0, 1.0]\n", "cameras[0].position"),
        ("[[cameras]]\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 1.0]\n", "look_at"),
        ("[[cameras]]\nposition = [0.0, 1.0, 0.0]\nlookat = [0.0, 1.0, 1.0]\n", "lookat"),
    ] {
        let e = parse(body).expect_err(body).to_string();
        assert!(e.contains(field) && e.contains("inline.toml"), "{body}: {e}");
    }
}

#[test]
fn cameras_change_no_bake() {
    let a = parse(OPEN).unwrap();
    let b = parse(&format!("{OPEN}\n[[cameras]]\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 1.0, 1.0]\n")).unwrap();
    assert_eq!(a.content_key(), b.content_key());
}
