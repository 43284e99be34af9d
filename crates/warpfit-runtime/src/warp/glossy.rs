//! Rough lookups of probe A: which prefiltered mip a lookup of perceptual roughness r reads,
//! and the radiance there. One implementation for the runtime sampler, the fit's objective
//! and the evaluation.
//!
//! A prefiltered mip holds the GGX lobe as seen from the probe; a parallax-corrected lookup
//! from a surface point wants the lobe as seen from that point (seed 002). The rules that
//! pick the mip ([`MipRule`]):
//! - `Plain`: the mip of r itself, as engines do without parallax awareness;
//! - `Engine`: the distance-based roughness engines ship, from Frostbite (Lagarde & de
//!   Rousiers 2014, "Moving Frostbite to Physically Based Rendering 3.0", §4.9.3, Listing 25;
//!   Unity HDRP's `ComputeDistanceBaseRoughness` is the same):
//!   `r' = lerp(clamp(r · d_surface / d_probe, 0, r), r, r)`;
//! - `Corrected`: the fitted distance-ratio correction `α' = f(α, k)`, `k = d_probe / d_surface`;
//! - `Fade`: the plain mip, with the fetch direction faded towards the query direction as
//!   r grows, `normalize(lerp(v̂, dir, r))` (seed 002: what people do by eye).
//!
//! Distances: a lookup that aims at a point (a corrective map's hit estimate) knows both
//! distances: `d_probe` from A to the point, `d_surface` from the shading point to it, with
//! no further fetch ([`Aim::k`]). Otherwise the hit estimate is where probe A sees along the
//! fetch direction, at the warp's depth mip, and `d_surface` is from the shading point to
//! that point. Sky (no finite hit) means k = 1: both lobes project to infinity alike.

use super::{Warp, WarpProbe};
use crate::octa;
use crate::roughness::RoughnessCorrection;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// How a rough lookup picks its mip.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MipRule {
    Plain,
    Engine,
    Corrected,
    Fade,
}

impl MipRule {
    pub const ALL: [MipRule; 4] = [MipRule::Plain, MipRule::Engine, MipRule::Corrected, MipRule::Fade];

    pub fn name(self) -> &'static str {
        match self {
            MipRule::Plain => "plain",
            MipRule::Engine => "engine",
            MipRule::Corrected => "corrected",
            MipRule::Fade => "fade",
        }
    }
}

impl WarpProbe {
    /// Fractional radiance mip of perceptual roughness `r` (linear between the mips' values,
    /// clamped to the chain; NaN reads as 0). For the chain every bake writes (mip m at
    /// r = m / (n − 1)) that is r · (n − 1) itself: one product, where a search and a
    /// division sat on every rough lookup's critical path.
    #[inline]
    #[must_use]
    pub fn lod_of_roughness(&self, r: f32) -> f32 {
        if let Some(n) = self.uniform_lods {
            return lod_on_even_chain(r, n);
        }
        let m = self.mip_roughness();
        if m.len() < 2 || !(r > m[0]) {
            return 0.0;
        }
        let last = m.len() - 1;
        if r >= m[last] {
            return last as f32;
        }
        // the mip below r: the last node ≤ r (m[0] < r < m[last], so 0 ≤ i < last)
        let i = m.iter().map(|&x| (x <= r) as usize).sum::<usize>().clamp(1, last) - 1;
        let span = m[i + 1] - m[i];
        let f = if span > 0.0 { (r - m[i]) / span } else { 0.0 };
        i as f32 + f.clamp(0.0, 1.0)
    }

    /// Distance ratio k = d_probe / d_surface of the point the probe sees along fetch vector
    /// `v` (whose octahedral coordinate is `uv`) at depth mip `depth_lod`, seen from `b`.
    /// 1 for sky and wherever a distance degenerates.
    #[inline]
    #[must_use]
    pub fn distance_ratio(&self, b: Vec3, v: Vec3, uv: Vec2, depth_lod: f32) -> f32 {
        let l = v.length();
        let w = self.inv_depth.sample_lod_uv(uv, depth_lod);
        if !(l > 0.0 && l.is_finite() && w > 0.0 && w.is_finite()) {
            return 1.0; // sky: both distances infinite
        }
        let d_probe = 1.0 / w;
        let d_surface = (self.position + v * (d_probe / l) - b).length();
        let k = d_probe / d_surface;
        if k.is_finite() && k > 0.0 { k } else { 1.0 }
    }
}

/// The mip of perceptual roughness `r` on a chain whose mip m has roughness m / n: r · n,
/// clamped to the chain (NaN and r ≤ 0 read mip 0, r past the chain its last mip).
#[inline(always)]
fn lod_on_even_chain(r: f32, n: f32) -> f32 {
    let lod = r * n;
    let lod = if lod > 0.0 { lod } else { 0.0 };
    lod.min(n)
}

/// Where a lookup reads: which probe (`Warp::probe_at`; 0 = probe A), the fetch vector `v`
/// and, when the lookup aimed at a known point, its distance ratio
/// `k = d_probe / d_surface` (`None`: read the probe's depth along `v`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aim {
    pub v: Vec3,
    pub k: Option<f32>,
    pub probe: u8,
}

