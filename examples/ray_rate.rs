//! Closest-hit ray rate on the triangles and rays `cargo bench --bench trace` dumps, the
//! counterpart of `benches/embree_reference.py` (same files, same rays, one thread, best of
//! several passes), so the two can be run alternately and compared as a ratio:
//!
//!     WARPFIT_DUMP_RAYS=/tmp/rays cargo bench --bench trace -- rays/atrium
//!     cargo run --release --example ray_rate -- /tmp/rays/atrium 5
//!     cargo run --release --example ray_rate -- /tmp/rays/atrium 5 portable
//!
//! Optional arguments after PASSES: `portable` forces the portable (SSE2) node test instead
//! of the widest this CPU has; `occluded` times occlusion rays instead (each ray to its
//! reach in CASE.tmax.f32 when that file exists, as `WARPFIT_DUMP_STREAMS` writes shadow
//! streams; else to 90% of its closest hit, so they walk the tree and find nothing:
//! `cargo run --release --example ray_rate -- /tmp/rays/atrium 5 occluded`); `packets` times the batch API instead
//! (`Tracer::closest_hits` on the rays sorted by `coherent_order`, the sort timed, after
//! checking every ray's hit against `closest_hit`), and with `nosort` on the rays as given;
//! `write-coherent` writes the rays in that order to CASE_coherent.rays.f32 (for Embree).

use glam::Vec3;
use std::path::Path;
use std::time::Instant;
use warpfit::scene::Scene;
use warpfit::trace::{NodeTest, Tracer};

fn floats(path: &str) -> Result<Vec<f32>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
    if bytes.len() % 4 != 0 {
        return Err(format!("{path}: {} bytes is not a whole number of float32", bytes.len()));
    }
    Ok(bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let case = args.get(1).ok_or("usage: ray_rate CASE [PASSES] [portable]")?;
    let passes: usize = args.get(2).map_or(Ok(5), |p| p.parse().map_err(|e| format!("passes {p:?}: {e}")))?;
    let flag = |f: &str| args.iter().skip(3).any(|a| a == f);
    let test = if flag("portable") { NodeTest::Portable } else { NodeTest::Auto };
    // occlusion rays instead: the same rays, each to 90% of its closest hit's distance (so
    // about every one ends unblocked, the case that walks the most of the tree) or to 100
    // scene units where it escapes
    let occluded = flag("occluded");

    // an empty scene, then the dumped world-space triangles (material 0)
    let mut scene = Scene::parse(
        "[probe]\nposition = [0.0, 0.0, 0.0]\n[grid]\nmin = [-1.0,-1.0,-1.0]\nmax = [1.0,1.0,1.0]\ncounts = [1,1,1]\n[[geometry]]\ntype = \"box\"\nmin = [0.0,0.0,0.0]\nmax = [0.1,0.1,0.1]\n",
        Path::new("ray_rate.toml"),
    )
    .map_err(|e| e.to_string())?;
    let t = &mut scene.triangles;
    t.v0.clear();
    t.v1.clear();
    t.v2.clear();
    t.material.clear();
    for c in floats(&format!("{case}.tris.f32"))?.chunks_exact(9) {
        t.v0.push(Vec3::new(c[0], c[1], c[2]));
        t.v1.push(Vec3::new(c[3], c[4], c[5]));
        t.v2.push(Vec3::new(c[6], c[7], c[8]));
        t.material.push(0);
    }
    let rays: Vec<(Vec3, Vec3)> = floats(&format!("{case}.rays.f32"))?
        .chunks_exact(6)
        .map(|c| (Vec3::new(c[0], c[1], c[2]), Vec3::new(c[3], c[4], c[5])))
        .collect();

    let tracer = Tracer::new(&scene).with_node_test(test);
    // a dumped shadow stream carries each ray's reach (CASE.tmax.f32): occlusion at it
    let given = floats(&format!("{case}.tmax.f32")).ok().filter(|t| t.len() == rays.len());
    let rays: Vec<(Vec3, Vec3, f32)> = match &given {
        Some(t) if occluded => rays.iter().zip(t).map(|(&(o, d), &t)| (o, d, t)).collect(),
        _ => rays
            .iter()
            .map(|&(o, d)| (o, d, tracer.closest_hit(o, d, f32::INFINITY).map_or(100.0, |h| h.t * 0.9)))
            .collect(),
    };
    // the batch API instead: the rays put in a coherent order (timed with the pass), then
    // walked in packets
    let packets = flag("packets");
    let pairs: Vec<(Vec3, Vec3)> = rays.iter().map(|&(o, d, _)| (o, d)).collect();
    if packets {
        // the same hits as one ray at a time, or the figure means nothing
        let out = tracer.closest_hits(&pairs, f32::INFINITY);
        let differ =
            pairs.iter().zip(&out).filter(|&(&(o, d), h)| *h != tracer.closest_hit(o, d, f32::INFINITY)).count();
        if differ > 0 {
            return Err(format!("{differ} rays hit differently in packets"));
        }
    }
    if flag("write-coherent") {
        // the rays in the packets' order, for the reference to trace in that order too
        let path = format!("{case}_coherent.rays.f32");
        let bytes: Vec<u8> = warpfit::trace::coherent_order(&pairs)
            .iter()
            .flat_map(|&i| pairs[i as usize].0.to_array().into_iter().chain(pairs[i as usize].1.to_array()))
            .flat_map(f32::to_le_bytes)
            .collect();
        std::fs::write(&path, bytes).map_err(|e| format!("{path}: {e}"))?;
        println!("wrote {path}");
    }
    let mut best = f64::INFINITY;
    let mut hits = 0;
    let mut sorted = pairs.clone();
    for _ in 0..passes.max(1) {
        let start = Instant::now();
        hits = if packets {
            let order: Vec<u32> =
                if flag("nosort") { (0..pairs.len() as u32).collect() } else { warpfit::trace::coherent_order(&pairs) };
            for (k, &i) in order.iter().enumerate() {
                sorted[k] = pairs[i as usize];
            }
            tracer.closest_hits(&sorted, f32::INFINITY).iter().filter(|h| h.is_some()).count()
        } else if occluded {
            rays.iter().filter(|(o, d, t)| tracer.occluded(*o, *d, *t)).count()
        } else {
            rays.iter().filter(|(o, d, _)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count()
        };
        best = best.min(start.elapsed().as_secs_f64());
    }
    println!(
        "{case}: {} triangles, {} nodes, {} rays, node test {:?}, BVH build {:.3} s: best of {passes} passes {:.2} Mrays/s {}, 1 thread ({hits} hits)",
        scene.triangles.v0.len(),
        tracer.node_count(),
        rays.len(),
        tracer.node_test(),
        tracer.build_time.as_secs_f64(),
        rays.len() as f64 / best / 1e6,
        if occluded {
            "occlusion"
        } else if packets {
            "closest hit in coherent packets"
        } else {
            "closest hit"
        }
    );
    Ok(())
}
