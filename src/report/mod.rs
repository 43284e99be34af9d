//! Everything a run leaves for people and tools to read, written from what the stages
//! computed: the evaluation (`eval.json`, `eval.md`, the error-against-cost plot and the
//! view tiles), the fit's diagnostics (`fit`), the roughness correction (`roughness`), the
//! sweep's record and figures (`sweep`), and the run report (`page`: report.json/.md/.html).
//! `folder::RunFolder` names the files. Computes nothing but summaries of its inputs.

pub mod fit;
pub mod folder;
pub mod page;
pub mod plot;
pub mod roughness;
pub mod sweep;

pub use crate::eval::{EvalReport, LevelEval};
use crate::eval::{Evaluation, RowId};
use crate::files::{FileError, write_atomic, write_json};
use crate::warp::Method;
use folder::RunFolder;
use std::fmt::Write as _;

/// Markdown table of the rows of roughness bucket `r`, in evaluation order.
pub fn methods_table(r: &EvalReport, roughness: f32) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| method | rel RMSE | rel RMSE, emitters apart | tone-mapped RMSE | gap closed | ꟻLIP | MAE | p95 | max | angular ° | ns/lookup | ns/lookup (random order) | ns/lookup (batch API) | × cheaper than a reference ray | note |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for m in r.methods.iter().filter(|m| m.roughness == roughness) {
        let ang = m.angular_deg.map_or("–".to_string(), |a| format!("{a:.2}"));
        let cheaper = if crate::eval::is_bound(&m.name) {
            "–".to_string()
        } else {
            format!("{:.0}", r.reference_ns_per_ray / m.ns_per_lookup.max(1e-9))
        };
        let batched = m.ns_per_lookup_batched.map_or("–".to_string(), |ns| format!("{ns:.1}"));
        let flip = m.flip.map_or("–".to_string(), |f| format!("{f:.4}"));
        let _ = writeln!(
            s,
            "| {} | {:.4} | {} | {:.4} | {} | {} | {:.4} | {:.4} | {:.3} | {} | {:.1} | {:.1} | {} | {} | {} |",
            m.label(),
            m.rel_rmse,
            m.rel_rmse_emitters_apart.map_or("–".to_string(), |x| format!("{x:.4}")),
            m.tm_rmse,
            m.gap_closed.map_or("–".to_string(), |g| format!("{g:.2}")),
            flip,
            m.mae,
            m.p95,
            m.max,
            ang,
            m.ns_per_lookup,
            m.ns_per_lookup_random,
            batched,
            cheaper,
            m.note
        );
    }
    s
}

/// Markdown table, one line per roughness bucket, of what the claims rest on: the fitted
/// grid through the runtime against the best other row costing ≤ 2× warp1 (by mean ꟻLIP),
/// and warp1 and box with plain mips; ꟻLIP / tone-mapped RMSE / rel RMSE each.
pub fn summary_table(r: &EvalReport) -> String {
    let mut s = String::from(
        "| roughness | runtime (ꟻLIP / tm RMSE / rel RMSE) | best other ≤ 2× warp1 | warp1 | box |\n|---:|---|---|---|---|\n",
    );
    let fmt = |m: &crate::eval::MethodResult| {
        format!("{} / {:.4} / {:.3}", m.flip.map_or("–".into(), |f| format!("{f:.4}")), m.tm_rmse, m.rel_rmse)
    };
    let plain = |m: &&crate::eval::MethodResult| {
        m.mip_rule.is_none() || m.mip_rule == Some(crate::warp::glossy::MipRule::Plain)
    };
    for b in &r.buckets {
        let rows: Vec<&crate::eval::MethodResult> = r.methods.iter().filter(|m| m.roughness == b.roughness).collect();
        let find = |id: RowId| rows.iter().copied().filter(plain).find(|m| m.is(id));
        let budget = find(RowId::method(Method::Warp1)).map_or(f64::INFINITY, |m| 2.0 * m.ns_per_lookup);
        let key = |m: &&crate::eval::MethodResult| m.flip.unwrap_or(m.tm_rmse);
        let best = rows
            .iter()
            .copied()
            .filter(|m| {
                m.ns_per_lookup <= budget && !crate::eval::is_runtime(&m.name) && !crate::eval::is_bound(&m.name)
            })
            .min_by(|a, b| key(a).total_cmp(&key(b)));
        let cell = |m: Option<&crate::eval::MethodResult>| m.map_or("–".into(), fmt);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            b.roughness,
            cell(rows.iter().copied().find(|m| m.is(RowId::RUNTIME))),
            best.map_or("–".into(), |m| format!("{}: {}", m.label(), fmt(m))),
            cell(find(RowId::method(Method::Warp1))),
            cell(find(RowId::method(Method::Box)))
        );
    }
    s
}

