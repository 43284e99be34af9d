//! GGX distance-ratio roughness correction (seed 002, "Notes on GGX parallax correction").
//!
//! A prefiltered probe stores, per direction, the GGX lobe as seen from the probe centre; a
//! parallax-corrected lookup from a surface point wants the lobe as seen from the surface.
//! Projected on a plane perpendicular to the lobe at the hit (distance `d_probe` from the
//! probe, `d_surface` from the surface), the two footprints differ: a lobe farther away
//! covers more of the plane. With `k = d_probe / d_surface`, for each (α, k) we fit the
//! probe-side roughness α' whose projected footprint, up to a scale and an additive offset
//! (the seed's fitting aid; only α' is used at runtime, a single prefiltered fetch cannot
//! apply the offset), best matches the surface's footprint. Two representations of
//! α'(α, k) are fitted and measured on held-out (α, k): a small 2-D table (bilinear in α and
//! log k) and the analytic `α' = min(1, c0 · α · k^−c1)` (Nelder-Mead).
//!
//! Footprint of a lobe of roughness α at distance d on the plane, at radius r = d·tanθ:
//! `D_α(θ) · cos³θ / d²` (GGX D of Walter et al. 2007; cos³θ/d² converts solid angle to plane
//! area). In probe units x = r / d_probe the surface footprint is `D_α(atan(k·x)) ·
//! cos³(atan(k·x)) · k²` (up to the common 1/d_probe²).

#[cfg(feature = "bake")]
mod fit;
#[cfg(feature = "bake")]
pub use fit::*;

use serde::{Deserialize, Serialize};

/// The fitted correction, both representations, and their measured residuals.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoughnessCorrection {
    /// Table axes: α (GGX alpha = perceptual²) and k = d_probe / d_surface (log-spaced).
    pub alphas: Vec<f32>,
    pub ratios: Vec<f32>,
    /// α' per (α row, k column), row-major.
    pub table: Vec<f32>,
    /// Relative lobe residual of each table entry (scale+offset fit).
    pub lobe_residual: Vec<f32>,
    /// Analytic model α' = min(1, c0 · α · k^−c1).
    pub c0: f32,
    pub c1: f32,
    /// RMS error in α' on held-out (α, k) pairs: table (bilinear) and analytic.
    pub heldout_rms_table: f64,
    pub heldout_rms_analytic: f64,
    /// Which representation the sampler should use (the lower held-out error).
    pub chosen: String,
}

impl RoughnessCorrection {
    /// α' from the table, bilinear in α and log k, clamped to the table's range.
    pub fn from_table(&self, alpha: f32, k: f32) -> f32 {
        let k = if k > 0.0 { k } else { self.ratios.first().copied().unwrap_or(1.0) };
        table_lookup(&self.alphas, &self.ratios, f32::ln, &self.table, alpha, k.ln())
    }

    pub fn analytic(&self, alpha: f32, k: f32) -> f32 {
        analytic(self.c0 as f64, self.c1 as f64, alpha as f64, k as f64) as f32
    }

    /// The chosen representation.
    pub fn corrected_alpha(&self, alpha: f32, k: f32) -> f32 {
        if !alpha.is_finite() {
            return 1e-3;
        }
        if !(k.is_finite() && k > 0.0) {
            return alpha.clamp(1e-3, 1.0);
        }
        if self.chosen == "table" { self.from_table(alpha, k) } else { self.analytic(alpha, k) }
    }
}

/// Bilinear lookup of an α-row, k-column table, clamped to its range: linear in α, linear in
/// ln k. `k_axis` is read through `key` (`f32::ln` for stored ratios, the identity for an
/// axis already in logs, as the runtime keeps it). Always finite, in [1e-3, 1].
#[inline]
pub fn table_lookup(
    alphas: &[f32],
    k_axis: &[f32],
    key: impl Fn(f32) -> f32,
    table: &[f32],
    alpha: f32,
    log_k: f32,
) -> f32 {
    let (na, nk) = (alphas.len(), k_axis.len());
    if na < 2 || nk < 2 || table.len() != na * nk {
        return alpha.clamp(1e-3, 1.0);
    }
    let (i, fa) = bracket(na, |t| alphas[t], alpha);
    let (j, fk) = bracket(nk, |t| key(k_axis[t]), log_k);
    let at = |i: usize, j: usize| table[i * nk + j];
    let v = (at(i, j) * (1.0 - fk) + at(i, j + 1) * fk) * (1.0 - fa)
        + (at(i + 1, j) * (1.0 - fk) + at(i + 1, j + 1) * fk) * fa;
    if v.is_finite() { v.clamp(1e-3, 1.0) } else { alpha.clamp(1e-3, 1.0) }
}

/// Node interval of `v` on an increasing axis of `n` nodes read through `node`, and the
/// fraction within it. Branch-free: counts the nodes at or below v (axes are a dozen long).
#[inline]
fn bracket(n: usize, node: impl Fn(usize) -> f32, v: f32) -> (usize, f32) {
    let v = v.clamp(node(0), node(n - 1));
    let i = (0..n).map(|t| (node(t) <= v) as usize).sum::<usize>().clamp(1, n - 1) - 1;
    let f = (v - node(i)) / (node(i + 1) - node(i));
    (i, if f.is_finite() { f.clamp(0.0, 1.0) } else { 0.0 })
}

pub(crate) fn analytic(c0: f64, c1: f64, alpha: f64, k: f64) -> f64 {
    (c0 * alpha * k.powf(-c1)).clamp(1e-3, 1.0)
}
