//! Surface reflections judged (seed 003): for each `[[surface_probes]]` patch of the scene,
//! its baked atlas against the volume methods on held-out points of that surface.
//!
//! - **Queries**: points area-uniform on the patch (near the grid, not inside
//!   geometry, a small offset off the surface), each with cosine-distributed reflection
//!   directions about the surface normal (a floor seen by cameras at every angle), on the
//!   evaluation's own streams; per roughness bucket the same queries with GGX lobe
//!   references (`trace::truth::lobe_reference`), whose own noise is reported.
//! - **Rows**: the seed's atlas lookup (four probes, each bilinear in its tile), the atlas
//!   with each probe warped by its own depth, probe A through the seed methods (plain mips,
//!   as engines read a probe) and the fitted grid through the runtime.
//! - **ꟻLIP** on a camera looking across the patch from above one of its edges, the patch
//!   shaded as a glossy reflector and everything else as the primary ray sees it (the same in
//!   every image); the mean is taken over the patch's pixels.

use super::methods::Row;
use super::metrics::error_stats;
use super::timing::best_of_three_ns;
use super::validation::DOMAIN_EVAL;
use super::{EvalSettings, FlipFigure, ROUGHNESS_BUCKETS};
use crate::perceptual::flip;
use crate::sampling::{Sampler, cosine_hemisphere, hash_pair};
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer, truth};
use crate::warp::glossy::Glossy;
use crate::warp::surface::SurfaceAtlas;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One method of the surface table.
#[derive(Clone, Copy)]
pub enum SurfaceMethod<'a> {
    /// The seed's lookup.
    Atlas(&'a SurfaceAtlas),
    /// The atlas, each probe warped by its own depth.
    AtlasWarped(&'a SurfaceAtlas),
    /// Probe A (or the fitted grid) as the main table reads it.
    Volume(Row<'a>),
}

impl SurfaceMethod<'_> {
    #[must_use]
    pub fn name(&self) -> String {
        match self {
            SurfaceMethod::Atlas(_) => "surface atlas (seed 003)".into(),
            SurfaceMethod::AtlasWarped(_) => "surface atlas + warp1 per probe".into(),
            SurfaceMethod::Volume(row) => row.name(),
        }
    }

    #[inline]
    fn radiance(&self, shading: Glossy, b: Vec3, dir: Vec3, r: f32) -> Vec3 {
        match self {
            SurfaceMethod::Atlas(a) => a.radiance(b, dir, r),
            SurfaceMethod::AtlasWarped(a) => a.radiance_warped(b, dir, r),
            // the oracle direction is not used by the rows listed here
            SurfaceMethod::Volume(row) => row.estimate(shading, b, dir, crate::trace::truth::Oracle::plain(dir), r),
        }
    }
}

/// One row of the surface table at one roughness.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SurfaceRow {
    pub name: String,
    pub roughness: f32,
    pub rel_rmse: f64,
    pub tm_rmse: f64,
    pub mae: f64,
    pub p95: f64,
    /// Mean ꟻLIP over the patch's pixels of the camera view.
    pub flip: Option<f64>,
    pub ns_per_lookup: f64,
}

/// One roughness bucket of the surface evaluation: its references and their noise.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SurfaceBucket {
    pub roughness: f32,
    pub lookups: usize,
    pub reference_spp: u32,
    /// RMS standard error of one reference's luminance over the mean reference.
    pub query_se_rel: f64,
    /// Patch pixels of the camera view, its references' samples, and the ꟻLIP between the
    /// two halves of those samples (the references' own noise).
    pub view_pixels: usize,
    pub view_reference_spp: u32,
    pub view_noise_flip: f64,
}

/// The evaluation of one surface-probe patch (eval.json's `surface`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SurfaceReport {
    /// Index of the `[[surface_probes]]` entry.
    pub index: usize,
    pub counts: [u32; 2],
    pub resolution: u32,
    /// The atlas in engine layout (RGBA16F, every mip), and what baking it took.
    pub bytes: u64,
    pub bake_seconds: f64,
    pub bake_rays: u64,
    pub points: usize,
    pub dirs_per_point: usize,
    /// Where the camera stands.
    pub camera: Option<[f32; 3]>,
    pub rows: Vec<SurfaceRow>,
    pub buckets: Vec<SurfaceBucket>,
}

/// Held-out queries on the patch: positions (off the surface) and directions, position-major.
#[derive(Clone, Debug, Default)]
pub struct SurfaceQueries {
    pub positions: Vec<Vec3>,
    pub dirs: Vec<Vec3>,
    pub dirs_per_position: usize,
}

