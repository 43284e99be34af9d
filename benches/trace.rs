//! Ray throughput: our closest-hit (one ray at a time, and sorted into coherent packets)
//! and occlusion paths against bare obvhs traversal on the
//! same BVH and rays, on `torture`, on a procedural two-storey atrium of about 100k
//! triangles (columns, arches, a gallery around a light well) and on a ~1M-triangle closed
//! room; 1 vs 2 threads; BVH build presets; bake time of the default scene.
//!
//! Run: `cargo bench --bench trace`. With `WARPFIT_DUMP_RAYS=DIR` it also writes each
//! case's triangles and rays (`DIR/<case>.tris.f32`, `DIR/<case>.rays.f32`, the layout of
//! the Embree reference script) so the same rays can be traced by Embree.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use std::hint::black_box;
use std::path::Path;
use warpfit::sampling::{Sampler, uniform_sphere};
use warpfit::scene::Scene;
use warpfit::trace::{BuildQuality, NodeTest, Tracer, coherent_order};

const RAYS: u32 = 65_536;

fn torture() -> Scene {
    Scene::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/torture.toml"))).unwrap()
}

/// A closed box room with each face tessellated into n×n quads (12·n² triangles).
fn tessellated_room(n: usize) -> Scene {
    let mut s = empty_scene();
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
        push_grid(&mut s, o, u * size.dot(u), v * size.dot(v), n, n);
    }
    s
}

/// An empty scene to fill with triangles (material 0).
fn empty_scene() -> Scene {
    let mut s = Scene::parse(
        "[probe]\nposition = [0.0, 0.0, 0.0]\n[grid]\nmin = [-1.0,-1.0,-1.0]\nmax = [1.0,1.0,1.0]\ncounts = [1,1,1]\n[[geometry]]\ntype = \"box\"\nmin = [0.0,0.0,0.0]\nmax = [0.1,0.1,0.1]\n",
        Path::new("procedural.toml"),
    )
    .unwrap();
    let t = &mut s.triangles;
    t.v0.clear();
    t.v1.clear();
    t.v2.clear();
    t.material.clear();
    s
}

fn push_quad(s: &mut Scene, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
    let t = &mut s.triangles;
    for (p, q, r) in [(a, b, c), (a, c, d)] {
        t.v0.push(p);
        t.v1.push(q);
        t.v2.push(r);
        t.material.push(0);
    }
}