/// The error columns the method tables share: ꟻLIP (or "–"), then tone-mapped RMSE, rel
/// RMSE, MAE and p95 (`errors`, four decimals), then ns per lookup.
pub(crate) fn error_cells(flip: Option<f64>, errors: [f64; 4], ns_per_lookup: f64) -> Vec<String> {
    let mut cells = vec![flip.map_or("–".into(), |f| format!("{f:.4}"))];
    cells.extend(errors.iter().map(|e| format!("{e:.4}")));
    cells.push(format!("{ns_per_lookup:.1}"));
    cells
}

/// Markdown section of one surface-probe patch (seed 003): the atlas, then every row at
/// every roughness, then the references' noise.
pub fn surface_section(sr: &crate::eval::surface::SurfaceReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n## Surface probes {} (seed 003)\n\nAn atlas of {}×{} hemi-octahedral probes of {}² texels on the patch ({:.1} MB as RGBA16F with its mips; baked in {:.1} s, {} rays). Held-out queries: {} points on the patch × {} cosine-distributed reflection directions. ꟻLIP: a camera across the patch{}, mean over the patch's pixels.\n",
        sr.index,
        sr.counts[0],
        sr.counts[1],
        sr.resolution,
        sr.bytes as f64 / 1e6,
        sr.bake_seconds,
        sr.bake_rays,
        sr.points,
        sr.dirs_per_point,
        sr.camera.map_or(" (none found)".into(), |c| format!(" from ({:.2}, {:.2}, {:.2})", c[0], c[1], c[2]))
    );
    s += "| roughness | method | ꟻLIP (patch camera) | tone-mapped RMSE | rel RMSE | MAE | p95 | ns/lookup |\n|---:|---|---:|---:|---:|---:|---:|---:|\n";
    for row in &sr.rows {
        let mut cells = vec![row.roughness.to_string(), row.name.clone()];
        cells.extend(error_cells(row.flip, [row.tm_rmse, row.rel_rmse, row.mae, row.p95], row.ns_per_lookup));
        let _ = writeln!(s, "| {} |", cells.join(" | "));
    }
    s += "\n| roughness | lookups | reference spp | single-reference SE (rel) | camera pixels on the patch | camera reference spp | ꟻLIP of the references' own noise |\n|---:|---:|---:|---:|---:|---:|---:|\n";
    for b in &sr.buckets {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.4} | {} | {} | {:.4} |",
            b.roughness,
            b.lookups,
            b.reference_spp,
            b.query_se_rel,
            b.view_pixels,
            b.view_reference_spp,
            b.view_noise_flip
        );
    }
    let _ = writeln!(
        s,
        "\n![atlas](surface_atlas{k}.png)\n\n![ꟻLIP, patch camera, r = 0](flip_surface{k}_r0.000.png)\n",
        k = sr.index
    );
    s
}

