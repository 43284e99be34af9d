//! The specular probe A: supersampled radiance and texel-centre distance on an octahedral
//! map, a GGX-prefiltered radiance mip chain and an inverse-distance-filtered depth chain.
//!
//! GGX prefiltering follows Karis (2013, "Real Shading in Unreal Engine 4"): N = V = R,
//! importance-sampled half vectors, N·L weights, and the source mip chosen per sample from the
//! sample's pdf (Křivánek & Colbert 2008, "Real-time Shading with Filtered Importance
//! Sampling") to avoid fireflies at low sample counts.

use crate::octa::{self, OctMap, OctMips, build_distance_mips, build_mips, texel_solid_angles};
use crate::progress::Progress;
use crate::sampling::{Sampler, ggx_d, ggx_half_vector, hash_pair};
use crate::trace::Renderer;
use crate::trace::truth::first_visible;
use crate::warp::WarpProbe;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Sampler domains (kept distinct so streams never overlap).
pub const DOMAIN_PROBE_RADIANCE: u64 = 0x5052_4144; // "PRAD"
pub const DOMAIN_PROBE_GGX: u64 = 0x5047_4758; // "PGGX"

/// A baked specular probe.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpecularProbe {
    pub position: Vec3,
    /// GGX-prefiltered radiance; level 0 is the supersampled mirror image.
    pub radiance: OctMips<Vec3>,
    /// Perceptual roughness r of each radiance mip (GGX alpha = r²).
    pub roughness: Vec<f32>,
    /// Distance of each texel-centre ray (+inf on miss) = `depth.levels[0]`.
    pub depth: OctMips<f32>,
}

impl SpecularProbe {
    pub fn resolution(&self) -> u32 {
        self.radiance.levels[0].res
    }
    pub fn distance(&self) -> &OctMap<f32> {
        &self.depth.levels[0]
    }

    /// The probe as the warps read it: inverse-distance and radiance mips.
    pub fn warp_probe(&self) -> WarpProbe {
        WarpProbe::from_distance_mips(self.position, &self.depth, self.radiance.clone(), self.roughness.clone())
    }

    /// Fractional radiance mip for a perceptual roughness (linear in r between mips).
    pub fn lod_for_roughness(&self, r: f32) -> f32 {
        let last = (self.roughness.len() - 1) as f32;
        if !(r > 0.0) || last == 0.0 {
            return 0.0;
        }
        (r.min(1.0) * last).clamp(0.0, last)
    }
}

/// Perceptual roughness of mip `m` of a chain of `levels` mips: r = m / (levels − 1).
pub fn mip_roughness(m: usize, levels: usize) -> f32 {
    if levels <= 1 { 0.0 } else { m as f32 / (levels - 1) as f32 }
}

pub struct ProbeSettings {
    pub position: Vec3,
    pub resolution: u32,
    pub samples_per_texel: u32,
    pub ggx_samples: u32,
    pub min_mip_resolution: u32,
    pub seed: u64,
}

/// Bakes the probe; returns it and the number of rays traced.
pub fn bake_probe(renderer: &Renderer, s: &ProbeSettings, progress: &Progress) -> (SpecularProbe, u64) {
    let n = s.resolution;
    let texels = (n * n) as usize;
    let bar = progress.bar(texels as u64, "probe radiance");
    let rows: Vec<(Vec<Vec3>, Vec<f32>, u64)> = (0..n)
        .into_par_iter()
        .map(|j| {
            let mut rays = 0u64;
            let mut rad = Vec::with_capacity(n as usize);
            let mut dist = Vec::with_capacity(n as usize);
            for i in 0..n {
                let mut sum = Vec3::ZERO;
                for k in 0..s.samples_per_texel {
                    let (mut sampler, d) = texel_sample(s, i, j, k);
                    sum += renderer.sample(s.position, d, &mut sampler, &mut rays).radiance;
                }
                rad.push(sum / s.samples_per_texel as f32);
                // the distance of the texel-centre ray: what it meets first, no shading needed
                let centre = octa::texel_dir(n, i, j).normalize();
                rays += 1;
                dist.push(first_visible(renderer.scene, renderer.tracer, s.position, centre));
            }
            bar.inc(n as u64);
            (rad, dist, rays)
        })
        .collect();
    bar.finish_and_clear();
    let mut rays = 0;
    let mut radiance = Vec::with_capacity(texels);
    let mut distance = Vec::with_capacity(texels);
    for (r, d, k) in rows {
        radiance.extend(r);
        distance.extend(d);
        rays += k;
    }
    let (radiance, roughness) = ggx_chain(OctMap::new(n, radiance), s, progress);
    let depth = build_distance_mips(OctMap::new(n, distance), s.min_mip_resolution);
    let probe = SpecularProbe { position: s.position, radiance, roughness, depth };
    (probe, rays)
}

/// Sample `k` of texel (i, j): its sampler (the jitter drawn) and its direction.
fn texel_sample(s: &ProbeSettings, i: u32, j: u32, k: u32) -> (Sampler, Vec3) {
    let n = s.resolution;
    let stream = hash_pair(DOMAIN_PROBE_RADIANCE, (j * n + i) as u64);
    let mut sampler = Sampler::new(s.seed, stream, k);
    let jitter = sampler.next_2d();
    let uv = (Vec2::new(i as f32, j as f32) + jitter) / n as f32;
    (sampler, octa::decode(uv))
}

