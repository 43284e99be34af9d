//! The bake's EXR files open in the reference OpenEXR library, through its Python binding
//! (`pip install OpenEXR`). Where the binding is not installed the test says so and passes:
//! the Rust round trip in tests/bake.rs still covers the format.

mod common;
use common::*;
use std::process::Command;
use warpfit::bake;
use warpfit::format::bake_io;
use warpfit::progress::Progress;
use warpfit::trace::Tracer;

const CHECK: &str = r#"
import sys, OpenEXR
for path in sys.argv[1:]:
    with OpenEXR.File(path) as f:
        for part in f.parts:
            for name, ch in part.channels.items():
                px = ch.pixels
                assert px.shape[:2] == (part.height(), part.width()), (path, part.name(), name, px.shape)
                print(path.split('/')[-1], part.name(), name, px.shape)
"#;

#[test]
fn bake_files_open_in_the_reference_openexr_library() {
    let has_binding =
        Command::new("python3").args(["-c", "import OpenEXR"]).output().map(|o| o.status.success()).unwrap_or(false);
    if !has_binding {
        eprintln!("skipped: the OpenEXR Python binding is not installed (pip install OpenEXR)");
        return;
    }
    let mut scene = load("sphere");
    scene.config.probe.resolution = 32;
    let tracer = Tracer::new(&scene);
    let baked = bake::bake(&scene, &tracer, &Progress::quiet());
    let dir = tmp_dir("openexr");
    bake_io::write_bake(&dir, &scene, &baked).unwrap();
    let out = Command::new("python3")
        .args(["-c", CHECK])
        .arg(dir.join("probe.exr"))
        .arg(dir.join("grid.exr"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "OpenEXR refused the files: {}", String::from_utf8_lossy(&out.stderr));
    // every layer we wrote is there with its channels
    for layer in ["radiance_mip0", "depth_mip0", "irradiance", "depth_moments"] {
        assert!(text.contains(layer), "{layer} missing in:\n{text}");
    }
}
