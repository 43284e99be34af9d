//! Diffuse lighting judged: irradiance at held-out surface points against traced references.
//!
//! - **References**: points area-uniform on the scene's triangles inside the grid (never
//!   on a fitting set: the fit draws from other streams), offset off the surface along the
//!   side they are seen from, each with its traced irradiance (`truth::irradiance_reference`:
//!   lamps by next-event estimation, the rest `π · L` over cosine-distributed directions)
//!   and its standard error. As the
//!   grid stores it, this is the light probes carry: sky, emitters and light bounced off
//!   surfaces, not the sun's disc itself (engines add direct sun by shadow maps).
//! - **Rows**: the dense grid through each step of DDGI's blend (`runtime::IrradianceBlend`:
//!   nearest cell, trilinear, back-face weight, Chebyshev visibility); the runtime (the
//!   written grid's `irradiance`: that blend with the fitted corrections); probe A alone (its own
//!   radiance convolved with the cosine lobe, one probe for the level); seed 004's voxel GI
//!   (a 3-D texture of the scene at the grid's resolution holding occupancy and outgoing
//!   radiance, sampled one voxel away over a hemisphere of 50 directions).
//! - **ꟻLIP** on the cameras of the specular evaluation with every surface shaded diffuse
//!   (white albedo: the image is E/π), references with the views' sample count.

use super::metrics::{difference_se, error_stats};
use super::timing::best_of_three_ns;
use super::validation::DOMAIN_EVAL;
use crate::octa::{self, OctMap};
use crate::perceptual::View;
use crate::perceptual::flip;
use crate::runtime::IrradianceBlend;
use crate::runtime::IrradianceGrid;
use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::trace::store::{self, ReferenceStore};
use crate::trace::{Renderer, Tracer, truth};
use glam::{UVec3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;

/// Held-out surface points with their traced irradiance.
#[derive(Clone, Debug, Default)]
pub struct DiffuseSet {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub reference: Vec<Vec3>,
    /// Standard error of each reference's luminance.
    pub reference_se: Vec<f32>,
    pub rays: u64,
}

/// `count` held-out surface points inside the grid's bounds (`trace::truth::surface_points`
/// on the evaluation's own streams), with their references of `spp` samples.
pub fn diffuse_set(
    (scene, tracer, store): (&Scene, &Tracer, Option<&ReferenceStore>),
    grid: &IrradianceGrid,
    count: u32,
    spp: u32,
    seed: u64,
) -> DiffuseSet {
    let pts = truth::surface_points(
        scene,
        tracer,
        (grid.geometry.min, grid.geometry.max),
        count,
        (seed, hash_pair(DOMAIN_EVAL, 0xD1F)),
    );
    let renderer = Renderer::new(scene, tracer);
    let trace = || -> Vec<(Vec3, f32, u64)> {
        (0..pts.len())
            .into_par_iter()
            .map(|i| {
                let mut rays = 0;
                let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0xD21), i as u64);
                let (e, se) = truth::irradiance_reference(
                    &renderer,
                    pts[i].0,
                    pts[i].1,
                    spp,
                    |k| Sampler::new(seed, stream, k),
                    &mut rays,
                );
                (e, se, rays)
            })
            .collect()
    };
    let refs = match store {
        Some(store) => {
            let (p, n): (Vec<Vec3>, Vec<Vec3>) = pts.iter().copied().unzip();
            let key = store.key("diffuse-points").vec3s(&p).vec3s(&n).words([u64::from(spp), seed]);
            // per point: E's bits, its standard error's, its rays (two words)
            let to = |v: &Vec<(Vec3, f32, u64)>| -> Vec<u32> {
                v.iter()
                    .flat_map(|(e, se, rays)| {
                        let [x, y, z] = e.to_array().map(f32::to_bits);
                        [x, y, z, se.to_bits(), (rays >> 32) as u32, *rays as u32]
                    })
                    .collect()
            };
            let len = pts.len();
            let from = |w: &[u32]| -> Option<Vec<(Vec3, f32, u64)>> {
                (w.len() == 6 * len).then(|| {
                    w.chunks_exact(6)
                        .map(|c| {
                            let e = Vec3::new(f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2]));
                            (e, f32::from_bits(c[3]), (u64::from(c[4]) << 32) | u64::from(c[5]))
                        })
                        .collect()
                })
            };
            store.cached("diffuse-points", key, (to, from), trace)
        }
        None => trace(),
    };
    let mut set = DiffuseSet::default();
    for ((p, n), (e, se, rays)) in pts.into_iter().zip(refs) {
        set.points.push(p);
        set.normals.push(n);
        set.reference.push(e);
        set.reference_se.push(se);
        set.rays += rays;
    }
    set
}

