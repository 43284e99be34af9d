//! What a game does with a fitted grid: load it once at level load, then every frame shade
//! G-buffer samples (position, normal, view direction, roughness) in tiles of 64, with the
//! fitted specular (batch API) and the grid's irradiance, from several worker threads
//! sharing the one grid.
//!
//! `cargo run --release --example runtime -- fits/torture` (defaults to the committed
//! `fits/tiny`). It uses the crate `warpfit-runtime` alone, as a game would.

use glam::Vec3;
use std::time::Instant;
use warpfit_runtime::FittedGrid;

/// A small deterministic random stream (xorshift64*), enough for a synthetic frame.
struct Rng(u64);

impl Rng {
    /// Uniform in [0, 1).
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform on the unit sphere.
    fn direction(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next();
        let phi = std::f32::consts::TAU * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * libm::cosf(phi), r * libm::sinf(phi), z)
    }
}

/// One G-buffer sample.
#[derive(Clone, Copy)]
struct Surface {
    position: Vec3,
    normal: Vec3,
    to_eye: Vec3,
    albedo: Vec3,
    f0: Vec3,
    roughness: f32,
}

/// Mirror direction and Schlick Fresnel of a sample (a real engine would use its own
/// split-sum DFG term).
fn reflection(s: &Surface) -> (Vec3, Vec3) {
    let n_dot_v = s.normal.dot(s.to_eye).max(1e-4);
    let reflected = 2.0 * n_dot_v * s.normal - s.to_eye;
    let fresnel = s.f0 + (Vec3::ONE - s.f0) * (1.0 - n_dot_v).powi(5);
    (reflected, fresnel)
}

/// Shades a tile of samples: specular through the batch API (lookups advance in lockstep,
/// bit for bit the single calls), diffuse from the irradiance per sample.
fn shade_tile(grid: &FittedGrid, tile: &[Surface], out: &mut [Vec3]) {
    const TILE: usize = 64;
    let n = tile.len();
    assert!(n <= TILE && out.len() == n);
    let (mut positions, mut reflected, mut roughness) = ([Vec3::ZERO; TILE], [Vec3::ZERO; TILE], [0.0f32; TILE]);
    let mut fresnel = [Vec3::ZERO; TILE];
    for (k, s) in tile.iter().enumerate() {
        (reflected[k], fresnel[k]) = reflection(s);
        (positions[k], roughness[k]) = (s.position, s.roughness);
    }
    let mut specular = [Vec3::ZERO; TILE];
    grid.specular_batch(&positions[..n], &reflected[..n], &roughness[..n], &mut specular[..n])
        .expect("slices of one length");
    for (k, s) in tile.iter().enumerate() {
        let diffuse = s.albedo / std::f32::consts::PI * grid.irradiance(s.position, s.normal);
        out[k] = diffuse * (Vec3::ONE - fresnel[k]) + fresnel[k] * specular[k];
    }
}

fn main() {
    let dir = std::env::args().nth(1).unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny").into());
    let t = Instant::now();
    let grid = match FittedGrid::load(&dir) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    println!("loaded {dir} in {:.1} ms ({} bytes in memory)", t.elapsed().as_secs_f64() * 1e3, grid.memory_bytes());

    // A synthetic "frame": surfaces scattered through the grid's volume, facing random ways.
    let (lo, hi) = grid.bounds();
    let mut rng = Rng(7);
    let frame: Vec<Surface> = (0..1 << 18)
        .map(|_| {
            let position = lo + (hi - lo) * Vec3::new(rng.next(), rng.next(), rng.next());
            let normal = rng.direction();
            let mut to_eye = rng.direction();
            if to_eye.dot(normal) < 0.0 {
                to_eye = -to_eye;
            }
            Surface { position, normal, to_eye, albedo: Vec3::splat(0.6), f0: Vec3::splat(0.04), roughness: rng.next() }
        })
        .collect();

    // Shade it on every core: FittedGrid is Send + Sync and sampling never allocates.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut image = vec![Vec3::ZERO; frame.len()];
    let t = Instant::now();
    std::thread::scope(|scope| {
        let chunk = frame.len().div_ceil(threads);
        for (src, dst) in frame.chunks(chunk).zip(image.chunks_mut(chunk)) {
            let grid = &grid;
            scope.spawn(move || {
                for (tile, out) in src.chunks(64).zip(dst.chunks_mut(64)) {
                    shade_tile(grid, tile, out);
                }
            });
        }
    });
    let secs = t.elapsed().as_secs_f64();
    let mean = image.iter().copied().sum::<Vec3>() / image.len() as f32;
    println!(
        "shaded {} samples on {threads} threads in {:.1} ms ({:.0} ns per sample per thread); mean colour {:.4} {:.4} {:.4}",
        image.len(),
        secs * 1e3,
        secs * 1e9 * threads as f64 / image.len() as f64,
        mean.x,
        mean.y,
        mean.z
    );
    assert!(image.iter().all(|c| c.is_finite()));
}
