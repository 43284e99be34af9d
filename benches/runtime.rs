//! The runtime sampler, single-threaded: ns per `specular` sample (mirror and rough, in both
//! quality tiers of `SpecularRead`, and with the faces blend) and per `irradiance` sample, next to `warp1` on the same
//! probe and queries; the load time of the fitted grid; and its bytes per stored cell
//! (printed).
//!
//! Uses `fits/torture` (written by `cargo run --release -- run`); if it is missing or
//! unreadable, fits the torture scene first into a temporary folder (about a minute).
//!
//! `WARPFIT_BENCH_GRIDS=DIR[,DIR…]` benches those fitted grids instead, each in a group
//! named by its folder (to compare two grids, say one probe against several, in one run).
//!
//! Run: `cargo bench --bench runtime`

#[path = "common/mod.rs"]
mod common;

use common::fitted_torture;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use std::hint::black_box;
use warpfit::runtime::{FittedGrid, SpecularRead};
use warpfit::warp::corrective::Blend;
use warpfit::warp::{self, Method};

fn runtime(c: &mut Criterion) {
    let dirs: Vec<std::path::PathBuf> = match std::env::var("WARPFIT_BENCH_GRIDS") {
        Ok(list) => list.split(',').filter(|s| !s.is_empty()).map(std::path::PathBuf::from).collect(),
        Err(_) => vec![fitted_torture()],
    };
    for dir in dirs {
        bench_grid(c, &dir);
    }
}

/// The runtime's benches on the fitted grid in `dir`.
fn bench_grid(c: &mut Criterion, dir: &std::path::Path) {
    let name = dir.file_name().map_or("grid".into(), |n| n.to_string_lossy().into_owned());
    let group = if name == "torture" { "runtime/torture".to_string() } else { format!("runtime/{name}") };
    let grid = FittedGrid::load(dir).unwrap();
    let m = &grid.manifest();
    let stored = m.correctives.as_ref().map_or(0, |c| c.stored_cells.len());
    let disk: u64 = m.payloads.iter().map(|p| p.bytes).sum();
    println!(
        "{}: {} stored warp maps, {} stored irradiance cells, {} bytes on disk, {} bytes in memory; {} bytes per stored warp map",
        dir.display(),
        stored,
        m.irradiance.stored_cells.len(),
        disk,
        grid.memory_bytes(),
        m.correctives.as_ref().map_or(0, |c| c.map_res * c.map_res * 4)
    );
    let q = common::queries(&grid, 64, 256);
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(q.len() as u64));
    g.sample_size(20);
    g.bench_function("warp1", |b| {
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for &(p, d) in &q {
                acc += grid.warp().lookup(Method::Warp1, p, d);
            }
            black_box(acc)
        })
    });
    // mirror, a rough lookup on the cell's map, one blending the map and the rough map;
    // then the rough ones reading probe A alone (`SpecularRead::ProbeOnly`)
    // and the same grid read with the faces blend (`Blend::Faces`, `warpfit fit --blend faces`)
    let probe_only = grid.clone().with_read(SpecularRead::ProbeOnly);
    let faces = grid.clone().with_lookup(|_, blend, _| *blend = Blend::Faces);
    let tiers = [(&grid, ""), (&probe_only, "_probe_only"), (&faces, "_faces")];
    let cases = |tier: &str| match tier {
        "" => vec![0.0f32, 0.5, 0.625],
        "_faces" => vec![0.0, 0.5],
        _ => vec![0.5, 0.625],
    };
    for (grid, tier) in tiers {
        for r in cases(tier) {
            g.bench_function(format!("specular{tier}_r{r}"), |b| {
                b.iter(|| {
                    let mut acc = Vec3::ZERO;
                    for &(p, d) in &q {
                        acc += grid.specular(p, d, r);
                    }
                    black_box(acc)
                })
            });
        }
    }
    // The batch APIs on the same queries (`octa::LANES` lookups in lockstep).
    let (positions, directions): (Vec<Vec3>, Vec<Vec3>) = q.iter().copied().unzip();
    let mut out = vec![Vec3::ZERO; q.len()];
    let mut vectors = vec![Vec3::ZERO; q.len()];
    g.bench_function("warp1_batch", |b| {
        b.iter(|| {
            warp::depth::warp1_batch(&grid.warp().probe, &q, grid.warp().options.depth_lod, &mut vectors);
            grid.warp().probe.radiance_batch(&vectors, &mut out);
            black_box(&out);
        })
    });
    for (grid, tier) in tiers {
        for r in cases(tier) {
            let roughness = vec![r; q.len()];
            g.bench_function(format!("specular{tier}_batch_r{r}"), |b| {
                b.iter(|| {
                    grid.specular_batch(&positions, &directions, &roughness, &mut out).unwrap();
                    black_box(&out);
                })
            });
        }
    }
    g.bench_function("irradiance", |b| {
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for &(p, d) in &q {
                acc += grid.irradiance(p, d);
            }
            black_box(acc)
        })
    });
    g.finish();
    let mut g = c.benchmark_group("load");
    g.sample_size(10);
    g.bench_function(format!("fits/{name}"), |b| b.iter(|| black_box(FittedGrid::load(dir).unwrap().memory_bytes())));
    g.finish();
}

fn config() -> Criterion {
    Criterion::default().without_plots()
}

criterion_group! { name = benches; config = config(); targets = runtime }
criterion_main!(benches);
