//! ꟻLIP, the perceptual error of a rendered image against its reference (Andersson et al.
//! 2020, "FLIP: A Difference Evaluator for Alternating Images"): NVIDIA's C++ implementation
//! of LDR-ꟻLIP (the code `nv-flip` binds) ported to Rust with the same constants, filters
//! and summation order, its `powf`, `expf` and the CIELab cube root taken from the `libm`
//! crate, so the same images give the same error maps on every CPU (the C++ calls the
//! platform's functions, which pick an FMA or a plain path per CPU; the fit chooses its
//! roughness rows with this measure, and fits must not depend on the CPU). The cube root is
//! `cbrtf` where NVIDIA writes `powf(v, 1/3)` (whose exponent is not exactly a third): the
//! same function, and twice as fast as the port with `powf`. The error maps agree with the
//! C++ through `nv-flip` to 1e-5 per pixel (unit test) and with NVIDIA's own Python package
//! (`tests/flip_reference.rs`). The filters run a tap at a time over a row, which
//! vectorises and keeps each pixel's sum in NVIDIA's order. Radiance is high dynamic range: both images are
//! tone-mapped (Reinhard, `tonemap`) at three exposures, two stops below, at and above the
//! scene's key, and each pixel keeps its largest LDR-ꟻLIP error over the three (HDR-ꟻLIP's
//! rule, with three fixed exposures instead of its automatic range). Errors lie in [0, 1]; a
//! lamp in view saturates like it does on a screen instead of ruling the mean. What one
//! image contributes to a comparison (its filtered colour in Lab and its feature
//! magnitudes) depends on that image alone, so a reference compared with many images has
//! its side found once ([`FlipReference`]), the maps bit for bit those of each pair.

#![allow(clippy::excessive_precision, clippy::unreadable_literal)]

use crate::tonemap::to_srgb8;
use glam::Vec3;

/// Exposures relative to the scene's key, in stops.
pub const EXPOSURE_STOPS: [f32; 3] = [-2.0, 0.0, 2.0];

/// Pixels per degree of visual angle: ꟻLIP's default viewing condition (a 0.7 m wide 4K
/// monitor at 0.7 m).
pub const PIXELS_PER_DEGREE: f32 = 67.0;

// ꟻLIP's constants (`sharedflip.h`, `color.h`), written as NVIDIA's source writes them so
// they parse to the same floats.
const GQC: f32 = 0.7;
const GPC: f32 = 0.4;
const GPT: f32 = 0.95;
const GW: f32 = 0.082;
const GQF: f32 = 0.5;
/// NVIDIA writes 3.14159265358979f: the same float.
const PI: f32 = std::f32::consts::PI;
/// The CSF Gaussians' (a, b) per channel: Y, Cx, and Cz's two.
const A1: [f32; 3] = [1.0, 1.0, 34.1];
const B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const A2Z: f32 = 13.5;
const B2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];
const ILLUMINANT: [f32; 3] = [0.950428545, 1.000000000, 1.088900371];
const INV_ILLUMINANT: [f32; 3] = [1.052156925, 1.000000000, 0.918357670];

fn gaussian_ab(x2: f32, a: f32, b: f32) -> f32 {
    a * (PI / b).sqrt() * libm::expf(-(PI * PI) * x2 / b)
}

fn gaussian_sqrt(x2: f32, a: f32, b: f32) -> f32 {
    (a * (PI / b).sqrt()).sqrt() * libm::expf(-(PI * PI) * x2 / b)
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { libm::powf((c + 0.055) / 1.055, 2.4) }
}

fn linear_rgb_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let m = [
        [10135552.0f32 / 24577794.0, 8788810.0 / 24577794.0, 4435075.0 / 24577794.0],
        [2613072.0 / 12288897.0, 8788810.0 / 12288897.0, 887015.0 / 12288897.0],
        [1425312.0 / 73733382.0, 8788810.0 / 73733382.0, 70074185.0 / 73733382.0],
    ];
    m.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

