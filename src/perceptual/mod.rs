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
    /// Its pixels.
    #[must_use]
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    /// Whether it has no pixels.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// Every pixel's query point and direction (the background's: zero), what its
    /// reference is traced for.
    #[must_use]
    pub fn queries(&self) -> (Vec<Vec3>, Vec<Vec3>) {
        self.pixels
            .iter()
            .map(|p| match *p {
                Pixel::Query { b, dir, .. } => (b, dir),
                Pixel::Background(c) => (c, Vec3::ZERO),
            })
            .unzip()
    }

    /// Share of the pixels that see geometry (a front face, or either face of a two-sided
    /// material): the rest show sky or a back face, the same for every row.
    #[must_use]
    pub fn coverage(&self) -> f64 {
        let seen = self.pixels.iter().filter(|p| matches!(p, Pixel::Query { .. })).count();
        seen as f64 / self.pixels.len().max(1) as f64
    }

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
    /// The mean of the first half of the samples (the reference is the mean of both): the
    /// halves' difference is the reference's own noise.
    pub half: Vec<Vec3>,
}

impl ViewReference {
    /// The mean of the second half of the samples.
    #[must_use]
    pub fn other_half(&self) -> Vec<Vec3> {
        self.reference.iter().zip(&self.half).map(|(r, a)| *r * 2.0 - *a).collect()
    }
}

/// Where a camera stands and where it looks (unit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    pub eye: Vec3,
    pub forward: Vec3,
}

impl CameraPose {
    /// The unit ray through the centre of each pixel of a `size` image (row-major, row 0
    /// at the top) with horizontal field of view `fov_deg`: what the CPU-drawn views trace.
    #[must_use]
    pub fn rays(&self, fov_deg: f32, size: (u32, u32)) -> Vec<Vec3> {
        let frame = Frame::new(self, fov_deg, size);
        (0..size.0 * size.1).map(|p| frame.ray(p)).collect()
    }

    /// World to clip space for a rasteriser drawing the pixels [`CameraPose::rays`] traces:
    /// right-handed, depth 1 at distance `near` and 0 at infinity (reverse Z), clip y up
    /// (row 0 at the top).
    #[must_use]
    pub fn view_projection(&self, fov_deg: f32, size: (u32, u32), near: f32) -> glam::Mat4 {
        use glam::{Mat4, Vec4};
        let frame = Frame::new(self, fov_deg, size);
        let (w, h) = (size.0 as f32, size.1 as f32);
        let projection = Mat4::from_cols(
            Vec4::new(1.0 / frame.half, 0.0, 0.0, 0.0),
            Vec4::new(0.0, w / (frame.half * h), 0.0, 0.0),
            Vec4::new(0.0, 0.0, 0.0, -1.0),
            Vec4::new(0.0, 0.0, near, 0.0),
        );
        // world to camera: right, up and backward as the rows, the eye at the origin
        let (r, u, b) = (frame.right, frame.up, -frame.forward);
        let view = Mat4::from_cols(
            Vec4::new(r.x, u.x, b.x, 0.0),
            Vec4::new(r.y, u.y, b.y, 0.0),
            Vec4::new(r.z, u.z, b.z, 0.0),
            Vec4::new(-r.dot(self.eye), -u.dot(self.eye), -b.dot(self.eye), 1.0),
        );
        projection * view
    }
}

/// Share of a camera's pixels that must see geometry (a front face or a two-sided surface)
/// for the evaluation to place it: a view of sky or back faces judges nothing.
pub const MIN_COVERAGE: f64 = 0.8;

/// Positions a camera may stand at: the first this many of the given ones.
const EYE_CANDIDATES: usize = 64;

/// How closely a camera is judged before it is placed: a preview of this many pixels.
const PREVIEW: (u32, u32) = (16, 10);

/// Headings tried around each eye, and the pitches (degrees below the horizon) in the
/// order they are preferred: 20° shows floors and far walls alike.
const HEADINGS: u32 = 24;
const PITCHES_DEG: [f32; 3] = [20.0, 5.0, 40.0];

/// Largest nearest-hit distance over 64 directions: how open a position is (a view hugging
/// a column shows mostly that column).
fn openness(tracer: &Tracer, b: Vec3) -> f32 {
    (0..64u32)
        .map(|k| uniform_sphere(Sampler::new(5, 0, k).next_2d()))
        .map(|d| tracer.closest_hit(b, d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t))
        .fold(f32::INFINITY, f32::min)
}

