//! Baking a surface-probe atlas (seed 003): for each probe of a `[[surface_probes]]` patch,
//! the radiance of its upper hemisphere on a hemi-octahedral tile in the surface's tangent
//! space (supersampled per texel, as probe A's texels are), the distance of each texel-centre
//! ray, and GGX-prefiltered mips at r = m/(M−1).
//!
//! The seed renders a cubemap per probe and flattens its hemisphere; tracing the hemisphere
//! texel by texel gives the same tile without the resampling. Prefiltering is an exact sum
//! over the mirror tile's texels (each by its solid angle) with the weights Karis's split-sum
//! importance sampling converges to, `D(n·h)·(n·l)` with N = V = R (the lobe probe A's mips
//! use); one weight matrix serves every probe, since all tiles share their geometry. Lobe
//! directions under the surface are not in the tile: they take no part.

use crate::octa::hemi;
use crate::progress::Progress;
use crate::sampling::{Sampler, ggx_d, hash_pair};
use crate::scene::SurfaceProbeSpec;
use crate::trace::{Renderer, truth};
use crate::warp::surface::{SurfaceAtlas, SurfacePatch};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Sampler domain of surface-probe texels.
pub const DOMAIN_SURFACE_RADIANCE: u64 = 0x5352_4144; // "SRAD"

/// Mips of every tile: r = 0, 0.2, …, 1 (probe A's default chain has as many).
pub const SURFACE_MIPS: usize = 6;

/// Bakes the atlas of `spec`; returns it and the rays traced. `index` (the entry's place in
/// the scene file) keeps two atlases' sample streams apart.
pub fn bake_surface_atlas(
    renderer: &Renderer,
    spec: &SurfaceProbeSpec,
    index: u64,
    seed: u64,
    progress: &Progress,
) -> (SurfaceAtlas, u64) {
    let n = spec.resolution;
    let centre = spec.corner + (spec.edge_u + spec.edge_v) * 0.5;
    let patch = SurfacePatch {
        corner: spec.corner,
        edge_u: spec.edge_u,
        edge_v: spec.edge_v,
        counts: spec.counts,
        resolution: n,
        offset: renderer.tracer.surface_offset(centre) * 4.0,
    };
    let (texels, probes, frame) = ((n * n) as usize, patch.probes(), patch.frame());
    let bar = progress.bar(probes as u64, "surface probes");
    let stream_base = hash_pair(DOMAIN_SURFACE_RADIANCE, index);
    let tiles: Vec<(Vec<Vec3>, Vec<f32>, u64)> = (0..probes)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k as u32 % spec.counts[0], k as u32 / spec.counts[0]);
            let origin = patch.probe_position(&frame, i, j);
            let mut rays = 0u64;
            let mut radiance = Vec::with_capacity(texels);
            let mut inv = Vec::with_capacity(texels);
            for t in 0..n * n {
                let (ti, tj) = (t % n, t / n);
                let stream = hash_pair(stream_base, (k * texels) as u64 + t as u64);
                let mut sum = Vec3::ZERO;
                for s in 0..spec.samples_per_texel {
                    let mut sampler = Sampler::new(seed, stream, s);
                    let uv = (Vec2::new(ti as f32, tj as f32) + sampler.next_2d()) / n as f32;
                    let d = frame.to_world(hemi::decode(uv));
                    sum += renderer.sample(origin, d, &mut sampler, &mut rays).radiance;
                }
                radiance.push(sum / spec.samples_per_texel as f32);
                let d = frame.to_world(hemi::texel_dir(n, ti, tj));
                let mut sampler = Sampler::new(seed, stream, u32::MAX);
                inv.push(crate::octa::inverse_distance(renderer.sample(origin, d, &mut sampler, &mut rays).distance));
            }
            bar.inc(1);
            (radiance, inv, rays)
        })
        .collect();
    bar.finish_and_clear();
    let mut base = Vec::with_capacity(probes * texels);
    let mut inv_distance = Vec::with_capacity(probes * texels);
    let mut rays = 0;
    for (r, w, k) in tiles {
        base.extend(r);
        inv_distance.extend(w);
        rays += k;
    }
    // probes inside geometry (under a column's foot) saw only back faces: their tiles take
    // their live neighbours' mean, so no blend near the column reads black
    let threshold = renderer.scene.config.grid.inside_backface_fraction;
    let inside_stream = hash_pair(stream_base, u64::MAX);
    let dead: Vec<bool> = (0..probes)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k as u32 % spec.counts[0], k as u32 / spec.counts[0]);
            let p = patch.probe_position(&frame, i, j);
            truth::is_inside(renderer.scene, renderer.tracer, p, threshold, |s| {
                Sampler::new(seed, hash_pair(inside_stream, k as u64), s)
            })
        })
        .collect();
    rays += probes as u64 * truth::INSIDE_PROBE_RAYS as u64;
    fill_dead_tiles(&mut base, &dead, spec.counts, texels);
    fill_dead_tiles(&mut inv_distance, &dead, spec.counts, texels);
    let roughness: Vec<f32> = (0..SURFACE_MIPS).map(|m| m as f32 / (SURFACE_MIPS - 1) as f32).collect();
    let mut radiance = vec![base];
    for &r in &roughness[1..] {
        let weights = ggx_weights(n, r * r);
        let level: Vec<Vec3> = radiance[0]
            .par_chunks(texels)
            .flat_map_iter(|tile| {
                weights.iter().map(move |row| row.iter().map(|&(t, w)| tile[t as usize] * w).sum::<Vec3>())
            })
            .collect();
        radiance.push(level);
    }
    (SurfaceAtlas::new(patch, radiance, roughness, inv_distance), rays)
}