impl SurfaceQueries {
    #[must_use]
    pub fn position_of(&self, k: usize) -> Vec3 {
        self.positions[k / self.dirs_per_position.max(1)]
    }
}

/// `count` points area-uniform on the atlas's patch inside `bounds` (the grid's, grown by a
/// cell) and not inside geometry,
/// `dirs` cosine-distributed reflection directions each.
#[must_use]
pub fn surface_queries(
    scene: &Scene,
    tracer: &Tracer,
    atlas: &SurfaceAtlas,
    bounds: (Vec3, Vec3),
    (count, dirs): (u32, u32),
    (seed, index): (u64, u64),
) -> SurfaceQueries {
    let p = &atlas.patch;
    let n = atlas.normal();
    let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0x5F0), index);
    let threshold = scene.config.grid.inside_backface_fraction;
    let attempt = |a: u32| -> Option<Vec3> {
        let st = Sampler::new(seed, stream, a).next_2d();
        let x = p.corner + p.edge_u * st.x + p.edge_v * st.y;
        if !(x.cmpge(bounds.0).all() && x.cmple(bounds.1).all()) {
            return None;
        }
        let b = x + n * tracer.surface_offset(x);
        let inside_stream = hash_pair(stream, 0x1D ^ (a as u64 + 1));
        (!truth::is_inside(scene, tracer, b, threshold, |j| Sampler::new(seed, inside_stream, j))).then_some(b)
    };
    let positions = truth::first_successes(count, count.saturating_mul(64), attempt);
    let dir_stream = hash_pair(stream, 0xD1);
    let mut q = SurfaceQueries { dirs_per_position: dirs as usize, ..Default::default() };
    for (k, &b) in positions.iter().enumerate() {
        for d in 0..dirs {
            let u = Sampler::new(seed, dir_stream, k as u32 * dirs + d).next_2d();
            q.dirs.push(cosine_hemisphere(u, n));
        }
        q.positions.push(b);
    }
    q
}

/// The camera view across the patch: per pixel the query (point off the patch, reflected
/// direction) or the radiance the primary ray sees elsewhere.
#[derive(Clone, Debug)]
pub struct PatchView {
    pub eye: Vec3,
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Result<(Vec3, Vec3), Vec3>>,
}

impl PatchView {
    fn patch_pixels(&self) -> usize {
        self.pixels.iter().filter(|p| p.is_ok()).count()
    }
}

/// A camera above the middle of one of the patch's edges (inset by a tenth), at a tenth of
/// the patch's longer side above it, looking at the patch's centre: the candidate edge whose
/// view shows the most of the patch. `None` when no candidate sees it.
#[must_use]
pub fn patch_view(
    scene: &Scene,
    tracer: &Tracer,
    atlas: &SurfaceAtlas,
    (width, height, fov_deg): (u32, u32, f32),
    (seed, index): (u64, u64),
) -> Option<PatchView> {
    let p = &atlas.patch;
    let n = atlas.normal();
    let lift = 0.1 * p.edge_u.length().max(p.edge_v.length());
    let target = p.corner + (p.edge_u + p.edge_v) * 0.5;
    let threshold = scene.config.grid.inside_backface_fraction;
    let renderer = Renderer::new(scene, tracer);
    let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0x5F3), index);
    let render = |eye: Vec3, shade: bool| -> PatchView {
        let forward = (target - eye).normalize_or(-n);
        let right = forward.cross(n).normalize_or(p.edge_u.normalize_or(Vec3::X));
        let up = right.cross(forward);
        let half = libm::tanf(fov_deg.to_radians() * 0.5);
        let pixels = (0..width * height)
            .into_par_iter()
            .map(|k| {
                let (x, y) = ((k % width) as f32 + 0.5, (k / width) as f32 + 0.5);
                let u = (2.0 * x / width as f32 - 1.0) * half;
                let v = (1.0 - 2.0 * y / height as f32) * half * height as f32 / width as f32;
                let ray = (forward + right * u + up * v).normalize();
                let hit = tracer.closest_hit(eye, ray, f32::INFINITY);
                if let Some(h) = hit {
                    let (s, t) = atlas.surface_coordinates(h.position);
                    let on_plane = (h.position - p.corner).dot(n).abs() <= 16.0 * tracer.surface_offset(h.position);
                    if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) && on_plane && ray.dot(n) < 0.0 {
                        let b = h.position + n * tracer.surface_offset(h.position);
                        return Ok((b, (ray - 2.0 * ray.dot(n) * n).normalize_or(n)));
                    }
                }
                if !shade {
                    return Err(Vec3::ZERO);
                }
                // elsewhere: what the primary ray sees, the same in every image
                // (traced once, shaded with 16 samples)
                let mut rays = 0;
                let mut sum = Vec3::ZERO;
                if let Some(first) = renderer.first_hit(eye, ray, &mut rays) {
                    for j in 0..16 {
                        let mut s = Sampler::new(seed, hash_pair(stream, k as u64), j);
                        sum += renderer.sample_after(&first, &mut s, &mut rays).0.radiance;
                    }
                }
                Err(sum / 16.0)
            })
            .collect();
        PatchView { eye, width, height, pixels }
    };
    let candidates = [(0.5f32, 0.1f32), (0.5, 0.9), (0.1, 0.5), (0.9, 0.5)];
    let eyes = candidates
        .iter()
        .map(|&(s, t)| p.corner + p.edge_u * s + p.edge_v * t + n * lift)
        .filter(|&e| !truth::is_inside(scene, tracer, e, threshold, |j| Sampler::new(seed, stream, j)));
    let best = eyes
        .map(|e| (e, render(e, false).patch_pixels()))
        .fold(None, |best: Option<(Vec3, usize)>, c| if best.is_none_or(|b| c.1 > b.1) { Some(c) } else { best })?;
    (best.1 > 0).then(|| render(best.0, true))
}