/// Markdown table of the diffuse evaluation (empty without one).
pub fn diffuse_table(r: &EvalReport) -> String {
    let Some(d) = &r.diffuse else { return String::new() };
    let mut s = String::from(
        "| method | ꟻLIP (diffuse-shaded cameras) | tone-mapped RMSE | rel RMSE | MAE | p95 | ns/lookup |\n|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for row in &d.rows {
        let mut cells = vec![row.name.clone()];
        cells.extend(error_cells(row.flip, [row.tm_rmse, row.rel_rmse, row.mae, row.p95], row.ns_per_lookup));
        let _ = writeln!(s, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(
        s,
        "\n{} held-out surface points, {}-sample references (single-reference SE {:.3} relative); best against runner-up ({} vs {}): tone-mapped RMSE difference {:.4}, its reference SE {:.4} ({}); ꟻLIP on {} camera pixels, {}-sample references whose own noise scores {:.4}.",
        d.points,
        d.reference_spp,
        d.reference_se_rel,
        d.claim.0,
        d.claim.1,
        d.difference_tm,
        d.reference_se_tm,
        if d.reference_ok { "SE ≤ ¼ difference" } else { "**SE > ¼ difference: more samples needed**" },
        d.view_pixels,
        d.view_reference_spp,
        d.view_noise_flip
    );
    s
}

/// A bucket's row labelled `label`, and its ꟻLIP on view `k`.
fn view_flip(r: &EvalReport, roughness: f32, label: &str, k: usize) -> Option<f64> {
    r.methods.iter().find(|m| m.roughness == roughness && m.label() == label)?.flip_views.get(k).copied()
}

/// A rival's label as a lighting engineer names it (`box` → box projection).
fn plain_name(label: &str) -> String {
    let (method, rule) = label.split_once('/').map_or((label, None), |(m, r)| (m, Some(r)));
    let name = match method {
        "box" => "box projection".to_string(),
        "kdop" => "the 18-DOP".to_string(),
        "warp1" => "the depth warp (warp1)".to_string(),
        "none" => "probe A unwarped".to_string(),
        "engine-blend" => "per-cell probe blending".to_string(),
        m => m.to_string(),
    };
    rule.map_or(name.clone(), |r| format!("{name} ({r} mips)"))
}

/// One bucket's verdict: the fitted grid's measure `ours` against the rival's `theirs`,
/// their difference (positive: ours lower) and its standard error.
struct Judged {
    roughness: f32,
    rival: String,
    ours: f64,
    theirs: f64,
    difference: f64,
    se: f64,
}

impl Judged {
    fn share(&self) -> f64 {
        100.0 * self.difference.abs() / self.theirs.max(1e-12)
    }
}

/// "r = 0, 0.125 and 0.25": the buckets of `group`.
fn roughness_list(group: &[&Judged]) -> String {
    let r: Vec<String> = group.iter().map(|j| j.roughness.to_string()).collect();
    match r.as_slice() {
        [] => String::new(),
        [one] => format!("r = {one}"),
        [head @ .., last] => format!("r = {} and {last}", head.join(", ")),
    }
}

/// "3–14%": the range of the group's shares.
fn share_range(group: &[&Judged]) -> String {
    let (lo, hi) = group.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), j| (lo.min(j.share()), hi.max(j.share())));
    if (hi - lo) < 0.5 { format!("{hi:.0}%") } else { format!("{lo:.0}–{hi:.0}%") }
}

