//! Real spherical harmonics to band 2 (nine functions), for the smooth, cheap read of a
//! cell's irradiance that rough specular lookups blend in.
//!
//! Irradiance is the radiance convolved with the clamped cosine, whose harmonic
//! coefficients fall off fast (Â₀ = π, Â₁ = 2π/3, Â₂ = π/4, Â₃ = 0, Â₄ = −π/24): bands 0–2
//! hold it to within a few percent (Ramamoorthi and Hanrahan 2001, "An Efficient
//! Representation for Irradiance Environment Maps"). The nine coefficients of a cell are
//! found by projecting its octahedral irradiance map, read bilinearly as everything else
//! reads it; [`projection_weights`] holds that integral per texel, once per map size.
//!
//! Evaluation is a fixed sum of products in f32 (no fused multiply-add), so every CPU and
//! every build gives the same floats.

use crate::octa;
use glam::{Vec2, Vec3, Vec3A};

/// Coefficients of bands 0–2.
pub const COEFFS: usize = 9;

/// The nine real harmonics at unit direction `d`, in the usual order (l, m) = (0, 0),
/// (1, −1), (1, 0), (1, 1), (2, −2), (2, −1), (2, 0), (2, 1), (2, 2), with y ↔ m = −1 and
/// x ↔ m = +1 (Sloan 2008, "Stupid Spherical Harmonics Tricks").
#[inline(always)]
#[must_use]
pub fn basis(d: Vec3) -> [f32; COEFFS] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * (x * y),
        1.092_548_4 * (y * z),
        0.315_391_57 * (3.0 * (z * z) - 1.0),
        1.092_548_4 * (x * z),
        0.546_274_2 * (x * x - y * y),
    ]
}

/// The function with coefficients `c` at unit direction `d`, clamped at 0 (a truncated
/// series can ring below zero opposite a bright source; irradiance cannot). The
/// coefficients are 16-byte vectors so the sum runs on SIMD registers; a product or a sum
/// there rounds exactly as the scalar one does.
#[inline(always)]
#[must_use]
pub fn eval(c: &[Vec3A; COEFFS], d: Vec3) -> Vec3 {
    Vec3::from(eval_a(c, d))
}

/// [`eval`] as a 16-byte vector.
#[inline(always)]
#[must_use]
pub fn eval_a(c: &[Vec3A; COEFFS], d: Vec3) -> Vec3A {
    let y = basis(d);
    let t = |i: usize| c[i] * y[i];
    // summed as a tree, so a single lookup waits for four additions, not eight
    let sum = ((t(0) + t(1)) + (t(2) + t(3))) + ((t(4) + t(5)) + (t(6) + t(7))) + t(8);
    sum.max(Vec3A::ZERO)
}

/// Per texel of an N×N octahedral map, the nine integrals ∫ tap_t(ω) Y_i(ω) dω, where
/// tap_t is texel t's weight in [`octa::bilinear_taps`] (seams folded): the coefficients of
/// a map with texel values E_t are Σ_t E_t · `w[t][i]`. The integral is a midpoint sum over
/// 16×16 points per texel with the octahedral map's solid angle, dω = 4 du dv · ‖p‖₁³ / ‖p‖₂³
/// for the unit direction p, rescaled so the whole sum is exactly 4π.
#[must_use]
pub fn projection_weights(res: u32) -> Vec<[f64; COEFFS]> {
    const SUB: u32 = 16;
    let n = res.max(1);
    let fine = n * SUB;
    let mut w = vec![[0.0f64; COEFFS]; (n * n) as usize];
    let mut total = 0.0f64;
    let du = 1.0 / fine as f64;
    for j in 0..fine {
        for i in 0..fine {
            let uv = Vec2::new(((i as f64 + 0.5) * du) as f32, ((j as f64 + 0.5) * du) as f32);
            let d = octa::decode(uv);
            let l1 = (d.x.abs() + d.y.abs() + d.z.abs()) as f64;
            let domega = 4.0 * du * du * l1 * l1 * l1;
            total += domega;
            let y = basis(d);
            for (t, wt) in octa::bilinear_taps(n, uv) {
                let row = &mut w[t as usize];
                for k in 0..COEFFS {
                    row[k] += wt as f64 * y[k] as f64 * domega;
                }
            }
        }
    }
    let scale = 4.0 * std::f64::consts::PI / total;
    for row in &mut w {
        for x in row.iter_mut() {
            *x *= scale;
        }
    }
    w
}

/// The coefficients of one map (`texels` row-major, N² values) given its
/// [`projection_weights`], summed in texel order in f64.
#[must_use]
pub fn project(texels: &[Vec3], weights: &[[f64; COEFFS]]) -> [Vec3A; COEFFS] {
    let mut acc = [[0.0f64; 3]; COEFFS];
    for (e, w) in texels.iter().zip(weights) {
        let e = [e.x as f64, e.y as f64, e.z as f64];
        for k in 0..COEFFS {
            for c in 0..3 {
                acc[k][c] += e[c] * w[k];
            }
        }
    }
    acc.map(|a| Vec3A::new(a[0] as f32, a[1] as f32, a[2] as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_map_projects_to_band_zero_and_reads_back_exactly() {
        let w = projection_weights(8);
        let c = project(&vec![Vec3::new(1.0, 2.0, 3.0); 64], &w);
        assert!(
            (Vec3::from(c[0]) / (4.0 * std::f32::consts::PI).sqrt() - Vec3::new(1.0, 2.0, 3.0)).abs().max_element()
                < 1e-5
        );
        // the midpoint sum's own error, a few parts in 10⁵ of band 0
        for k in 1..COEFFS {
            assert!(c[k].abs().max_element() < 1e-4 * c[0].max_element(), "coefficient {k}: {:?}", c[k]);
        }
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.3, -0.5, 0.81).normalize()] {
            assert!((eval(&c, d) - Vec3::new(1.0, 2.0, 3.0)).abs().max_element() < 1e-3);
        }
    }

    #[test]
    fn a_band_two_function_sampled_on_a_map_projects_back_to_itself() {
        // E(d) = 1 + 0.5 z + 0.3 (3z² − 1) + 0.2 xy, sampled at texel centres, read back
        // through the projection at directions between texels
        let f = |d: Vec3| 1.0 + 0.5 * d.z + 0.3 * (3.0 * d.z * d.z - 1.0) + 0.2 * d.x * d.y;
        let res = 16;
        let texels: Vec<Vec3> =
            (0..res * res).map(|t| Vec3::splat(f(octa::texel_dir(res, t % res, t / res)))).collect();
        let c = project(&texels, &projection_weights(res));
        for d in [Vec3::Z, Vec3::NEG_Z, Vec3::new(0.6, 0.64, 0.48), Vec3::new(-0.36, 0.48, -0.8)] {
            let got = eval(&c, d).x;
            assert!((got - f(d)).abs() < 0.02 * f(d).abs().max(0.2), "{d}: {got} against {}", f(d));
        }
    }
}
