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

use crate::octa::LANES;
use serde::{Deserialize, Serialize};

/// Which representation of α'(α, k) a correction uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Representation {
    /// Bilinear in α and ln k over the fitted table.
    Table,
    /// `α' = min(1, c0 · α · k^−c1)`.
    Analytic,
}

/// The fitted correction as stored (`roughness.json`, the grid manifest's `roughness`):
/// both representations, their measured residuals, and the choice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughnessFit {
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
    /// Which representation the sampler uses (the lower held-out error).
    pub chosen: Representation,
    /// What the chosen correction was fitted to.
    #[serde(default)]
    pub source: Source,
    /// Tone-mapped RMSE of the scene's held-out rough lookups through the fitted grid for
    /// each candidate, when the correction was chosen on the scene.
    #[serde(default)]
    pub heldout_scene: Option<SceneComparison>,
    /// Per row of `alphas`: the share of a rough lookup the runtime takes from the dense
    /// grid's irradiance for the lookup's direction (over π) instead of probe A
    /// ([`RoughnessCorrection::irradiance_weight`]); linear in perceptual roughness between
    /// the rows. Empty: probe A alone (every grid fitted before the blend, and corrections
    /// not fitted to a scene).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub irradiance_weight: Vec<f32>,
}

/// What a roughness correction was fitted to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Analytic GGX lobes projected on planes (seed 002's derivation; any scene).
    #[default]
    AnalyticLobes,
    /// This scene's own GGX references through the fitted grid's lookups.
    SceneReferences,
}

/// How the candidate corrections did on a scene's held-out rough lookups (tone-mapped RMSE).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneComparison {
    pub lookups: usize,
    /// The mip of r itself.
    pub plain: f64,
    /// Frostbite's distance-based roughness.
    pub engine: f64,
    /// The analytic-lobe fit (table or analytic form, as chosen on lobes).
    pub lobe_fit: f64,
    /// The table fitted to the scene's references.
    pub scene_fit: f64,
    /// Its exponents per fitted roughness: (k > 1, k < 1).
    pub scene_exponents: Vec<[f32; 2]>,
    /// The scene fit with the fitted irradiance blend ([`RoughnessFit::irradiance_weight`];
    /// absent when no blend was fitted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_fit_blended: Option<f64>,
    /// Per fitted roughness (the scene table's rows after α = 0): the rule the row holds,
    /// chosen by mean ꟻLIP on views rendered at held-out positions, and each candidate's
    /// scores. Empty in grids fitted before rows were chosen (every row the exponents').
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rows: Vec<RowChoice>,
}

/// What a row of the scene's table holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RowRule {
    /// `α' = c0·α·k^−e` with the exponents fitted to the scene's tone-mapped error.
    SceneFit,
    /// The analytic-lobe correction.
    Lobes,
    /// Frostbite's distance-based roughness.
    Engine,
    /// The mip of r itself.
    Plain,
}

impl RowRule {
    /// The candidates in the order ties are broken.
    pub const ALL: [RowRule; 4] = [RowRule::SceneFit, RowRule::Lobes, RowRule::Engine, RowRule::Plain];
}

/// A score per candidate rule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerRule {
    pub scene_fit: f64,
    pub lobes: f64,
    pub engine: f64,
    pub plain: f64,
}

impl PerRule {
    #[must_use]
    pub fn get(&self, rule: RowRule) -> f64 {
        match rule {
            RowRule::SceneFit => self.scene_fit,
            RowRule::Lobes => self.lobes,
            RowRule::Engine => self.engine,
            RowRule::Plain => self.plain,
        }
    }

    /// The scores of `f` per rule.
    pub fn from_fn(mut f: impl FnMut(RowRule) -> f64) -> PerRule {
        PerRule {
            scene_fit: f(RowRule::SceneFit),
            lobes: f(RowRule::Lobes),
            engine: f(RowRule::Engine),
            plain: f(RowRule::Plain),
        }
    }

    /// The row's rule from its views: the scene fit unless another rule's mean ꟻLIP
    /// (`self`) is lower than the scene fit's by more than twice `se`, the standard error of
    /// that rule's paired difference from the scene fit; of those that are, the lowest
    /// (ties: the earlier in [`RowRule::ALL`]). Non-finite scores never win.
    #[must_use]
    pub fn chosen_with(&self, se: &PerRule) -> RowRule {
        let base = self.scene_fit;
        let mut best = RowRule::SceneFit;
        for rule in RowRule::ALL {
            let (score, margin) = (self.get(rule), 2.0 * se.get(rule));
            let clear = score.is_finite() && margin.is_finite() && score + margin < base;
            if clear && (best == RowRule::SceneFit || score < self.get(best)) {
                best = rule;
            }
        }
        best
    }
}