/// The run's verdict in three plain lines: where the fitted grid's pictures (ꟻLIP of the
/// rendered views, else tone-mapped RMSE) beat their best rival at each roughness beyond 2
/// SE (the best classic method costing at most twice warp1's probe reads, or with several
/// probes the engines' per-cell blend of them), where they lose, and where the two are
/// even, with the pointwise result beside it. Empty when the evaluation had no fitted grid.
#[must_use]
pub fn verdict(r: &EvalReport) -> Vec<String> {
    let row = |roughness: f32, label: &str| r.methods.iter().find(|m| m.roughness == roughness && m.label() == label);
    let ours =
        |b: &crate::eval::BucketSummary| row(b.roughness, &b.claim.0).filter(|m| crate::eval::is_runtime(&m.name));
    // ꟻLIP where every bucket with the runtime has its claim, else tone-mapped RMSE
    let by_flip = r.buckets.iter().filter(|b| ours(b).is_some()).all(|b| b.flip_claim.is_some());
    let judged: Vec<Judged> = r
        .buckets
        .iter()
        .filter_map(|b| {
            let o = ours(b)?;
            if by_flip {
                // the rival with the lowest ꟻLIP among those judged on the same tiles
                let probe_only = |c: &&crate::eval::FlipClaim| {
                    crate::eval::RowId::parse(&c.challenger) == Some(crate::eval::RowId::RUNTIME_PROBE_ONLY)
                };
                let claims: Vec<&crate::eval::FlipClaim> = if b.flip_against.is_empty() {
                    b.flip_claim.iter().collect()
                } else {
                    b.flip_against.iter().filter(|c| !probe_only(c)).collect()
                };
                let (c, t) = claims
                    .into_iter()
                    .filter_map(|c| Some((c, row(b.roughness, &c.challenger)?.flip?)))
                    .min_by(|x, y| x.1.total_cmp(&y.1))?;
                Some(Judged {
                    roughness: b.roughness,
                    rival: c.challenger.clone(),
                    ours: o.flip?,
                    theirs: t,
                    difference: c.difference,
                    se: c.se,
                })
            } else {
                let t = row(b.roughness, &b.claim.1)?;
                Some(Judged {
                    roughness: b.roughness,
                    rival: b.claim.1.clone(),
                    ours: o.tm_rmse,
                    theirs: t.tm_rmse,
                    difference: b.difference_tm,
                    se: b.reference_se_tm,
                })
            }
        })
        .collect();
    if judged.is_empty() {
        return Vec::new();
    }
    let measure = if by_flip { "ꟻLIP of the rendered views" } else { "tone-mapped RMSE" };
    let wins: Vec<&Judged> = judged.iter().filter(|j| j.difference > 2.0 * j.se).collect();
    let losses: Vec<&Judged> = judged.iter().filter(|j| j.difference < -2.0 * j.se).collect();
    let even: Vec<&Judged> = judged.iter().filter(|j| j.difference.abs() <= 2.0 * j.se).collect();
    // the rivals of a group by method (mip rules apart), then its largest difference
    let rivals = |group: &[&Judged]| {
        let mut names: Vec<String> = Vec::new();
        for name in group.iter().map(|j| plain_name(j.rival.split('/').next().unwrap_or(&j.rival))) {
            if !names.contains(&name) {
                names.push(name);
            }
        }
        let j = group.iter().max_by(|a, b| a.share().total_cmp(&b.share())).copied();
        let example = j.map_or(String::new(), |j| {
            format!("; r = {}: {:.3} against {:.3} for {}", j.roughness, j.ours, j.theirs, plain_name(&j.rival))
        });
        format!("{}{example}", names.join(", "))
    };
    let win = if wins.is_empty() {
        format!("Wins: nowhere beyond 2 SE ({measure}) against the best rival of similar cost.")
    } else {
        format!(
            "Wins: at {} the fitted grid's pictures are {} closer to the reference ({measure}) than the best rival of similar cost ({}), beyond 2 SE.",
            roughness_list(&wins),
            share_range(&wins),
            rivals(&wins),
        )
    };
    let lose = if losses.is_empty() {
        "Loses: nowhere beyond 2 SE.".to_string()
    } else {
        format!(
            "Loses: at {} they are {} further from it than the best rival's ({}), beyond 2 SE.",
            roughness_list(&losses),
            share_range(&losses),
            rivals(&losses),
        )
    };
    // the pointwise result, bucket by bucket, against each bucket's best classic row
    let tm: Vec<(f32, f64)> = r
        .buckets
        .iter()
        .filter(|b| ours(b).is_some())
        .map(|b| (b.roughness, b.difference_tm / (2.0 * b.reference_se_tm).max(1e-300)))
        .collect();
    let tm_lower = tm.iter().filter(|(_, z)| *z > 1.0).count();
    let tm_higher: Vec<String> = tm.iter().filter(|(_, z)| *z < -1.0).map(|(r, _)| r.to_string()).collect();
    let pointwise = format!(
        "pointwise (tone-mapped RMSE) the fitted grid is lower than the best classic method at {tm_lower} of {} roughnesses and higher at {}",
        tm.len(),
        if tm_higher.is_empty() { "none".to_string() } else { format!("r = {}", tm_higher.join(", ")) }
    );
    let tie = if even.is_empty() {
        format!("Even: at no roughness within 2 SE; {pointwise}.")
    } else {
        format!("Even (within 2 SE): {}; {pointwise}.", roughness_list(&even))
    };
    vec![win, lose, tie]
}

/// Markdown table of every bucket's views one by one: how much of each sees geometry, its
/// references' own noise, the champion's ꟻLIP and each rival's, and their difference with
/// its paired standard error over the view's tiles (empty without views).
pub fn views_table(r: &EvalReport) -> String {
    if r.buckets.iter().all(|b| b.views.is_empty()) {
        return String::new();
    }
    let mut s = String::from(
        "| roughness | view | sees geometry | references' noise | champion | its ꟻLIP | rival | its ꟻLIP | difference ± 2 SE (tiles) |\n|---:|---|---:|---:|---|---:|---|---:|---|\n",
    );
    for b in &r.buckets {
        for (k, v) in b.views.iter().enumerate() {
            let champion = view_flip(r, b.roughness, &b.claim.0, k).map_or("–".into(), |f| format!("{f:.4}"));
            for c in &v.against {
                let rival = view_flip(r, b.roughness, &c.challenger, k).map_or("–".into(), |f| format!("{f:.4}"));
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.0}% | {:.4} | {} | {champion} | {} | {rival} | {:+.4} ± {:.4}{} |",
                    b.roughness,
                    v.name,
                    100.0 * v.coverage,
                    v.noise_flip,
                    b.claim.0,
                    c.challenger,
                    c.difference,
                    2.0 * c.se,
                    if c.difference < -2.0 * c.se { " **worse**" } else { "" }
                );
            }
        }
    }
    s
}

