//! Every row of the evaluation: a way to fetch probe A (a seed method, the oracle, a
//! corrective grid, or a loaded fitted grid through the runtime sampler) with a way to pick
//! the mip of a rough lookup (`warp::glossy::MipRule`), judged on one roughness bucket.

use super::engine::EngineBlend;
use super::metrics::{error_stats, mean_angle_deg};
use super::timing;
use super::validation::ValidationSet;
use crate::runtime::{FittedGrid, SpecularRead};
use crate::trace::truth::Oracle;
use crate::warp::corrective::{Blend, Correctives};
use crate::warp::glossy::{Aim, Glossy, MipRule};
use crate::warp::reproject::{HoleFill, reproject_with};
use crate::warp::{Method, Warp};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Error and cost of one row on one roughness bucket. Keys as in `eval.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MethodResult {
    pub name: String,
    /// Perceptual roughness of the bucket's queries (0 = mirror).
    #[serde(default)]
    pub roughness: f32,
    /// How the lookup picks its mip (absent at roughness 0, where every rule reads mip 0, and
    /// for the runtime, which applies the grid's stored correction).
    #[serde(default)]
    pub mip_rule: Option<MipRule>,
    /// RMSE of linear RGB radiance over the mean reference radiance.
    pub rel_rmse: f64,
    /// The same for the light apart from the emitters (`metrics::rel_rmse_emitters_apart`):
    /// lookup and reference each without the part seen straight from a lamp or an emissive
    /// surface, which otherwise rule it. Absent for the bounds (their lookups are searches)
    /// and in files written before it.
    #[serde(default)]
    pub rel_rmse_emitters_apart: Option<f64>,
    /// RMSE after tone mapping (see `metrics::ErrorStats::tm_rmse`).
    #[serde(default)]
    pub tm_rmse: f64,
    /// Mean absolute error (mean over RGB), radiance units.
    pub mae: f64,
    /// 95th percentile of the per-lookup error (mean abs over RGB).
    pub p95: f64,
    pub max: f64,
    /// Mean ꟻLIP of the bucket's rendered views (see `eval::views`), when rendered.
    #[serde(default)]
    pub flip: Option<f64>,
    /// Each view's mean ꟻLIP (the views of the bucket's summary, in order; empty without
    /// views and in files written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flip_views: Vec<f64>,
    /// How its error jumps at cell faces in the camera views (`perceptual::SeamSums::ratio`:
    /// about 1 without seams; the bucket's `seam_reference` is the references' own).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seam: Option<f64>,
    /// Mean angle between the method's fetch direction and the oracle's, degrees (null for
    /// methods without a single fetch direction).
    pub angular_deg: Option<f64>,
    /// Single-threaded warm-loop cost per lookup, queries in coherent order (see
    /// `timing::timing_order`).
    pub ns_per_lookup: f64,
    /// The same with queries in random order (cache-hostile).
    pub ns_per_lookup_random: f64,
    /// Per lookup through the method's batch API (queries in coherent order, [`LANES`](crate::octa::LANES)
    /// lookups in lockstep), for methods that have one.
    #[serde(default)]
    pub ns_per_lookup_batched: Option<f64>,
    /// Share of the `none` → `best-aim` gap in tone-mapped RMSE the row closes (1: as good
    /// as the best point on the query's ray; `bound::set_gap_closed`).
    #[serde(default)]
    pub gap_closed: Option<f64>,
    pub note: String,
}

/// What a row fetches, as a type (see [`RowId`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RowKind {
    /// A seed method or the oracle (`Method::Reproject` is the push-pull reprojection).
    Method(Method),
    /// Seed 002's reprojection with median + farthest-neighbour dilation.
    ReprojectDilate,
    /// One of the evaluation's corrective grids.
    Grid(CorrectiveVariant),
    /// The loaded fitted grid through the runtime sampler, in one read tier.
    Runtime(SpecularRead),
    /// The per-query bound: the texel of A that matches the reference best.
    BestFetch,
    /// The per-query bound: the best point on the query's ray.
    BestAim,
    /// Of several probes, the fetch towards the true hit from the nearest probe that sees
    /// it (`truth::Oracle::any`): the bound of choosing a probe and an aim per query.
    OracleProbes,
    /// Several probes as engines blend them (`eval::engine`).
    EngineBlend,
}

impl RowKind {
    /// Every kind of row.
    pub fn all() -> impl Iterator<Item = RowKind> {
        Method::ALL
            .into_iter()
            .map(RowKind::Method)
            .chain(CorrectiveVariant::ALL.into_iter().map(RowKind::Grid))
            .chain(SpecularRead::ALL.into_iter().map(RowKind::Runtime))
            .chain([
                RowKind::ReprojectDilate,
                RowKind::BestFetch,
                RowKind::BestAim,
                RowKind::OracleProbes,
                RowKind::EngineBlend,
            ])
    }

    /// The row's name without the renormalization mark.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            RowKind::Method(m) => m.name(),
            RowKind::ReprojectDilate => "reproject-dilate",
            RowKind::Grid(v) => v.name(),
            RowKind::Runtime(SpecularRead::Blended) => "runtime",
            RowKind::Runtime(SpecularRead::ProbeOnly) => "runtime-probe-only",
            RowKind::BestFetch => "best-fetch",
            RowKind::BestAim => "best-aim",
            RowKind::OracleProbes => "oracle-probes",
            RowKind::EngineBlend => "engine-blend",
        }
    }
}

/// Which row a result is: the evaluation and the report find rows by this type, never by
/// spelling a name. `eval.json` stores it as the row's name ([`RowId::name`]), as before.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RowId {
    pub kind: RowKind,
    /// Scaled by the grid's irradiance over probe A's (seed 000's renormalization).
    pub renorm: bool,
}

impl RowId {
    /// The runtime as loaded (the blended tier): the subject of every comparison.
    pub const RUNTIME: RowId = RowId::of(RowKind::Runtime(SpecularRead::Blended));
    /// The runtime's cheaper tier.
    pub const RUNTIME_PROBE_ONLY: RowId = RowId::of(RowKind::Runtime(SpecularRead::ProbeOnly));
    pub const BEST_FETCH: RowId = RowId::of(RowKind::BestFetch);
    pub const BEST_AIM: RowId = RowId::of(RowKind::BestAim);

    /// The row of `kind`, not renormalized.
    #[must_use]
    pub const fn of(kind: RowKind) -> RowId {
        RowId { kind, renorm: false }
    }

    /// The row of seed method `m`.
    #[must_use]
    pub const fn method(m: Method) -> RowId {
        RowId::of(RowKind::Method(m))
    }

    /// The name `eval.json` and the tables use (`box`, `fitted-trilinear`, `runtime+renorm`).
    #[must_use]
    pub fn name(self) -> String {
        let base = self.kind.name();
        if self.renorm { format!("{base}+renorm") } else { base.to_string() }
    }

    /// The row a name (or a label, `name/rule`) stands for; `None` for a name no row has.
    #[must_use]
    pub fn parse(name_or_label: &str) -> Option<RowId> {
        let name = name_or_label.split('/').next().unwrap_or(name_or_label);
        let (base, renorm) = match name.strip_suffix("+renorm") {
            Some(base) => (base, true),
            None => (name, false),
        };
        RowKind::all().find(|kind| kind.name() == base).map(|kind| RowId { kind, renorm })
    }

    /// The runtime's own row, in either tier, renormalized or not: the subject of the
    /// comparisons, never "the best other row".
    #[must_use]
    pub fn is_runtime(self) -> bool {
        matches!(self.kind, RowKind::Runtime(_))
    }

    /// A bound rather than a method (`oracle`, `oracle-probes`, `best-fetch`, `best-aim`,
    /// `in-sample`).
    #[must_use]
    pub fn is_bound(self) -> bool {
        matches!(
            self.kind,
            RowKind::Method(Method::Oracle)
                | RowKind::OracleProbes
                | RowKind::BestFetch
                | RowKind::BestAim
                | RowKind::Grid(CorrectiveVariant::InSample)
        )
    }
}

impl MethodResult {
    /// Which row this is (`None` only for a name written by another version).
    #[must_use]
    pub fn id(&self) -> Option<RowId> {
        RowId::parse(&self.name)
    }

    /// Whether this is row `id`.
    #[must_use]
    pub fn is(&self, id: RowId) -> bool {
        self.id() == Some(id)
    }

    /// The row's name with its mip rule, as tables show it (`box/engine`).
    pub fn label(&self) -> String {
        match self.mip_rule {
            Some(rule) => format!("{}/{}", self.name, rule.name()),
            None => self.name.clone(),
        }
    }
}

/// The corrective grids the evaluation judges beside the warp methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CorrectiveVariant {
    /// Unfitted maps from the grid's raytraced distances in every active cell.
    Celldepth,
    /// The fitted grid as stored (maps where selection kept them), containing cell.
    Fitted,
    /// The fitted map of every active cell, before model selection.
    FittedL2All,
    /// The fitted grid as stored, blended over 8 cells.
    FittedTrilinear,
    /// With several probes: every active cell's map fitted with one probe for the whole
    /// cell (the probe chosen per cell, as engines choose by position).
    PerCell,
    /// The fitted grid as stored, each lookup's radiance blended over the cells whose
    /// faces are near (each cell's own shift and probe; [`face_blend`]).
    FittedFaces,
    /// A bound: every cell's map refitted on the evaluation's own mirror queries
    /// (`fit::in_sample`), what a per-cell map could reach on them; mirror bucket only.
    InSample,
}

/// The `fitted-faces` radiance of query (B, dir, r): the runtime's faces blend
/// (`Correctives::face_aims`, `Blend::Faces`) shaded with the row's mip rule: inside a cell
/// the containing cell's lookup; within `corrective::FACE_MARGIN` of a face each near cell's
/// own lookup (its shift, its probe), the radiances blended.
pub fn face_blend(shading: Glossy, rule: MipRule, c: &Correctives, (b, dir, r): (Vec3, Vec3, f32)) -> Vec3 {
    let aims = c.face_aims(shading.warp, b, dir, r);
    (0..aims.n).fold(Vec3::ZERO, |sum, k| sum + aims.weights[k] * shading.radiance(rule, b, dir, aims.aims[k], r))
}

impl CorrectiveVariant {
    pub const ALL: [CorrectiveVariant; 7] = [
        CorrectiveVariant::Celldepth,
        CorrectiveVariant::Fitted,
        CorrectiveVariant::FittedL2All,
        CorrectiveVariant::FittedTrilinear,
        CorrectiveVariant::PerCell,
        CorrectiveVariant::FittedFaces,
        CorrectiveVariant::InSample,
    ];

    pub fn name(self) -> &'static str {
        match self {
            CorrectiveVariant::Celldepth => "celldepth",
            CorrectiveVariant::Fitted => "fitted",
            CorrectiveVariant::FittedL2All => "fitted-L2-all",
            CorrectiveVariant::FittedTrilinear => "fitted-trilinear",
            CorrectiveVariant::PerCell => "per-cell",
            CorrectiveVariant::FittedFaces => "fitted-faces",
            CorrectiveVariant::InSample => "in-sample",
        }
    }

    pub fn note(self) -> &'static str {
        match self {
            CorrectiveVariant::Celldepth => "unfitted shift maps from the grid's raytraced distances, containing cell",
            CorrectiveVariant::Fitted => "fitted shift maps (levels as stored), containing cell",
            CorrectiveVariant::FittedL2All => {
                "level 2 in every active cell (fitted maps before model selection), containing cell"
            }
            CorrectiveVariant::FittedTrilinear => "fitted shift maps (levels as stored), trilinear blend of 8 cells",
            CorrectiveVariant::FittedFaces => {
                "fitted shift maps (levels as stored), each near cell's lookup (its shift, its probe) blended across an eighth of a cell either side of each face"
            }
            CorrectiveVariant::PerCell => {
                "a shift map in every active cell fitted with one probe for the cell (the probe most of its texels chose), containing cell"
            }
            CorrectiveVariant::InSample => {
                "bound: each cell's map refitted on these queries themselves (in-sample), the fit's probe per texel, containing cell"
            }
        }
    }

    pub fn blend(self) -> Blend {
        match self {
            CorrectiveVariant::FittedTrilinear => Blend::Trilinear,
            _ => Blend::Cell,
        }
    }
}

/// A corrective grid and the variant it is judged as.
#[derive(Clone, Copy)]
pub struct CorrectiveRow<'a> {
    pub variant: CorrectiveVariant,
    pub correctives: &'a Correctives,
}

/// How a row fetches probe A.
#[derive(Clone, Copy)]
pub enum Fetch<'a> {
    /// A seed method or the oracle (`reproject` is evaluated apart).
    Method(Method),
    /// The oracle over several probes (`truth::Oracle::any`).
    OracleProbes,
    /// Several probes, box-projected and blended by influence (`eval::engine`).
    EngineBlend(&'a EngineBlend),
    /// A corrective grid.
    Grid(CorrectiveRow<'a>),
    /// A fitted grid loaded from disk: `FittedGrid::specular` in the given read tier, its
    /// own mip rule included.
    Runtime(&'a FittedGrid, SpecularRead),
}

impl Fetch<'_> {
    fn note(&self) -> String {
        match self {
            Fetch::Method(Method::Oracle) => {
                "bound: fetch towards the true hit traced from B (tracing cost not counted)".into()
            }
            Fetch::Method(Method::Box) => "scene bounds as the box; query direction outside it".into(),
            Fetch::Method(Method::Kdop) => "18-DOP fitted to the probe's depth samples".into(),
            Fetch::Method(_) => String::new(),
            Fetch::OracleProbes => "bound: fetch towards the true hit from the nearest probe that sees it (tracing cost not counted)".into(),
            Fetch::EngineBlend(_) => "each probe box-projected against a box fitted to its depth, blended by influence volumes with a falloff margin (Lagarde & Zanuttini 2012)".into(),
            Fetch::Grid(r) => r.variant.note().into(),
            Fetch::Runtime(g, read) => {
                let f16 = g
                    .manifest()
                    .payloads
                    .iter()
                    .flat_map(|p| &p.layers)
                    .any(|l| l.precision == crate::runtime::Precision::F16);
                format!(
                    "the fitted grid loaded from disk ({}), runtime::FittedGrid::specular with its stored roughness correction{}",
                    if f16 { "f16 radiance" } else { "f32" },
                    match read {
                        SpecularRead::Blended => "",
                        SpecularRead::ProbeOnly => ", probe A alone (SpecularRead::ProbeOnly: no irradiance blend)",
                    }
                )
            }
        }
    }
}

/// Probe renormalization (seed 000: what Black Ops 3 shipped instead of warping): a
/// specular lookup scaled by the ratio of the dense grid's irradiance at the shading point to
/// probe A's own irradiance, both around the lookup's direction, `L · E_grid(B, R) / E_A(R)`
/// (the normalization Call of Duty describes: Lazarov 2013, "Getting More Physical in Call
/// of Duty: Black Ops II", environment map normalization). The ratio is capped at 16, which
/// only a probe that sees nearly nothing in a direction reaches.
pub struct Renorm<'a> {
    pub grid: &'a crate::runtime::IrradianceGrid,
    pub probe_a: &'a crate::octa::OctMap<Vec3>,
}

impl Renorm<'_> {
    /// The scale of a lookup at `b` in unit direction `dir`.
    #[inline]
    pub fn scale(&self, b: Vec3, dir: Vec3) -> f32 {
        let (e, ea) = (self.grid.irradiance(b, dir), self.probe_a.bilinear(dir));
        let (y, ya) = (crate::tonemap::luminance(e), crate::tonemap::luminance(ea));
        let k = if ya > 0.0 { y / ya } else { 1.0 };
        if k.is_finite() { k.clamp(0.0, 16.0) } else { 1.0 }
    }
}

/// A row of the table: how it fetches, how it picks its mip (`None` where the rule is not
/// the row's choice: mirror buckets and the runtime), and whether it is renormalized.
#[derive(Clone, Copy)]
pub struct Row<'a> {
    pub fetch: Fetch<'a>,
    pub rule: Option<MipRule>,
    pub renorm: Option<&'a Renorm<'a>>,
}

impl Row<'_> {
    /// Which row this is.
    pub fn id(&self) -> RowId {
        let kind = match self.fetch {
            Fetch::Method(m) => RowKind::Method(m),
            Fetch::OracleProbes => RowKind::OracleProbes,
            Fetch::EngineBlend(_) => RowKind::EngineBlend,
            Fetch::Grid(r) => RowKind::Grid(r.variant),
            Fetch::Runtime(_, read) => RowKind::Runtime(read),
        };
        RowId { kind, renorm: self.renorm.is_some() }
    }

    /// The row's method name (`+renorm` marks a renormalized row).
    pub fn name(&self) -> String {
        self.id().name()
    }

    /// Whether `m` is this row's result (the same row and mip rule).
    pub fn made(&self, m: &MethodResult) -> bool {
        m.is(self.id()) && self.rule == m.mip_rule
    }

    /// Fetch vector of query (B, dir) (the oracle's direction given), or `None` for the
    /// runtime, which shades on its own.
    #[inline]
    fn aim(&self, warp: &Warp, b: Vec3, dir: Vec3, oracle: Oracle, r: f32) -> Option<Aim> {
        match self.fetch {
            Fetch::Method(Method::Oracle) => Some(oracle.a.into()),
            Fetch::OracleProbes => Some(oracle.any),
            Fetch::EngineBlend(_) => None,
            Fetch::Method(m) => Some(warp.fetch_vector(m, b, dir).into()),
            Fetch::Grid(g) => Some(g.correctives.fetch(g.variant.blend(), warp, b, dir, r)),
            Fetch::Runtime(..) => None,
        }
    }

    /// The row's radiance for query (B, dir, roughness r).
    #[inline]
    pub fn estimate(&self, shading: Glossy, b: Vec3, dir: Vec3, oracle: Oracle, r: f32) -> Vec3 {
        let l = match (self.fetch, self.aim(shading.warp, b, dir, oracle, r)) {
            (Fetch::Runtime(g, read), _) => g.specular_as(read, b, dir, r),
            (Fetch::EngineBlend(e), _) => e.radiance(shading, self.rule.unwrap_or(MipRule::Plain), b, dir, r),
            (Fetch::Grid(g), _) if g.variant == CorrectiveVariant::FittedFaces => {
                face_blend(shading, self.rule.unwrap_or(MipRule::Plain), g.correctives, (b, dir, r))
            }
            (_, Some(aim)) => shading.radiance(self.rule.unwrap_or(MipRule::Plain), b, dir, aim, r),
            (_, None) => Vec3::ZERO,
        };
        match self.renorm {
            Some(n) => l * n.scale(b, dir),
            None => l,
        }
    }

    /// Unit fetch direction of query (B, dir) (the runtime's own for the runtime).
    fn fetch_dir(&self, warp: &Warp, b: Vec3, dir: Vec3, oracle: Oracle) -> Vec3 {
        let v = match self.fetch {
            Fetch::Runtime(g, _) => g.fetch_vector(b, dir),
            _ => self.aim(warp, b, dir, oracle, 0.0).map_or(dir, |a| a.v),
        };
        if v == dir { dir } else { v.try_normalize().unwrap_or(dir) }
    }
}

/// The rows of one bucket: every method with the given rules, every corrective grid with
/// them, then the runtime (and, on a rough bucket, the runtime reading probe A alone). At
/// roughness 0 the rules coincide, so `rules` is `[Plain]` there.
pub fn rows<'a>(
    methods: &[Method],
    grids: &[CorrectiveRow<'a>],
    runtime: Option<&'a FittedGrid>,
    (rules, probes): (&[MipRule], Option<&'a EngineBlend>),
    renorm: Option<&'a Renorm<'a>>,
) -> Vec<Row<'a>> {
    let rough = rules.len() > 1;
    let rule_of = |r: MipRule| rough.then_some(r);
    let mut out = Vec::new();
    for &m in methods.iter().filter(|&&m| m != Method::Reproject) {
        out.extend(rules.iter().map(|&r| Row { fetch: Fetch::Method(m), rule: rule_of(r), renorm: None }));
    }
    if let Some(e) = probes {
        out.extend(rules.iter().map(|&r| Row { fetch: Fetch::EngineBlend(e), rule: rule_of(r), renorm: None }));
        if methods.contains(&Method::Oracle) {
            out.extend(rules.iter().map(|&r| Row { fetch: Fetch::OracleProbes, rule: rule_of(r), renorm: None }));
        }
    }
    // (the in-sample bound is fitted on the mirror queries: it bounds nothing rough)
    for &g in grids.iter().filter(|g| !(rough && g.variant == CorrectiveVariant::InSample)) {
        out.extend(rules.iter().map(|&r| Row { fetch: Fetch::Grid(g), rule: rule_of(r), renorm: None }));
    }
    let tier = |read| runtime.map(|g| Row { fetch: Fetch::Runtime(g, read), rule: None, renorm: None });
    out.extend(tier(SpecularRead::Blended));
    if rough {
        out.extend(tier(SpecularRead::ProbeOnly));
    }
    // renormalized: the parallax-corrected cubemap engines ship (box, the plain mip) and the
    // runtime, each scaled by the grid's irradiance
    if let Some(n) = renorm {
        if methods.contains(&Method::Box) {
            out.push(Row { fetch: Fetch::Method(Method::Box), rule: rough.then_some(MipRule::Plain), renorm: Some(n) });
        }
        out.extend(runtime.map(|g| Row {
            fetch: Fetch::Runtime(g, SpecularRead::Blended),
            rule: None,
            renorm: Some(n),
        }));
    }
    out
}

/// Probe A's emitted part as every row reads it: the evaluation's warp context and, for the
/// runtime's rows, the loaded grid, each with probe A's radiance replaced by its emitted
/// chain (`bake::probe::emitted_mips`), so a row's lookup of it is the emitted part of its
/// lookup of probe A (fetches read only depth and proxies; reads and mips are linear).
#[derive(Clone, Copy)]
pub struct Emitters<'a> {
    pub shading: Glossy<'a>,
    pub runtime: Option<&'a FittedGrid>,
}

/// The emitted part of every lookup of `row` on `set`: zero where the scene has no emitter
/// (`emitters` is `None`), `None` for a runtime row without its emitted twin.
pub fn emitted_estimates(row: &Row, emitters: Option<&Emitters>, set: &ValidationSet) -> Option<Vec<Vec3>> {
    let Some(em) = emitters else {
        return Some(vec![Vec3::ZERO; set.dirs.len()]);
    };
    let row = match row.fetch {
        Fetch::Runtime(_, read) => Row { fetch: Fetch::Runtime(em.runtime?, read), ..*row },
        _ => *row,
    };
    Some(estimates(&row, em.shading, set))
}

/// Estimates of `row` for every query of `set` (parallel, deterministic).
pub fn estimates(row: &Row, shading: Glossy, set: &ValidationSet) -> Vec<Vec3> {
    estimates_of_first(row, shading, set, set.dirs.len())
}

/// [`estimates`] of the set's first `n` queries.
pub fn estimates_of_first(row: &Row, shading: Glossy, set: &ValidationSet, n: usize) -> Vec<Vec3> {
    (0..n.min(set.dirs.len()))
        .into_par_iter()
        .map(|k| row.estimate(shading, set.position_of(k), set.dirs[k], set.oracle(k), set.roughness[k]))
        .collect()
}

/// Error and cost of `row` on `set` (all queries of one roughness), timed over
/// `timing_lookups` queries.
pub fn evaluate_row(
    row: &Row,
    (shading, emitters): (Glossy, Option<&Emitters>),
    set: &ValidationSet,
    exposure: f32,
    timing_lookups: usize,
) -> MethodResult {
    let est = estimates(row, shading, set);
    let emitted = emitted_estimates(row, emitters, set);
    let warp = shading.warp;
    let dirs: Vec<Vec3> = (0..set.dirs.len())
        .into_par_iter()
        .map(|k| row.fetch_dir(warp, set.position_of(k), set.dirs[k], set.oracle(k)))
        .collect();
    let r = set.roughness.first().copied().unwrap_or(0.0);
    let lookup = |b, dir, oracle| row.estimate(shading, b, dir, oracle, r);
    let ns = (
        timing::time_queries(set, timing_lookups, false, lookup),
        timing::time_queries(set, timing_lookups, true, lookup),
    );
    let note = match row.renorm {
        Some(_) => {
            format!("{}; scaled by the grid's irradiance over probe A's (renormalization, seed 000)", row.fetch.note())
        }
        None => row.fetch.note(),
    };
    let mut out = result(set, &row.name(), note, (&est, emitted.as_deref()), Some(&dirs), ns, exposure);
    out.mip_rule = row.rule;
    if matches!(row.fetch, Fetch::Method(Method::Warp1)) && warp.options.relax_texels == 0.0 && r == 0.0 {
        out.ns_per_lookup_batched = Some(timing::time_warp1_batched(warp, set, timing_lookups));
    }
    out
}

/// `old`, the row's result on an earlier tracing of the same queries, with its errors
/// measured again against `set`'s references: the lookups are the same, so their costs,
/// fetch directions and ꟻLIP (judged on the rendered views) stand.
pub fn rescore_row(
    row: &Row,
    (shading, emitters): (Glossy, Option<&Emitters>),
    set: &ValidationSet,
    exposure: f32,
    old: &MethodResult,
) -> MethodResult {
    let est = estimates(row, shading, set);
    let emitted = emitted_estimates(row, emitters, set);
    let ns = (old.ns_per_lookup, old.ns_per_lookup_random);
    let mut out = result(set, &old.name, old.note.clone(), (&est, emitted.as_deref()), None, ns, exposure);
    out.mip_rule = old.mip_rule;
    out.angular_deg = old.angular_deg;
    out.flip = old.flip;
    out.flip_views.clone_from(&old.flip_views);
    out.seam = old.seam;
    out.ns_per_lookup_batched = old.ns_per_lookup_batched;
    out
}

/// One table row from estimates, fetch directions (none for methods without a single fetch)
/// and coherent/random-order costs.
pub(super) fn result(
    set: &ValidationSet,
    name: &str,
    note: String,
    (est, emitted): (&[Vec3], Option<&[Vec3]>),
    dirs: Option<&[Vec3]>,
    (ns_per_lookup, ns_per_lookup_random): (f64, f64),
    exposure: f32,
) -> MethodResult {
    let e = error_stats(est, &set.reference, exposure);
    let apart = emitted.map(|em| super::metrics::rel_rmse_emitters_apart(est, em, &set.reference, &set.emitted));
    MethodResult {
        name: name.into(),
        roughness: set.roughness.first().copied().unwrap_or(0.0),
        mip_rule: None,
        rel_rmse: e.rel_rmse,
        rel_rmse_emitters_apart: apart,
        tm_rmse: e.tm_rmse,
        mae: e.mae,
        p95: e.p95,
        max: e.max,
        flip: None,
        flip_views: Vec::new(),
        seam: None,
        angular_deg: dirs.map(|d| mean_angle_deg(d, &set.oracle_dir)),
        ns_per_lookup,
        ns_per_lookup_random,
        ns_per_lookup_batched: None,
        gap_closed: None,
        note,
    }
}

/// Fetch directions of a per-lookup method for the whole set (parallel, deterministic).
pub fn fetch_dirs(warp: &Warp, set: &ValidationSet, method: Method) -> Vec<Vec3> {
    if method == Method::Oracle {
        return set.oracle_dir.clone();
    }
    (0..set.dirs.len()).into_par_iter().map(|k| warp.fetch_dir(method, set.position_of(k), set.dirs[k])).collect()
}

/// Radiance estimates of `reproject` (one reprojected mirror probe per position).
pub fn reproject_estimates(warp: &Warp, set: &ValidationSet, fill: HoleFill) -> Vec<Vec3> {
    let res = warp.probe.radiance.levels[0].res;
    let per_pos: Vec<Vec<Vec3>> = set
        .positions
        .par_iter()
        .enumerate()
        .map(|(k, &b)| {
            let map = reproject_with(&warp.probe, b, res, fill);
            (0..set.dirs_per_position).map(|d| map.bilinear(set.dirs[k * set.dirs_per_position + d])).collect()
        })
        .collect();
    per_pos.into_iter().flatten().collect()
}

/// `reproject` on the mirror bucket: per-location scatter + hole filling (`fill`), its build
/// amortised over the lookups it serves (rough buckets have no reprojected prefiltered
/// chain). Push-pull is the `reproject` row, seed 002's median + dilation `reproject-dilate`.
///
/// `emitted_warp` is the warp context reading probe A's emitted chain (`None`: the scene has
/// no emitter); the reprojection of that chain, holes filled the same way, is the part of
/// the row's lookups taken out as emitted (exact for push-pull, which is linear; the median
/// is not, so for `reproject-dilate` it is the reprojected emitters' own median).
pub fn evaluate_reproject(
    (warp, emitted_warp): (&Warp, Option<&Warp>),
    set: &ValidationSet,
    exposure: f32,
    fill: HoleFill,
) -> MethodResult {
    let est = reproject_estimates(warp, set, fill);
    let emitted = emitted_warp.map_or_else(|| vec![Vec3::ZERO; est.len()], |w| reproject_estimates(w, set, fill));
    // one per-location pass serves a location's lookups in any order: timed once
    let ns = timing::time_reproject(warp, set, fill);
    let (name, how) = match fill {
        HoleFill::PushPull => (RowId::method(Method::Reproject), "push-pull"),
        HoleFill::MedianDilate => {
            (RowId::of(RowKind::ReprojectDilate), "seed 002's median + farthest-neighbour dilation")
        }
    };
    let note = format!("per-location scatter + {how} amortised over {} lookups per location", set.dirs_per_position);
    result(set, &name.name(), note, (&est, Some(&emitted)), None, (ns, ns), exposure)
}
