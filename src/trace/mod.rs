//! Ray tracing: the BVH wrapper (closest hit, occlusion) and the radiance model, plus the one
//! batch entry point later stages use for references.

pub mod bvh;
pub mod cwbvh;
pub mod radiance;
pub mod store;
pub mod streams;
pub mod truth;

pub use bvh::{BuildQuality, Hit, Tracer, coherent_order};
pub use cwbvh::NodeTest;
pub use radiance::{RaySample, Renderer};

use crate::sampling::Sampler;
use glam::Vec3;
use rayon::prelude::*;

/// Rays per rayon task: large enough to amortise scheduling, small enough to balance.
const CHUNK: usize = 256;

/// Radiance (mean of `spp` samples) and hit distance for a batch of rays, in parallel.
/// Ray `k` uses sampler stream `stream_base + k`, so the result does not depend on how the
/// batch is split across threads. Returns the samples and the number of rays traced.
pub fn trace_batch(
    renderer: &Renderer,
    origins: &[Vec3],
    dirs: &[Vec3],
    seed: u64,
    stream_base: u64,
    spp: u32,
) -> (Vec<RaySample>, u64) {
    assert_eq!(origins.len(), dirs.len(), "one origin per direction");
    let spp = spp.max(1);
    let mut out = vec![RaySample::default(); origins.len()];
    let rays: u64 = out
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut rays = 0u64;
            for (k, slot) in chunk.iter_mut().enumerate() {
                let idx = c * CHUNK + k;
                let mut sum = Vec3::ZERO;
                let mut first = RaySample::default();
                for s in 0..spp {
                    let mut sampler = Sampler::new(seed, stream_base + idx as u64, s);
                    let r = renderer.sample(origins[idx], dirs[idx], &mut sampler, &mut rays);
                    if s == 0 {
                        first = r;
                    }
                    sum += r.radiance;
                }
                *slot = RaySample { radiance: sum / spp as f32, ..first };
            }
            rays
        })
        .sum();
    (out, rays)
}
