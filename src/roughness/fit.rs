//! Fitting the roughness correction with argmin (bake-side; the runtime only reads it).

use super::{Representation, RoughnessCorrection, RoughnessFit, Source, analytic};
use crate::sampling::ggx_d;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::brent::BrentOpt;
use argmin::solver::neldermead::NelderMead;

/// Samples of the plane radius (in units of the probe distance) used by the fit: up to
/// tan θ = 4 (76°), area-weighted.
const X_MAX: f64 = 4.0;
const X_SAMPLES: usize = 256;

fn footprint(alpha: f64, x: f64) -> f64 {
    let cos = 1.0 / (1.0 + x * x).sqrt();
    ggx_d(cos as f32, alpha as f32) as f64 * cos.powi(3)
}

/// Weighted least-squares residual of `s·C + o ≈ T` with the best s, o in closed form,
/// relative to Σ w T².
fn scale_offset_residual(target: &[f64], candidate: &[f64], weight: &[f64]) -> f64 {
    let (mut sw, mut sc, mut st, mut scc, mut sct, mut stt) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for ((t, c), w) in target.iter().zip(candidate).zip(weight) {
        sw += w;
        sc += w * c;
        st += w * t;
        scc += w * c * c;
        sct += w * c * t;
        stt += w * t * t;
    }
    let det = sw * scc - sc * sc;
    let (s, o) = if det.abs() > 1e-300 {
        ((sw * sct - sc * st) / det, (scc * st - sc * sct) / det)
    } else {
        (0.0, st / sw.max(1e-300))
    };
    let resid = stt - 2.0 * s * sct - 2.0 * o * st + s * s * scc + 2.0 * s * o * sc + o * o * sw;
    (resid.max(0.0) / stt.max(1e-300)).sqrt()
}

struct LobeProblem {
    target: Vec<f64>,
    xs: Vec<f64>,
    weight: Vec<f64>,
}

impl CostFunction for LobeProblem {
    type Param = f64;
    type Output = f64;
    fn cost(&self, alpha: &f64) -> Result<f64, Error> {
        let a = alpha.clamp(1e-3, 1.0);
        let cand: Vec<f64> = self.xs.iter().map(|&x| footprint(a, x)).collect();
        Ok(scale_offset_residual(&self.target, &cand, &self.weight))
    }
}

/// Best α' (and its relative residual) for surface roughness `alpha` and ratio `k`.
pub fn fit_alpha(alpha: f64, k: f64) -> (f64, f64) {
    let xs: Vec<f64> = (0..X_SAMPLES).map(|i| (i as f64 + 0.5) / X_SAMPLES as f64 * X_MAX).collect();
    let weight: Vec<f64> = xs.iter().map(|x| x * (X_MAX / X_SAMPLES as f64)).collect();
    let target: Vec<f64> = xs.iter().map(|&x| footprint(alpha, k * x) * k * k).collect();
    let problem = LobeProblem { target, xs, weight };
    let guess = (alpha / k).clamp(1e-3, 1.0);
    let res = Executor::new(problem, BrentOpt::new(1e-3, 1.0).set_tolerance(1e-6, 1e-8))
        .configure(|s| s.param(guess).max_iters(100))
        .run();
    match res {
        Ok(r) => {
            let st = r.state();
            (st.get_best_param().copied().unwrap_or(guess).clamp(1e-3, 1.0), st.get_best_cost())
        }
        Err(_) => (guess, f64::NAN),
    }
}

struct ModelProblem<'a> {
    samples: &'a [(f64, f64, f64)],
}

impl CostFunction for ModelProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        let e: f64 = self.samples.iter().map(|&(a, k, target)| (analytic(p[0], p[1], a, k) - target).powi(2)).sum();
        Ok((e / self.samples.len().max(1) as f64).sqrt())
    }
}