/// One row of a scene table: its roughness, the rule chosen, and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RowChoice {
    /// Perceptual roughness of the row.
    pub roughness: f32,
    pub chosen: RowRule,
    /// Mean ꟻLIP of the views at this roughness per rule (all 0 when no view could be
    /// rendered: the row keeps the scene fit).
    pub flip: PerRule,
    /// Standard error of each rule's mean ꟻLIP difference from the scene fit's, over
    /// 8×8-pixel tiles of the views (paired: the same pixels, the same reference).
    pub flip_se: PerRule,
    /// Tone-mapped RMSE of the held-out rough lookups at this roughness per rule.
    pub tm_rmse: PerRule,
    /// Mean ꟻLIP of the views with the chosen rule's lookups blended with the irradiance:
    /// by the weight the row keeps, or when it keeps none, by the weight fitted for this
    /// roughness (absent: the fitted weight is 0). A row keeps the largest of the fitted
    /// weight, its half and its quarter whose views score no higher than the chosen rule's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flip_blended: Option<f64>,
}

/// A roughness correction ready to look up: validated (finite, increasing axes, a table of
/// the axes' size), with the table's log-k axis precomputed. Serialised as [`RoughnessFit`];
/// deserialising validates, so a malformed table never reaches a lookup.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RoughnessFit", into = "RoughnessFit")]
pub struct RoughnessCorrection {
    fit: RoughnessFit,
    log_ratios: Vec<f32>,
    lookup: Lookup,
    /// (perceptual roughness, weight) of each row with `irradiance_weight`, r increasing.
    blend: Vec<(f32, f32)>,
}

/// Nodes per axis of [`Lookup`].
const LOOKUP_NODES: usize = 33;

/// The chosen representation resampled for lookups: perceptual roughness r' of the mip to
/// read, on a uniform grid over perceptual r ∈ [0, 1] and over `pseudo_log2(k)` across the
/// table's k range, bilinear between nodes. Index arithmetic instead of searches and no
/// logarithm: a rough lookup's mip costs a few integer and float operations, the same on
/// every CPU. Its nodes are the exact correction; between nodes it differs from the exact
/// form by interpolation only (bounded in tests).
#[derive(Clone, Debug, PartialEq)]
struct Lookup {
    x0: f32,
    inv_dx: f32,
    k_min: f32,
    k_max: f32,
    /// r' per (r node, x node), row-major.
    values: Vec<f32>,
    /// The same nodes by interval: per (row, column) of the `(nodes − 1)²` intervals, its
    /// four corners `[(i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1)]`. A lookup reads one
    /// 16-byte entry instead of four scattered values, and the clamped interval index needs
    /// no bounds check: the rough lookup's gather is one load per lane.
    cells: Box<[[f32; 4]; LOOKUP_CELLS]>,
}

/// Intervals of [`Lookup`]'s grid.
const LOOKUP_CELLS: usize = (LOOKUP_NODES - 1) * (LOOKUP_NODES - 1);

/// Exponent plus the mantissa's fraction: monotone, continuous, exact at powers of two and
/// linear between them. For positive normal `k`.
#[inline]
#[must_use]
pub fn pseudo_log2(k: f32) -> f32 {
    let bits = k.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    e as f32 + (m - 1.0)
}

/// Inverse of [`pseudo_log2`].
#[must_use]
pub fn pseudo_exp2(x: f32) -> f32 {
    let e = x.floor();
    let pow = f32::from_bits(((e as i32 + 127).clamp(1, 254) as u32) << 23);
    (1.0 + (x - e)) * pow
}

impl std::ops::Deref for RoughnessCorrection {
    type Target = RoughnessFit;
    fn deref(&self) -> &RoughnessFit {
        &self.fit
    }
}

impl From<RoughnessCorrection> for RoughnessFit {
    fn from(c: RoughnessCorrection) -> RoughnessFit {
        c.fit
    }
}