fn xyz_to_linear_rgb(c: [f32; 3]) -> [f32; 3] {
    let m = [
        [3.241003275f32, -1.537398934, -0.498615861],
        [-0.969224334, 1.875930071, 0.041554224],
        [0.055639423, -0.204011202, 1.057148933],
    ];
    m.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

fn xyz_to_ycxcz(c: [f32; 3]) -> [f32; 3] {
    let (x, y, z) = (c[0] * INV_ILLUMINANT[0], c[1] * INV_ILLUMINANT[1], c[2] * INV_ILLUMINANT[2]);
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let y = (c[0] + 16.0) / 116.0;
    let (cx, cz) = (c[1] / 500.0, c[2] / 200.0);
    [(y + cx) * ILLUMINANT[0], y * ILLUMINANT[1], (y - cz) * ILLUMINANT[2]]
}

fn xyz_to_cielab(c: [f32; 3]) -> [f32; 3] {
    let delta = 6.0f32 / 29.0;
    let delta_square = delta * delta;
    let delta_cube = delta * delta_square;
    let factor = 1.0 / (3.0 * delta_square);
    let term = 4.0f32 / 29.0;
    let f = |v: f32| if v > delta_cube { libm::cbrtf(v) } else { factor * v + term };
    let (x, y, z) = (f(c[0] * INV_ILLUMINANT[0]), f(c[1] * INV_ILLUMINANT[1]), f(c[2] * INV_ILLUMINANT[2]));
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn hunt(l: f32, c: f32) -> f32 {
    0.01 * l * c
}

fn hyab(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] - b[0]).abs() + ((a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])).sqrt()
}

/// Linear RGB (clamped to [0, 1]) to Hunt-adjusted CIELab.
fn lab_hunt(rgb: [f32; 3]) -> [f32; 3] {
    let lab = xyz_to_cielab(linear_rgb_to_xyz(rgb));
    [lab[0], hunt(lab[0], lab[1]), hunt(lab[0], lab[2])]
}

fn max_distance() -> f32 {
    libm::powf(hyab(lab_hunt([0.0, 1.0, 0.0]), lab_hunt([0.0, 0.0, 1.0])), GQC)
}

/// The separated CSF filters: (Y, Cx) weights and Cz's two Gaussians' weights per tap.
fn spatial_filters(ppd: f32) -> Vec<([f32; 2], [f32; 2])> {
    let dx = 1.0 / ppd;
    let max_b = B1[0].max(B1[1]).max(B1[2].max(B2[0])).max(B2[1].max(B2[2]));
    let radius = libm::ceilf(3.0 * (max_b / (2.0 * (PI * PI))).sqrt() * ppd) as i32;
    let mut taps: Vec<([f32; 2], [f32; 2])> = (0..2 * radius + 1)
        .map(|x| {
            let ix = (x - radius) as f32 * dx;
            let ix2 = ix * ix;
            (
                [gaussian_ab(ix2, A1[0], B1[0]), gaussian_ab(ix2, A1[1], B1[1])],
                [gaussian_sqrt(ix2, A1[2], B1[2]), gaussian_sqrt(ix2, A2Z, B2[2])],
            )
        })
        .collect();
    let (mut sum_ycx, mut sum_cz) = ([0.0f32; 2], [0.0f32; 2]);
    for (ycx, cz) in &taps {
        sum_ycx = [sum_ycx[0] + ycx[0], sum_ycx[1] + ycx[1]];
        sum_cz = [sum_cz[0] + cz[0], sum_cz[1] + cz[1]];
    }
    let norm_ycx = [1.0 / sum_ycx[0], 1.0 / sum_ycx[1]];
    let norm_cz = 1.0 / (sum_cz[0] * sum_cz[0] + sum_cz[1] * sum_cz[1]).sqrt();
    for (ycx, cz) in &mut taps {
        *ycx = [ycx[0] * norm_ycx[0], ycx[1] * norm_ycx[1]];
        *cz = [cz[0] * norm_cz, cz[1] * norm_cz];
    }
    taps
}

