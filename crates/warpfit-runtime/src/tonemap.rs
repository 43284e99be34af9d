//! Tone mapping, for judging and for looking: an exposure from a scene's key (log-average
//! luminance mapped to middle grey, Reinhard et al. 2002, "Photographic Tone Reproduction"),
//! the Reinhard curve `x / (1 + x)` per channel, and sRGB encoding. Errors measured after
//! this mapping are bounded per pixel, so a few samples of a lamp or the sun's disc cannot
//! rule them.

use glam::Vec3;

/// Rec. 709 luminance.
#[inline]
#[must_use]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Exposure that maps the log-average luminance of `radiance` to middle grey (0.18); 1 when
/// nothing is lit.
#[must_use]
pub fn key_exposure(radiance: &[Vec3]) -> f32 {
    let (mut sum, mut n) = (0.0f64, 0u32);
    for &c in radiance {
        let l = luminance(c);
        if l > 0.0 && l.is_finite() {
            sum += libm::log(l as f64 + 1e-6);
            n += 1;
        }
    }
    if n == 0 {
        return 1.0;
    }
    let avg = libm::exp(sum / n as f64) as f32;
    let e = 0.18 / avg.max(1e-9);
    if e.is_finite() { e } else { 1.0 }
}

/// Reinhard's curve per channel after `exposure`: finite inputs map into [0, 1); NaN and
/// negative values map to 0.
#[inline]
#[must_use]
pub fn reinhard(c: Vec3, exposure: f32) -> Vec3 {
    let v = (c * exposure).max(Vec3::ZERO);
    let v = v / (Vec3::ONE + v);
    Vec3::select(v.cmpge(Vec3::ZERO), v, Vec3::ZERO).min(Vec3::ONE)
}

/// Linear [0, 1] to an 8-bit sRGB code: [`srgb8_exact`]'s code, found among the codes'
/// lower thresholds (eight comparisons instead of a `powf` per channel; the ꟻLIP images of
/// an evaluation encode every pixel of every method at three exposures).
#[inline]
#[must_use]
pub fn srgb8(x: f32) -> u8 {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    code_thresholds().partition_point(|&t| t <= x) as u8
}

/// Linear [0, 1] to an 8-bit sRGB code by the sRGB curve itself (IEC 61966-2-1),
/// rounded to the nearest code.
#[must_use]
pub fn srgb8_exact(x: f32) -> u8 {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    let s = if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * libm::powf(x, 1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// For each code k in 1..=255, the least x in [0, 1] that [`srgb8_exact`] maps to k or above:
/// a bisection over the floats in [0, 1], which are ordered like their bit patterns (the
/// curve is monotone; tests check the two forms agree).
fn code_thresholds() -> &'static [f32; 255] {
    static THRESHOLDS: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    THRESHOLDS.get_or_init(|| {
        let mut t = [0.0f32; 255];
        for (k, t) in t.iter_mut().enumerate() {
            let code = k as u8 + 1;
            // srgb8_exact(from_bits(lo)) < code ≤ srgb8_exact(from_bits(hi))
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if srgb8_exact(f32::from_bits(mid)) >= code { hi = mid } else { lo = mid }
            }
            *t = f32::from_bits(hi);
        }
        t
    })
}

/// Tone-maps linear radiance to 8-bit sRGB pixels (RGB, row-major).
#[must_use]
pub fn to_srgb8(radiance: &[Vec3], exposure: f32) -> Vec<u8> {
    let mut out = Vec::with_capacity(radiance.len() * 3);
    for &c in radiance {
        let v = reinhard(c, exposure);
        out.extend([srgb8(v.x), srgb8(v.y), srgb8(v.z)]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curve_is_bounded_and_monotone() {
        let mut last = -1.0;
        for x in [0.0f32, 1e-6, 0.1, 1.0, 10.0, 1e6, f32::MAX] {
            let y = reinhard(Vec3::splat(x), 1.0).x;
            assert!((0.0..=1.0).contains(&y) && y >= last, "{x} → {y}");
            last = y;
        }
        assert_eq!(reinhard(Vec3::splat(f32::NAN), 1.0), Vec3::ZERO);
        assert_eq!(reinhard(Vec3::splat(-3.0), 1.0), Vec3::ZERO);
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(f32::NAN), 0);
    }

    #[test]
    fn the_code_search_is_the_curve_bit_for_bit() {
        // every code's threshold and its neighbouring floats, a sweep through every 97th float
        // in [0, 1] (about 11 million), and what lies outside (all 1,065,353,217 floats in
        // [0, 1] were checked once, with no difference)
        let mut xs: Vec<f32> =
            code_thresholds().iter().flat_map(|&t| [t, t.next_down(), f32::from_bits(t.to_bits() + 1)]).collect();
        xs.extend((0..=1.0f32.to_bits()).step_by(97).map(f32::from_bits));
        xs.extend([-1.0, -0.0, 0.0, 1.0, 2.0, f32::MIN_POSITIVE, f32::NAN, f32::INFINITY, f32::NEG_INFINITY]);
        for x in xs {
            assert_eq!(srgb8(x), srgb8_exact(x), "x = {x} ({:#x})", x.to_bits());
        }
        // the thresholds are increasing: every code is reached
        assert!(code_thresholds().windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn the_key_maps_a_constant_image_to_middle_grey() {
        let img = vec![Vec3::splat(4.0); 16];
        let e = key_exposure(&img);
        assert!((luminance(img[0]) * e - 0.18).abs() < 1e-4);
        assert_eq!(key_exposure(&[Vec3::ZERO; 4]), 1.0);
    }
}