impl From<Vec3> for Aim {
    #[inline]
    fn from(v: Vec3) -> Aim {
        Aim { v, k: None, probe: 0 }
    }
}

impl Aim {
    /// The distance ratio of the aimed point seen from `b` (see the module docs).
    #[inline]
    #[must_use]
    pub fn ratio(&self, warp: &Warp, b: Vec3, uv: Vec2) -> f32 {
        match self.k {
            Some(k) => k,
            None => warp.probe_at(self.probe.into()).distance_ratio(b, self.v, uv, warp.options.depth_lod),
        }
    }
}

/// What a rough lookup shades with: the warp context (probe A and the depth mip distances
/// are read at) and the distance-ratio correction of the `Corrected` rule.
#[derive(Clone, Copy, Debug)]
pub struct Glossy<'a> {
    pub warp: &'a Warp,
    pub correction: Option<&'a RoughnessCorrection>,
}

impl Glossy<'_> {
    /// [`glossy_radiance`] with this context.
    #[inline]
    #[must_use]
    pub fn radiance(&self, rule: MipRule, b: Vec3, dir: Vec3, aim: impl Into<Aim>, r: f32) -> Vec3 {
        glossy_radiance(self.warp, self.correction, rule, b, dir, aim.into(), r)
    }
}

/// Frostbite's distance-based roughness (see the module docs) for distance ratio k.
#[inline]
#[must_use]
pub fn engine_roughness(r: f32, k: f32) -> f32 {
    let reduced = (r / k).clamp(0.0, r);
    let out = reduced + (r - reduced) * r;
    if out.is_finite() { out } else { r }
}

/// Radiance of probe A for the query (B, unit `dir`, perceptual roughness `r`) fetched along
/// `aim` (the method's fetch vector and what it knows of distances), the mip picked by `rule`. `Corrected` without a
/// correction reads the plain mip. A mirror query (r = 0) reads mip 0 along `v` whatever
/// the rule.
#[inline]
#[must_use]
pub fn glossy_radiance(
    warp: &Warp,
    correction: Option<&RoughnessCorrection>,
    rule: MipRule,
    b: Vec3,
    dir: Vec3,
    aim: Aim,
    r: f32,
) -> Vec3 {
    let probe = warp.probe_at(aim.probe.into());
    let v = aim.v;
    if r == 0.0 {
        return probe.radiance(v);
    }
    let (v, r_mip) = match rule {
        MipRule::Plain => (v, r),
        MipRule::Fade => {
            let u = v.normalize_or(dir);
            let faded = u + (dir - u) * r;
            (faded.try_normalize().unwrap_or(dir), r)
        }
        MipRule::Engine => {
            let k = aim.ratio(warp, b, octa::encode(v));
            (v, engine_roughness(r, k))
        }
        MipRule::Corrected => match correction {
            Some(c) => {
                let uv = octa::encode(v);
                let k = aim.ratio(warp, b, uv);
                let rough = c.corrected_roughness(r, k);
                return probe.radiance.sample_lod_uv_inline(uv, probe.lod_of_roughness(rough));
            }
            None => (v, r),
        },
    };
    probe.radiance.sample_lod_uv(octa::encode(v), probe.lod_of_roughness(r_mip))
}

/// [`glossy_radiance`] under the `Corrected` rule for [`octa::LANES`] lookups aimed at known
/// points (fetch vectors `v` as components, distance ratios `k`, perceptual roughness `r`),
/// bit for bit the same values, in stages over the lanes: the octahedral coordinates, each
/// lane's mip (a mirror lane reads mip 0), then the trilinear reads side by side. Shared by
/// the runtime's batches and the fit's objective.
#[inline(always)]
#[must_use]
pub fn corrected_lanes(
    probe: &WarpProbe,
    correction: Option<&RoughnessCorrection>,
    r: &[f32; octa::LANES],
    v: &octa::Soa3,
    k: &[f32; octa::LANES],
) -> [Vec3; octa::LANES] {
    let uv = octa::encode_soa(v);
    let rough = match correction {
        None => *r,
        Some(c) => c.corrected_roughness_lanes(r, k),
    };
    let mut lod = [0.0f32; octa::LANES];
    match probe.uniform_lods {
        // `lod_of_roughness`'s evenly spaced chain, for all lanes at once
        Some(n) => {
            for l in 0..octa::LANES {
                let at = lod_on_even_chain(rough[l], n);
                lod[l] = if r[l] == 0.0 { 0.0 } else { at };
            }
        }
        None => {
            for l in 0..octa::LANES {
                lod[l] = if r[l] == 0.0 { 0.0 } else { probe.lod_of_roughness(rough[l]) };
            }
        }
    }
    probe.radiance.sample_each_lod_uv_lanes(&uv, &lod)
}