/// One line per bucket and rival: the camera where the champion fares worst against it
/// (the lowest difference), and whether beyond 2 SE of its tiles.
pub fn worst_cameras(r: &EvalReport) -> String {
    let mut s = String::new();
    for b in &r.buckets {
        let rivals: Vec<&str> =
            b.views.first().map(|v| v.against.iter().map(|c| c.challenger.as_str()).collect()).unwrap_or_default();
        for (j, rival) in rivals.iter().enumerate() {
            let worst = b
                .views
                .iter()
                .filter(|v| v.camera)
                .filter_map(|v| Some((v, v.against.get(j)?)))
                .min_by(|x, y| x.1.difference.total_cmp(&y.1.difference));
            let Some((v, c)) = worst else { continue };
            let _ = writeln!(
                s,
                "- r = {}: {} against {rival}, worst {}: {:+.4} ± {:.4} ({})",
                b.roughness,
                b.claim.0,
                v.name,
                c.difference,
                2.0 * c.se,
                if c.difference < -2.0 * c.se { "worse beyond 2 SE" } else { "within 2 SE or better" }
            );
        }
    }
    s
}

/// Markdown table of how each bucket's errors jump at cell faces in the camera views
/// (`perceptual::SeamSums::ratio`; empty without it): the references' own, then the
/// runtime and a few rows (by name; of several mip rules, the one with the lowest ꟻLIP).
pub fn seams_table(r: &EvalReport) -> String {
    if r.buckets.iter().all(|b| b.seam_reference.is_none()) {
        return String::new();
    }
    let names = ["runtime", "runtime-probe-only", "fitted", "fitted-trilinear", "box", "kdop", "warp1"];
    let mut s = format!(
        "| roughness | references' own | {} |\n|---:|---:|{}\n",
        names.join(" | "),
        "---:|".repeat(names.len())
    );
    let ratio = |x: Option<f64>| x.map_or("–".into(), |v| format!("{v:.2}"));
    for b in &r.buckets {
        let cells: Vec<String> = names
            .iter()
            .map(|name| {
                let best = r
                    .methods
                    .iter()
                    .filter(|m| m.roughness == b.roughness && m.name == *name && m.seam.is_some())
                    .min_by(|x, y| x.flip.unwrap_or(1.0).total_cmp(&y.flip.unwrap_or(1.0)));
                ratio(best.and_then(|m| m.seam))
            })
            .collect();
        let _ = writeln!(s, "| {} | {} | {} |", b.roughness, ratio(b.seam_reference), cells.join(" | "));
    }
    s
}

