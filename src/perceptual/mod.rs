//! What a player sees, judged perceptually: rendered views of a scene (a camera looking into
//! it with every visible surface shaded as a glossy reflector, each pixel a query: the
//! surface point, the reflected view direction, a roughness; and spheres of directions,
//! octahedral maps seen from a point), their GGX references traced with many samples
//! (`trace::truth`), and ꟻLIP ([`flip`]) between a rendering and its reference. The
//! evaluation judges every method with it, and the fit chooses the roughness correction's
//! rows with it (`fit::roughness`).

pub mod flip;

use crate::octa;
use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::trace::truth::{self, Oracle};
use crate::trace::{Renderer, Tracer};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Sizes of the rendered views and their references' samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Camera image width and height in pixels, and how many cameras (from as many of the
    /// most open of the given positions: one viewpoint is a small, lucky or unlucky sample
    /// of a level).
    pub camera: (u32, u32),
    #[serde(default = "one_camera")]
    pub cameras: u32,
    /// Horizontal field of view, degrees.
    pub fov_deg: f32,
    /// Side of each sphere-of-directions map, and how many (from as many positions).
    pub sphere_res: u32,
    pub spheres: u32,
    /// Lobe samples per reference pixel.
    pub reference_spp: u32,
    /// With several specular probes: one more camera at the position nearest each of the
    /// first this many probes after probe A (the most open positions of a level of rooms
    /// may all lie where probe A sees, and the picture would never show a room it does not).
    #[serde(default)]
    pub probe_cameras: u32,
}

fn one_camera() -> u32 {
    1
}

impl RenderSettings {
    pub const fn standard() -> Self {
        RenderSettings {
            camera: (96, 60),
            cameras: 3,
            fov_deg: 75.0,
            sphere_res: 48,
            spheres: 2,
            reference_spp: 256,
            probe_cameras: 3,
        }
    }