/// The separated edge and point detection filter: (Gaussian, 1st, 2nd derivative) per tap.
fn feature_filter(ppd: f32) -> Vec<[f32; 3]> {
    let sd = 0.5 * GW * ppd;
    let radius = libm::ceilf(3.0 * sd) as i32;
    let (mut g_sum, mut dg_neg, mut dg_pos, mut ddg_neg, mut ddg_pos) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let mut taps: Vec<[f32; 3]> = (0..2 * radius + 1)
        .map(|x| {
            let xx = (x - radius) as f32;
            let g = libm::expf(-(xx * xx) / (2.0 * sd * sd));
            g_sum += g;
            let dg = -xx * g;
            if dg > 0.0 {
                dg_pos += dg;
            } else {
                dg_neg -= dg;
            }
            let ddg = (xx * xx / (sd * sd) - 1.0) * g;
            if ddg > 0.0 {
                ddg_pos += ddg;
            } else {
                ddg_neg -= ddg;
            }
            [g, dg, ddg]
        })
        .collect();
    for t in &mut taps {
        *t = [
            t[0] / g_sum,
            t[1] / if t[1] > 0.0 { dg_pos } else { dg_neg },
            t[2] / if t[2] > 0.0 { ddg_pos } else { ddg_neg },
        ];
    }
    taps
}

/// LDR-ꟻLIP error map of two 8-bit sRGB images (RGB, row-major) of `width × height`.
#[must_use]
pub fn flip_ldr(reference: &[u8], test: &[u8], width: u32, height: u32) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    let n = w * h;
    if n == 0 || reference.len() < 3 * n || test.len() < 3 * n {
        return vec![0.0; n];
    }
    Side::of(reference, w, h).error_against(&Side::of(test, w, h))
}

/// What LDR-ꟻLIP compares of one image, per pixel: its spatially filtered colour in
/// Hunt-adjusted CIELab, and the magnitudes of its edge and point features on Y. The
/// reference's side of a comparison is the same for every test image, so it is found once
/// ([`FlipReference`]).
#[derive(Clone, Debug)]
struct Side {
    lab: Vec<[f32; 3]>,
    edge: Vec<f32>,
    point: Vec<f32>,
}

impl Side {
    /// The side of an 8-bit sRGB image of `w × h` (at least `3·w·h` bytes).
    fn of(img: &[u8], w: usize, h: usize) -> Side {
        let planes = Planes::ycxcz(img, w * h);
        let ppd = PIXELS_PER_DEGREE;
        let lab = filtered_lab(&planes, w, &spatial_filters(ppd));
        let (edge, point) = features(&planes.0[0], w, &feature_filter(ppd));
        Side { lab, edge, point }
    }

    /// The error map of `test` against `self` (the reference): the colour difference
    /// remapped to [0, 1], raised to `1 − feature difference`.
    fn error_against(&self, test: &Side) -> Vec<f32> {
        let cmax = max_distance();
        let pccmax = GPC * cmax;
        let norm = 1.0 / 2.0f32.sqrt();
        (0..self.lab.len())
            .map(|p| {
                let d = libm::powf(hyab(self.lab[p], test.lab[p]), GQC);
                let colour =
                    if d < pccmax { d * (GPT / pccmax) } else { GPT + ((d - pccmax) / (cmax - pccmax)) * (1.0 - GPT) };
                let de = (self.edge[p] - test.edge[p]).abs();
                let dp = (self.point[p] - test.point[p]).abs();
                let feature = libm::powf(norm * de.max(dp), GQF);
                libm::powf(colour, 1.0 - feature)
            })
            .collect()
    }
}

/// An image's Y, Cx and Cz planes.
struct Planes([Vec<f32>; 3]);

impl Planes {
    fn ycxcz(img: &[u8], n: usize) -> Planes {
        // an 8-bit channel has 256 values: each converted once, by the same function
        let linear: [f32; 256] = std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0));
        let mut planes = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        for p in 0..n {
            let c = xyz_to_ycxcz(linear_rgb_to_xyz([0, 1, 2].map(|k| linear[img[3 * p + k] as usize])));
            for k in 0..3 {
                planes[k][p] = c[k];
            }
        }
        Planes(planes)
    }
}

