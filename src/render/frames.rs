//! `warpfit render`: frames of a level drawn through the exported shader ([`Rasteriser`]),
//! each beside its traced reference, box projection (the 2012 method, probe A through the
//! box proxy) and the same pixels drawn by the CPU sampler, judged with ꟻLIP; PNG strips,
//! `render.json` and `render.md` in `<out>/render/`.
//!
//! Cameras: the scene's `[[cameras]]`, else placed as the evaluation places its own
//! (`perceptual::cameras`: open positions, aimed at geometry, ≥ 80% of the pixels on
//! surfaces). Specular frames shade every surface as a glossy reflector of one roughness;
//! diffuse frames as a diffuse one (irradiance × the material's base colour / π; textures
//! are not drawn).

use super::{Camera, Frame, Rasteriser, RenderError, Shading, gpu::Gpu};
use crate::eval::{diffuse, validation};
use crate::files::FileError;
use crate::perceptual::{self, CameraPose, RenderSettings, flip};
use crate::runtime::FittedGrid;
use crate::sampling::hash_pair;
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::Method;
use crate::warp::glossy::{MipRule, glossy_radiance};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What `warpfit render` draws.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width and height in pixels, and the horizontal field of view (degrees).
    pub size: (u32, u32),
    pub fov_deg: f32,
    /// Cameras placed when the scene sets none.
    pub cameras: u32,
    /// The roughness of each specular frame.
    pub roughness: Vec<f32>,
    /// A diffuse frame per camera as well.
    pub diffuse: bool,
    /// Samples per reference pixel.
    pub spp: u32,
    pub seed: u64,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            size: (320, 200),
            fov_deg: 75.0,
            cameras: 2,
            roughness: vec![0.0, 0.5],
            diffuse: true,
            spp: 64,
            seed: 1,
        }
    }
}

/// ꟻLIP of one frame's images against its reference.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameFlips {
    /// Drawn through the exported shader.
    pub shader: f64,
    /// The same pixels drawn by the CPU sampler (`FittedGrid`).
    pub cpu: f64,
    /// Probe A through the box proxy (specular frames).
    pub box_projection: Option<f64>,
    /// The reference's own noise: ꟻLIP between the halves of its samples.
    pub reference_noise: f64,
}

/// How closely the shader's frame equals the CPU-drawn one.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Agreement {
    /// Pixels both show a shaded surface in.
    pub pixels: usize,
    /// Of those, the share whose radiance agrees within 1e-3 (relative, values below 1e-3
    /// of the frame's mean compared against that floor): the f16 texels' bound.
    pub within_bound: f64,
    /// The largest relative difference of any such pixel.
    pub worst: f32,
}

/// One frame's record in `render.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameRecord {
    pub camera: usize,
    pub eye: [f32; 3],
    pub forward: [f32; 3],
    /// "specular" or "diffuse".
    pub shading: String,
    pub roughness: Option<f32>,
    /// Share of the pixels showing a surface.
    pub coverage: f64,
    pub flip: FrameFlips,
    pub agreement: Agreement,
    /// The PNG strip: reference | shader | box projection (or the CPU-drawn frame, diffuse)
    /// | the shader's ꟻLIP map.
    pub image: String,
}

/// `render.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RenderReport {
    pub scene: String,
    pub adapter: String,
    pub size: (u32, u32),
    pub fov_deg: f32,
    pub spp: u32,
    pub frames: Vec<FrameRecord>,
    pub seconds: f64,
}

/// Why `warpfit render` stopped.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    File(#[from] FileError),
}

/// The cameras frames are drawn from: the scene's own, else `opts.cameras` placed among
/// random open positions of the grid as the evaluation places its cameras.
#[must_use]
pub fn cameras(scene: &Scene, tracer: &Tracer, grid: &FittedGrid, opts: &RenderOptions) -> Vec<Camera> {
    let geometry = &grid.irradiance_grid().geometry;
    let all: Vec<usize> = (0..geometry.cell_count()).collect();
    let positions = validation::positions(scene, tracer, (geometry, &all), 64, opts.seed);
    let settings = settings(opts);
    perceptual::cameras(scene, tracer, &positions, &grid.warp().probe_positions(), &settings)
        .into_iter()
        .map(|pose| Camera { pose, fov_deg: opts.fov_deg, size: opts.size })
        .collect()
}

fn settings(opts: &RenderOptions) -> RenderSettings {
    RenderSettings {
        camera: opts.size,
        cameras: opts.cameras,
        fov_deg: opts.fov_deg,
        reference_spp: opts.spp,
        probe_cameras: 0,
        ..RenderSettings::quick()
    }
}