/// Probe A's own irradiance: its radiance (a mip of at most 64²) convolved with the cosine
/// lobe, on a 16² octahedral map of normals. The one-probe baseline: the same answer
/// anywhere in the level.
pub fn probe_irradiance(radiance: &crate::octa::OctMips<Vec3>) -> OctMap<Vec3> {
    let level = radiance.levels.iter().find(|l| l.res <= 64).or(radiance.levels.last()).expect("a probe has mips");
    let n = level.res;
    let omega = octa::texel_solid_angles(n);
    let texels: Vec<(Vec3, Vec3)> =
        (0..n * n).map(|t| (octa::texel_dir(n, t % n, t / n), level.texels[t as usize] * omega[t as usize])).collect();
    let res = 16u32;
    let out = (0..res * res)
        .into_par_iter()
        .map(|t| {
            let normal = octa::texel_dir(res, t % res, t / res);
            texels.iter().map(|(d, l)| *l * normal.dot(*d).max(0.0)).sum::<Vec3>()
        })
        .collect();
    OctMap::new(res, out)
}

/// Seed 004's 3-D texture: per voxel (one per grid cell), the distance from its centre to
/// the nearest surface in voxel sizes (capped at 2) and the mean outgoing radiance of the
/// surfaces within one voxel size, traced from the centre over 64 directions.
#[derive(Clone, Debug)]
pub struct VoxelGi {
    pub counts: UVec3,
    pub min: Vec3,
    pub size: Vec3,
    pub distance: Vec<f32>,
    pub colour: Vec<Vec3>,
    pub sky: crate::scene::Sky,
}

impl VoxelGi {
    pub fn build(scene: &Scene, tracer: &Tracer, geo: crate::grid::GridGeometry, seed: u64) -> VoxelGi {
        let renderer = Renderer::new(scene, tracer);
        let size = geo.cell_size();
        let voxel = size.max_element();
        let cells: Vec<(f32, Vec3)> = (0..geo.cell_count())
            .into_par_iter()
            .map(|c| {
                let centre = geo.cell_centre(c);
                let (mut nearest, mut sum, mut hits, mut rays) = (f32::INFINITY, Vec3::ZERO, 0u32, 0u64);
                for k in 0..64u32 {
                    let mut s = Sampler::new(seed, hash_pair(hash_pair(DOMAIN_EVAL, 0x40C), c as u64), k);
                    let d = uniform_sphere(s.next_2d());
                    let r = renderer.sample(centre, d, &mut s, &mut rays);
                    nearest = nearest.min(r.distance);
                    if r.distance <= voxel {
                        sum += r.radiance;
                        hits += 1;
                    }
                }
                ((nearest / voxel).min(2.0), if hits > 0 { sum / hits as f32 } else { Vec3::ZERO })
            })
            .collect();
        VoxelGi {
            counts: geo.counts,
            min: geo.min,
            size,
            distance: cells.iter().map(|c| c.0).collect(),
            colour: cells.iter().map(|c| c.1).collect(),
            sky: scene.sky,
        }
    }

    /// Trilinear (distance, colour) at `p` (clamped to the texture).
    fn sample(&self, p: Vec3) -> (f32, Vec3) {
        let f = (p - self.min) / self.size - 0.5;
        let hi = (self.counts - UVec3::ONE).as_vec3();
        let f = if f.is_finite() { f.clamp(Vec3::ZERO, hi) } else { Vec3::ZERO };
        let base = f.floor();
        let frac = f - base;
        let base = base.as_uvec3();
        let (mut d, mut c) = (0.0f32, Vec3::ZERO);
        for corner in 0..8u32 {
            let o = UVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let q = (base + o).min(self.counts - UVec3::ONE);
            let w = (if o.x == 1 { frac.x } else { 1.0 - frac.x })
                * (if o.y == 1 { frac.y } else { 1.0 - frac.y })
                * (if o.z == 1 { frac.z } else { 1.0 - frac.z });
            let k = (q.x + self.counts.x * (q.y + self.counts.y * q.z)) as usize;
            d += self.distance[k] * w;
            c += self.colour[k] * w;
        }
        (d, c)
    }