impl TryFrom<RoughnessFit> for RoughnessCorrection {
    type Error = String;
    fn try_from(fit: RoughnessFit) -> Result<Self, String> {
        let increasing =
            |a: &[f32]| a.len() >= 2 && a.iter().all(|x| x.is_finite()) && a.windows(2).all(|w| w[0] < w[1]);
        if !increasing(&fit.alphas) || !increasing(&fit.ratios) || !(fit.ratios[0] > 0.0) {
            return Err("the α and k axes must be finite, increasing, with k > 0".into());
        }
        // what a fit can produce: GGX α and α' in [0, 1], distance ratios within a million
        let unit = |x: &f32| (0.0..=1.0).contains(x);
        if !fit.alphas.iter().all(unit) || !(fit.ratios[fit.ratios.len() - 1] <= 1e6) {
            return Err("the α axis must lie in [0, 1] and the k axis in (0, 1e6]".into());
        }
        if fit.table.len() != fit.alphas.len() * fit.ratios.len() || !fit.table.iter().all(unit) {
            return Err(format!(
                "the table must hold {}×{} values of α' in [0, 1], found {} values in [{}, {}]",
                fit.alphas.len(),
                fit.ratios.len(),
                fit.table.len(),
                fit.table.iter().copied().fold(f32::INFINITY, f32::min),
                fit.table.iter().copied().fold(f32::NEG_INFINITY, f32::max),
            ));
        }
        if !(fit.c0.is_finite() && fit.c0 > 0.0 && fit.c1.is_finite()) {
            return Err("c0 must be finite and > 0, c1 finite".into());
        }
        let residual = |x: f64| x.is_finite() && x >= 0.0;
        if !fit.lobe_residual.iter().all(|&x| residual(f64::from(x)))
            || !residual(fit.heldout_rms_table)
            || !residual(fit.heldout_rms_analytic)
        {
            return Err("residuals must be finite and ≥ 0".into());
        }
        let w = &fit.irradiance_weight;
        if !w.is_empty() && (w.len() != fit.alphas.len() || !w.iter().all(|x| (0.0..=1.0).contains(x))) {
            return Err(format!(
                "irradiance_weight must hold one value in [0, 1] per α row ({}), found {:?}",
                fit.alphas.len(),
                w
            ));
        }
        if !w.is_empty() && !(fit.alphas[0] >= 0.0) {
            return Err("irradiance_weight needs α rows ≥ 0".into());
        }
        let blend = fit.alphas.iter().zip(w).map(|(&a, &w)| (a.sqrt(), w)).collect();
        let log_ratios = fit.ratios.iter().map(|&r| libm::logf(r)).collect();
        let mut c = RoughnessCorrection { fit, log_ratios, lookup: Lookup::default(), blend };
        c.lookup = Lookup::resample(&c);
        Ok(c)
    }
}

impl Default for Lookup {
    fn default() -> Self {
        Lookup {
            x0: 0.0,
            inv_dx: 0.0,
            k_min: 1.0,
            k_max: 1.0,
            values: Vec::new(),
            cells: Box::new([[0.0; 4]; LOOKUP_CELLS]),
        }
    }
}

