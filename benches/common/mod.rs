//! What the runtime benches share: the fitted torture grid they time and their queries.

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
    warpfit::jobs::run::fit(
        p.baked(),
        &warp,
        &warpfit::fit::FitSettings::standard(),
        Default::default(),
        Default::default(),
        o,
    )
    .unwrap();
    out
}

/// `positions` positions uniform in stored cells × `dirs` uniform directions,
/// position-major (as eval issues them): what the runtime benches time.
pub fn queries(g: &FittedGrid, positions: u32, dirs: u32) -> Vec<(glam::Vec3, glam::Vec3)> {
    use warpfit::sampling::{Sampler, uniform_sphere};
    let geo = &g.irradiance_grid().geometry;
    let cells: Vec<usize> =
        (0..geo.cell_count()).filter(|&c| g.irradiance_grid().slot[c] != warpfit::warp::corrective::NO_MAP).collect();
    let mut q = Vec::with_capacity((positions * dirs) as usize);
    for p in 0..positions {
        let mut s = Sampler::new(0xBE7C, 1, p);
        let cell = cells[(s.next_1d() * cells.len() as f32) as usize % cells.len()];
        let lo = geo.min + geo.cell_coords(cell).as_vec3() * geo.cell_size();
        let b = lo + geo.cell_size() * glam::Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        for k in 0..dirs {
            q.push((b, uniform_sphere(Sampler::new(0xBE7C, 2 + p as u64, k).next_2d())));
        }
    }
    q
}