/// A quad `o + u·[0,1] + v·[0,1]` tessellated into `nu × nv` quads.
fn push_grid(s: &mut Scene, o: Vec3, u: Vec3, v: Vec3, nu: usize, nv: usize) {
    let at = |i: usize, j: usize| o + u * (i as f32 / nu as f32) + v * (j as f32 / nv as f32);
    for j in 0..nv {
        for i in 0..nu {
            push_quad(s, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
        }
    }
}

/// A closed cylinder (column) from `base` up `h`, radius `r`, `seg` sides, `rings` bands.
fn push_column(s: &mut Scene, base: Vec3, r: f32, h: f32, seg: usize, rings: usize) {
    let p = |k: usize, y: f32| {
        let a = k as f32 / seg as f32 * std::f32::consts::TAU;
        base + Vec3::new(r * libm::cosf(a), y, r * libm::sinf(a))
    };
    for j in 0..rings {
        let (y0, y1) = (h * j as f32 / rings as f32, h * (j + 1) as f32 / rings as f32);
        for k in 0..seg {
            push_quad(s, p(k, y0), p(k + 1, y0), p(k + 1, y1), p(k, y1));
        }
    }
}

/// A semicircular arch of square section `w` spanning from `a` to `b` (same height), its
/// crown `rise` above them, `seg` segments.
fn push_arch(s: &mut Scene, a: Vec3, b: Vec3, w: f32, seg: usize) {
    let (mid, half) = ((a + b) * 0.5, (b - a) * 0.5);
    let side = half.normalize().cross(Vec3::Y) * (w * 0.5);
    let ring = |k: usize, r: f32| {
        let t = k as f32 / seg as f32 * std::f32::consts::PI;
        mid - half.normalize() * (r * libm::cosf(t)) + Vec3::Y * (r * libm::sinf(t))
    };
    let (r0, r1) = (half.length() - w * 0.5, half.length() + w * 0.5);
    for k in 0..seg {
        let (i0, i1, o0, o1) = (ring(k, r0), ring(k + 1, r0), ring(k, r1), ring(k + 1, r1));
        push_quad(s, i0 - side, i1 - side, i1 + side, i0 + side); // intrados
        push_quad(s, o0 + side, o1 + side, o1 - side, o0 - side); // extrados
        push_quad(s, i0 + side, i1 + side, o1 + side, o0 + side); // faces
        push_quad(s, o0 - side, o1 - side, i1 - side, i0 - side);
    }
}

/// A two-storey atrium of about 100k triangles: a 48 × 30 m hall, 14 m high, with
/// tessellated walls, floor and roof; a gallery slab at 7 m around a central light well;
/// rows of columns on both storeys carrying arches; the depth complexity of a real level
/// (many occluders, long and short rays) in one procedural scene.
fn atrium() -> Scene {
    let mut s = empty_scene();
    let (lx, ly, lz) = (48.0f32, 14.0f32, 30.0f32);
    let (n, m) = (24usize, 16usize);
    // floor, roof, four walls
    push_grid(&mut s, Vec3::ZERO, Vec3::Z * lz, Vec3::X * lx, m, n);
    push_grid(&mut s, Vec3::new(0.0, ly, 0.0), Vec3::X * lx, Vec3::Z * lz, n, m);
    push_grid(&mut s, Vec3::ZERO, Vec3::X * lx, Vec3::Y * ly, n, 8);
    push_grid(&mut s, Vec3::new(0.0, 0.0, lz), Vec3::Y * ly, Vec3::X * lx, 8, n);
    push_grid(&mut s, Vec3::ZERO, Vec3::Y * ly, Vec3::Z * lz, 8, m);
    push_grid(&mut s, Vec3::new(lx, 0.0, 0.0), Vec3::Z * lz, Vec3::Y * ly, m, 8);
    // the gallery slab at 7 m: a frame around a 24 × 10 m light well (top and bottom faces)
    let (y, well) = (7.0f32, (Vec3::new(12.0, 0.0, 10.0), Vec3::new(36.0, 0.0, 20.0)));
    for (o, u, v) in [
        (Vec3::new(0.0, y, 0.0), Vec3::X * lx, Vec3::Z * well.0.z),
        (Vec3::new(0.0, y, well.1.z), Vec3::X * lx, Vec3::Z * (lz - well.1.z)),
        (Vec3::new(0.0, y, well.0.z), Vec3::X * well.0.x, Vec3::Z * (well.1.z - well.0.z)),
        (Vec3::new(well.1.x, y, well.0.z), Vec3::X * (lx - well.1.x), Vec3::Z * (well.1.z - well.0.z)),
    ] {
        push_grid(&mut s, o, v, u, 8, 16);
        push_grid(&mut s, o - Vec3::Y * 0.3, u, v, 16, 8);
    }
    // columns and arches on both storeys: rows along x at four depths
    for (floor, h) in [(0.0f32, 5.5f32), (7.0, 5.0)] {
        for z in [4.0f32, 9.0, 21.0, 26.0] {
            let xs: Vec<f32> = (0..13).map(|i| 2.0 + i as f32 * 3.666).collect();
            for &x in &xs {
                push_column(&mut s, Vec3::new(x, floor, z), 0.35, h, 32, 12);
            }
            for w in xs.windows(2) {
                push_arch(&mut s, Vec3::new(w[0], floor + h, z), Vec3::new(w[1], floor + h, z), 0.5, 40);
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
    if let Ok(dir) = std::env::var("WARPFIT_DUMP_RAYS") {
        // world-space triangles and rays, float32 little-endian (the Embree script's layout)
        let t = &scene.triangles;
        let tris: Vec<u8> = (0..t.v0.len())
            .flat_map(|k| [t.v0[k], t.v1[k], t.v2[k]])
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let rays_bytes: Vec<u8> =
            rays.iter().flat_map(|(o, d)| [o.to_array(), d.to_array()]).flatten().flat_map(f32::to_le_bytes).collect();
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(Path::new(&dir).join(format!("{name}.tris.f32")), tris).unwrap();
        std::fs::write(Path::new(&dir).join(format!("{name}.rays.f32")), rays_bytes).unwrap();
    }
    let mut g = c.benchmark_group(format!("rays/{name}"));
    g.throughput(Throughput::Elements(RAYS as u64));
    g.sample_size(20);
    g.bench_function("closest_hit/ours/1t", |b| {
        b.iter(|| rays.iter().filter(|(o, d)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count())
    });
    // the batch API: the rays put in a coherent order, then walked in packets (the sort is
    // timed with them)
    let mut sorted = rays.clone();
    g.bench_function("closest_hit/ours_packets/1t", |b| {
        b.iter(|| {
            for (k, &i) in coherent_order(&rays).iter().enumerate() {
                sorted[k] = rays[i as usize];
            }
            tracer.closest_hits(&sorted, f32::INFINITY).iter().filter(|h| h.is_some()).count()
        })
    });
    let portable = Tracer::new(scene).with_node_test(NodeTest::Portable);
    g.bench_function("closest_hit/ours_portable/1t", |b| {
        b.iter(|| rays.iter().filter(|(o, d)| portable.closest_hit(*o, *d, f32::INFINITY).is_some()).count())
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
    let atrium = atrium();
    println!("atrium: {} triangles", atrium.triangles.len());
    bench_scene(c, "atrium", &atrium, Vec3::new(17.3, 8.6, 14.2));
    let room = tessellated_room(290); // 12·290² ≈ 1.01M triangles
    bench_scene(c, "room_1M", &room, Vec3::new(0.3, 1.4, -0.5));
}

fn builders(c: &mut Criterion) {
    let t = torture();
    let torture_origin = Vec3::from_array(t.config.probe.position);
    for (case, scene, origin) in [("torture", t, torture_origin), ("atrium", atrium(), Vec3::new(17.3, 8.6, 14.2))] {
        let rays = probe_rays(origin);
        let mut g = c.benchmark_group(format!("bvh_preset/{case}"));
        g.throughput(Throughput::Elements(RAYS as u64));
        g.sample_size(20);
        for (name, q) in [("fast", BuildQuality::Fast), ("medium", BuildQuality::Medium), ("slow", BuildQuality::Slow)]
        {
            let tracer = Tracer::with_quality(&scene, q);
            println!("bvh_preset/{case}/{name}: build {:.3} s", tracer.build_time.as_secs_f64());
            g.bench_function(name, |b| {
                b.iter(|| rays.iter().filter(|(o, d)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count())
            });
        }
        g.finish();
    }
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
