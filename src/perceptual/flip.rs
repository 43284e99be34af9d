//! ꟻLIP, the perceptual error of a rendered image against its reference (Andersson et al.
//! 2020, "FLIP: A Difference Evaluator for Alternating Images"), through NVIDIA's own C++
//! implementation (`nv-flip`). Radiance is high dynamic range: both images are tone-mapped
//! (Reinhard, `tonemap`) at three exposures, two stops below, at and above the scene's key,
//! and each pixel keeps its largest LDR-ꟻLIP error over the three (HDR-ꟻLIP's rule, with
//! three fixed exposures instead of its automatic range). Errors lie in [0, 1]; a lamp in
//! view saturates like it does on a screen instead of ruling the mean.

use crate::tonemap::to_srgb8;
use glam::Vec3;

/// Exposures relative to the scene's key, in stops.
pub const EXPOSURE_STOPS: [f32; 3] = [-2.0, 0.0, 2.0];

/// Pixels per degree of visual angle: ꟻLIP's default viewing condition (a 0.7 m wide 4K
/// monitor at 0.7 m).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// LDR-ꟻLIP error map of two 8-bit sRGB images (RGB, row-major) of `width × height`.
#[must_use]
pub fn flip_ldr(reference: &[u8], test: &[u8], width: u32, height: u32) -> Vec<f32> {
    let r = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let t = nv_flip::FlipImageRgb8::with_data(width, height, test);
    nv_flip::flip(r, t, PIXELS_PER_DEGREE).to_vec()
}

/// Per-pixel HDR error map (largest LDR-ꟻLIP over [`EXPOSURE_STOPS`] around `exposure`) of
/// linear radiance images.
#[must_use]
pub fn flip_hdr(reference: &[Vec3], test: &[Vec3], width: u32, height: u32, exposure: f32) -> Vec<f32> {
    assert_eq!(reference.len(), (width * height) as usize, "reference image size");
    assert_eq!(test.len(), reference.len(), "test image size");
    let mut out = vec![0.0f32; reference.len()];
    for stops in EXPOSURE_STOPS {
        let e = exposure * libm::exp2f(stops);
        let map = flip_ldr(&to_srgb8(reference, e), &to_srgb8(test, e), width, height);
        for (o, m) in out.iter_mut().zip(map) {
            *o = o.max(if m.is_finite() { m } else { 1.0 });
        }
    }
    out
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

    #[test]
    fn identical_images_have_no_error() {
        let img: Vec<Vec3> = (0..32 * 16).map(|k| Vec3::new((k % 32) as f32 / 8.0, (k / 32) as f32, 0.5)).collect();
        let map = flip_hdr(&img, &img, 32, 16, 1.0);
        assert!(map.iter().all(|&x| x == 0.0));
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