/// Draws every camera's frames through the export in `export_dir` and writes them with
/// their references and ꟻLIP into `out` (`render.json`, `render.md`, one PNG per frame).
pub fn render(
    (scene, tracer): (&Scene, &Tracer),
    grid: &FittedGrid,
    export_dir: &Path,
    out: &Path,
    opts: &RenderOptions,
) -> Result<RenderReport, FramesError> {
    let t0 = std::time::Instant::now();
    let gpu = Gpu::new()?;
    let raster = Rasteriser::new(&gpu, export_dir, scene, tracer)?;
    std::fs::create_dir_all(out).map_err(|source| FileError::Io { path: out.to_path_buf(), source })?;
    let exposure = grid.warp().probe.key_exposure();
    let mut frames = Vec::new();
    for (c, camera) in cameras(scene, tracer, grid, opts).iter().enumerate() {
        let view =
            perceptual::camera_view(scene, tracer, &grid.warp().probe_positions(), &camera.pose, &settings(opts));
        let mut shadings: Vec<Shading> = opts.roughness.iter().map(|&r| Shading::Specular(r)).collect();
        if opts.diffuse {
            shadings.push(Shading::Diffuse);
        }
        for (k, &shading) in shadings.iter().enumerate() {
            let drawn = raster.draw(scene, camera, shading);
            let judged = judge((scene, tracer), grid, &view, camera, shading, &drawn, (opts, exposure, c, k));
            let name = match shading {
                Shading::Specular(r) => format!("frame_c{c}_r{r}.png"),
                Shading::Diffuse => format!("frame_c{c}_diffuse.png"),
            };
            write_strip(&out.join(&name), &judged, &drawn, exposure)?;
            frames.push(FrameRecord {
                camera: c,
                eye: camera.pose.eye.to_array(),
                forward: camera.pose.forward.to_array(),
                shading: if shading == Shading::Diffuse { "diffuse" } else { "specular" }.to_string(),
                roughness: match shading {
                    Shading::Specular(r) => Some(r),
                    Shading::Diffuse => None,
                },
                coverage: view.coverage(),
                flip: judged.flips,
                agreement: judged.agreement,
                image: name,
            });
        }
    }
    let report = RenderReport {
        scene: scene.name.clone(),
        adapter: format!("{} ({:?})", gpu.adapter.name, gpu.adapter.backend),
        size: opts.size,
        fov_deg: opts.fov_deg,
        spp: opts.spp,
        frames,
        seconds: t0.elapsed().as_secs_f64(),
    };
    crate::files::write_json(&out.join("render.json"), &report)?;
    crate::files::write_atomic(&out.join("render.md"), markdown(&report).as_bytes())?;
    Ok(report)
}

/// A frame's images and figures.
struct Judged {
    reference: Vec<Vec3>,
    /// Box projection (specular) or the CPU-drawn frame (diffuse).
    beside: Vec<Vec3>,
    flip_map: Vec<f32>,
    flips: FrameFlips,
    agreement: Agreement,
}

/// The frame's reference (traced), the CPU-drawn frame and box projection, and their ꟻLIP.
fn judge(
    (scene, tracer): (&Scene, &Tracer),
    grid: &FittedGrid,
    view: &perceptual::View,
    camera: &Camera,
    shading: Shading,
    drawn: &Frame,
    (opts, exposure, c, k): (&RenderOptions, f32, usize, usize),
) -> Judged {
    let (w, h) = (view.width, view.height);
    let surfaces = view.surfaces();
    let (reference, noise, cpu, box_projection) = match shading {
        Shading::Specular(r) => {
            let stream = hash_pair(hash_pair(0x5EED_F4A3, c as u64), k as u64);
            let v = perceptual::reference(scene, tracer, view, r, opts.spp, (opts.seed, stream, exposure));
            let cpu = perceptual::render(&v, |b, dir, _| grid.specular(b, dir, r));
            let warp = grid.warp();
            let boxed = perceptual::render(&v, |b, dir, _| {
                glossy_radiance(warp, None, MipRule::Plain, b, dir, warp.fetch_vector(Method::Box, b, dir).into(), r)
            });
            (v.reference, v.noise_flip, cpu, Some(boxed))
        }
        Shading::Diffuse => {
            let albedo = albedos(scene, tracer, &camera.pose, camera.fov_deg, camera.size);
            let halves = diffuse::view_halves((scene, tracer, None), std::slice::from_ref(view), opts.spp, opts.seed)
                .pop()
                .unwrap_or_default();
            let tinted = |pick: fn(&(Vec3, Vec3)) -> Vec3| -> Vec<Vec3> {
                halves
                    .iter()
                    .zip(&surfaces)
                    .zip(&albedo)
                    .map(|((p, s), a)| if s.is_ok() { pick(p) * *a } else { pick(p) })
                    .collect()
            };
            let (a, b) = (tinted(|p| p.0), tinted(|p| p.1));
            let noise = flip::mean(&flip::flip_hdr(&a, &b, w, h, exposure));
            let reference = a.iter().zip(&b).map(|(a, b)| (*a + *b) * 0.5).collect();
            let cpu = surfaces
                .par_iter()
                .zip(&albedo)
                .map(|(s, a)| match *s {
                    Ok((b, n)) => grid.irradiance(b, n) * *a * std::f32::consts::FRAC_1_PI,
                    Err(bg) => bg,
                })
                .collect();
            (reference, noise, cpu, None)
        }
    };
    let flip_of = |img: &[Vec3]| flip::flip_hdr(&reference, img, w, h, exposure);
    let flip_map = flip_of(&drawn.radiance);
    let flips = FrameFlips {
        shader: flip::mean(&flip_map),
        cpu: flip::mean(&flip_of(&cpu)),
        box_projection: box_projection.as_ref().map(|b| flip::mean(&flip_of(b))),
        reference_noise: noise,
    };
    let agreement = agreement(drawn, &cpu, &surfaces);
    Judged { beside: box_projection.unwrap_or(cpu), reference, flip_map, flips, agreement }
}