    /// Irradiance at `p` around unit `n`, as seed 004 gathers it: 50 directions leaning
    /// from the normal up to 4π/10 in 10 steps, 5 around it (Rodrigues rotations), each
    /// sampling the texture one voxel away; the voxel's colour is mixed towards the
    /// environment by the squared distance to the nearest surface there (the seed's
    /// `mix(color, env, clamp(dist², 0, 1))`); the samples are cosine-weighted into E.
    #[must_use]
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        let Some(n) = octa::unit_direction(n) else { return Vec3::ZERO };
        let rod = |a: Vec3, b: Vec3, t: f32| {
            let (s, c) = (libm::sinf(t), libm::cosf(t));
            (a * c + b.cross(a) * s + b * b.dot(a) * (1.0 - c)).normalize_or(a)
        };
        let t = n.cross(n + Vec3::new(n.z, n.x, n.y)).normalize_or(n.any_orthonormal_vector());
        let step = self.size.max_element();
        let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
        for i in 0..10 {
            let mut r = rod(n, t, i as f32 * 0.125_664);
            for _ in 0..5 {
                let (d, c) = self.sample(p + r * step);
                let l = c.lerp(self.sky.radiance(r), (d * d).clamp(0.0, 1.0));
                let w = r.dot(n).max(0.0);
                sum += l * w;
                wsum += w;
                r = rod(r, n, 1.256_64);
            }
        }
        if wsum > 0.0 { sum * (PI / wsum) } else { Vec3::ZERO }
    }
}

/// One diffuse method.
#[derive(Clone, Copy)]
pub enum DiffuseMethod<'a> {
    Grid(&'a IrradianceGrid, IrradianceBlend),
    /// What the runtime answers: the DDGI blend times the cell's fitted correction.
    Runtime(&'a IrradianceGrid),
    ProbeA(&'a OctMap<Vec3>),
    Voxel(&'a VoxelGi),
}

impl DiffuseMethod<'_> {
    pub fn name(&self) -> String {
        match self {
            DiffuseMethod::Grid(_, b) => format!("grid: {}", b.name()),
            DiffuseMethod::Runtime(_) => "runtime: DDGI + fitted bias and corrections".into(),
            DiffuseMethod::ProbeA(_) => "probe A alone".into(),
            DiffuseMethod::Voxel(_) => "voxel GI (seed 004)".into(),
        }
    }

    /// The diffuse figure's label of the row, if it shows it (trilinear, DDGI, the runtime).
    fn figure_label(&self) -> Option<&'static str> {
        match self {
            DiffuseMethod::Grid(_, IrradianceBlend::Trilinear) => Some("trilinear"),
            DiffuseMethod::Grid(_, IrradianceBlend::Chebyshev) => Some("DDGI blend"),
            DiffuseMethod::Runtime(_) => Some("runtime (corrected)"),
            _ => None,
        }
    }

    #[inline]
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        match self {
            DiffuseMethod::Grid(g, b) => g.irradiance_blend(p, n, *b),
            DiffuseMethod::Runtime(g) => g.irradiance(p, n),
            DiffuseMethod::ProbeA(map) => octa::unit_direction(n).map_or(Vec3::ZERO, |n| map.bilinear(n)),
            DiffuseMethod::Voxel(v) => v.irradiance(p, n),
        }
    }
}

/// One row of the diffuse table.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DiffuseRow {
    pub name: String,
    pub rel_rmse: f64,
    pub tm_rmse: f64,
    pub mae: f64,
    pub p95: f64,
    /// Mean ꟻLIP of the diffuse-shaded cameras.
    pub flip: Option<f64>,
    pub ns_per_lookup: f64,
}

/// The diffuse evaluation (eval.json's `diffuse`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DiffuseReport {
    pub points: usize,
    pub reference_spp: u32,
    /// RMS standard error of one reference's luminance over the mean reference.
    pub reference_se_rel: f64,
    pub rows: Vec<DiffuseRow>,
    /// The best row against the next best by tone-mapped RMSE, their difference and the
    /// standard error the references put on it (rel, tm).
    pub claim: (String, String),
    pub difference_tm: f64,
    pub reference_se_tm: f64,
    pub reference_ok: bool,
    pub view_pixels: usize,
    pub view_reference_spp: u32,
    pub view_noise_flip: f64,
}