    pub const fn quick() -> Self {
        RenderSettings {
            camera: (48, 32),
            cameras: 1,
            fov_deg: 75.0,
            sphere_res: 16,
            spheres: 1,
            reference_spp: 16,
            probe_cameras: 0,
        }
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
        oracle: Oracle,
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
    /// `reference`'s side of every ꟻLIP against it, at the exposure it was traced for
    /// ([`flip_map`] uses it when asked at that exposure).
    pub flip: flip::FlipReference,
}

/// The most open of the first 32 of `positions`: largest nearest-hit distance over 64
/// directions (a view hugging a column shows mostly that column).
pub fn open_position(tracer: &Tracer, positions: &[Vec3], skip: usize) -> Option<Vec3> {
    let openness = |b: Vec3| {
        (0..64u32)
            .map(|k| uniform_sphere(Sampler::new(5, 0, k).next_2d()))
            .map(|d| tracer.closest_hit(b, d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t))
            .fold(f32::INFINITY, f32::min)
    };
    let mut candidates: Vec<Vec3> = positions.iter().take(32).copied().collect();
    candidates.sort_by(|p, q| openness(*q).total_cmp(&openness(*p)));
    candidates.get(skip).copied()
}

/// The views of a scene from the most open of `positions` (the probes at `probes`, probe A
/// first, for the pixels' oracle fetches): the cameras, then the spheres of directions.
pub fn views(scene: &Scene, tracer: &Tracer, positions: &[Vec3], probes: &[Vec3], s: &RenderSettings) -> Vec<View> {
    let mut out = Vec::new();
    for k in 0..s.cameras as usize {
        let Some(eye) = open_position(tracer, positions, k) else { break };
        out.push(camera_view(scene, tracer, probes, eye, s));
    }
    // several probes: a camera where each of the first placed probes stands (the position
    // of `positions` nearest it), so the picture covers what probe A does not see
    for &p in probes.iter().skip(1).take(s.probe_cameras as usize) {
        let near = |q: &Vec3| (*q - p).length_squared();
        let Some(&eye) = positions.iter().min_by(|a, b| near(a).total_cmp(&near(b))) else { break };
        out.push(camera_view(scene, tracer, probes, eye, s));
    }
    for k in 0..s.spheres as usize {
        let Some(b) = open_position(tracer, positions, k) else { break };
        let n = s.sphere_res;
        let pixels = (0..n * n)
            .map(|t| {
                let dir = octa::texel_dir(n, t % n, t / n);
                Pixel::Query { b, dir, oracle: truth::oracles(scene, tracer, probes, b, dir).0, normal: dir }
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
fn camera_view(scene: &Scene, tracer: &Tracer, probes: &[Vec3], eye: Vec3, s: &RenderSettings) -> View {
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
                    Pixel::Query { b, dir, oracle: truth::oracles(scene, tracer, probes, b, dir).0, normal: n }
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
/// samples (pixel p drawing from the stream `hash_pair(stream, p)`: the caller gives each
/// view and roughness a stream of its own), in two halves whose mean is the reference and
/// whose ꟻLIP against each other measures its noise.
pub fn reference(
    scene: &Scene,
    tracer: &Tracer,
    view: &View,
    r: f32,
    spp: u32,
    (seed, stream, exposure): (u64, u64, f32),
) -> ViewReference {
    let renderer = Renderer::new(scene, tracer);
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
    let reference: Vec<Vec3> = halves.iter().map(|(a, b)| (*a + *b) * 0.5).collect();
    let (a, b): (Vec<Vec3>, Vec<Vec3>) = halves.into_iter().unzip();
    let noise_flip = flip::mean(&flip::flip_hdr(&a, &b, view.width, view.height, exposure));
    let flip = flip::FlipReference::new(&reference, view.width, view.height, exposure);
    ViewReference { view: view.clone(), roughness: r, reference, spp: 2 * half, noise_flip, flip }
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

/// What a lookup renders for a view: `estimate(b, dir, oracle)` per query pixel (the
/// surface point, the unit reflected direction, the oracle's fetch direction into probe A),
/// the background's radiance elsewhere.
pub fn render(v: &ViewReference, estimate: impl Fn(Vec3, Vec3, Oracle) -> Vec3 + Sync) -> Vec<Vec3> {
    v.view
        .pixels
        .par_iter()
        .map(|px| match *px {
            Pixel::Background(c) => c,
            Pixel::Query { b, dir, oracle, .. } => estimate(b, dir, oracle),
        })
        .collect()
}

/// ꟻLIP of `image` against the view's reference (see `flip::flip_hdr`).
#[must_use]
pub fn flip_map(v: &ViewReference, image: &[Vec3], exposure: f32) -> Vec<f32> {
    if v.flip.exposure() == exposure {
        v.flip.error_map(image)
    } else {
        flip::flip_hdr(&v.reference, image, v.view.width, v.view.height, exposure)
    }
}

/// Mean ꟻLIP over the views, weighted by their pixel counts, of what `estimate` renders
/// (called with the view's roughness and the pixel's point, direction and oracle fetch).
pub fn mean_flip(
    views: &[ViewReference],
    exposure: f32,
    estimate: impl Fn(f32, Vec3, Vec3, Oracle) -> Vec3 + Sync,
) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for v in views {
        let map = flip_map(v, &render(v, |b, dir, oracle| estimate(v.roughness, b, dir, oracle)), exposure);
        sum += flip::mean(&map) * map.len() as f64;
        n += map.len();
    }
    sum / n.max(1) as f64
}

/// The ꟻLIP maps of what `estimate` renders for each view (as [`mean_flip`] calls it),
/// as [`tiles`] of `tile` × `tile` pixels, view after view.
pub fn flip_tiles(
    views: &[ViewReference],
    exposure: f32,
    tile: u32,
    estimate: impl Fn(f32, Vec3, Vec3, Oracle) -> Vec3 + Sync,
) -> Vec<Tile> {
    views
        .iter()
        .flat_map(|v| {
            let image = render(v, |b, dir, oracle| estimate(v.roughness, b, dir, oracle));
            tiles(&flip_map(v, &image, exposure), v.view.width, tile)
        })
        .collect()
}

/// One tile of an error map: its mean and its pixel count.
pub type Tile = (f64, usize);

/// The means of a `width`-wide error map over `tile × tile` pixel tiles (row-major; edge
/// tiles partial), each with its pixel count.
#[must_use]
pub fn tiles(map: &[f32], width: u32, tile: u32) -> Vec<Tile> {
    let (w, t) = (width.max(1) as usize, tile.max(1) as usize);
    let h = map.len() / w;
    let (tw, th) = (w.div_ceil(t), h.div_ceil(t));
    let mut sums = vec![(0.0f64, 0usize); tw * th];
    for (p, &e) in map.iter().take(w * h).enumerate() {
        let cell = &mut sums[(p / w / t) * tw + (p % w) / t];
        cell.0 += e as f64;
        cell.1 += 1;
    }
    sums.into_iter().map(|(s, n)| (s / n.max(1) as f64, n)).collect()
}

/// Mean over tiles weighted by their pixels: the map's mean.
#[must_use]
pub fn weighted_mean(tiles: &[Tile]) -> f64 {
    let n: usize = tiles.iter().map(|t| t.1).sum();
    tiles.iter().map(|&(m, k)| m * k as f64).sum::<f64>() / n.max(1) as f64
}

/// Standard error of the pixel-weighted mean of the tile-wise differences `a − b` (the same
/// tiles of two renderings): tiles, not pixels, are the samples, since neighbouring pixels'
/// errors are not independent. 0 for identical maps; infinite with fewer than two tiles.
#[must_use]
pub fn paired_standard_error(a: &[Tile], b: &[Tile]) -> f64 {
    let d: Vec<(f64, usize)> = a.iter().zip(b).map(|(x, y)| (x.0 - y.0, x.1)).collect();
    let n: usize = d.iter().map(|t| t.1).sum();
    if d.len() < 2 || n == 0 {
        return f64::INFINITY;
    }
    let mean = weighted_mean(&d);
    // weighted variance of the tile differences, and the effective number of tiles
    let var = d.iter().map(|&(x, k)| k as f64 * (x - mean).powi(2)).sum::<f64>() / n as f64;
    let n_eff = (n as f64).powi(2) / d.iter().map(|&(_, k)| (k as f64).powi(2)).sum::<f64>();
    (var / (n_eff - 1.0).max(1.0)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_every_pixel_once_and_keep_the_mean() {
        // 10 × 7 pixels in tiles of 4: 3 × 2 tiles, the edge ones partial
        let map: Vec<f32> = (0..70).map(|p| (p % 13) as f32 / 13.0).collect();
        let t = tiles(&map, 10, 4);
        assert_eq!(t.len(), 6);
        assert_eq!(t.iter().map(|x| x.1).sum::<usize>(), 70);
        assert_eq!(t.iter().map(|x| x.1).collect::<Vec<_>>(), [16, 16, 8, 12, 12, 6]);
        let mean = map.iter().map(|&x| x as f64).sum::<f64>() / 70.0;
        assert!((weighted_mean(&t) - mean).abs() < 1e-12);
    }

    #[test]
    fn paired_error_is_zero_for_a_constant_shift_and_grows_with_scatter() {
        let a = [(0.3, 64), (0.5, 64), (0.2, 64), (0.4, 64)];
        let shifted: Vec<(f64, usize)> = a.iter().map(|&(m, n)| (m + 0.1, n)).collect();
        assert!(paired_standard_error(&shifted, &a) < 1e-12);
        let scattered = [(0.5, 64), (0.5, 64), (0.2, 64), (0.5, 64)];
        let se = paired_standard_error(&scattered, &a);
        // differences 0.2, 0, 0, 0.1: sd 0.0829, over √3
        assert!((se - 0.082_915_6 / 3f64.sqrt()).abs() < 1e-6, "{se}");
        assert_eq!(paired_standard_error(&a[..1], &a[..1]), f64::INFINITY);
    }
}