/// The probe's mip chain from its mirror image: GGX-prefiltered levels and their perceptual
/// roughness.
fn ggx_chain(base: OctMap<Vec3>, s: &ProbeSettings, progress: &Progress) -> (OctMips<Vec3>, Vec<f32>) {
    let box_chain = build_mips(base.clone(), s.min_mip_resolution);
    let levels = box_chain.levels.len();
    let roughness: Vec<f32> = (0..levels).map(|m| mip_roughness(m, levels)).collect();
    let bar = progress.bar(levels as u64 - 1, "probe GGX mips");
    let mut radiance_levels = vec![base];
    for m in 1..levels {
        let alpha = roughness[m] * roughness[m];
        let res = box_chain.levels[m].res;
        radiance_levels.push(prefilter_ggx(&box_chain, res, alpha, s.ggx_samples, s.seed, m as u64));
        bar.inc(1);
    }
    bar.finish_and_clear();
    (OctMips { levels: radiance_levels }, roughness)
}

/// The part of a probe baked with `s` that its rays received straight from an emitter (a
/// sphere light, an emissive triangle; `Renderer::emitted_along`), as radiance mips
/// prefiltered as the probe's are: each texel's samples are the bake's own rays, so a
/// texel's emitted part never exceeds its radiance where the bake's estimate holds, and a
/// lookup of this chain at the same fetch and mip reads the emitted part of what the same
/// lookup of the probe reads (bilinear reads and prefiltering are linear). The evaluation
/// separates the emitters from its linear errors with it. All zero, with no ray traced,
/// when the scene has no such emitter.
pub fn emitted_mips(renderer: &Renderer, s: &ProbeSettings, progress: &Progress) -> (OctMips<Vec3>, u64) {
    let n = s.resolution;
    let texels = (n * n) as usize;
    if !renderer.has_emitters() {
        return (build_mips(OctMap::new(n, vec![Vec3::ZERO; texels]), s.min_mip_resolution), 0);
    }
    let rows: Vec<(Vec<Vec3>, u64)> = (0..n)
        .into_par_iter()
        .map(|j| {
            let mut rays = 0u64;
            let row = (0..n)
                .map(|i| {
                    let mut sum = Vec3::ZERO;
                    for k in 0..s.samples_per_texel {
                        let (_, d) = texel_sample(s, i, j, k);
                        if let Some(first) = renderer.first_hit(s.position, d, &mut rays) {
                            sum += renderer.emitted_along(&first);
                        }
                    }
                    sum / s.samples_per_texel.max(1) as f32
                })
                .collect();
            (row, rays)
        })
        .collect();
    let mut rays = 0;
    let mut base = Vec::with_capacity(texels);
    for (row, k) in rows {
        base.extend(row);
        rays += k;
    }
    let (mips, _) = ggx_chain(OctMap::new(n, base), s, progress);
    (mips, rays)
}

/// GGX-prefiltered map of resolution `res` from a box mip chain (split-sum, N = V = R).
pub fn prefilter_ggx(
    source: &OctMips<Vec3>,
    res: u32,
    alpha: f32,
    samples: u32,
    seed: u64,
    level: u64,
) -> OctMap<Vec3> {
    let n0 = source.levels[0].res;
    let texel_solid_angle = 4.0 * std::f32::consts::PI / (n0 * n0) as f32;
    let texels: Vec<Vec3> = (0..res * res)
        .into_par_iter()
        .map(|t| {
            let (i, j) = (t % res, t / res);
            let n = octa::texel_dir(res, i, j);
            // One sample pattern for every texel of a level: per-texel rotations would turn the
            // residual variance into sparkles; a shared pattern gives smooth, structured error
            // that filtered importance sampling keeps small.
            let _ = t;
            let stream = hash_pair(DOMAIN_PROBE_GGX, level);
            let mut sum = Vec3::ZERO;
            let mut wsum = 0.0f32;
            for k in 0..samples {
                let mut sampler = Sampler::new(seed, stream, k);
                let h = ggx_half_vector(sampler.next_2d(), n, alpha);
                let nh = n.dot(h).max(0.0);
                let l = 2.0 * nh * h - n;
                let nl = n.dot(l);
                if nl <= 0.0 {
                    continue;
                }
                // pdf(l) = D·(n·h) / (4 (v·h)) with v = n.
                let pdf = ggx_d(nh, alpha) * 0.25;
                let sample_solid_angle = 1.0 / (samples as f32 * pdf.max(1e-8));
                let lod = (0.5 * libm::log2f(sample_solid_angle / texel_solid_angle) + 1.0).max(0.0);
                sum += source.sample_lod(l, lod) * nl;
                wsum += nl;
            }
            if wsum > 0.0 { sum / wsum } else { source.sample_lod(n, 0.0) }
        })
        .collect();
    OctMap::new(res, texels)
}

/// Solid angles of the probe's base texels (exposed for metrics and tests).
pub fn probe_solid_angles(probe: &SpecularProbe) -> Vec<f32> {
    texel_solid_angles(probe.resolution())
}