impl Lookup {
    fn resample(c: &RoughnessCorrection) -> Lookup {
        let n = LOOKUP_NODES;
        let (k_min, k_max) = (c.fit.ratios[0], c.fit.ratios[c.fit.ratios.len() - 1]);
        let (x0, x1) = (pseudo_log2(k_min), pseudo_log2(k_max));
        let dx = (x1 - x0) / (n - 1) as f32;
        let values: Vec<f32> = (0..n * n)
            .map(|t| {
                let r = (t / n) as f32 / (n - 1) as f32;
                let k = if t % n == n - 1 { k_max } else { pseudo_exp2(x0 + (t % n) as f32 * dx).clamp(k_min, k_max) };
                if r == 0.0 { 0.0 } else { c.corrected_alpha(r * r, k).sqrt() }
            })
            .collect();
        let mut cells = Box::new([[0.0f32; 4]; LOOKUP_CELLS]);
        for (c, cell) in cells.iter_mut().enumerate() {
            let (i, j) = (c / (n - 1), c % (n - 1));
            let at = |i: usize, j: usize| values[i * n + j];
            *cell = [at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1)];
        }
        Lookup { x0, inv_dx: if dx > 0.0 { 1.0 / dx } else { 0.0 }, k_min, k_max, values, cells }
    }

    #[inline]
    fn roughness(&self, r: f32, k: f32) -> f32 {
        let (i, a) = self.row(r);
        let (j, b) = self.column(k);
        self.blend(i, a, j, b)
    }

    /// `roughness` for [`LANES`] lookups, bit for bit the same: the coordinates of all
    /// lanes first (plain loops over lanes), then each lane's four nodes.
    #[inline(always)]
    fn roughness_lanes(&self, r: &[f32; LANES], k: &[f32; LANES]) -> [f32; LANES] {
        // `row` and `column` in 32-bit lanes (the interval's flat index as i32, not two
        // usizes: 64-bit lanes kept this loop from vectorising, and it cost a quarter of a
        // batched rough lookup), the same operations on the same floats
        let (mut cell, mut a, mut b) = ([0i32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        let last = (LOOKUP_NODES - 1) as f32;
        for l in 0..LANES {
            let fr = if r[l].is_finite() { (r[l] * last).clamp(0.0, last) } else { 0.0 };
            let (i, fa) = node_below_i32(fr);
            // `column`'s k clamped by max then min: the same values for the finite k here
            // (the axis is increasing) without `clamp`'s check of its bounds in every lane
            let k = if k[l].is_finite() & (k[l] > 0.0) { k[l] } else { 1.0 };
            let fx = ((pseudo_log2(k.max(self.k_min).min(self.k_max)) - self.x0) * self.inv_dx).clamp(0.0, last);
            let (j, fb) = node_below_i32(fx);
            (cell[l], a[l], b[l]) = (i * (LOOKUP_NODES - 1) as i32 + j, fa, fb);
        }
        // each lane's interval corners, as four arrays, then the blend of all lanes at once
        let mut q = [[0.0f32; LANES]; 4];
        for l in 0..LANES {
            [q[0][l], q[1][l], q[2][l], q[3][l]] = self.cells[cell[l] as usize];
        }
        let mut out = [0.0f32; LANES];
        for l in 0..LANES {
            out[l] = bilinear([q[0][l], q[1][l], q[2][l], q[3][l]], a[l], b[l]);
        }
        out
    }

    /// Row (roughness node) below `r` and the fraction towards the next.
    #[inline(always)]
    fn row(&self, r: f32) -> (usize, f32) {
        let last = (LOOKUP_NODES - 1) as f32;
        let fr = if r.is_finite() { (r * last).clamp(0.0, last) } else { 0.0 };
        node_below(fr)
    }

    /// Column (k node) below `k` and the fraction towards the next.
    #[inline(always)]
    fn column(&self, k: f32) -> (usize, f32) {
        let k = if k.is_finite() & (k > 0.0) {
            k.clamp(self.k_min, self.k_max)
        } else {
            1.0f32.clamp(self.k_min, self.k_max)
        };
        self.column_of(k)
    }

    /// Column of a `k` already clamped to the table's range.
    #[inline(always)]
    fn column_of(&self, k: f32) -> (usize, f32) {
        let last = (LOOKUP_NODES - 1) as f32;
        let fx = ((pseudo_log2(k) - self.x0) * self.inv_dx).clamp(0.0, last);
        node_below(fx)
    }

    /// Bilinear between the nodes at (row i, column j) with fractions (a, b).
    #[inline(always)]
    fn blend(&self, i: usize, a: f32, j: usize, b: f32) -> f32 {
        bilinear(self.cell(i, j), a, b)
    }

    /// The corners of the interval at (row i, column j), both ≤ nodes − 2 (`node_below`
    /// clamps them).
    #[inline(always)]
    fn cell(&self, i: usize, j: usize) -> [f32; 4] {
        self.cells[i * (LOOKUP_NODES - 1) + j]
    }
}

/// Bilinear blend of an interval's corners `[(i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1)]`
/// at fractions (a along rows, b along columns).
#[inline(always)]
fn bilinear(q: [f32; 4], a: f32, b: f32) -> f32 {
    (q[0] * (1.0 - b) + q[1] * b) * (1.0 - a) + (q[2] * (1.0 - b) + q[3] * b) * a
}

/// The node at or below a coordinate `x` in [0, nodes − 1] (the last interval's lower
/// node at its end) and the fraction past it: `x as usize` clamped, written with
/// `octa::floor_small` because x86-64's baseline has no unsigned float → integer conversion
/// (a float-to-usize cast there is a branchy sequence on every rough lookup).
#[inline(always)]
fn node_below(x: f32) -> (usize, f32) {
    const LAST: usize = LOOKUP_NODES - 2;
    let (i, below) = crate::octa::floor_small(x);
    let below = below.min(LAST as f32);
    // x ≥ 0, so i ≥ 0: the integer comes off the float's bits, not from a saturating cast
    (i.clamp(0, LAST as i32) as usize, x - below)
}

/// [`node_below`] with the node as an `i32`, for lane loops.
#[inline(always)]
fn node_below_i32(x: f32) -> (i32, f32) {
    const LAST: i32 = LOOKUP_NODES as i32 - 2;
    let (i, below) = crate::octa::floor_small(x);
    let below = below.min(LAST as f32);
    (i.clamp(0, LAST), x - below)
}

/// The resampled correction as a shader reads it (see [`RoughnessCorrection::lookup_table`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LookupTable {
    /// Nodes per axis (the table is `nodes × nodes`, row = roughness node, column = k node).
    pub nodes: u32,
    /// `x = (pseudo_log2(clamp(k, k_min, k_max)) − x0) · inv_dx`, the column coordinate.
    pub x0: f32,
    pub inv_dx: f32,
    pub k_min: f32,
    pub k_max: f32,
    /// r' per (r node, x node), row-major.
    pub values: Vec<f32>,
    /// The lookup, spelled out.
    pub rule: &'static str,
}