pub fn buckets_table(r: &EvalReport) -> String {
    let mut s = String::from(
        "| roughness | lookups | reference samples | claim | difference (rel RMSE / tm RMSE) | its reference SE (rel / tm) | SE ≤ ¼ difference | single reference SE (rel) | emitter queries | view pixels | view reference samples | ꟻLIP of the views' reference noise | ꟻLIP claim: difference ± 2 SE (tiles) against |\n|---:|---:|---:|---|---|---|---|---:|---:|---:|---:|---:|---|\n",
    );
    for b in &r.buckets {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} vs {} | {:.4} / {:.4} | {:.4} / {:.4} | {} | {:.3} | {:.1}% | {} | {} | {:.4} | {} |",
            b.roughness,
            b.lookups,
            b.reference_spp,
            b.claim.0,
            b.claim.1,
            b.difference_rel,
            b.difference_tm,
            b.reference_se_rel,
            b.reference_se_tm,
            if b.reference_ok { "yes" } else { "**no**" },
            b.query_se_rel,
            100.0 * b.emitter_queries,
            b.view_pixels,
            b.view_reference_spp,
            b.view_noise_flip,
            b.flip_claim.as_ref().map_or("–".to_string(), |c| format!(
                "{:+.4} ± {:.4} against {}",
                c.difference,
                2.0 * c.se,
                c.challenger
            ))
        );
    }
    for b in &r.buckets {
        let Some(c) = &b.noise_ceiling else { continue };
        let _ = writeln!(
            s,
            "\nThe references' own noise at r = {}: {} of these queries traced again with {} samples each from streams of their own. Tone-mapped RMSE against the bucket's references / against the quiet ones: none {:.4} / {:.4}, best-fetch {:.4} / {:.4}, best-aim {:.4} / {:.4} (both bounds chosen on the bucket's references){}. The quiet references themselves score {:.4} against the bucket's: a lookup with no error at all, so no row can close more than {:.2} of the none → best-fetch gap or {:.2} of the none → best-aim gap in the table above.",
            b.roughness,
            c.queries,
            c.spp,
            c.none.0,
            c.none.1,
            c.best_fetch.0,
            c.best_fetch.1,
            c.best_aim.0,
            c.best_aim.1,
            match (&c.champion, c.champion_gap_quiet) {
                (Some((name, a, q)), Some((f, g))) => format!(
                    ", {name} {a:.4} / {q:.4}: against the quiet references it closes {f:.2} of the none → best-fetch gap and {g:.2} of the none → best-aim gap"
                ),
                _ => String::new(),
            } + &match (c.oracle, c.oracle_gap_quiet) {
                (Some((a, q)), Some((f, g))) => format!(
                    "; the oracle, the exact fetch towards the true hit, {a:.4} / {q:.4}: it closes {f:.2} of the none → best-fetch gap and {g:.2} of the none → best-aim gap"
                ),
                _ => String::new(),
            },
            c.reference_vs_quiet,
            c.ceiling_fetch,
            c.ceiling_aim
        );
    }
    s
}

/// Writes eval.json, eval.md, the error-against-cost plots, the ꟻLIP figures and
/// eval_views.png into `folder`.
pub fn write_evaluation(folder: &RunFolder, ev: &Evaluation) -> Result<(), FileError> {
    write_eval(folder, &ev.report)?;
    // one file per bucket and kind, a pair of rows (images, ꟻLIP maps) per camera
    let key = |f: &crate::eval::FlipFigure| (f.roughness.to_bits(), f.diffuse, f.surface);
    for group in ev.flip_figures.chunk_by(|a, b| key(a) == key(b)) {
        write_flip_figure(folder, &ev.report, group)?;
    }
    for (k, atlas) in ev.surface_atlases.iter().enumerate() {
        let (w, h, texels) = atlas.atlas_image();
        let rgb = crate::tonemap::to_srgb8(&texels, ev.report.exposure);
        crate::preview::write_png(&folder.surface_atlas(k), w, h, &rgb)?;
    }
    match &ev.views {
        Some(v) => plot::views(&folder.eval_views(), &v.title, &v.tiles),
        None => Ok(()),
    }
}

/// `flip_r{r}.png`: the camera view at one roughness, the reference and a few rows' images
/// (tone-mapped at the scene's key), each above its ꟻLIP map (magma: black = no visible
/// difference, yellow = large).
fn write_flip_figure(folder: &RunFolder, r: &EvalReport, group: &[crate::eval::FlipFigure]) -> Result<(), FileError> {
    let Some(f) = group.first() else { return Ok(()) };
    let mut rows = Vec::new();
    for (k, f) in group.iter().enumerate() {
        let (w, h) = (f.width as usize, f.height as usize);
        let tile = |label: String, rgb: Vec<u8>| plot::Tile { label, rgb, width: w, height: h }.enlarged(2);
        let label = if group.len() > 1 { format!("reference, camera {}", k + 1) } else { "reference".into() };
        let mut images = vec![tile(label, crate::tonemap::to_srgb8(&f.reference, r.exposure))];
        let mut maps = vec![tile(String::new(), vec![255; w * h * 3])];
        for (label, image, map, mean) in &f.tiles {
            images.push(tile(label.clone(), crate::tonemap::to_srgb8(image, r.exposure)));
            maps.push(tile(format!("ꟻLIP {mean:.3}"), crate::perceptual::flip::magma(map, f.width, f.height)));
        }
        rows.push(images);
        rows.push(maps);
    }
    if let Some(k) = f.surface {
        let title = format!(
            "{}, surface probes {k}, roughness {}: the patch a glossy reflector, the rest as seen; below, ꟻLIP against the reference",
            r.scene, f.roughness
        );
        return plot::image_grid(&folder.flip_surface(k, f.roughness), &title, &rows);
    }
    if f.diffuse {
        let title = format!(
            "{}, diffuse: every surface white Lambertian lit by the grid's irradiance; below, ꟻLIP against the reference",
            r.scene
        );
        return plot::image_grid(&folder.flip_diffuse(), &title, &rows);
    }
    let title = format!(
        "{}, roughness {}: every surface a glossy reflector, camera by camera; below each, ꟻLIP against the reference",
        r.scene, f.roughness
    );
    plot::image_grid(&folder.flip_figure(f.roughness), &title, &rows)
}