/// The patch view's reference at roughness `r` in two halves of `spp` lobe samples: their
/// mean, and the ꟻLIP between them over the patch's pixels.
fn view_reference(
    renderer: &Renderer,
    view: &PatchView,
    r: f32,
    spp: u32,
    (seed, tag, exposure): (u64, u64, f32),
) -> (Vec<Vec3>, f64) {
    let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0x5F4), tag);
    let half = (spp / 2).max(1);
    let halves: Vec<(Vec3, Vec3)> = view
        .pixels
        .par_iter()
        .enumerate()
        .map(|(k, px)| match *px {
            Err(c) => (c, c),
            Ok((b, dir)) => {
                crate::perceptual::lobe_halves(renderer, (b, dir, r), half, (seed, hash_pair(stream, k as u64)))
            }
        })
        .collect();
    let (a, b): (Vec<Vec3>, Vec<Vec3>) = halves.iter().copied().unzip();
    let noise = patch_mean(view, &flip::flip_hdr(&a, &b, view.width, view.height, exposure));
    (halves.iter().map(|(a, b)| (*a + *b) * 0.5).collect(), noise)
}

/// Mean of a per-pixel map over the patch's pixels.
fn patch_mean(view: &PatchView, map: &[f32]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (px, &m) in view.pixels.iter().zip(map) {
        if px.is_ok() {
            sum += m as f64;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// What to judge and how: the atlas with its bake figures, the patch's index, the methods.
pub struct SurfaceSubject<'a> {
    pub atlas: &'a SurfaceAtlas,
    pub index: usize,
    pub bake: (f64, u64),
    pub methods: &'a [SurfaceMethod<'a>],
}

/// Evaluates the methods on the patch's held-out queries and camera at every roughness
/// bucket (only the mirror bucket when the settings have no rough buckets). Also returns the
/// camera figures at roughness 0 and 0.5.
#[must_use]
pub fn evaluate(
    scene: &Scene,
    tracer: &Tracer,
    subject: &SurfaceSubject,
    shading: Glossy,
    (settings, bounds, exposure): (&EvalSettings, (Vec3, Vec3), f32),
) -> (SurfaceReport, Vec<FlipFigure>) {
    let SurfaceSubject { atlas, index, bake, methods } = *subject;
    let seed = settings.seed;
    let renderer = Renderer::new(scene, tracer);
    let size = (settings.surface_points, settings.surface_dirs);
    let queries = surface_queries(scene, tracer, atlas, bounds, size, (seed, index as u64));
    let view = settings
        .renders
        .and_then(|rs| patch_view(scene, tracer, atlas, (rs.camera.0, rs.camera.1, rs.fov_deg), (seed, index as u64)));
    // no held-out point on the patch (inside geometry, or away from the grid): nothing to
    // judge, rather than rows of zeros
    let rough = settings.rough_positions > 0 && settings.rough_dirs > 0;
    let mut rows = Vec::new();
    let mut buckets = Vec::new();
    let mut figures = Vec::new();
    let judged = if queries.dirs.is_empty() { &[][..] } else { &ROUGHNESS_BUCKETS[..] };
    for (bucket, &r) in judged.iter().enumerate().filter(|(_, r)| **r == 0.0 || rough) {
        let spp = if r == 0.0 { settings.reference_spp } else { settings.rough_reference_spp };
        let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0x5F2), (index * 16 + bucket) as u64);
        let refs: Vec<truth::Reference> = (0..queries.dirs.len())
            .into_par_iter()
            .map(|k| {
                let mut rays = 0;
                let b = queries.position_of(k);
                let sampler = |j| Sampler::new(seed, hash_pair(stream, k as u64), j);
                truth::lobe_reference(&renderer, b, queries.dirs[k], r, spp, sampler, &mut rays)
            })
            .collect();
        let reference: Vec<Vec3> = refs.iter().map(|x| x.radiance).collect();
        let view_ref = match (&view, settings.renders) {
            (Some(v), Some(rs)) => {
                Some(view_reference(&renderer, v, r, rs.reference_spp, (seed, (index * 16 + bucket) as u64, exposure)))
            }
            _ => None,
        };
        let mut figure =
            view_ref.as_ref().filter(|_| r == 0.0 || r == 0.5).zip(view.as_ref()).map(|((reference, _), v)| {
                FlipFigure {
                    roughness: r,
                    diffuse: false,
                    surface: Some(index),
                    view: String::new(),
                    width: v.width,
                    height: v.height,
                    reference: reference.clone(),
                    tiles: Vec::new(),
                }
            });
        // the view reference's side of ꟻLIP, found once for every row
        let flip_ref = view_ref
            .as_ref()
            .zip(view.as_ref())
            .map(|((reference, _), v)| flip::FlipReference::new(reference, v.width, v.height, exposure));
        for m in methods {
            let est: Vec<Vec3> = (0..queries.dirs.len())
                .into_par_iter()
                .map(|k| m.radiance(shading, queries.position_of(k), queries.dirs[k], r))
                .collect();
            let st = error_stats(&est, &reference, exposure);
            let n = queries.dirs.len().min(settings.timing_lookups as usize / 4).max(1).min(queries.dirs.len());
            let ns = best_of_three_ns(n, || {
                let mut acc = Vec3::ZERO;
                for k in 0..n {
                    acc += std::hint::black_box(m.radiance(shading, queries.position_of(k), queries.dirs[k], r));
                }
                std::hint::black_box(acc);
            });
            let flip = flip_ref.as_ref().zip(view.as_ref()).map(|(flip_ref, v)| {
                let image: Vec<Vec3> = v
                    .pixels
                    .par_iter()
                    .map(|px| match *px {
                        Ok((b, dir)) => m.radiance(shading, b, dir, r),
                        Err(c) => c,
                    })
                    .collect();
                let map = flip_ref.error_map(&image);
                let mean = patch_mean(v, &map);
                if let Some(f) = figure.as_mut() {
                    f.tiles.push((m.name(), image, map, mean));
                }
                mean
            });
            rows.push(SurfaceRow {
                name: m.name(),
                roughness: r,
                rel_rmse: st.rel_rmse,
                tm_rmse: st.tm_rmse,
                mae: st.mae,
                p95: st.p95,
                flip,
                ns_per_lookup: ns,
            });
        }
        let mean_ref =
            reference.iter().map(|c| crate::tonemap::luminance(*c) as f64).sum::<f64>() / reference.len().max(1) as f64;
        let se2 = refs.iter().map(|x| (x.se as f64).powi(2)).sum::<f64>() / refs.len().max(1) as f64;
        buckets.push(SurfaceBucket {
            roughness: r,
            lookups: reference.len(),
            reference_spp: spp,
            query_se_rel: se2.sqrt() / mean_ref.max(1e-30),
            view_pixels: view.as_ref().map_or(0, PatchView::patch_pixels),
            view_reference_spp: settings.renders.map_or(0, |rs| 2 * (rs.reference_spp / 2).max(1)),
            view_noise_flip: view_ref.as_ref().map_or(0.0, |v| v.1),
        });
        figures.extend(figure);
    }
    let report = SurfaceReport {
        index,
        counts: atlas.patch.counts,
        resolution: atlas.patch.resolution,
        bytes: atlas.bytes(),
        bake_seconds: bake.0,
        bake_rays: bake.1,
        points: queries.positions.len(),
        dirs_per_point: queries.dirs_per_position,
        camera: view.as_ref().map(|v| v.eye.to_array()),
        rows,
        buckets,
    };
    (report, figures)
}