/// Diffuse references of the camera views: E per surface pixel (background as is), in two
/// halves of `spp` samples, and the ꟻLIP between the halves.
fn view_references(
    (scene, tracer, store): (&Scene, &Tracer, Option<&ReferenceStore>),
    views: &[View],
    spp: u32,
    seed: u64,
    exposure: f32,
) -> Vec<(Vec<Vec3>, f64)> {
    view_halves((scene, tracer, store), views, spp, seed)
        .into_iter()
        .zip(views)
        .map(|(px, view)| {
            let (a, b): (Vec<Vec3>, Vec<Vec3>) = px.iter().copied().unzip();
            let noise = flip::mean(&flip::flip_hdr(&a, &b, view.width, view.height, exposure));
            (px.iter().map(|(a, b)| (*a + *b) * 0.5).collect(), noise)
        })
        .collect()
}

/// Each camera view's diffuse reference at white albedo (E/π per surface pixel, the
/// background as is), as two halves of `spp` samples whose mean is the reference.
pub fn view_halves(
    (scene, tracer, store): (&Scene, &Tracer, Option<&ReferenceStore>),
    views: &[View],
    spp: u32,
    seed: u64,
) -> Vec<Vec<(Vec3, Vec3)>> {
    let renderer = Renderer::new(scene, tracer);
    views
        .iter()
        .enumerate()
        .map(|(v, view)| {
            let half = (spp / 2).max(1);
            let surfaces = view.surfaces();
            let trace = || -> Vec<(Vec3, Vec3)> {
                surfaces
                    .par_iter()
                    .enumerate()
                    .map(|(k, s)| match *s {
                        Ok((b, n)) => {
                            let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0xD22 + v as u64), k as u64);
                            let mut rays = 0;
                            let a = truth::irradiance_reference(
                                &renderer,
                                b,
                                n,
                                half,
                                |j| Sampler::new(seed, stream, j),
                                &mut rays,
                            )
                            .0;
                            let c = truth::irradiance_reference(
                                &renderer,
                                b,
                                n,
                                half,
                                |j| Sampler::new(seed, stream, j + half),
                                &mut rays,
                            )
                            .0;
                            (a / PI, c / PI)
                        }
                        Err(bg) => (bg, bg),
                    })
                    .collect()
            };
            match store {
                Some(store) => {
                    let (b, n): (Vec<Vec3>, Vec<Vec3>) =
                        surfaces.iter().map(|s| s.map_or_else(|bg| (bg, Vec3::ZERO), |x| x)).unzip();
                    let key = store.key("diffuse-view").vec3s(&b).vec3s(&n).words([u64::from(spp), seed, v as u64]);
                    let len = surfaces.len();
                    let codec = (|h: &Vec<_>| store::pairs_to_words(h), |w: &[u32]| store::pairs_from_words(w, len));
                    store.cached("diffuse-view", key, codec, trace)
                }
                None => trace(),
            }
        })
        .collect()
}

