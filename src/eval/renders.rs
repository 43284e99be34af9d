//! Rendered views for ꟻLIP, what a player sees at a roughness: a camera looking into the
//! scene from an open validation position with every visible surface shaded as a glossy
//! reflector (each pixel a query: the surface point, the reflected view direction, the
//! bucket's roughness), and spheres of directions (octahedral maps) seen from validation
//! positions. References are the GGX lobes traced from the same points (`trace::truth`)
//! with many samples; each row renders the same pixels through its own lookup.

use super::flip;
use super::methods::Row;
use super::validation::{DOMAIN_EVAL, ValidationSet};
use crate::octa;
use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer, truth};
use crate::warp::glossy::Glossy;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Sizes of the rendered views and their references' samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Camera image width and height in pixels, and how many cameras (from as many of the
    /// most open validation positions: one viewpoint is a small, lucky or unlucky sample of
    /// a level).
    pub camera: (u32, u32),
    #[serde(default = "one_camera")]
    pub cameras: u32,
    /// Horizontal field of view, degrees.
    pub fov_deg: f32,
    /// Side of each sphere-of-directions map, and how many (from as many validation positions).
    pub sphere_res: u32,
    pub spheres: u32,
    /// Lobe samples per reference pixel.
    pub reference_spp: u32,
}

fn one_camera() -> u32 {
    1
}

impl RenderSettings {
    pub const fn standard() -> Self {
        RenderSettings { camera: (96, 60), cameras: 3, fov_deg: 75.0, sphere_res: 48, spheres: 2, reference_spp: 256 }
    }

    pub const fn quick() -> Self {
        RenderSettings { camera: (48, 32), cameras: 1, fov_deg: 75.0, sphere_res: 16, spheres: 1, reference_spp: 16 }
    }
}

/// One pixel: the query it asks (point, unit direction, the oracle's fetch direction), or
/// nothing to shade (the camera sees sky: the same radiance for every row).
#[derive(Clone, Copy, Debug)]
enum Pixel {
    /// `normal`: the surface's, facing the camera (camera views); the query direction for
    /// spheres of directions, which see no surface.
    Query {
        b: Vec3,
        dir: Vec3,
        oracle: Vec3,
        normal: Vec3,
    },
    Background(Vec3),
}

/// A rendered view's pixels, without their radiance.
#[derive(Clone, Debug)]
pub struct View {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pixels: Vec<Pixel>,
    /// A camera on surfaces (not a sphere of directions).
    pub camera: bool,
}

impl View {
    /// Per pixel: the shaded surface point and its normal facing the camera, or the
    /// background radiance (camera views; a sphere of directions has no surfaces).
    #[must_use]
    pub fn surfaces(&self) -> Vec<Result<(Vec3, Vec3), Vec3>> {
        self.pixels
            .iter()
            .map(|p| match *p {
                Pixel::Query { b, normal, .. } => Ok((b, normal)),
                Pixel::Background(c) => Err(c),
            })
            .collect()
    }
}

/// A view at one roughness with its traced reference.
#[derive(Clone, Debug)]
pub struct ViewReference {
    pub view: View,
    pub roughness: f32,
    pub reference: Vec<Vec3>,
    /// Lobe samples per reference pixel.
    pub spp: u32,
    /// Mean ꟻLIP between the references traced from the two halves of the samples: the
    /// references' own noise as ꟻLIP sees it (each half noisier than the whole).
    pub noise_flip: f64,
}

/// The most open of the first 32 validation positions: largest nearest-hit distance over 64
/// directions (a view hugging a column shows mostly that column).
pub fn open_position(tracer: &Tracer, set: &ValidationSet, skip: usize) -> Option<Vec3> {
    let openness = |b: Vec3| {
        (0..64u32)
            .map(|k| uniform_sphere(Sampler::new(5, 0, k).next_2d()))
            .map(|d| tracer.closest_hit(b, d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t))
            .fold(f32::INFINITY, f32::min)
    };
    let mut candidates: Vec<Vec3> = set.positions.iter().take(32).copied().collect();
    candidates.sort_by(|p, q| openness(*q).total_cmp(&openness(*p)));
    candidates.get(skip).copied()
}

/// The views of a scene: the cameras, then the spheres of directions.
pub fn views(scene: &Scene, tracer: &Tracer, set: &ValidationSet, a: Vec3, s: &RenderSettings) -> Vec<View> {
    let mut out = Vec::new();
    for k in 0..s.cameras as usize {
        let Some(eye) = open_position(tracer, set, k) else { break };
        out.push(camera_view(scene, tracer, a, eye, s));
    }
    for k in 0..s.spheres as usize {
        let Some(b) = open_position(tracer, set, k) else { break };
        let n = s.sphere_res;
        let pixels = (0..n * n)
            .map(|t| {
                let dir = octa::texel_dir(n, t % n, t / n);
                Pixel::Query { b, dir, oracle: truth::oracle(scene, tracer, a, b, dir).0, normal: dir }
            })
            .collect();
        out.push(View {
            name: format!("directions from ({:.2}, {:.2}, {:.2})", b.x, b.y, b.z),
            width: n,
            height: n,
            pixels,
            camera: false,
        });
    }
    out
}