/// `src` (rows of `w`) filtered along x by `taps` (centred), edges clamped: each output
/// pixel sums its taps in order, as the C++ does, so the floats are the same; the loop runs
/// over pixels inside each tap, which vectorises.
fn filter_x(src: &[f32], w: usize, taps: &[f32]) -> Vec<f32> {
    let half = taps.len() / 2;
    let mut out = vec![0.0f32; src.len()];
    for (row, dst) in src.chunks_exact(w).zip(out.chunks_exact_mut(w)) {
        for (k, &tap) in taps.iter().enumerate() {
            // pixel x reads row[clamp(x + k − half)]
            let lo = half.saturating_sub(k).min(w); // x below lo reads row[0]
            let hi = (w + half).saturating_sub(k).min(w).max(lo); // x at or above hi reads row[w − 1]
            for d in &mut dst[..lo] {
                *d += tap * row[0];
            }
            let shift = k as isize - half as isize;
            for (x, d) in dst[lo..hi].iter_mut().enumerate() {
                *d += tap * row[((lo + x) as isize + shift) as usize];
            }
            for d in &mut dst[hi..] {
                *d += tap * row[w - 1];
            }
        }
    }
    out
}

/// `src` (rows of `w`) filtered along y by `taps`, edges clamped, in the same order.
fn filter_y(src: &[f32], w: usize, taps: &[f32]) -> Vec<f32> {
    let h = src.len() / w;
    let half = taps.len() / 2;
    let mut out = vec![0.0f32; src.len()];
    for (y, dst) in out.chunks_exact_mut(w).enumerate() {
        for (k, &tap) in taps.iter().enumerate() {
            let yy = (y + k).saturating_sub(half).min(h - 1);
            for (d, &s) in dst.iter_mut().zip(&src[yy * w..(yy + 1) * w]) {
                *d += tap * s;
            }
        }
    }
    out
}

/// Each pixel's spatially filtered colour in Hunt-adjusted CIELab: Y with Y's filter, Cx
/// with Cx's, Cz with each of its two Gaussians, along x then y.
fn filtered_lab(p: &Planes, w: usize, taps: &[([f32; 2], [f32; 2])]) -> Vec<[f32; 3]> {
    let tap = |i: usize| -> Vec<f32> { taps.iter().map(|(ycx, cz)| [ycx[0], ycx[1], cz[0], cz[1]][i]).collect() };
    let (w_y, w_cx, w_cz1, w_cz2) = (tap(0), tap(1), tap(2), tap(3));
    let f = [(&p.0[0], &w_y), (&p.0[1], &w_cx), (&p.0[2], &w_cz1), (&p.0[2], &w_cz2)]
        .map(|(plane, taps)| filter_y(&filter_x(plane, w, taps), w, taps));
    (0..p.0[0].len())
        .map(|q| {
            let rgb = xyz_to_linear_rgb(ycxcz_to_xyz([f[0][q], f[1][q], f[2][q] + f[3][q]]));
            lab_hunt(rgb.map(|v| v.clamp(0.0, 1.0)))
        })
        .collect()
}

/// Each pixel's edge and point feature magnitudes on the Y plane `y` (rows of `w`):
/// x-derivatives along x then the Gaussian along y; the Gaussian along x then
/// y-derivatives along y.
fn features(plane: &[f32], w: usize, taps: &[[f32; 3]]) -> (Vec<f32>, Vec<f32>) {
    let (one_over_116, sixteen_over_116) = (1.0f32 / 116.0, 16.0f32 / 116.0);
    let (g, dg, ddg): (Vec<f32>, Vec<f32>, Vec<f32>) =
        (taps.iter().map(|f| f[0]).collect(), taps.iter().map(|f| f[1]).collect(), taps.iter().map(|f| f[2]).collect());
    let y: Vec<f32> = plane.iter().map(|&v| v * one_over_116 + sixteen_over_116).collect();
    let (dx, ddx, gx) = (filter_x(&y, w, &dg), filter_x(&y, w, &ddg), filter_x(&y, w, &g));
    let (dx, ddx, dy, ddy) =
        (filter_y(&dx, w, &g), filter_y(&ddx, w, &g), filter_y(&gx, w, &dg), filter_y(&gx, w, &ddg));
    let edge = dx.iter().zip(&dy).map(|(&x, &y)| (x * x + y * y).sqrt()).collect();
    let point = ddx.iter().zip(&ddy).map(|(&x, &y)| (x * x + y * y).sqrt()).collect();
    (edge, point)
}