impl RoughnessCorrection {
    /// The table `corrected_roughness` interpolates, with its coordinates: for a shader or
    /// an engine that ports the lookup (`warpfit export` writes it).
    #[must_use]
    pub fn lookup_table(&self) -> LookupTable {
        let l = &self.lookup;
        LookupTable {
            nodes: LOOKUP_NODES as u32,
            x0: l.x0,
            inv_dx: l.inv_dx,
            k_min: l.k_min,
            k_max: l.k_max,
            values: l.values.clone(),
            rule: "fr = clamp(r·(nodes−1), 0, nodes−1) (r non-finite: 0); k non-finite or ≤ 0 reads as 1; fx = clamp((pseudo_log2(clamp(k, k_min, k_max)) − x0)·inv_dx, 0, nodes−1) with pseudo_log2(k) = exponent(k) + mantissa(k) − 1; r' = bilinear of values at (row fr, column fx), node-aligned",
        }
    }

    /// α' from the table, bilinear in α and log k, clamped to the table's range.
    #[must_use]
    pub fn from_table(&self, alpha: f32, k: f32) -> f32 {
        table_lookup(&self.fit.alphas, &self.log_ratios, &self.fit.table, alpha, libm::logf(k))
    }

    /// α' from the analytic model.
    #[must_use]
    pub fn analytic(&self, alpha: f32, k: f32) -> f32 {
        analytic(self.fit.c0 as f64, self.fit.c1 as f64, alpha as f64, k as f64) as f32
    }

    /// Perceptual roughness of the mip a lookup of perceptual roughness `r` at distance
    /// ratio `k` reads: [`RoughnessCorrection::corrected_alpha`] resampled (see `Lookup`).
    /// Always finite, in [0, 1]; r = 0 gives 0. What every rough lookup uses (`warp::glossy`).
    #[inline]
    #[must_use]
    pub fn corrected_roughness(&self, r: f32, k: f32) -> f32 {
        self.lookup.roughness(r, k)
    }

    /// Share of a lookup of perceptual roughness `r` taken from the dense grid's irradiance
    /// ([`RoughnessFit::irradiance_weight`]): linear in r between the rows, the last row's
    /// beyond them; 0 without weights, at r ≤ 0 and for a non-finite r. Always in [0, 1].
    ///
    /// Why the irradiance: the lobe the probe's mips and the references hold,
    /// `∫ L(l) D(h)(n·l) dl / ∫ D(h)(n·l) dl` at N = V = dir, is at α = 1 (D = 1/π) the
    /// clamped cosine itself, so the reference there is E(B, dir)/π exactly, and the dense
    /// grid stores E traced next to B, where probe A saw from elsewhere.
    #[inline]
    #[must_use]
    pub fn irradiance_weight(&self, r: f32) -> f32 {
        // on the last segment starting below r (ra, wa)–(rb, wb): wa·(1 − t) + wb·t with
        // t = (r − ra)/(rb − ra) clamped, exact at the nodes
        let b = &self.blend;
        let Some(&(_, w0)) = b.first() else { return 0.0 };
        if !(r > 0.0) {
            return 0.0;
        }
        let Some(pair) = b.windows(2).rev().find(|p| r > p[0].0) else { return w0.clamp(0.0, 1.0) };
        let ((ra, wa), (rb, wb)) = (pair[0], pair[1]);
        let t = ((r - ra) / (rb - ra)).clamp(0.0, 1.0);
        (wa * (1.0 - t) + wb * t).clamp(0.0, 1.0)
    }