/// Evaluates `methods` on `set` and on the diffuse-shaded camera `views`; also returns the
/// first camera's figure (reference and every grid row with its ꟻLIP map).
pub fn evaluate(
    (scene, tracer, store): (&Scene, &Tracer, Option<&ReferenceStore>),
    set: &DiffuseSet,
    methods: &[DiffuseMethod],
    views: &[View],
    (view_spp, seed, exposure): (u32, u64, f32),
) -> (DiffuseReport, Option<super::FlipFigure>) {
    let cameras: Vec<&View> = views.iter().filter(|v| v.camera).collect();
    let cams: Vec<View> = cameras.iter().map(|v| (*v).clone()).collect();
    let refs = view_references((scene, tracer, store), &cams, view_spp, seed, exposure);
    let mut rows = Vec::new();
    let mut estimates = Vec::new();
    // the figure shows the camera of most contrast (variance of the reference's log
    // luminance): light and shadow side by side, where a grid has the most to get wrong
    let contrast = |k: usize| {
        let logs: Vec<f64> = refs[k].0.iter().map(|e| libm::log(crate::tonemap::luminance(*e) as f64 + 1e-3)).collect();
        let n = logs.len().max(1) as f64;
        let mean = logs.iter().sum::<f64>() / n;
        logs.iter().map(|l| (l - mean) * (l - mean)).sum::<f64>() / n
    };
    let shown = (0..cams.len()).max_by(|&a, &b| contrast(a).total_cmp(&contrast(b)));
    // each camera's reference side of ꟻLIP, found once for every row
    let flip_refs: Vec<flip::FlipReference> = cams
        .iter()
        .zip(&refs)
        .map(|(v, (reference, _))| flip::FlipReference::new(reference, v.width, v.height, exposure))
        .collect();
    let mut figure = shown.map(|k| (&cams[k], &refs[k])).map(|(v, (reference, _))| super::FlipFigure {
        roughness: 1.0,
        diffuse: true,
        surface: None,
        view: v.name.clone(),
        width: v.width,
        height: v.height,
        reference: reference.clone(),
        tiles: Vec::new(),
    });
    for m in methods {
        let est: Vec<Vec3> =
            (0..set.points.len()).into_par_iter().map(|k| m.irradiance(set.points[k], set.normals[k])).collect();
        let st = error_stats(&est, &set.reference, exposure);
        let n = set.points.len().min(4096);
        let ns = best_of_three_ns(n, || {
            let mut acc = Vec3::ZERO;
            for k in 0..n {
                acc += std::hint::black_box(m.irradiance(set.points[k], set.normals[k]));
            }
            std::hint::black_box(acc);
        });
        let flip = (!cams.is_empty()).then(|| {
            let (mut sum, mut px) = (0.0, 0usize);
            for (i, (view, flip_ref)) in cams.iter().zip(&flip_refs).enumerate() {
                let img: Vec<Vec3> = view
                    .surfaces()
                    .par_iter()
                    .map(|s| match *s {
                        Ok((b, n)) => m.irradiance(b, n) / PI,
                        Err(bg) => bg,
                    })
                    .collect();
                let map = flip_ref.error_map(&img);
                sum += flip::mean(&map) * map.len() as f64;
                px += map.len();
                if let (Some(f), Some(label)) = (figure.as_mut().filter(|_| Some(i) == shown), m.figure_label()) {
                    let mean = flip::mean(&map);
                    f.tiles.push((label.into(), img, map, mean));
                }
            }
            sum / px.max(1) as f64
        });
        rows.push(DiffuseRow {
            name: m.name(),
            rel_rmse: st.rel_rmse,
            tm_rmse: st.tm_rmse,
            mae: st.mae,
            p95: st.p95,
            flip,
            ns_per_lookup: ns,
        });
        estimates.push(est);
    }
    // the claim: the best row against the runner-up, with the references' noise on it
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| rows[a].tm_rmse.total_cmp(&rows[b].tm_rmse));
    let (best, next) = (order.first().copied().unwrap_or(0), order.get(1).copied().unwrap_or(0));
    let (_, se_tm) = if rows.len() > 1 {
        difference_se(&estimates[best], &estimates[next], &set.reference, &set.reference_se, exposure)
    } else {
        (0.0, 0.0)
    };
    let difference_tm = rows.get(next).map_or(0.0, |r| r.tm_rmse) - rows.get(best).map_or(0.0, |r| r.tm_rmse);
    let mean_ref = set.reference.iter().map(|e| crate::tonemap::luminance(*e) as f64).sum::<f64>()
        / set.reference.len().max(1) as f64;
    let se_rel = (set.reference_se.iter().map(|s| (*s as f64).powi(2)).sum::<f64>()
        / set.reference_se.len().max(1) as f64)
        .sqrt()
        / mean_ref.max(1e-30);
    let report = DiffuseReport {
        points: set.points.len(),
        reference_spp: 0,
        reference_se_rel: se_rel,
        claim: (
            rows.get(best).map(|r| r.name.clone()).unwrap_or_default(),
            rows.get(next).map(|r| r.name.clone()).unwrap_or_default(),
        ),
        difference_tm,
        reference_se_tm: se_tm,
        reference_ok: se_tm <= difference_tm.abs() / 4.0,
        view_pixels: cams.iter().map(|v| (v.width * v.height) as usize).sum(),
        view_reference_spp: view_spp,
        view_noise_flip: refs.iter().zip(&cams).map(|((_, n), v)| n * (v.width * v.height) as f64).sum::<f64>()
            / cams.iter().map(|v| (v.width * v.height) as f64).sum::<f64>().max(1.0),
        rows,
    };
    (report, figure)
}