/// Fits the table over α ∈ [0.02, 1] × k ∈ [1/8, 8] and the analytic model, and measures
/// both on held-out (α, k) between the grid points.
pub fn fit_correction() -> RoughnessCorrection {
    let alphas: Vec<f32> = (0..12).map(|i| 0.02 + 0.98 * (i as f32 / 11.0).powi(2)).collect();
    let ratios: Vec<f32> = (0..13).map(|j| libm::powf(2f32, -3.0 + 6.0 * j as f32 / 12.0)).collect();
    let mut table = Vec::new();
    let mut lobe_residual = Vec::new();
    let mut samples = Vec::new();
    for &a in &alphas {
        for &k in &ratios {
            let (ap, r) = fit_alpha(a as f64, k as f64);
            table.push(ap as f32);
            lobe_residual.push(r as f32);
            samples.push((a as f64, k as f64, ap));
        }
    }
    let simplex = vec![vec![1.0, 1.0], vec![1.2, 1.0], vec![1.0, 0.8]];
    let (c0, c1) = NelderMead::new(simplex)
        .with_sd_tolerance(1e-10)
        .ok()
        .and_then(|nm| Executor::new(ModelProblem { samples: &samples }, nm).configure(|s| s.max_iters(400)).run().ok())
        .and_then(|r| r.state().get_best_param().cloned())
        .map_or((1.0, 1.0), |p| (p[0], p[1]));
    let fit = RoughnessFit {
        alphas,
        ratios,
        table,
        lobe_residual,
        c0: c0 as f32,
        c1: c1 as f32,
        heldout_rms_table: 0.0,
        heldout_rms_analytic: 0.0,
        chosen: Representation::Table,
        source: Source::AnalyticLobes,
        heldout_scene: None,
        irradiance_weight: Vec::new(),
    };
    let corr = RoughnessCorrection::try_from(fit.clone()).expect("the fitted axes are finite and increasing");
    // Held-out points: midway between table nodes (in α and log k).
    let (mut et, mut ea, mut n) = (0.0, 0.0, 0.0);
    for i in 0..fit.alphas.len() - 1 {
        for j in 0..fit.ratios.len() - 1 {
            let a = 0.5 * (fit.alphas[i] + fit.alphas[i + 1]);
            let k = (fit.ratios[j] * fit.ratios[j + 1]).sqrt();
            let (truth, _) = fit_alpha(a as f64, k as f64);
            et += (corr.from_table(a, k) as f64 - truth).powi(2);
            ea += (corr.analytic(a, k) as f64 - truth).powi(2);
            n += 1.0;
        }
    }
    let (heldout_rms_table, heldout_rms_analytic) = ((et / n).sqrt(), (ea / n).sqrt());
    let chosen =
        if heldout_rms_table <= heldout_rms_analytic { Representation::Table } else { Representation::Analytic };
    RoughnessCorrection::try_from(RoughnessFit { heldout_rms_table, heldout_rms_analytic, chosen, ..fit })
        .expect("validated above")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_leaves_the_scene_fit_only_for_a_clear_flip_win() {
        use crate::roughness::{PerRule, RowRule};
        let s = |scene_fit, lobes, engine, plain| PerRule { scene_fit, lobes, engine, plain };
        let se = s(0.0, 0.01, 0.01, 0.01);
        // engine lower by 0.05 > 2·0.01: clear; lobes lower by 0.01 < 0.02: not
        assert_eq!(s(0.30, 0.29, 0.25, 0.40).chosen_with(&se), RowRule::Engine);
        assert_eq!(s(0.30, 0.29, 0.285, 0.40).chosen_with(&se), RowRule::SceneFit);
        // of two clear wins the lower; equal ones: the earlier rule
        assert_eq!(s(0.30, 0.20, 0.25, 0.40).chosen_with(&se), RowRule::Lobes);
        assert_eq!(s(0.30, 0.20, 0.20, 0.20).chosen_with(&se), RowRule::Lobes);
        // non-finite scores or errors never win
        assert_eq!(s(0.30, f64::NAN, 0.1, 0.2).chosen_with(&s(0.0, 0.0, f64::INFINITY, f64::NAN)), RowRule::SceneFit);
        assert_eq!(s(f64::NAN, 0.1, 0.1, 0.1).chosen_with(&se), RowRule::SceneFit);
    }

    #[test]
    fn equal_distances_need_no_correction() {
        for a in [0.05, 0.2, 0.5, 0.9] {
            let (ap, r) = fit_alpha(a, 1.0);
            assert!((ap - a).abs() < 2e-3 * a.max(0.1), "{a} → {ap}");
            assert!(r < 1e-3, "residual {r}");
        }
    }

    #[test]
    fn narrow_lobes_scale_with_the_distance_ratio() {
        // For small α the footprint depends on tanθ/α only, so α' = α / k.
        for k in [0.5, 2.0, 4.0] {
            let a = 0.04;
            let (ap, _) = fit_alpha(a, k);
            assert!((ap - a / k).abs() < 0.05 * a / k, "k {k}: {ap} vs {}", a / k);
        }
    }

    #[test]
    fn pseudo_log2_is_monotone_and_inverts() {
        let mut last = f32::NEG_INFINITY;
        for t in 0..=4000 {
            let k = libm::powf(2f32, -8.0 + 16.0 * t as f32 / 4000.0);
            let x = super::super::pseudo_log2(k);
            assert!(x >= last, "{k}");
            last = x;
            let back = super::super::pseudo_exp2(x);
            assert!((back - k).abs() <= 1e-6 * k, "{k} → {x} → {back}");
        }
        for e in -6..6 {
            assert_eq!(super::super::pseudo_log2(2f32.powi(e)), e as f32);
        }
    }

    #[test]
    fn the_lane_lookup_is_the_single_lookup_bit_for_bit() {
        use crate::octa::LANES;
        let c = fit_correction();
        // a sweep over and past both axes, and every degenerate input, in groups of lanes
        let mut inputs: Vec<(f32, f32)> = Vec::new();
        for i in 0..=50 {
            for j in 0..=70 {
                inputs.push((-0.1 + 1.2 * i as f32 / 50.0, libm::powf(2f32, -8.0 + 16.0 * j as f32 / 70.0)));
            }
        }
        let odd = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, -1.0, f32::MIN_POSITIVE, 1e-40, f32::MAX];
        for &x in &odd {
            for &y in &odd {
                inputs.push((x, y));
            }
            inputs.push((x, 1.5));
            inputs.push((0.5, x));
        }
        for group in inputs.chunks(LANES) {
            let (mut r, mut k) = ([0.0f32; LANES], [1.0f32; LANES]);
            for (l, &(x, y)) in group.iter().enumerate() {
                (r[l], k[l]) = (x, y);
            }
            let lanes = c.corrected_roughness_lanes(&r, &k);
            for l in 0..LANES {
                assert_eq!(lanes[l].to_bits(), c.corrected_roughness(r[l], k[l]).to_bits(), "r {}, k {}", r[l], k[l]);
            }
        }
    }

    #[test]
    fn the_resampled_lookup_follows_the_exact_correction() {
        let c = fit_correction();
        let mut worst = 0.0f32;
        // from the first node on (below it the lookup blends to the mirror's 0 at r = 0)
        for i in 0..=40 {
            let r = 1.0 / 32.0 + (1.0 - 1.0 / 32.0) * i as f32 / 40.0;
            for j in 0..=60 {
                let k = libm::powf(2f32, -3.0 + 6.0 * j as f32 / 60.0);
                let exact = c.corrected_alpha(r * r, k).sqrt();
                let fast = c.corrected_roughness(r, k);
                assert!(fast.is_finite() && (0.0..=1.0).contains(&fast));
                worst = worst.max((fast - exact).abs());
            }
        }
        assert!(worst < 0.02, "largest difference in perceptual roughness {worst}");
        // outside the table's k range: clamped; degenerate inputs: finite
        assert_eq!(c.corrected_roughness(0.5, 1e9), c.corrected_roughness(0.5, 8.0));
        for (r, k) in [(f32::NAN, 1.0), (0.5, f32::NAN), (0.5, 0.0), (0.5, -1.0), (2.0, 1.0), (0.5, f32::INFINITY)] {
            assert!(c.corrected_roughness(r, k).is_finite(), "{r} {k}");
        }
    }
}
