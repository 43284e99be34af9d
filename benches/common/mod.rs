//! What the benches share: the fitted torture grid they time.

use std::path::{Path, PathBuf};
use warpfit::runtime::FittedGrid;

/// `fits/torture` (written by `cargo run --release -- run`); if it is missing or unreadable,
/// fits the torture scene first into a temporary folder (about a minute).
pub fn fitted_torture() -> PathBuf {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/fits/torture"));
    if FittedGrid::load(&dir).is_ok() {
        return dir;
    }
    let out = std::env::temp_dir().join(format!("warpfit-bench-runtime-{}", std::process::id()));
    let scene =
        warpfit::scene::Scene::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/torture.toml")))
            .expect("torture scene");
    let quiet = warpfit::progress::Progress::quiet();
    let folder = warpfit::report::folder::RunFolder::new(&out);
    let p = warpfit::jobs::run::prepare(scene, folder.clone(), &quiet).unwrap();
    let warp = p.baked().warp(warpfit::warp::WarpOptions::standard());
    let o = warpfit::jobs::run::Output { folder: &folder, command: "bench", progress: &quiet };
    warpfit::jobs::run::fit(p.baked(), &warp, &warpfit::fit::FitSettings::standard(), Default::default(), o).unwrap();
    out
}