/// The reference side of HDR-ꟻLIP comparisons ([`flip_hdr`]), found once for a reference
/// image and an exposure: at each of [`EXPOSURE_STOPS`], what LDR-ꟻLIP compares of the
/// tone-mapped reference. [`FlipReference::error_map`] of any test image is then
/// `flip_hdr` of the two, bit for bit, for half the work.
#[derive(Clone, Debug)]
pub struct FlipReference {
    width: u32,
    height: u32,
    exposure: f32,
    stops: Vec<Side>,
}

impl FlipReference {
    /// The reference side of `reference` (`width × height` linear radiance) at `exposure`.
    #[must_use]
    pub fn new(reference: &[Vec3], width: u32, height: u32, exposure: f32) -> FlipReference {
        assert_eq!(reference.len(), (width * height) as usize, "reference image size");
        let (w, h) = (width as usize, height as usize);
        let stops = if w * h == 0 {
            Vec::new()
        } else {
            EXPOSURE_STOPS.iter().map(|&s| Side::of(&to_srgb8(reference, exposure * libm::exp2f(s)), w, h)).collect()
        };
        FlipReference { width, height, exposure, stops }
    }

    /// The exposure the reference was prepared at.
    #[must_use]
    pub fn exposure(&self) -> f32 {
        self.exposure
    }

    /// Per-pixel HDR error map of `test` (linear radiance, the reference's size): the
    /// largest LDR-ꟻLIP error over the exposure stops.
    #[must_use]
    pub fn error_map(&self, test: &[Vec3]) -> Vec<f32> {
        let (w, h) = (self.width as usize, self.height as usize);
        assert_eq!(test.len(), w * h, "test image size");
        let mut out = vec![0.0f32; w * h];
        for (side, &s) in self.stops.iter().zip(&EXPOSURE_STOPS) {
            let map = side.error_against(&Side::of(&to_srgb8(test, self.exposure * libm::exp2f(s)), w, h));
            for (o, m) in out.iter_mut().zip(map) {
                *o = o.max(if m.is_finite() { m } else { 1.0 });
            }
        }
        out
    }
}

/// Per-pixel HDR error map (largest LDR-ꟻLIP over [`EXPOSURE_STOPS`] around `exposure`) of
/// linear radiance images.
#[must_use]
pub fn flip_hdr(reference: &[Vec3], test: &[Vec3], width: u32, height: u32, exposure: f32) -> Vec<f32> {
    assert_eq!(test.len(), reference.len(), "test image size");
    FlipReference::new(reference, width, height, exposure).error_map(test)
}

/// Mean of an error map.
#[must_use]
pub fn mean(map: &[f32]) -> f64 {
    map.iter().map(|&x| x as f64).sum::<f64>() / map.len().max(1) as f64
}

