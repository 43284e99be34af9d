//! ns per lookup of each per-lookup warp method on the default scene's probe (fetch
//! direction + bilinear radiance), single-threaded, over the validation set's queries.
//!
//! Run: `cargo bench --bench warp`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use std::hint::black_box;
use std::path::Path;
use warpfit::eval::{self, EvalSettings};
use warpfit::progress::Progress;
use warpfit::scene::Scene;
use warpfit::trace::Tracer;
use warpfit::warp::{Method, WarpOptions};

fn methods(c: &mut Criterion) {
    let scene = Scene::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/torture.toml"))).unwrap();
    let tracer = Tracer::new(&scene);
    let baked = warpfit::bake::bake(&scene, &tracer, &Progress::quiet());
    let settings = EvalSettings { positions: 64, dirs_per_position: 256, reference_spp: 1, ..EvalSettings::default() };
    let set = eval::validation_set(&scene, &tracer, &baked.grid, &[baked.probe.position], &settings, None);
    let warp = warpfit::bake::warp(&scene, &baked.probe, WarpOptions::standard());
    let n = set.dirs.len();
    let queries: Vec<(Vec3, Vec3)> = (0..n).map(|k| (set.position_of(k), set.dirs[k])).collect();
    let mut g = c.benchmark_group("lookup/torture");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(20);
    for m in Method::PER_LOOKUP {
        g.bench_function(m.name(), |b| {
            b.iter(|| {
                let mut acc = Vec3::ZERO;
                for &(p, d) in &queries {
                    acc += warp.lookup(m, p, d);
                }
                black_box(acc)
            })
        });
    }
    g.finish();

    // Coherent bundles: per position, a 16×16 fan of directions inside a 20° cone, as
    // neighbouring pixels of a reflective surface query a probe.
    let bundles: Vec<(Vec3, Vec3)> = set
        .positions
        .iter()
        .enumerate()
        .flat_map(|(k, &p)| {
            let axis = set.dirs[k * set.dirs_per_position];
            let (t, b) = warpfit::sampling::orthonormal_basis(axis);
            (0..256).map(move |i| {
                let (u, v) = ((i % 16) as f32 / 15.0 - 0.5, (i / 16) as f32 / 15.0 - 0.5);
                let half = libm::tanf(20f32.to_radians());
                (p, (axis + (t * u + b * v) * half).normalize())
            })
        })
        .collect();
    // Batched warp1: the same lookups through the batch API (`octa::LANES` in lockstep),
    // bit for bit the per-lookup results.
    let mut g = c.benchmark_group("lookup_batch/torture");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(20);
    let (mut vectors, mut radiance) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    g.bench_function("warp1", |b| {
        b.iter(|| {
            warpfit::warp::depth::warp1_batch(&warp.probe, &queries, warp.options.depth_lod, &mut vectors);
            warp.probe.radiance_batch(&vectors, &mut radiance);
            black_box(&radiance);
        })
    });
    g.bench_function("none", |b| {
        b.iter(|| {
            warp.probe.radiance_batch(black_box(&set.dirs), &mut radiance);
            black_box(&radiance);
        })
    });
    g.finish();

    let mut g = c.benchmark_group("lookup_coherent/torture");
    g.throughput(Throughput::Elements(bundles.len() as u64));
    g.sample_size(20);
    for m in Method::PER_LOOKUP {
        g.bench_function(m.name(), |b| {
            b.iter(|| {
                let mut acc = Vec3::ZERO;
                for &(p, d) in &bundles {
                    acc += warp.lookup(m, p, d);
                }
                black_box(acc)
            })
        });
    }
    g.finish();
}

// Criterion's own plots need a system font that a fresh machine lacks (plotters would
// panic); the figures that matter are the printed estimates.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = methods
}
criterion_main!(benches);
