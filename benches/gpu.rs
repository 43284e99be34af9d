//! The reference shader's cost on the adapter wgpu finds (Mesa's lavapipe where there is no
//! GPU): ns per lookup over 1,048,576 queries for the fitted `specular` (mirror and rough),
//! `irradiance`, and, in the same shader style on the same probe and queries, seed 000's
//! one-step warp and the box proxy alone; the fitted lookups through the generic pipeline
//! (settings read from `params`) and through one specialised to the grid (`override`s set). Printed as ratios to `warp1`: absolute figures
//! from a software rasteriser on a shared machine say little, the ratios say what the fitted
//! lookup costs over the baselines an engine already runs.
//!
//! Uses `fits/torture` (fitted first if missing, as `benches/runtime.rs` does). Eleven rounds
//! of every kernel in turn (so a change in the machine's load hits them alike); the first two
//! warm up, each kernel's figure is the median of the other nine, timed from submit to
//! completion.
//!
//! `WARPFIT_BENCH_GRIDS=DIR[,DIR…]` times those fitted grids instead, their rows side by side.
//!
//! Run: `cargo bench --bench gpu`

#[path = "common/mod.rs"]
mod common;
#[path = "../tests/gpu_harness/mod.rs"]
mod gpu_harness;

use gpu_harness::{Lookup, Pipeline};
use warpfit::runtime::FittedGrid;

const POSITIONS: u32 = 4096;
const DIRS: u32 = 256;

/// The runtime bench's queries (`common::queries`) at roughness `r`, as the kernels read them:
/// two vec4 per query.
fn queries(g: &FittedGrid, r: f32) -> Vec<[f32; 4]> {
    common::queries(g, POSITIONS, DIRS)
        .into_iter()
        .flat_map(|(b, d)| [b.extend(r).to_array(), d.extend(0.0).to_array()])
        .collect()
}

fn main() {
    // `cargo bench` passes libtest-style flags (`--bench`); a filter argument picks kernels
    let filter: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    let gpu = gpu_harness::gpu_device().unwrap_or_else(|e| panic!("{e}"));
    // `WARPFIT_BENCH_GRIDS=DIR[,DIR…]`: these fitted grids, each kernel's rows per grid in
    // the same rounds (to compare two grids, say one probe against several, in one run)
    let dirs: Vec<std::path::PathBuf> = match std::env::var("WARPFIT_BENCH_GRIDS") {
        Ok(list) => list.split(',').filter(|s| !s.is_empty()).map(std::path::PathBuf::from).collect(),
        Err(_) => vec![common::fitted_torture()],
    };
    let n = (POSITIONS * DIRS) as f64;
    println!("adapter: {} ({:?}, {})", gpu.adapter.name, gpu.adapter.backend, gpu.adapter.driver_info);
    let mut loaded = Vec::new();
    for (k, d) in dirs.iter().enumerate() {
        let grid = FittedGrid::load(d).unwrap();
        let dir = std::env::temp_dir().join(format!("warpfit-bench-gpu-{}-{k}", std::process::id()));
        warpfit::export::export(&grid, &dir).unwrap();
        let generic = Lookup::load(&gpu, &dir, Pipeline::Generic);
        let specialised = Lookup::load(&gpu, &dir, Pipeline::Specialised);
        let label = if dirs.len() > 1 {
            format!("{}: ", d.file_name().map_or("grid".into(), |f| f.to_string_lossy()))
        } else {
            String::new()
        };
        loaded.push((label, grid, dir, generic, specialised));
    }
    let mut cases = Vec::new();
    for (label, grid, _, generic, specialised) in &loaded {
        let first = cases.is_empty();
        for (name, kernel, r, specialised_pipeline) in [
            ("warp1", "warp1_queries", 0.0, false),
            ("box", "box_queries", 0.0, false),
            ("specular r=0", "specular_queries", 0.0, false),
            ("specular r=0.5", "specular_queries", 0.5, false),
            ("specular r=0, specialised", "specular_queries", 0.0, true),
            ("specular r=0.5, specialised", "specular_queries", 0.5, true),
            ("irradiance", "irradiance_queries", 0.0, false),
        ] {
            // warp1 always runs (the other rows are its multiples), once
            let wanted = if name == "warp1" {
                first
            } else {
                filter.is_empty() || filter.iter().any(|f| name.contains(f.as_str()))
            };
            if wanted {
                let lookup = if specialised_pipeline { specialised } else { generic };
                cases.push((format!("{label}{name}"), kernel, r, lookup, grid));
            }
        }
    }
    let batches: Vec<_> = cases.iter().map(|(_, _, r, lookup, grid)| lookup.batch(&gpu, &queries(grid, *r))).collect();
    // rounds of every kernel in turn, so a change in the machine's load hits them alike
    let mut times = vec![Vec::new(); cases.len()];
    for round in 0..11 {
        for (k, (_, kernel, _, lookup, _)) in cases.iter().enumerate() {
            let t = lookup.dispatch(&gpu, kernel, &batches[k], false).as_secs_f64();
            if round >= 2 {
                times[k].push(t); // the first two rounds warm up
            }
        }
    }
    let mut warp1 = None;
    println!("{:<28} {:>12} {:>10}", "kernel", "ns/lookup", "÷ warp1");
    for (k, (name, ..)) in cases.iter().enumerate() {
        let t = &mut times[k];
        t.sort_by(f64::total_cmp);
        let ns = t[t.len() / 2] * 1e9 / n;
        let base = *warp1.get_or_insert(ns);
        println!("{name:<28} {ns:>12.2} {:>10.2}", ns / base);
    }
    for (_, _, dir, ..) in &loaded {
        let _ = std::fs::remove_dir_all(dir);
    }
}
