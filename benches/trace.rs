//! Ray throughput: our closest-hit and occlusion paths against bare obvhs traversal on the
//! same BVH and rays, on `torture` and on a ~1M-triangle closed room; 1 vs 2 threads; BVH
//! build presets; bake time of the default scene.
//!
//! Run: `cargo bench --bench trace`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use std::hint::black_box;
use std::path::Path;
use warpfit::sampling::{Sampler, uniform_sphere};
use warpfit::scene::Scene;
use warpfit::trace::{BuildQuality, Tracer};

const RAYS: u32 = 65_536;

fn torture() -> Scene {
    Scene::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/torture.toml"))).unwrap()
}

/// A closed box room with each face tessellated into n×n quads (12·n² triangles).
fn tessellated_room(n: usize) -> Scene {
    let mut s = Scene::parse(
        "[probe]\nposition = [0.0, 0.0, 0.0]\n[grid]\nmin = [-1.0,-1.0,-1.0]\nmax = [1.0,1.0,1.0]\ncounts = [1,1,1]\n[[geometry]]\ntype = \"box\"\nmin = [0.0,0.0,0.0]\nmax = [0.1,0.1,0.1]\n",
        Path::new("room.toml"),
    )
    .unwrap();
    let t = &mut s.triangles;
    t.v0.clear();
    t.v1.clear();
    t.v2.clear();
    t.material.clear();
    let (lo, hi) = (Vec3::new(-4.0, 0.0, -6.0), Vec3::new(4.0, 3.0, 6.0));
    let size = hi - lo;
    let faces = [
        (lo, Vec3::Y, Vec3::Z),
        (Vec3::new(hi.x, lo.y, lo.z), Vec3::Z, Vec3::Y),
        (lo, Vec3::Z, Vec3::X),
        (Vec3::new(lo.x, hi.y, lo.z), Vec3::X, Vec3::Z),
        (lo, Vec3::X, Vec3::Y),
        (Vec3::new(lo.x, lo.y, hi.z), Vec3::Y, Vec3::X),
    ];
    for (o, u, v) in faces {
        let (su, sv) = (u * size.dot(u), v * size.dot(v));
        let at = |i: usize, j: usize| o + su * (i as f32 / n as f32) + sv * (j as f32 / n as f32);
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                for (p, q, r) in [(a, b, c), (a, c, d)] {
                    t.v0.push(p);
                    t.v1.push(q);
                    t.v2.push(r);
                    t.material.push(0);
                }
            }
        }
    }
    s
}

fn probe_rays(origin: Vec3) -> Vec<(Vec3, Vec3)> {
    (0..RAYS).map(|k| (origin, uniform_sphere(Sampler::new(7, 0, k).next_2d()))).collect()
}

fn bench_scene(c: &mut Criterion, name: &str, scene: &Scene, origin: Vec3) {
    let tracer = Tracer::new(scene);
    let rays = probe_rays(origin);
    let tris = tracer.normalised_triangles();
    let bare_rays: Vec<(Vec3A, Vec3A)> =
        rays.iter().map(|(o, d)| (tracer.to_normalised(*o), Vec3A::from(*d))).collect();
    let mut g = c.benchmark_group(format!("rays/{name}"));
    g.throughput(Throughput::Elements(RAYS as u64));
    g.sample_size(20);
    g.bench_function("closest_hit/ours/1t", |b| {
        b.iter(|| rays.iter().filter(|(o, d)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count())
    });
    g.bench_function("closest_hit/bare_obvhs/1t", |b| {
        b.iter(|| bare_rays.iter().filter(|(o, d)| tracer.bare_closest_t(&tris, *o, *d).is_finite()).count())
    });
    g.bench_function("occluded/ours/1t", |b| {
        b.iter(|| rays.iter().filter(|(o, d)| tracer.occluded(*o, *d, f32::INFINITY)).count())
    });
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        g.bench_with_input(BenchmarkId::new("closest_hit/ours/rayon", threads), &threads, |b, _| {
            b.iter(|| {
                pool.install(|| {
                    rays.par_chunks(256)
                        .map(|ch| {
                            ch.iter().filter(|(o, d)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count()
                        })
                        .sum::<usize>()
                })
            })
        });
    }
    g.finish();
}

fn rays(c: &mut Criterion) {
    let t = torture();
    let origin = Vec3::from_array(t.config.probe.position);
    bench_scene(c, "torture", &t, origin);
    let room = tessellated_room(290); // 12·290² ≈ 1.01M triangles
    bench_scene(c, "room_1M", &room, Vec3::new(0.3, 1.4, -0.5));
}

fn builders(c: &mut Criterion) {
    let t = torture();
    let origin = Vec3::from_array(t.config.probe.position);
    let rays = probe_rays(origin);
    let mut g = c.benchmark_group("bvh_preset/torture");
    g.throughput(Throughput::Elements(RAYS as u64));
    g.sample_size(20);
    for (name, q) in [("fast", BuildQuality::Fast), ("medium", BuildQuality::Medium), ("slow", BuildQuality::Slow)] {
        let tracer = Tracer::with_quality(&t, q);
        g.bench_function(name, |b| {
            b.iter(|| rays.iter().filter(|(o, d)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count())
        });
    }
    g.finish();
}

fn bake_default(c: &mut Criterion) {
    let scene = torture();
    let mut g = c.benchmark_group("bake");
    g.sample_size(10);
    g.bench_function("torture/default", |b| {
        b.iter(|| {
            let tracer = Tracer::new(&scene);
            black_box(warpfit::bake::bake(&scene, &tracer, &warpfit::progress::Progress::quiet()))
        })
    });
    g.finish();
}

// Criterion's own plots need a system font that a fresh machine lacks (plotters would
// panic); the figures that matter are the printed estimates.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = rays, builders, bake_default
}
criterion_main!(benches);