/// The magma colour map of ꟻLIP's error maps, as 8-bit RGB pixels.
#[must_use]
pub fn magma(map: &[f32], width: u32, height: u32) -> Vec<u8> {
    let img = nv_flip::FlipImageFloat::with_data(width, height, map);
    img.apply_color_lut(&nv_flip::magma_lut()).to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// NVIDIA's C++ through `nv-flip` (platform `powf`/`expf`): the port's error maps agree
    /// to within those functions' last-bit differences, on images with edges, gradients,
    /// colour and noise, at several sizes (the filters' clamped borders included).
    #[test]
    fn the_port_matches_nvidias_cpp() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        };
        for (w, h) in [(48u32, 32u32), (17, 9), (96, 60), (5, 64)] {
            let n = (w * h) as usize;
            let reference: Vec<u8> = (0..3 * n)
                .map(|k| {
                    let (p, c) = (k / 3, k % 3);
                    let (x, y) = (p % w as usize, p / w as usize);
                    let edge = if x * 3 > w as usize { 200u8 } else { 30 };
                    edge.wrapping_add((y * 4 + c * 40) as u8) / 2 + next() / 8
                })
                .collect();
            let test: Vec<u8> =
                reference.iter().map(|&v| v.saturating_add(next() / 6).saturating_sub(next() / 6)).collect();
            let ours = flip_ldr(&reference, &test, w, h);
            let theirs = nv_flip::flip(
                nv_flip::FlipImageRgb8::with_data(w, h, &reference),
                nv_flip::FlipImageRgb8::with_data(w, h, &test),
                PIXELS_PER_DEGREE,
            )
            .to_vec();
            assert_eq!(ours.len(), theirs.len());
            let worst = ours.iter().zip(&theirs).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            let same = ours.iter().zip(&theirs).filter(|(a, b)| a == b).count();
            assert!(worst < 1e-5, "{w}×{h}: worst pixel differs by {worst} ({same} of {n} identical)");
            assert!(mean(&ours) > 0.01, "{w}×{h}: the images differ");
        }
    }

    #[test]
    fn identical_images_have_no_error() {
        let img: Vec<Vec3> = (0..32 * 16).map(|k| Vec3::new((k % 32) as f32 / 8.0, (k / 32) as f32, 0.5)).collect();
        let map = flip_hdr(&img, &img, 32, 16, 1.0);
        assert!(map.iter().all(|&x| x == 0.0));
    }

    /// One reference side serves every test image: each map is the one a fresh pair gives,
    /// and the side is not changed by use (the evaluation prepares a view's once for all
    /// its rows).
    #[test]
    fn a_prepared_reference_answers_as_each_fresh_pair_does() {
        let (w, h) = (24u32, 20u32);
        let img: Vec<Vec3> =
            (0..w * h).map(|k| Vec3::new((k % w) as f32 / 6.0, (k / w) as f32 / 9.0, ((k * 7) % 5) as f32)).collect();
        let prepared = FlipReference::new(&img, w, h, 0.8);
        for scale in [1.0f32, 0.5, 3.0, 1.02, 1.0] {
            let test: Vec<Vec3> =
                img.iter().enumerate().map(|(k, c)| *c * scale + Vec3::splat((k % 3) as f32 * 0.01)).collect();
            let fresh = flip_ldr_hdr_pairwise(&img, &test, w, h, 0.8);
            assert_eq!(prepared.error_map(&test), fresh, "scale {scale}");
        }
    }

    /// `flip_hdr` as it was written before the reference side could be prepared: both
    /// images through [`flip_ldr`] at each stop.
    fn flip_ldr_hdr_pairwise(reference: &[Vec3], test: &[Vec3], w: u32, h: u32, exposure: f32) -> Vec<f32> {
        let mut out = vec![0.0f32; reference.len()];
        for stops in EXPOSURE_STOPS {
            let e = exposure * libm::exp2f(stops);
            let map = flip_ldr(&to_srgb8(reference, e), &to_srgb8(test, e), w, h);
            for (o, m) in out.iter_mut().zip(map) {
                *o = o.max(if m.is_finite() { m } else { 1.0 });
            }
        }
        out
    }

    #[test]
    fn errors_grow_with_the_difference_and_stay_in_range() {
        let img: Vec<Vec3> = (0..32 * 32).map(|k| Vec3::splat(((k % 32) as f32 / 31.0) * 2.0)).collect();
        let small: Vec<Vec3> = img.iter().map(|c| *c * 1.05).collect();
        let large: Vec<Vec3> = img.iter().map(|c| *c * 3.0 + Vec3::new(0.5, 0.0, 0.0)).collect();
        let (a, b) = (mean(&flip_hdr(&img, &small, 32, 32, 1.0)), mean(&flip_hdr(&img, &large, 32, 32, 1.0)));
        assert!(0.0 < a && a < b && b <= 1.0, "{a} {b}");
    }
}