/// Each pixel's material base colour where the camera sees a surface (white elsewhere).
fn albedos(scene: &Scene, tracer: &Tracer, pose: &CameraPose, fov_deg: f32, size: (u32, u32)) -> Vec<Vec3> {
    pose.rays(fov_deg, size)
        .par_iter()
        .map(|&ray| {
            tracer
                .closest_hit(pose.eye, ray, f32::INFINITY)
                .map_or(Vec3::ONE, |hit| scene.materials[hit.material as usize].albedo)
        })
        .collect()
}

/// The shader's frame against the CPU-drawn one on the pixels both shade.
fn agreement(drawn: &Frame, cpu: &[Vec3], surfaces: &[Result<(Vec3, Vec3), Vec3>]) -> Agreement {
    let both: Vec<usize> =
        (0..cpu.len()).filter(|&p| surfaces[p].is_ok() && drawn.points.get(p).is_some_and(Option::is_some)).collect();
    let mean = both.iter().map(|&p| cpu[p].max_element()).sum::<f32>() / both.len().max(1) as f32;
    let floor = (1e-3 * mean).max(f32::MIN_POSITIVE);
    let rel: Vec<f32> = both
        .iter()
        .map(|&p| (drawn.radiance[p] - cpu[p]).abs().max_element() / cpu[p].max_element().max(floor))
        .collect();
    let within = rel.iter().filter(|&&r| r <= 1e-3).count();
    Agreement {
        pixels: both.len(),
        within_bound: within as f64 / both.len().max(1) as f64,
        worst: rel.iter().copied().fold(0.0, f32::max),
    }
}

/// reference | shader | box projection or CPU | ꟻLIP map, tone-mapped side by side.
fn write_strip(path: &Path, j: &Judged, drawn: &Frame, exposure: f32) -> Result<(), FileError> {
    let (w, h) = (drawn.width as usize, drawn.height as usize);
    let tiles = [
        crate::tonemap::to_srgb8(&j.reference, exposure),
        crate::tonemap::to_srgb8(&drawn.radiance, exposure),
        crate::tonemap::to_srgb8(&j.beside, exposure),
        flip::magma(&j.flip_map, drawn.width, drawn.height),
    ];
    let gap = 4;
    let width = tiles.len() * w + (tiles.len() - 1) * gap;
    let mut rgb = vec![255u8; width * h * 3];
    for (t, tile) in tiles.iter().enumerate() {
        for y in 0..h {
            let dst = (y * width + t * (w + gap)) * 3;
            rgb[dst..dst + w * 3].copy_from_slice(&tile[y * w * 3..(y + 1) * w * 3]);
        }
    }
    crate::preview::write_png(path, width as u32, h as u32, &rgb)
}

/// `render.md`: one row per frame.
#[must_use]
pub fn markdown(r: &RenderReport) -> String {
    let mut s = format!(
        "# Frames drawn through the exported shader: {}\n\n{}×{} pixels, {}° horizontal, references of {} samples per pixel, on {}, in {:.1} s.\nEach PNG: reference | shader | box projection (diffuse: the CPU-drawn frame) | the shader's ꟻLIP map.\n\n| camera | shading | coverage | ꟻLIP shader | ꟻLIP CPU | ꟻLIP box | reference noise | pixels equal to the CPU's (1e-3) | worst | image |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|---|\n",
        r.scene, r.size.0, r.size.1, r.fov_deg, r.spp, r.adapter, r.seconds
    );
    for f in &r.frames {
        let shading = match f.roughness {
            Some(x) => format!("specular r = {x}"),
            None => "diffuse".to_string(),
        };
        s += &format!(
            "| {} | {} | {:.2} | {:.4} | {:.4} | {} | {:.4} | {:.2}% of {} | {:.1e} | {} |\n",
            f.camera,
            shading,
            f.coverage,
            f.flip.shader,
            f.flip.cpu,
            f.flip.box_projection.map_or("–".to_string(), |b| format!("{b:.4}")),
            f.flip.reference_noise,
            100.0 * f.agreement.within_bound,
            f.agreement.pixels,
            f.agreement.worst,
            f.image
        );
    }
    s
}

/// Where `warpfit render` writes into a run folder.
#[must_use]
pub fn folder(run: &Path) -> PathBuf {
    run.join("render")
}