/// Writes eval.json, eval.md and the error-against-cost plots into `folder`.
pub fn write_eval(folder: &RunFolder, r: &EvalReport) -> Result<(), FileError> {
    std::fs::create_dir_all(&folder.dir).map_err(FileError::io(&folder.dir))?;
    write_json(&folder.eval_json(), r)?;

    let mut md = String::new();
    let _ = writeln!(md, "# Warp evaluation: {}\n", r.scene);
    let _ = writeln!(md, "Produced by `{}`.\n", r.command);
    let _ = writeln!(
        md,
        "Validation set: {} positions uniformly random inside grid cells that are not inside geometry, {} uniformly random directions each ({} lookups), references traced with {} samples. Seed {:#x}, independent of any fitting data.\n",
        r.positions, r.settings.dirs_per_position, r.lookups, r.settings.reference_spp, r.settings.seed
    );
    let _ = writeln!(
        md,
        "Hidden fraction (true hit not visible from probe A; no single fetch of A can fix these): **{:.1}%**.\n",
        100.0 * r.hidden_fraction
    );
    if let Some((all, k)) = r.hidden_fraction_all {
        let _ = writeln!(
            md,
            "With all {k} probes (true hit visible from none of them; `oracle-probes` fetches the nearest that sees it): **{:.1}%**.\n",
            100.0 * all
        );
    }
    let _ = writeln!(
        md,
        "A reference ray (one radiance sample, with shadow and bounce rays) costs {:.0} ns single-threaded.\n",
        r.reference_ns_per_ray
    );
    let _ = writeln!(
        md,
        "Headline errors: **ꟻLIP** on rendered views (a camera on glossy surfaces and spheres of directions, tone-mapped at three exposures, each pixel's largest error) and the **tone-mapped RMSE** of the lookups (exposure {:.3}, the key of probe A): both bounded per pixel, so a lamp or the sun's disc in view cannot rule them as it rules the relative RMSE, which is kept beside them.\n",
        r.exposure
    );
    let _ = writeln!(md, "## Roughness buckets and the references' noise\n");
    md += &buckets_table(r);
    let views = views_table(r);
    if !views.is_empty() {
        let _ = writeln!(
            md,
            "\n## The views one by one\n\nEach rendered view's ꟻLIP for the claim's champion against its rivals (the best seed method within the claim's budget by mean ꟻLIP and, where the runtime blends irradiance into rough lookups, the runtime reading its probes alone). Difference: rival − champion (positive: the champion lower), ± 2 standard errors over the view's 8×8-pixel tiles.\n\n{}\n{views}",
            worst_cameras(r)
        );
    }
    let seams = seams_table(r);
    if !seams.is_empty() {
        let _ = writeln!(
            md,
            "\n## Seams at cell faces\n\nNeighbouring pixels of the camera views on one surface (normals within 8°, points nearer than a quarter cell), sorted by whether a cell face runs between them: the mean squared jump of the tone-mapped error across cell faces over the same within cells. About 1 where the error does not know where cells meet; above 1 where it jumps at their faces (cell-sized tiles). The references' own is one half of their samples against the other.\n\n{seams}"
        );
    }
    if r.diffuse.is_some() {
        md += "\n## Diffuse lighting\n\nIrradiance at held-out surface points (area-uniform on triangles inside the grid), against traced references (lamps sampled directly, the rest along cosine-distributed rays): what the light probes carry (sky, emitters, bounced light; direct sun is the renderer's job). Rows: the grid through each step of DDGI's blend, the runtime (the blend times the cell's fitted correction), probe A alone, and seed 004's voxel GI.\n\n";
        md += &diffuse_table(r);
        md += "\n![ꟻLIP, diffuse](flip_diffuse.png)\n";
    }
    for sr in &r.surface {
        md += &surface_section(sr);
    }
    let _ = writeln!(md, "\n## Mirror lookups (roughness 0)\n");
    md += &methods_table(r, 0.0);
    if !r.fitted_levels.is_empty() {
        let _ = writeln!(
            md,
            "\n`fitted` by the level of the cell containing the query position (tone-mapped RMSE / rel RMSE over each subset):\n"
        );
        let _ = writeln!(md, "| level | lookups | fitted | fallback on the same lookups |\n|---|---:|---:|---:|");
        for l in &r.fitted_levels {
            let _ = writeln!(
                md,
                "| {} | {} | {:.4} / {:.4} | {:.4} / {:.4} ({}) |",
                l.level,
                l.lookups,
                l.fitted_tm_rmse,
                l.fitted_rel_rmse,
                l.fallback_tm_rmse,
                l.fallback_rel_rmse,
                l.fallback
            );
        }
    }
    let _ = writeln!(
        md,
        "\nrel RMSE = RMSE of linear RGB radiance / mean reference radiance; MAE, p95, max: per-lookup mean absolute RGB error. Gap closed: the share of the none → best-aim gap in tone-mapped RMSE (best-aim: per query the best point on the query ray to fetch probe A towards, any mip: the bound of every warp, which all aim at a point on that ray; best-fetch: the best fetch in any direction, which no single-fetch lookup can beat). Angular error: fetch direction against the oracle's. Costs: single-threaded warm loop, fetch + bilinear radiance lookup; queries issued per position in Morton order of their octahedral uv (coherent, as neighbouring pixels query a probe), and in random order (cache-hostile).\n"
    );
    for b in r.buckets.iter().filter(|b| b.roughness > 0.0) {
        let _ = writeln!(
            md,
            "\n## Roughness {} ({} lookups, lobe references with {} samples)\n\nRows are `method/mip rule`: `plain` reads the mip of r; `engine` Frostbite's distance-based roughness (Lagarde & de Rousiers 2014, Listing 25); `corrected` the stored distance-ratio correction α'(α, k); `fade` the plain mip with the fetch faded towards the query direction by r. `runtime` is the fitted grid through `FittedGrid::specular`.\n",
            b.roughness, b.lookups, b.reference_spp
        );
        md += &methods_table(r, b.roughness);
        let _ = writeln!(md, "\n![ꟻLIP, roughness {0}](flip_r{0:.3}.png)", b.roughness);
    }
    let _ = writeln!(md, "\n![mean ꟻLIP against cost per roughness](eval_rough.png)\n");
    let _ = writeln!(md, "## warp1 options (depth mip the warp reads, UV relaxation)\n");
    let _ = writeln!(md, "| depth mip | relax (texels) | rel RMSE |\n|---:|---:|---:|");
    for row in &r.warp1_sweep {
        let _ = writeln!(md, "| {} | {} | {:.4} |", row.depth_lod, row.relax_texels, row.rel_rmse);
    }
    let _ = writeln!(md, "\n![error against cost](eval_error_vs_cost.png)");
    write_atomic(&folder.eval_md(), md.as_bytes())?;

    let points: Vec<(String, f64, f64)> =
        r.methods.iter().filter(|m| m.roughness == 0.0).map(|m| (m.name.clone(), m.ns_per_lookup, m.tm_rmse)).collect();
    plot::error_vs_cost(
        &folder.eval_plot(),
        &format!("{}: mirror lookups, error against cost", r.scene),
        "tone-mapped RMSE (log)",
        &points,
    )?;
    let panels: Vec<plot::Panel> = r
        .buckets
        .iter()
        .map(|b| {
            let points = r
                .methods
                .iter()
                .filter(|m| m.roughness == b.roughness)
                .filter_map(|m| m.flip.map(|f| (m.label(), m.ns_per_lookup, f)))
                .collect();
            (format!("roughness {}", b.roughness), points)
        })
        .filter(|(_, p): &(String, Vec<_>)| !p.is_empty())
        .collect();
    if panels.is_empty() {
        return Ok(());
    }
    plot::error_vs_cost_panels(
        &folder.eval_rough_plot(),
        &format!("{}: mean ꟻLIP against cost per roughness (red: Pareto front; green: the fitted grid)", r.scene),
        "mean ꟻLIP",
        &panels,
    )
}
