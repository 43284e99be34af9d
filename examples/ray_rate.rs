//! Closest-hit ray rate on the triangles and rays `cargo bench --bench trace` dumps, the
//! counterpart of `benches/embree_reference.py` (same files, same rays, one thread, best of
//! several passes), so the two can be run alternately and compared as a ratio:
//!
//!     WARPFIT_DUMP_RAYS=/tmp/rays cargo bench --bench trace -- rays/atrium
//!     cargo run --release --example ray_rate -- /tmp/rays/atrium 5
//!     cargo run --release --example ray_rate -- /tmp/rays/atrium 5 portable
//!
//! The optional third argument forces the portable (SSE2) node test instead of the widest
//! this CPU has.

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
    let test = if args.get(3).map(String::as_str) == Some("portable") { NodeTest::Portable } else { NodeTest::Auto };

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
    let mut best = f64::INFINITY;
    let mut hits = 0;
    for _ in 0..passes.max(1) {
        let start = Instant::now();
        hits = rays.iter().filter(|(o, d)| tracer.closest_hit(*o, *d, f32::INFINITY).is_some()).count();
        best = best.min(start.elapsed().as_secs_f64());
    }
    println!(
        "{case}: {} triangles, {} nodes, {} rays, node test {:?}, BVH build {:.3} s: best of {passes} passes {:.2} Mrays/s closest hit, 1 thread ({hits} hits)",
        scene.triangles.v0.len(),
        tracer.node_count(),
        rays.len(),
        tracer.node_test(),
        tracer.build_time.as_secs_f64(),
        rays.len() as f64 / best / 1e6
    );
    Ok(())
}
