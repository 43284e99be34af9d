//! `FittedGrid::specular_batch` (or `specular` per call) over the runtime bench's 16,384
//! queries, many times in one loop: a steady workload to count under valgrind or to time
//! two builds alternately, where criterion's statistics are in the way.
//!
//!     cargo build --profile profiling --example specular_loop
//!     valgrind --tool=callgrind --toggle-collect='*specular_batch*' \
//!         target/profiling/examples/specular_loop fits/torture 0.5 20
//!     target/profiling/examples/specular_loop fits/torture 0.5 300 [percall] [plain] [probe-only]
//!
//! Arguments: a fitted grid folder, the roughness of every query, the passes; `percall`
//! calls `specular` once per query instead of the batch API; `plain` drops the grid's
//! roughness correction after loading (the mip of plain r), to see what the correction
//! costs; `probe-only` reads probe A alone (`SpecularRead::ProbeOnly`), to see what the
//! irradiance blend costs. Prints ns per lookup (one timed run of all passes).

#[path = "../benches/common/mod.rs"]
#[allow(dead_code)]
mod common;

use glam::Vec3;
use std::time::Instant;
use warpfit::runtime::FittedGrid;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: specular_loop FIT_DIR ROUGHNESS PASSES [percall] [plain] [probe-only]";
    let dir = args.get(1).ok_or(usage)?;
    let r: f32 = args.get(2).ok_or(usage)?.parse().map_err(|e| format!("roughness: {e}"))?;
    let passes: usize = args.get(3).ok_or(usage)?.parse().map_err(|e| format!("passes: {e}"))?;
    let flag = |name: &str| args.iter().skip(4).any(|a| a == name);
    let per_call = flag("percall");
    let mut grid = FittedGrid::load(dir).map_err(|e| e.to_string())?;
    if flag("plain") {
        grid = grid.with_roughness(None);
    }
    if flag("probe-only") {
        grid = grid.with_read(warpfit::runtime::SpecularRead::ProbeOnly);
    }
    let (positions, directions): (Vec<Vec3>, Vec<Vec3>) = common::queries(&grid, 64, 256).into_iter().unzip();
    let roughness = vec![r; positions.len()];
    let mut out = vec![Vec3::ZERO; positions.len()];
    let mut acc = Vec3::ZERO;
    let start = Instant::now();
    for _ in 0..passes.max(1) {
        if per_call {
            for k in 0..positions.len() {
                out[k] = grid.specular(positions[k], directions[k], roughness[k]);
            }
        } else {
            grid.specular_batch(&positions, &directions, &roughness, &mut out).map_err(|e| e.to_string())?;
        }
        acc += out[7];
    }
    let ns = start.elapsed().as_secs_f64() * 1e9 / (passes.max(1) * positions.len()) as f64;
    println!(
        "{} at roughness {r}: {ns:.2} ns per lookup over {} passes of {} queries (checksum {acc})",
        if per_call { "specular" } else { "specular_batch" },
        passes.max(1),
        positions.len()
    );
    Ok(())
}