/// [`corrected_lanes`] with lane l reading probe `probes[l]` (several probes), bit for bit
/// what each lane's own probe answers.
#[inline(always)]
#[must_use]
pub fn corrected_lanes_of(
    probes: &[&WarpProbe; octa::LANES],
    correction: Option<&RoughnessCorrection>,
    r: &[f32; octa::LANES],
    v: &octa::Soa3,
    k: &[f32; octa::LANES],
) -> [Vec3; octa::LANES] {
    let uv = octa::encode_soa(v);
    let lod = corrected_lods(probes, correction, r, k);
    let chains: [&octa::OctMips<Vec3>; octa::LANES] = std::array::from_fn(|l| &probes[l].radiance);
    octa::OctMips::sample_each_lod_uv_lanes_of(&chains, &uv, &lod)
}

/// Each lane's radiance mip under the `Corrected` rule (a mirror lane reads mip 0), lane l
/// on probe `probes[l]`'s chain.
#[inline(always)]
fn corrected_lods(
    probes: &[&WarpProbe; octa::LANES],
    correction: Option<&RoughnessCorrection>,
    r: &[f32; octa::LANES],
    k: &[f32; octa::LANES],
) -> [f32; octa::LANES] {
    let rough = match correction {
        None => *r,
        Some(c) => c.corrected_roughness_lanes(r, k),
    };
    let mut lod = [0.0f32; octa::LANES];
    for l in 0..octa::LANES {
        lod[l] = match probes[l].uniform_lods {
            // `lod_of_roughness`'s evenly spaced chain
            Some(n) => lod_on_even_chain(rough[l], n),
            None => probes[l].lod_of_roughness(rough[l]),
        };
        if r[l] == 0.0 {
            lod[l] = 0.0;
        }
    }
    lod
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mip_of_a_baked_chain_is_the_product_and_the_searchs_mip_to_rounding() {
        use crate::octa::{OctMap, OctMips};
        // the general rule, as it reads any increasing chain
        let search = |m: &[f32], r: f32| -> f32 {
            if !(r > m[0]) {
                return 0.0;
            }
            let last = m.len() - 1;
            if r >= m[last] {
                return last as f32;
            }
            let i = m.iter().map(|&x| (x <= r) as usize).sum::<usize>().clamp(1, last) - 1;
            let f = (r - m[i]) / (m[i + 1] - m[i]);
            i as f32 + f.clamp(0.0, 1.0)
        };
        let probe_of = |chain: Vec<f32>| {
            let one = OctMips { levels: vec![OctMap::new(1, vec![1.0f32])] };
            WarpProbe::from_distance_mips(
                Vec3::ZERO,
                &one,
                OctMips { levels: vec![OctMap::new(1, vec![Vec3::ONE])] },
                chain,
            )
        };
        for n in [2usize, 3, 6, 7, 9] {
            let chain: Vec<f32> = (0..n).map(|m| m as f32 / (n - 1) as f32).collect();
            let probe = probe_of(chain.clone());
            assert!(probe.uniform_lods.is_some());
            // every node, its neighbouring floats, and a fine sweep
            let mut rs: Vec<f32> =
                chain.iter().flat_map(|&x| [x, f32::from_bits(x.to_bits() + 1), x.next_down()]).collect();
            rs.extend((0..=10_000).map(|t| t as f32 / 10_000.0));
            for r in rs {
                let (fast, slow) = (probe.lod_of_roughness(r), search(&chain, r));
                assert_eq!(fast, (r * (n - 1) as f32).clamp(0.0, (n - 1) as f32), "n = {n}, r = {r}");
                assert!((fast - slow).abs() <= 4.0 * f32::EPSILON * n as f32, "n = {n}, r = {r}: {fast} vs {slow}");
                // a whole mip at its own node
                if let Some(m) = chain.iter().position(|&x| x == r) {
                    assert_eq!(fast, m as f32);
                }
            }
            for (r, lod) in [(-1.0, 0.0), (0.0, 0.0), (-0.0, 0.0), (1.0, (n - 1) as f32), (2.0, (n - 1) as f32)] {
                assert_eq!(probe.lod_of_roughness(r), lod);
            }
            for r in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE] {
                let lod = probe.lod_of_roughness(r);
                assert!(lod.is_finite() && (0.0..=(n - 1) as f32).contains(&lod), "r = {r}: {lod}");
            }
        }
        // any other chain: the search
        let chain = vec![0.0, 0.1, 0.5, 1.0];
        let probe = probe_of(chain.clone());
        assert!(probe.uniform_lods.is_none());
        for t in 0..=1000 {
            let r = t as f32 / 1000.0;
            assert_eq!(probe.lod_of_roughness(r).to_bits(), search(&chain, r).to_bits(), "r = {r}");
        }
    }

    #[test]
    fn the_engine_rule_is_frostbites() {
        // a surface twice as near the hit as the probe halves the roughness, then blends back
        // towards r by r itself
        let r = 0.4f32;
        assert!((engine_roughness(r, 2.0) - (0.2 + 0.2 * 0.4)).abs() < 1e-6);
        // never rougher than r, equal to r at k ≤ 1 and at r = 1
        assert_eq!(engine_roughness(r, 0.5), r);
        assert_eq!(engine_roughness(1.0, 8.0), 1.0);
        assert_eq!(engine_roughness(0.0, 3.0), 0.0);
        assert!(engine_roughness(r, f32::INFINITY).is_finite());
    }
}