/// The most open of the first 32 of `positions`, after `skip` more open ones.
pub fn open_position(tracer: &Tracer, positions: &[Vec3], skip: usize) -> Option<Vec3> {
    let mut candidates: Vec<(f32, Vec3)> = positions.iter().take(32).map(|&p| (openness(tracer, p), p)).collect();
    candidates.sort_by(|p, q| q.0.total_cmp(&p.0));
    candidates.get(skip).map(|c| c.1)
}

/// A camera's image plane: its rays through the pixel centres of a `w` × `h` image.
struct Frame {
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Tangent of half the horizontal field of view.
    half: f32,
    size: (u32, u32),
}

impl Frame {
    /// +Y up; a camera looking straight up or down turns its right to +X.
    fn new(pose: &CameraPose, fov_deg: f32, size: (u32, u32)) -> Frame {
        let right = pose.forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let half = libm::tanf(fov_deg.to_radians() * 0.5);
        Frame { forward: pose.forward, right, up: right.cross(pose.forward), half, size }
    }

    /// The unit ray through the centre of pixel `p` (row-major).
    fn ray(&self, p: u32) -> Vec3 {
        let (w, h) = self.size;
        let (x, y) = ((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
        let u = (2.0 * x / w as f32 - 1.0) * self.half;
        let v = (1.0 - 2.0 * y / h as f32) * self.half * h as f32 / w as f32;
        (self.forward + self.right * u + self.up * v).normalize()
    }
}

/// What a camera ray sees: the geometry it hits (a front face, or either face of a
/// two-sided material), or `None` (sky or a back face).
fn seen(scene: &Scene, tracer: &Tracer, eye: Vec3, ray: Vec3) -> Option<crate::trace::Hit> {
    tracer
        .closest_hit(eye, ray, f32::INFINITY)
        .filter(|hit| !hit.backface || scene.materials[hit.material as usize].two_sided)
}

/// How a camera at `eye` looks: of `HEADINGS` headings at each of `PITCHES_DEG`, the
/// one whose `PREVIEW` sees the most geometry; among equals, the preferred pitch, then
/// the deepest view (largest mean distance to what it sees). Returns the pose and its
/// preview's coverage.
pub fn aim_camera(scene: &Scene, tracer: &Tracer, eye: Vec3, fov_deg: f32) -> (CameraPose, f64) {
    let (w, h) = PREVIEW;
    // (pose, pixels seeing geometry, pitch index, mean depth)
    let mut best: Option<(CameraPose, u32, usize, f32)> = None;
    for (i, pitch) in PITCHES_DEG.into_iter().enumerate() {
        let (cp, sp) = (libm::cosf(pitch.to_radians()), libm::sinf(pitch.to_radians()));
        for k in 0..HEADINGS {
            let phi = k as f32 / HEADINGS as f32 * std::f32::consts::TAU;
            let pose = CameraPose { eye, forward: Vec3::new(libm::cosf(phi) * cp, -sp, libm::sinf(phi) * cp) };
            let frame = Frame::new(&pose, fov_deg, PREVIEW);
            let (mut hits, mut depth) = (0u32, 0.0f32);
            for p in 0..w * h {
                if let Some(hit) = seen(scene, tracer, eye, frame.ray(p)) {
                    hits += 1;
                    depth += hit.t;
                }
            }
            let depth = depth / hits.max(1) as f32;
            // more coverage wins; then the preferred pitch (tried first), then depth
            let better = best.is_none_or(|(_, bh, bi, bd)| hits > bh || (hits == bh && i == bi && depth > bd));
            if better {
                best = Some((pose, hits, i, depth));
            }
        }
    }
    let (pose, hits, ..) = best.unwrap_or((CameraPose { eye, forward: Vec3::Z }, 0, 0, 0.0));
    (pose, f64::from(hits) / f64::from(w * h))
}

/// The cameras of a scene: the scene's own `[[cameras]]` when it sets any, all of them;
/// else `s.cameras` placed among the more open half of the first `EYE_CANDIDATES` of
/// `positions`, each aimed by [`aim_camera`] and kept only if it sees geometry in
/// [`MIN_COVERAGE`] of its image (the most open such position first, then each the farthest from those chosen, so the
/// cameras cover different parts of the level; if none qualifies, the one that sees most),
/// then one at the position nearest each of the first `s.probe_cameras` probes after probe
/// A that qualifies (the most open positions of a level of rooms may all lie where probe A
/// sees, and the picture would never show a room it does not).
pub fn cameras(
    scene: &Scene,
    tracer: &Tracer,
    positions: &[Vec3],
    probes: &[Vec3],
    s: &RenderSettings,
) -> Vec<CameraPose> {
    if !scene.config.cameras.is_empty() {
        return scene
            .config
            .cameras
            .iter()
            .map(|c| {
                let eye = Vec3::from_array(c.position);
                CameraPose { eye, forward: (Vec3::from_array(c.look_at) - eye).normalize_or(Vec3::Z) }
            })
            .collect();
    }
    let candidates: Vec<Vec3> = positions.iter().take(EYE_CANDIDATES).copied().collect();
    let open: Vec<f32> = candidates.par_iter().map(|&p| openness(tracer, p)).collect();
    // the open half of the candidates is aimed (a camera in a corner or on the floor sees
    // the level as no player does); the rest only if none of those qualifies
    let mut by_openness: Vec<f32> = open.clone();
    by_openness.sort_by(f32::total_cmp);
    let median = by_openness.get(by_openness.len() / 2).copied().unwrap_or(0.0);
    let aim_half = |open_half: bool| -> Vec<Option<(CameraPose, f64)>> {
        (0..candidates.len())
            .into_par_iter()
            .map(|k| {
                let wanted = s.cameras > 0 && (open[k] >= median) == open_half;
                wanted.then(|| aim_camera(scene, tracer, candidates[k], s.fov_deg))
            })
            .collect()
    };
    let mut aimed = aim_half(true);
    let coverage_of = |a: &[Option<(CameraPose, f64)>], k: usize| a[k].map_or(-1.0, |x| x.1);
    let mut qualified: Vec<usize> = (0..aimed.len()).filter(|&k| coverage_of(&aimed, k) >= MIN_COVERAGE).collect();
    if qualified.is_empty() && s.cameras > 0 {
        let rest = aim_half(false);
        aimed = aimed.into_iter().zip(rest).map(|(a, b)| a.or(b)).collect();
        let best = (0..aimed.len())
            .filter(|&k| aimed[k].is_some())
            .max_by(|&a, &b| coverage_of(&aimed, a).total_cmp(&coverage_of(&aimed, b)).then(b.cmp(&a)));
        qualified.extend(best);
    }
    let pose_of = |k: usize| aimed[k].map_or(CameraPose { eye: candidates[k], forward: Vec3::Z }, |a| a.0);
    let mut chosen: Vec<usize> = Vec::new();
    while chosen.len() < s.cameras as usize {
        // the most open first, then the farthest from the cameras so far (ties: the lower
        // index)
        let score = |k: usize| {
            if chosen.is_empty() {
                open[k]
            } else {
                chosen.iter().map(|&c| (candidates[c] - candidates[k]).length()).fold(f32::INFINITY, f32::min)
            }
        };
        let next = qualified
            .iter()
            .copied()
            .filter(|k| !chosen.contains(k))
            .max_by(|&a, &b| score(a).total_cmp(&score(b)).then(b.cmp(&a)));
        let Some(next) = next else { break };
        // the preview judged it; the full image decides
        if coverage(scene, tracer, &pose_of(next), s) >= MIN_COVERAGE || qualified.len() == 1 {
            chosen.push(next);
        } else {
            qualified.retain(|&k| k != next);
        }
    }
    let mut out: Vec<CameraPose> = chosen.iter().map(|&k| pose_of(k)).collect();
    for &p in probes.iter().skip(1).take(s.probe_cameras as usize) {
        let mut near: Vec<Vec3> = positions.to_vec();
        near.sort_by(|a, b| (*a - p).length_squared().total_cmp(&(*b - p).length_squared()));
        let pose = near
            .iter()
            .take(16)
            .map(|&eye| aim_camera(scene, tracer, eye, s.fov_deg))
            .find(|a| a.1 >= MIN_COVERAGE && coverage(scene, tracer, &a.0, s) >= MIN_COVERAGE)
            .map(|a| a.0);
        out.extend(pose);
    }
    out
}

/// Share of the pixels of `pose`'s image (`s.camera`) that see geometry (as
/// [`View::coverage`] counts them).
fn coverage(scene: &Scene, tracer: &Tracer, pose: &CameraPose, s: &RenderSettings) -> f64 {
    let (w, h) = s.camera;
    let frame = Frame::new(pose, s.fov_deg, s.camera);
    let hits = (0..w * h).into_par_iter().filter(|&p| seen(scene, tracer, pose.eye, frame.ray(p)).is_some()).count();
    hits as f64 / f64::from((w * h).max(1))
}

/// The views of a scene: its [`cameras`] (the probes at `probes`, probe A first, for the
/// pixels' oracle fetches), then the spheres of directions from the most open of
/// `positions`.
pub fn views(scene: &Scene, tracer: &Tracer, positions: &[Vec3], probes: &[Vec3], s: &RenderSettings) -> Vec<View> {
    let poses = cameras(scene, tracer, positions, probes, s);
    let mut out: Vec<View> = poses.iter().map(|pose| camera_view(scene, tracer, probes, pose, s)).collect();
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

/// The camera `pose`'s view: every pixel that sees geometry a query (the surface point,
/// the view ray reflected about its normal), the others the sky or black (a back face).
pub fn camera_view(scene: &Scene, tracer: &Tracer, probes: &[Vec3], pose: &CameraPose, s: &RenderSettings) -> View {
    let (w, h) = s.camera;
    let frame = Frame::new(pose, s.fov_deg, s.camera);
    let eye = pose.eye;
    let pixels = (0..w * h)
        .map(|p| {
            let ray = frame.ray(p);
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
    let halves = reference_halves(scene, tracer, view, r, spp, (seed, stream));
    reference_from_halves(view, r, spp, halves, exposure)
}

/// The traced part of [`reference()`]: each pixel's two halves of `spp` lobe samples.
pub fn reference_halves(
    scene: &Scene,
    tracer: &Tracer,
    view: &View,
    r: f32,
    spp: u32,
    (seed, stream): (u64, u64),
) -> Vec<(Vec3, Vec3)> {
    let renderer = Renderer::new(scene, tracer);
    let half = (spp / 2).max(1);
    view.pixels
        .par_iter()
        .enumerate()
        .map(|(p, px)| match *px {
            Pixel::Background(c) => (c, c),
            Pixel::Query { b, dir, .. } => {
                lobe_halves(&renderer, (b, dir, r), half, (seed, hash_pair(stream, p as u64)))
            }
        })
        .collect()
}

/// [`reference()`] from its traced halves ([`reference_halves`]).
#[must_use]
pub fn reference_from_halves(view: &View, r: f32, spp: u32, halves: Vec<(Vec3, Vec3)>, exposure: f32) -> ViewReference {
    let half = (spp / 2).max(1);
    let reference: Vec<Vec3> = halves.iter().map(|(a, b)| (*a + *b) * 0.5).collect();
    let (a, b): (Vec<Vec3>, Vec<Vec3>) = halves.into_iter().unzip();
    let noise_flip = flip::mean(&flip::flip_hdr(&a, &b, view.width, view.height, exposure));
    let flip = flip::FlipReference::new(&reference, view.width, view.height, exposure);
    ViewReference { view: view.clone(), roughness: r, reference, spp: 2 * half, noise_flip, flip, half: a }
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
    pixel_weighted(views, &view_flips(views, exposure, estimate))
}

/// Each view's mean ꟻLIP of what `estimate` renders (as [`mean_flip`] calls it).
pub fn view_flips(
    views: &[ViewReference],
    exposure: f32,
    estimate: impl Fn(f32, Vec3, Vec3, Oracle) -> Vec3 + Sync,
) -> Vec<f64> {
    judge_views(views, exposure, &[], estimate).flips
}

/// What [`judge_views`] measures of one lookup's renderings of the views.
#[derive(Clone, Debug, Default)]
pub struct Judged {
    /// Each view's mean ꟻLIP.
    pub flips: Vec<f64>,
    /// Each view's ꟻLIP map as [`tiles`] of [`CLAIM_TILE`]² pixels.
    pub tiles: Vec<Vec<Tile>>,
    /// How the error jumps at cell faces, over the given pairs.
    pub seams: SeamSums,
}

/// Side of the tiles whose means the paired standard errors of ꟻLIP differences take as
/// their samples (neighbouring pixels' errors are not independent).
pub const CLAIM_TILE: u32 = 8;

/// Renders each view through `estimate` once and measures it: its mean ꟻLIP, its ꟻLIP
/// map's tiles and, over `pairs` (per view, in order; views without pairs add nothing),
/// its [`SeamSums`].
pub fn judge_views(
    views: &[ViewReference],
    exposure: f32,
    pairs: &[SeamPairs],
    estimate: impl Fn(f32, Vec3, Vec3, Oracle) -> Vec3 + Sync,
) -> Judged {
    let mut out = Judged::default();
    for (k, v) in views.iter().enumerate() {
        let image = render(v, |b, dir, oracle| estimate(v.roughness, b, dir, oracle));
        let map = flip_map(v, &image, exposure);
        out.flips.push(flip::mean(&map));
        out.tiles.push(tiles(&map, v.view.width, CLAIM_TILE));
        if let Some(p) = pairs.get(k) {
            out.seams = out.seams.add(&image, &v.reference, p, exposure);
        }
    }
    out
}

/// The mean of per-view values (`flips`, one per view) weighted by the views' pixel counts.
#[must_use]
pub fn pixel_weighted(views: &[ViewReference], flips: &[f64]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (v, f) in views.iter().zip(flips) {
        let pixels = v.reference.len();
        sum += f * pixels as f64;
        n += pixels;
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
    view_tiles(views, exposure, tile, estimate).concat()
}

/// [`flip_tiles`], each view's tiles apart.
pub fn view_tiles(
    views: &[ViewReference],
    exposure: f32,
    tile: u32,
    estimate: impl Fn(f32, Vec3, Vec3, Oracle) -> Vec3 + Sync,
) -> Vec<Vec<Tile>> {
    views
        .iter()
        .map(|v| {
            let image = render(v, |b, dir, oracle| estimate(v.roughness, b, dir, oracle));
            tiles(&flip_map(v, &image, exposure), v.view.width, tile)
        })
        .collect()
}

/// Neighbouring pixels of a camera view on one surface (normals within 8°, points nearer
/// than a quarter of the smallest cell extent), sorted by whether their points lie in
/// different cells of a grid (`crossing`: the pair straddles a cell face) or in the same
/// (`within`). Indices into the view's pixels.
#[derive(Clone, Debug, Default)]
pub struct SeamPairs {
    pub crossing: Vec<(u32, u32)>,
    pub within: Vec<(u32, u32)>,
}

/// The [`SeamPairs`] of `view` over the cells `cell_of` names (a sphere of directions has
/// none: it sees no surface), `step` the largest distance between a pair's points.
pub fn seam_pairs(view: &View, cell_of: impl Fn(Vec3) -> u32, step: f32) -> SeamPairs {
    let mut out = SeamPairs::default();
    if !view.camera {
        return out;
    }
    let (w, h) = (view.width, view.height);
    let surface = |p: u32| match view.pixels[p as usize] {
        Pixel::Query { b, normal, .. } => Some((b, normal)),
        Pixel::Background(_) => None,
    };
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let Some((bp, np)) = surface(p) else { continue };
            for q in [(x + 1 < w).then_some(p + 1), (y + 1 < h).then_some(p + w)].into_iter().flatten() {
                let Some((bq, nq)) = surface(q) else { continue };
                if np.dot(nq) < 0.99 || (bp - bq).length() > step {
                    continue;
                }
                if cell_of(bp) == cell_of(bq) { &mut out.within } else { &mut out.crossing }.push((p, q));
            }
        }
    }
    out
}

/// How an error jumps across cell faces: sums over [`SeamPairs`] (of any number of views)
/// of the squared jump of the tone-mapped error between the pair's pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SeamSums {
    pub crossing: f64,
    pub crossings: usize,
    pub within: f64,
    pub withins: usize,
}

impl SeamSums {
    /// The mean squared jump across cell faces over the mean within cells: about 1 where
    /// the error does not know where cells meet, above 1 where it jumps at their faces
    /// (tiles). `None` without pairs of either kind or without any error; an error that
    /// jumps only at faces divides by a floor of 1e-12 (finite, and huge).
    #[must_use]
    pub fn ratio(&self) -> Option<f64> {
        let (c, w) = (self.crossing / self.crossings.max(1) as f64, self.within / self.withins.max(1) as f64);
        (self.crossings > 0 && self.withins > 0 && (c > 0.0 || w > 0.0)).then(|| c / w.max(1e-12))
    }

    /// The sums of `image` against `reference` (tone-mapped at `exposure`) over `pairs`,
    /// added to these.
    #[must_use]
    pub fn add(mut self, image: &[Vec3], reference: &[Vec3], pairs: &SeamPairs, exposure: f32) -> Self {
        let error = |p: u32| {
            let p = p as usize;
            crate::tonemap::reinhard(image[p], exposure) - crate::tonemap::reinhard(reference[p], exposure)
        };
        let jump = |&(p, q): &(u32, u32)| f64::from((error(p) - error(q)).length_squared());
        self.crossing += pairs.crossing.iter().map(jump).sum::<f64>();
        self.crossings += pairs.crossing.len();
        self.within += pairs.within.iter().map(jump).sum::<f64>();
        self.withins += pairs.within.len();
        self
    }

    /// The references' own: the first half of their samples against the second, view by
    /// view (the views and their pairs in the same order).
    #[must_use]
    pub fn of_references(views: &[ViewReference], pairs: &[SeamPairs], exposure: f32) -> Self {
        views.iter().zip(pairs).fold(SeamSums::default(), |s, (v, p)| s.add(&v.half, &v.other_half(), p, exposure))
    }
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

    /// A camera view of a floor (20 × 10 pixels, 0.1 apart, normal +Y); pixels with x ≥ 15
    /// are a step up by 1 (a ledge), the last row is sky.
    fn floor_view() -> View {
        let (w, h) = (20u32, 10u32);
        let pixels = (0..w * h)
            .map(|p| {
                let (x, y) = (p % w, p / w);
                if y == h - 1 {
                    return Pixel::Background(Vec3::ONE);
                }
                let up = if x >= 15 { 1.0 } else { 0.0 };
                let b = Vec3::new(x as f32 * 0.1, up, y as f32 * 0.1);
                let oracle = Oracle { a: Vec3::Y, any: crate::warp::glossy::Aim { v: Vec3::Y, k: None, probe: 0 } };
                Pixel::Query { b, dir: Vec3::Y, oracle, normal: Vec3::Y }
            })
            .collect();
        View { name: "floor".into(), width: w, height: h, pixels, camera: true }
    }

    /// Cells 0.5 wide along x: a face every 5 pixels.
    fn cell(b: Vec3) -> u32 {
        libm::floorf(b.x / 0.5) as u32
    }

    #[test]
    fn seam_pairs_straddle_cell_faces_on_one_surface_only() {
        let v = floor_view();
        let pairs = seam_pairs(&v, cell, 0.2);
        // horizontal pairs: 9 surface rows × 19 neighbours, less the ledge's (x 14–15);
        // faces between x = 4|5, 9|10 (the ledge's 14|15 is no pair): 2 per row
        assert_eq!(pairs.crossing.len(), 9 * 2);
        // vertical pairs stay in their cell: 8 per column; horizontal within: 19 − 1 − 2
        assert_eq!(pairs.within.len(), 9 * 16 + 20 * 8);
        assert!(pairs.crossing.iter().all(|&(p, q)| cell(b_of(&v, p)) != cell(b_of(&v, q))));
        // a sphere of directions has no surfaces
        assert!(seam_pairs(&View { camera: false, ..v }, cell, 0.2).crossing.is_empty());
    }

    fn b_of(v: &View, p: u32) -> Vec3 {
        match v.pixels[p as usize] {
            Pixel::Query { b, .. } => b,
            Pixel::Background(_) => panic!("background"),
        }
    }

    #[test]
    fn a_cell_sized_tile_shows_as_a_seam_and_a_smooth_error_does_not() {
        let v = floor_view();
        let pairs = seam_pairs(&v, cell, 0.2);
        let n = (v.width * v.height) as usize;
        let reference = vec![Vec3::splat(0.2); n];
        let at = |f: &dyn Fn(Vec3) -> f32| -> Vec<Vec3> {
            (0..n as u32)
                .map(|p| match v.pixels[p as usize] {
                    Pixel::Query { b, .. } => Vec3::splat(0.2 + f(b)),
                    Pixel::Background(c) => c,
                })
                .collect()
        };
        // an error that grows smoothly along x and y: jumps the same everywhere
        let smooth = at(&|b| 0.01 * (b.x + b.z));
        let r = SeamSums::default().add(&smooth, &reference, &pairs, 1.0).ratio().unwrap();
        assert!((0.8..1.25).contains(&r), "{r}");
        // a constant error per cell (tiles)
        let tiles = at(&|b| 0.05 * (cell(b) % 2) as f32);
        let r = SeamSums::default().add(&tiles, &reference, &pairs, 1.0).ratio().unwrap();
        assert!(r.is_finite() && r > 1e6, "no jump within cells: {r}");
        let both = at(&|b| 0.05 * (cell(b) % 2) as f32 + 0.01 * (b.x + b.z));
        let r = SeamSums::default().add(&both, &reference, &pairs, 1.0).ratio().unwrap();
        assert!(r > 10.0, "{r}");
        // no error at all: no ratio
        assert_eq!(SeamSums::default().add(&reference, &reference, &pairs, 1.0).ratio(), None);
    }

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