    /// The blend's nodes, (perceptual roughness, weight) by increasing roughness (empty:
    /// no blend): for a shader or an engine that ports [`Self::irradiance_weight`].
    #[must_use]
    pub fn irradiance_nodes(&self) -> &[(f32, f32)] {
        &self.blend
    }

    /// `corrected_roughness` for [`LANES`] lookups, bit for bit the same values.
    #[inline]
    #[must_use]
    pub fn corrected_roughness_lanes(&self, r: &[f32; LANES], k: &[f32; LANES]) -> [f32; LANES] {
        self.lookup.roughness_lanes(r, k)
    }

    /// Probe-side α' for surface α and distance ratio k = d_probe / d_surface, by the
    /// chosen representation (k clamped to the fitted range): always finite, in [1e-3, 1].
    /// A non-finite α gives 1e-3; a non-finite or non-positive k means no correction.
    #[inline]
    #[must_use]
    pub fn corrected_alpha(&self, alpha: f32, k: f32) -> f32 {
        if !alpha.is_finite() {
            return 1e-3;
        }
        if !(k.is_finite() && k > 0.0) {
            return alpha.clamp(1e-3, 1.0);
        }
        let v = match self.fit.chosen {
            Representation::Table => self.from_table(alpha, k),
            Representation::Analytic => self.analytic(alpha, k),
        };
        if v.is_finite() { v.clamp(1e-3, 1.0) } else { alpha.clamp(1e-3, 1.0) }
    }
}

/// Bilinear lookup of an α-row, ln k-column table, clamped to its range: linear in α,
/// linear in ln k. Always finite, in [1e-3, 1].
#[inline]
#[must_use]
pub fn table_lookup(alphas: &[f32], log_ks: &[f32], table: &[f32], alpha: f32, log_k: f32) -> f32 {
    let (na, nk) = (alphas.len(), log_ks.len());
    if na < 2 || nk < 2 || table.len() != na * nk {
        return alpha.clamp(1e-3, 1.0);
    }
    let (i, fa) = bracket(na, |t| alphas[t], alpha);
    let (j, fk) = bracket(nk, |t| log_ks[t], log_k);
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

pub fn analytic(c0: f64, c1: f64, alpha: f64, k: f64) -> f64 {
    (c0 * alpha * libm::pow(k, -c1)).clamp(1e-3, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_irradiance_weight_is_linear_in_roughness_between_the_rows() {
        let alphas = vec![0.0, 0.25, 1.0]; // perceptual r 0, 0.5, 1
        let ratios = vec![0.5, 1.0, 2.0];
        let fit = RoughnessFit {
            table: vec![0.5; alphas.len() * ratios.len()],
            lobe_residual: vec![0.0; alphas.len() * ratios.len()],
            alphas,
            ratios,
            c0: 1.0,
            c1: 1.0,
            heldout_rms_table: 0.0,
            heldout_rms_analytic: 0.0,
            chosen: Representation::Table,
            source: Source::AnalyticLobes,
            heldout_scene: None,
            irradiance_weight: Vec::new(),
        };
        let plain = RoughnessCorrection::try_from(fit.clone()).unwrap();
        assert_eq!(plain.irradiance_weight(1.0), 0.0, "no weights: probe A alone");
        let c = RoughnessCorrection::try_from(RoughnessFit { irradiance_weight: vec![0.0, 0.5, 0.9], ..fit }).unwrap();
        assert_eq!(c.irradiance_nodes(), &[(0.0, 0.0), (0.5, 0.5), (1.0, 0.9)]);
        for (r, w) in [(0.0, 0.0), (0.25, 0.25), (0.5, 0.5), (0.75, 0.7), (1.0, 0.9), (2.0, 0.9), (-1.0, 0.0)] {
            assert!((c.irradiance_weight(r) - w).abs() < 1e-6, "r {r}: {} against {w}", c.irradiance_weight(r));
        }
        assert_eq!(c.irradiance_weight(f32::NAN), 0.0);
        assert_eq!(c.irradiance_weight(f32::INFINITY), 0.9);
    }
}
