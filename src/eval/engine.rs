//! `engine-blend`: how engines light a level with several reflection probes (Lagarde &
//! Zanuttini 2012, "Local image-based lighting with parallax-corrected cubemaps"; Unity's
//! and Unreal's reflection probes): each probe has a box proxy it is parallax-corrected
//! against and an influence volume, and a shading point blends the probes whose influence
//! holds it, weighted by how deep inside it lies.
//!
//! Nobody authored boxes for these probes, so each is fitted to what the probe sees, as an
//! artist would draw it around the probe's room: the axis-aligned box of the points its
//! distance map sees, between the [`BOX_QUANTILE`] and `1 − BOX_QUANTILE` quantiles per axis
//! (the few points seen through a door or a window do not stretch it), grown to hold the
//! probe. The influence volume is the same box; its weight is 1 deeper inside than
//! [`FALLOFF`] of the box's smallest extent from every face, falling linearly to 0 at the
//! faces (Lagarde's box influence). Weights are normalised; a point no influence holds takes
//! the probe whose box is nearest (the level's fallback probe).

use crate::octa;
use crate::warp::glossy::{Aim, Glossy, MipRule};
use crate::warp::proxy::BoxProxy;
use crate::warp::{Warp, WarpProbe};
use glam::Vec3;

/// The quantile a fitted box is cut at, per axis and side.
pub const BOX_QUANTILE: f64 = 0.02;
/// The influence's falloff margin, a fraction of the box's smallest extent.
pub const FALLOFF: f32 = 0.1;

/// The probes of a warp with their fitted boxes.
pub struct EngineBlend {
    pub boxes: Vec<(Vec3, Vec3)>,
    proxies: Vec<BoxProxy>,
}

/// The box a probe's distance map fits (see the module docs).
#[must_use]
pub fn fitted_box(p: &WarpProbe) -> (Vec3, Vec3) {
    let level = &p.inv_depth.levels[0];
    let mut axes: [Vec<f32>; 3] = Default::default();
    for (t, &w) in level.texels.iter().enumerate() {
        if !(w > 0.0 && w.is_finite()) {
            continue;
        }
        let dir = octa::texel_dir(level.res, t as u32 % level.res, t as u32 / level.res);
        let x = p.position + dir / w;
        for (c, axis) in axes.iter_mut().enumerate() {
            axis.push(x[c]);
        }
    }
    if axes[0].is_empty() {
        return (p.position - Vec3::ONE, p.position + Vec3::ONE);
    }
    let (mut lo, mut hi) = (p.position, p.position);
    for (c, axis) in axes.iter_mut().enumerate() {
        axis.sort_by(f32::total_cmp);
        let at = |q: f64| axis[((axis.len() - 1) as f64 * q).round() as usize];
        lo[c] = lo[c].min(at(BOX_QUANTILE));
        hi[c] = hi[c].max(at(1.0 - BOX_QUANTILE));
    }
    // never flat: a probe that sees one wall still gets a box around it
    let pad = Vec3::splat(1e-3 * (hi - lo).max_element().max(1e-3));
    (lo - pad, hi + pad)
}

/// How deep `b` lies inside box (`lo`, `hi`): 1 beyond the falloff margin, 0 outside.
#[must_use]
pub fn influence(b: Vec3, (lo, hi): (Vec3, Vec3)) -> f32 {
    let margin = FALLOFF * (hi - lo).min_element();
    let depth = (b - lo).min(hi - b).min_element();
    if !(depth > 0.0) {
        return 0.0;
    }
    if margin > 0.0 { (depth / margin).min(1.0) } else { 1.0 }
}

impl EngineBlend {
    /// The probes of `warp` with their fitted boxes.
    #[must_use]
    pub fn of(warp: &Warp) -> EngineBlend {
        let boxes: Vec<(Vec3, Vec3)> = (0..warp.probe_count()).map(|k| fitted_box(warp.probe_at(k))).collect();
        let proxies = boxes.iter().map(|&(lo, hi)| BoxProxy::aabb(lo, hi)).collect();
        EngineBlend { boxes, proxies }
    }

    /// The blend's radiance for query (B, unit `dir`, roughness `r`), each probe
    /// box-projected against its own box and read with mip rule `rule`: the probes whose
    /// influence holds B, weighted by it and normalised, or, outside every influence, the
    /// probe whose box is nearest.
    #[must_use]
    pub fn radiance(&self, shading: Glossy, rule: MipRule, b: Vec3, dir: Vec3, r: f32) -> Vec3 {
        let read = |k: usize| {
            let a = shading.warp.probe_at(k).position;
            let v = self.proxies[k].fetch_dir(a, b, dir);
            shading.radiance(rule, b, dir, Aim { v, k: None, probe: k as u8 }, r)
        };
        let sum: f32 = self.boxes.iter().map(|&bx| influence(b, bx)).sum();
        if !(sum > 0.0) {
            let gap = |(lo, hi): (Vec3, Vec3)| (lo - b).max(b - hi).max(Vec3::ZERO).length_squared();
            let nearest =
                (0..self.boxes.len()).min_by(|&i, &j| gap(self.boxes[i]).total_cmp(&gap(self.boxes[j]))).unwrap_or(0);
            return read(nearest);
        }
        let mut out = Vec3::ZERO;
        for (k, &bx) in self.boxes.iter().enumerate() {
            let w = influence(b, bx);
            if w > 0.0 {
                out += (w / sum) * read(k);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn influence_is_one_inside_the_margin_and_zero_outside() {
        let bx = (Vec3::ZERO, Vec3::splat(10.0));
        assert_eq!(influence(Vec3::splat(5.0), bx), 1.0);
        assert_eq!(influence(Vec3::new(0.5, 5.0, 5.0), bx), 0.5);
        assert_eq!(influence(Vec3::new(-0.1, 5.0, 5.0), bx), 0.0);
        assert_eq!(influence(Vec3::NAN, bx), 0.0);
    }
}
