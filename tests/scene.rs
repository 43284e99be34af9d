//! Scene loading: fixtures load with the right counts and transforms, and every bad input is
//! a clear error naming the file (never a panic).

mod common;
use common::*;
use glam::Vec3;
use warpfit::scene::{Scene, SceneError};

fn err_text(r: Result<Scene, SceneError>) -> String {
    match r {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn builtin_scenes_load() {
    for name in ["torture", "cornell", "courtyard", "sphere", "gallery", "hall", "atrium", "town"] {
        let s = load(name);
        assert!(s.triangles.len() + s.spheres.len() > 0, "{name}");
        assert_eq!(s.degenerate_skipped, 0, "{name} has degenerate triangles");
    }
    // the level-sized scene the fit is timed on is the size it says
    let atrium = load("atrium").triangles.len();
    assert!((100_000..110_000).contains(&atrium), "atrium: {atrium} triangles");
    // the open level: 400 × 400 m, at most 20 m tall, its grid box 3.2M cells at 1 m
    let town = load("town");
    let (lo, hi) = town.bounds();
    assert!((hi - lo).x >= 400.0 && (hi - lo).z >= 400.0 && hi.y <= 20.0, "town: {lo} – {hi}");
    let g = warpfit::bake::grid_settings(&town).geometry;
    assert!((g.max - g.min).round().element_product() >= 3.0e6, "town's grid box: {:?} – {:?}", g.min, g.max);
}

#[test]
fn gltf_fixture_applies_node_transforms() {
    let s = parse(
        r#"
[[geometry]]
type = "gltf"
path = "quad_nodes.gltf"
"#,
    )
    .unwrap();
    // Parent and child each instance the 2-triangle quad.
    assert_eq!(s.triangles.len(), 4);
    let (lo, hi) = s.bounds();
    // parent: scale 2 then translate (1,2,3): x∈[1,3], y∈[2,4], z=3
    // child: translate (0,0,1) in parent space → z = 3 + 2·1 = 5
    assert!((lo - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6, "{lo}");
    assert!((hi - Vec3::new(3.0, 4.0, 5.0)).length() < 1e-6, "{hi}");
    let m = s.materials[s.triangles.material[0] as usize];
    assert!((m.albedo - Vec3::new(0.2, 0.4, 0.6)).length() < 1e-6);
    assert!((m.emission - Vec3::new(1.0, 0.5, 0.25)).length() < 1e-6);
}

#[test]
fn obj_fixture_counts_materials_and_transform() {
    let s = parse(
        r#"
[[geometry]]
type = "obj"
path = "cube.obj"
transform = { translate = [10.0, 0.0, 0.0], scale = [2.0, 2.0, 2.0] }
"#,
    )
    .unwrap();
    assert_eq!(s.triangles.len(), 12);
    let (lo, hi) = s.bounds();
    assert_eq!(lo, Vec3::new(10.0, 0.0, 0.0));
    assert_eq!(hi, Vec3::new(12.0, 2.0, 2.0));
    let m = s.materials[s.triangles.material[0] as usize];
    assert_eq!(m.albedo, Vec3::new(0.5, 0.25, 0.125));
    assert_eq!(m.emission, Vec3::new(2.0, 3.0, 4.0));
    // Front faces point out of the cube.
    let c = Vec3::new(11.0, 1.0, 1.0);
    for k in 0..12 {
        let t = &s.triangles;
        let n = (t.v1[k] - t.v0[k]).cross(t.v2[k] - t.v0[k]);
        assert!(n.dot(t.v0[k] - c) > 0.0, "triangle {k} faces inward");
    }
}

#[test]
fn missing_scene_file() {
    let e = err_text(Scene::load(&repo().join("data/scenes/nope.toml")));
    assert!(e.contains("nope.toml") && e.contains("cannot read"), "{e}");
}

#[test]
fn unknown_key_is_named_with_its_line() {
    let e = err_text(parse("[[geometry]]\ntype = \"box\"\nmin = [0.0,0.0,0.0]\nmax = [1.0,1.0,1.0]\ncolour = 3\n"));
    assert!(e.contains("inline.toml") && e.contains("colour") && e.contains("line"), "{e}");
    let e = err_text(parse("bouncez = 2\n[[geometry]]\ntype = \"box\"\nmin = [0.0,0.0,0.0]\nmax = [1.0,1.0,1.0]\n"));
    assert!(e.contains("bouncez"), "{e}");
}

#[test]
fn missing_mesh_file() {
    let e = err_text(parse("[[geometry]]\ntype = \"obj\"\npath = \"missing.obj\"\n"));
    assert!(e.contains("missing.obj"), "{e}");
}

#[test]
fn nan_vertex_is_rejected() {
    let e = err_text(parse("[[geometry]]\ntype = \"obj\"\npath = \"nan_vertex.obj\"\n"));
    assert!(e.contains("nan_vertex.obj") && e.contains("not finite"), "{e}");
}

#[test]
fn nan_in_scene_file_is_rejected() {
    let e = err_text(parse("[[geometry]]\ntype = \"sphere\"\ncenter = [0.0, nan, 0.0]\nradius = 1.0\n"));
    assert!(e.contains("geometry[0].center") && e.contains("finite"), "{e}");
    let e = err_text(parse("[[geometry]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = inf\n"));
    assert!(e.contains("geometry[0].radius"), "{e}");
}

#[test]
fn out_of_range_index_is_rejected() {
    let e = err_text(parse("[[geometry]]\ntype = \"obj\"\npath = \"bad_index.obj\"\n"));
    assert!(e.contains("bad_index.obj"), "{e}");
}

#[test]
fn truncated_gltf_is_rejected() {
    let e = err_text(parse("[[geometry]]\ntype = \"gltf\"\npath = \"truncated.gltf\"\n"));
    assert!(e.contains("truncated.gltf") && e.contains("glTF"), "{e}");
}

#[test]
fn empty_scene_is_rejected() {
    let e = err_text(parse(""));
    assert!(e.contains("no geometry") && e.contains("inline.toml"), "{e}");
}

#[test]
fn degenerate_triangles_are_skipped_and_counted() {
    let s = parse("[[geometry]]\ntype = \"obj\"\npath = \"degenerate.obj\"\n").unwrap();
    assert_eq!(s.triangles.len(), 1);
    assert_eq!(s.degenerate_skipped, 2);
}

#[test]
fn bad_settings_are_named() {
    let body = "[[geometry]]\ntype = \"box\"\nmin = [0.0,0.0,0.0]\nmax = [1.0,1.0,1.0]\n";
    let text = HEADER.replace("resolution = 16", "resolution = 17");
    let e = err_text(Scene::parse(&format!("{text}\n{body}"), &fixture("x.toml")));
    assert!(e.contains("probe.resolution"), "{e}");
    // a distance texel's hit count is kept in a byte
    let text = HEADER.replace("depth_samples = 1", "depth_samples = 256");
    let e = err_text(Scene::parse(&format!("{text}\n{body}"), &fixture("x.toml")));
    assert!(e.contains("grid.depth_samples") && e.contains("1..=255"), "{e}");
    let text = HEADER.replace("depth_samples = 1", "depth_samples = 255");
    Scene::parse(&format!("{text}\n{body}"), &fixture("x.toml")).unwrap();
    let e = err_text(parse("[[geometry]]\ntype = \"box\"\nmin = [1.0,0.0,0.0]\nmax = [0.0,1.0,1.0]\n"));
    assert!(e.contains("geometry[0]") && e.contains("max must exceed min"), "{e}");
    let e =
        err_text(parse("[[geometry]]\ntype = \"room\"\nmin = [0.0,0.0,0.0]\nmax = [1.0,1.0,1.0]\nopen = [\"top\"]\n"));
    assert!(e.contains("geometry[0].open"), "{e}");
}
