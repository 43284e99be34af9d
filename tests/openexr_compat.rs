//! The bake's and the fitted grid's EXR files open in the reference OpenEXR library, through
//! its Python binding (`pip install OpenEXR`, which `.ci/run` installs): every layer with its
//! size and channels, f16 layers as HALF. Without the binding the test says SKIPPED, and in
//! CI (`WARPFIT_REQUIRE_EXTERNAL=1`) it fails.

mod common;
use common::*;
use std::process::Command;
use warpfit::bakefile;
use warpfit::fit::FitSettings;
use warpfit::gridfile::Precision;
use warpfit::jobs::run::{self as job, Output, StoreOptions};
use warpfit::progress::Progress;
use warpfit::report::folder::RunFolder;
use warpfit::trace::Tracer;

/// Prints `folder/file layer channels shape dtype` per channel (the binding groups R, G, B
/// as `RGB`); fails on a shape that is not the layer's size.
const CHECK: &str = r#"
import sys, OpenEXR
for path in sys.argv[1:]:
    with OpenEXR.File(path) as f:
        for part in f.parts:
            for name, ch in part.channels.items():
                px = ch.pixels
                assert px.shape[:2] == (part.height(), part.width()), (path, part.name(), name, px.shape)
                print('/'.join(path.split('/')[-2:]), part.name(), name, px.shape, px.dtype)
"#;

#[test]
fn bake_and_grid_files_open_in_the_reference_openexr_library() {
    let has_binding =
        Command::new("python3").args(["-c", "import OpenEXR"]).output().map(|o| o.status.success()).unwrap_or(false);
    if !has_binding {
        tool_missing("OpenEXR compatibility", "the OpenEXR Python binding", "pip install OpenEXR");
        return;
    }
    let scene = load("tiny");
    let tracer = Tracer::new(&scene);
    let dir = tmp_dir("openexr");
    let folder = RunFolder::new(&dir);
    let quiet = Progress::quiet();
    let baked = job::bake(&scene, &tracer, &folder, &quiet).unwrap();
    let b = job::Baked { others: &[], ..baked.baked(&scene, &tracer) };
    let warp = b.warp(warpfit::warp::WarpOptions::standard());
    let store = StoreOptions { precision: Precision::F16, ..Default::default() };
    let out = Output { folder: &folder, command: "test", progress: &quiet };
    let (fit, manifest) = job::fit(b, &warp, &FitSettings::quick(), store, Default::default(), out).unwrap();
    assert!(fit.correctives.stored_cells() > 0, "the check needs a correctives.exr");
    let files = [
        folder.bake().join(bakefile::PROBE_FILE),
        folder.bake().join(bakefile::GRID_FILE),
        dir.join("probe.exr"),
        dir.join("correctives.exr"),
        dir.join("irradiance.exr"),
    ];
    let run = Command::new("python3").args(["-c", CHECK]).args(&files).output().unwrap();
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "OpenEXR refused the files: {}", String::from_utf8_lossy(&run.stderr));
    // every layer the grid's manifest lists is there, in the precision it says
    let grid_folder = dir.file_name().unwrap().to_string_lossy().to_string();
    for p in &manifest.payloads {
        for l in &p.layers {
            let dtype = match l.precision {
                Precision::F16 => "float16",
                Precision::F32 => "float32",
            };
            let prefix = format!("{grid_folder}/{} {} ", p.file, l.name);
            let lines: Vec<&str> = text.lines().filter(|t| t.starts_with(&prefix)).collect();
            assert!(!lines.is_empty(), "{prefix}missing in:\n{text}");
            for line in lines {
                assert!(line.ends_with(dtype), "{line}: expected {dtype}");
            }
        }
    }
    assert!(text.contains("float16"), "an f16 grid stores f16 radiance:\n{text}");
    for layer in ["radiance_mip0", "distance_mip0", "irradiance", "depth_moments", "shift_maps"] {
        assert!(text.contains(layer), "{layer} missing in:\n{text}");
    }
}