/// The camera: at `eye`, looking 20° down along the most open near-horizontal direction.
fn camera_view(scene: &Scene, tracer: &Tracer, a: Vec3, eye: Vec3, s: &RenderSettings) -> View {
    let far = |d: Vec3| tracer.closest_hit(eye, d, f32::INFINITY).map_or(1e30, |h| h.t);
    let look = (0..64u32)
        .map(|k| {
            let phi = k as f32 / 64.0 * std::f32::consts::TAU;
            Vec3::new(libm::cosf(phi), -0.15, libm::sinf(phi)).normalize()
        })
        .max_by(|p, q| far(*p).total_cmp(&far(*q)))
        .unwrap_or(Vec3::Z);
    let horizontal = Vec3::new(look.x, 0.0, look.z).normalize_or(Vec3::Z);
    let forward = (horizontal * libm::cosf(20f32.to_radians()) - Vec3::Y * libm::sinf(20f32.to_radians())).normalize();
    let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let (w, h) = s.camera;
    let half = libm::tanf(s.fov_deg.to_radians() * 0.5);
    let pixels = (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
            let u = (2.0 * x / w as f32 - 1.0) * half;
            let v = (1.0 - 2.0 * y / h as f32) * half * h as f32 / w as f32;
            let ray = (forward + right * u + up * v).normalize();
            match tracer.closest_hit(eye, ray, f32::INFINITY) {
                Some(hit) if !hit.backface || scene.materials[hit.material as usize].two_sided => {
                    let n = if hit.normal.dot(ray) > 0.0 { -hit.normal } else { hit.normal };
                    let b = hit.position + n * tracer.surface_offset(hit.position);
                    let dir = (ray - 2.0 * ray.dot(n) * n).normalize_or(n);
                    Pixel::Query { b, dir, oracle: truth::oracle(scene, tracer, a, b, dir).0, normal: n }
                }
                Some(_) => Pixel::Background(Vec3::ZERO),
                None => Pixel::Background(scene.sky.radiance(ray)),
            }
        })
        .collect();
    View {
        name: format!("camera at ({:.2}, {:.2}, {:.2})", eye.x, eye.y, eye.z),
        width: w,
        height: h,
        pixels,
        camera: true,
    }
}

/// Traces the reference of `view` at roughness `r`: each query pixel's GGX lobe with `spp`
/// samples (streams of their own, per view, bucket and pixel), in two halves whose mean is
/// the reference and whose ꟻLIP against each other measures its noise.
pub fn reference(
    scene: &Scene,
    tracer: &Tracer,
    view: &View,
    r: f32,
    spp: u32,
    (seed, tag, exposure): (u64, u64, f32),
) -> ViewReference {
    let renderer = Renderer::new(scene, tracer);
    let stream = hash_pair(hash_pair(DOMAIN_EVAL, 0x7E57), tag);
    let half = (spp / 2).max(1);
    let halves: Vec<(Vec3, Vec3)> = view
        .pixels
        .par_iter()
        .enumerate()
        .map(|(p, px)| match *px {
            Pixel::Background(c) => (c, c),
            Pixel::Query { b, dir, .. } => {
                lobe_halves(&renderer, (b, dir, r), half, (seed, hash_pair(stream, p as u64)))
            }
        })
        .collect();
    let reference = halves.iter().map(|(a, b)| (*a + *b) * 0.5).collect();
    let (a, b): (Vec<Vec3>, Vec<Vec3>) = halves.into_iter().unzip();
    let noise_flip = flip::mean(&flip::flip_hdr(&a, &b, view.width, view.height, exposure));
    ViewReference { view: view.clone(), roughness: r, reference, spp: 2 * half, noise_flip }
}

/// A pixel's lobe reference (query `(b, dir, r)`) as two independent halves of `half`
/// samples each, drawn from `Sampler::new(seed, stream, k)`: their mean is the reference,
/// their difference its noise.
pub fn lobe_halves(
    renderer: &Renderer,
    (b, dir, r): (Vec3, Vec3, f32),
    half: u32,
    (seed, stream): (u64, u64),
) -> (Vec3, Vec3) {
    let mut rays = 0;
    let mut trace = |first: u32| {
        truth::lobe_reference(renderer, b, dir, r, half, |k| Sampler::new(seed, stream, first + k), &mut rays).radiance
    };
    let a = trace(0);
    (a, trace(half))
}

/// What `row` renders for a view at the reference's roughness.
pub fn render(row: &Row, shading: Glossy, v: &ViewReference) -> Vec<Vec3> {
    v.view
        .pixels
        .par_iter()
        .map(|px| match *px {
            Pixel::Background(c) => c,
            Pixel::Query { b, dir, oracle, .. } => row.estimate(shading, b, dir, oracle, v.roughness),
        })
        .collect()
}

/// ꟻLIP of `image` against the view's reference (see `flip::flip_hdr`).
pub fn flip_map(v: &ViewReference, image: &[Vec3], exposure: f32) -> Vec<f32> {
    flip::flip_hdr(&v.reference, image, v.view.width, v.view.height, exposure)
}

/// Mean ꟻLIP of `row` over the views, weighted by their pixel counts.
pub fn mean_flip(row: &Row, shading: Glossy, views: &[ViewReference], exposure: f32) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for v in views {
        let map = flip_map(v, &render(row, shading, v), exposure);
        sum += flip::mean(&map) * map.len() as f64;
        n += map.len();
    }
    sum / n.max(1) as f64
}