/// Fills the tiles of dead probes, ring by ring, with the mean of their live 4-neighbours'
/// tiles; a probe becomes live once filled. Nothing changes when every probe is dead.
fn fill_dead_tiles<T>(layer: &mut [T], dead: &[bool], counts: [u32; 2], texels: usize)
where
    T: crate::octa::Texel + std::ops::Div<f32, Output = T>,
{
    let mut dead = dead.to_vec();
    let (cu, cv) = (counts[0] as i64, counts[1] as i64);
    while dead.iter().any(|&d| d) {
        let ring: Vec<(usize, Vec<usize>)> = (0..dead.len())
            .filter(|&k| dead[k])
            .filter_map(|k| {
                let (i, j) = (k as i64 % cu, k as i64 / cu);
                let live: Vec<usize> = [(i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)]
                    .into_iter()
                    .filter(|&(a, b)| (0..cu).contains(&a) && (0..cv).contains(&b))
                    .map(|(a, b)| (b * cu + a) as usize)
                    .filter(|&n| !dead[n])
                    .collect();
                (!live.is_empty()).then_some((k, live))
            })
            .collect();
        if ring.is_empty() {
            return;
        }
        for (k, live) in &ring {
            for t in 0..texels {
                let sum = live.iter().fold(T::default(), |acc, &n| acc + layer[n * texels + t]);
                layer[k * texels + t] = sum / live.len() as f32;
            }
        }
        for (k, _) in ring {
            dead[k] = false;
        }
    }
}

/// Per output texel of an N×N tile, the normalised weights of the mirror tile's texels in
/// the GGX lobe of `alpha` around the texel's direction (N = V = R): `D(n·h)·(n·l)·Ω_l`,
/// `h = normalize(n + l)`; texels with a weight below 1e-6 of their row's largest dropped.
#[must_use]
pub fn ggx_weights(res: u32, alpha: f32) -> Vec<Vec<(u32, f32)>> {
    let omega = hemi::texel_solid_angles(res);
    let dirs: Vec<Vec3> = (0..res * res).map(|t| hemi::texel_dir(res, t % res, t / res)).collect();
    dirs.iter()
        .map(|&n| {
            let row: Vec<(u32, f32)> = dirs
                .iter()
                .zip(&omega)
                .enumerate()
                .filter_map(|(t, (&l, &o))| {
                    let nl = n.dot(l);
                    let h = (n + l).try_normalize()?;
                    (nl > 0.0).then(|| (t as u32, ggx_d(n.dot(h), alpha) * nl * o))
                })
                .collect();
            let max = row.iter().map(|r| r.1).fold(0.0f32, f32::max);
            let kept: Vec<(u32, f32)> = row.into_iter().filter(|r| r.1 >= max * 1e-6).collect();
            let sum: f32 = kept.iter().map(|r| r.1).sum();
            kept.into_iter().map(|(t, w)| (t, w / sum)).collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ggx_weights_are_normalised_and_narrow_with_alpha() {
        for alpha in [0.04f32, 0.25, 1.0] {
            let w = ggx_weights(8, alpha);
            assert_eq!(w.len(), 64);
            for row in &w {
                let s: f32 = row.iter().map(|r| r.1).sum();
                assert!((s - 1.0).abs() < 1e-5);
            }
        }
        // the texel's own weight grows as the lobe narrows
        let own = |alpha: f32| {
            let w = ggx_weights(8, alpha);
            w[27].iter().find(|r| r.0 == 27).map_or(0.0, |r| r.1)
        };
        assert!(own(0.04) > own(0.25) && own(0.25) > own(1.0));
    }
}
