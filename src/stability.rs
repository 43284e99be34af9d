//! The stability suite: stiff and extreme cases run through the real code paths (scene
//! loading, tracing, bake, warps, fit, the fitted-grid writer and the runtime loader), each
//! with a stated expectation, a measured value and a verdict. `warpfit stability` prints the
//! rows and exits non-zero on any failure; `tests/stability.rs` runs the quick mode.
//!
//! Every case also checks that no NaN or Inf reaches any output it touches. A case that
//! panics is a failed row, not an aborted suite.

use crate::bake::{self, Bake};
use crate::eval::{self, EvalSettings};
use crate::fit::objective::{CellProblem, Sample};
use crate::fit::{FitSettings, Solver};
use crate::octa::{self, OctMap, OctMips};
use crate::pipeline::{self, Baked, StoreOptions};
use crate::progress::Progress;
use crate::runtime::{FittedGrid, Precision};
use crate::sampling::{Sampler, uniform_sphere};
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::{self, Method, Warp, WarpOptions, WarpProbe};
use glam::Vec3;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How thorough the suite is: `Quick` for the tests (seconds), `Full` for the command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Quick,
    Full,
}

/// One row of the suite.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    pub case: String,
    pub expectation: String,
    pub measured: String,
    pub pass: bool,
    pub seconds: f64,
}

/// The committed small scene every case starts from (a room open to the sky, a block, a
/// column, a sun).
const TINY: &str = include_str!("../data/scenes/tiny.toml");

/// A room 4×2×4 with a solid block filling the cells x<0, y<1, z<0 of a 4×2×4 grid, a wall
/// 1e-3 thick across it, a window, and a sun of irradiance `sun`.
fn block_room(sun: f32, albedo: f32) -> String {
    format!(
        r#"
name = "block_room"
seed = 5
bounces = 1
[probe]
position = [0.6, 1.3, 0.7]
resolution = 32
samples_per_texel = 2
ggx_samples = 16
[grid]
min = [-2.0, 0.0, -2.0]
max = [2.0, 2.0, 2.0]
counts = [4, 2, 4]
irradiance_resolution = 4
depth_resolution = 8
depth_samples = 2
[sky]
color = [0.2, 0.3, 0.5]
[sun]
direction = [0.3, 0.9, 0.2]
angular_radius_deg = 0.27
irradiance = [{sun}, {sun}, {sun}]
[[geometry]]
type = "room"
min = [-2.0, 0.0, -2.0]
max = [2.0, 2.0, 2.0]
open = ["+y"]
material = {{ albedo = [{albedo}, {albedo}, {albedo}] }}
[[geometry]]
type = "box"
min = [-2.0, 0.0, -2.0]
max = [0.0, 1.0, 0.0]
[[geometry]]
type = "box"
min = [1.0, 0.0, -1.5]
max = [1.001, 1.8, 1.5]
"#
    )
}

/// A floor 100 units wide under an open sky.
const OPEN_FLOOR: &str = r#"
name = "open_floor"
seed = 2
[probe]
position = [0.0, 1.0, 0.0]
resolution = 32
samples_per_texel = 2
ggx_samples = 16
[grid]
min = [-2.0, 0.1, -2.0]
max = [2.0, 2.1, 2.0]
counts = [2, 1, 2]
irradiance_resolution = 4
depth_resolution = 8
depth_samples = 2
[sky]
zenith = [0.3, 0.5, 1.0]
horizon = [0.9, 0.9, 1.0]
ground = [0.2, 0.2, 0.2]
[[geometry]]
type = "box"
min = [-50.0, -1.0, -50.0]
max = [50.0, 0.0, 50.0]
"#;

fn parse(text: &str, name: &str) -> Result<Scene, String> {
    Scene::parse(text, Path::new(&format!("<stability>/{name}.toml"))).map_err(|e| e.to_string())
}

fn finite3(v: &[Vec3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Bake outputs that must be finite (distances may be +inf for sky; never NaN).
fn bake_is_clean(b: &Bake) -> bool {
    b.probe.radiance.levels.iter().all(|l| finite3(&l.texels))
        && b.probe.depth.levels.iter().all(|l| l.texels.iter().all(|d| !d.is_nan() && *d >= 0.0))
        && finite3(&b.grid.irradiance)
        && finite(&b.grid.depth_mean)
        && finite(&b.grid.depth_mean_sq)
}

fn unit_and_finite(v: Vec3) -> bool {
    v.is_finite() && (v.length() - 1.0).abs() < 1e-3
}

/// Directions on the octahedral map's seams, poles and diagonals, and just beside them.
pub fn seam_directions() -> Vec<Vec3> {
    let mut base = Vec::new();
    for a in [-1.0f32, 0.0, 1.0] {
        for b in [-1.0f32, 0.0, 1.0] {
            for c in [-1.0f32, 0.0, 1.0] {
                if (a, b, c) != (0.0, 0.0, 0.0) {
                    base.push(Vec3::new(a, b, c));
                }
            }
        }
    }
    base.push(Vec3::new(-0.0, -0.0, -1.0));
    base.push(Vec3::new(-0.0, 1.0, -0.0));
    let mut out = Vec::new();
    for d in base {
        out.push(d.normalize());
        for e in [1e-7f32, -1e-7, f32::MIN_POSITIVE, 1e-30] {
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                out.push((d + axis * e).normalize());
            }
        }
    }
    out
}

/// `n` directions: a seeded uniform set plus the seam directions.
fn directions(n: u32) -> Vec<Vec3> {
    let mut d: Vec<Vec3> = (0..n).map(|k| uniform_sphere(Sampler::new(0x57AB, 1, k).next_2d())).collect();
    d.extend(seam_directions());
    d
}

/// Every per-lookup method at `b` over `dirs`: how many fetch directions are not finite unit
/// vectors.
fn bad_fetches(warp: &Warp, b: Vec3, dirs: &[Vec3]) -> usize {
    let mut bad = 0;
    for m in Method::PER_LOOKUP {
        for &d in dirs {
            let f = warp.fetch_dir(m, b, d);
            let r = warp.lookup(m, b, d);
            if !unit_and_finite(f) || !r.is_finite() {
                bad += 1;
            }
        }
    }
    bad
}

/// Runtime answers at `b` over `dirs` that are not finite and ≥ 0.
fn bad_runtime(g: &FittedGrid, b: Vec3, dirs: &[Vec3]) -> usize {
    let mut bad = 0;
    for &d in dirs {
        for r in [0.0, 0.3, 1.0] {
            let s = g.specular(b, d, r);
            if !s.is_finite() || s.min_element() < 0.0 {
                bad += 1;
            }
        }
        let e = g.irradiance(b, d);
        if !e.is_finite() || e.min_element() < 0.0 {
            bad += 1;
        }
    }
    bad
}

/// A scene, its tracer, its bake and the warp context.
struct Fixture {
    scene: Scene,
    tracer: Tracer,
    bake: Bake,
    warp: Warp,
}

impl Fixture {
    fn new(scene: Scene) -> Fixture {
        let tracer = Tracer::new(&scene);
        let bake = bake::bake(&scene, &tracer, &Progress::quiet());
        let warp = bake::warp(&scene, &bake.probe, WarpOptions::standard());
        Fixture { scene, tracer, bake, warp }
    }

    fn baked(&self) -> Baked<'_> {
        Baked { scene: &self.scene, tracer: &self.tracer, probe: &self.bake.probe, grid: &self.bake.grid }
    }

    /// Fits, writes the fitted grid to a fresh folder and loads it back.
    fn fit_and_load(&self, mode: Mode, store: StoreOptions) -> Result<(crate::fit::Fit, FittedGrid, TempDir), String> {
        let dir = TempDir::new(&self.scene.name);
        let (fit, _) = pipeline::fit(
            self.baked(),
            &self.warp,
            &fit_settings(mode),
            store,
            &dir.0,
            "warpfit stability",
            &Progress::quiet(),
        )
        .map_err(|e| e.to_string())?;
        let g = FittedGrid::load(&dir.0).map_err(|e| e.to_string())?;
        Ok((fit, g, dir))
    }
}

fn fit_settings(mode: Mode) -> FitSettings {
    match mode {
        Mode::Quick => FitSettings::quick(),
        Mode::Full => FitSettings::moderate(),
    }
}

/// A scratch folder removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        use std::sync::atomic::{AtomicU32, Ordering};
        static N: AtomicU32 = AtomicU32::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let p = std::env::temp_dir().join(format!("warpfit-stability-{}-{tag}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

type Outcome = Result<(String, bool), String>;

/// A case: name, expectation, the check.
type Case = (&'static str, &'static str, Box<dyn Fn(Mode) -> Outcome>);

/// Runs the suite; `on_row` sees each row as it finishes.
pub fn run(mode: Mode, mut on_row: impl FnMut(&CaseResult)) -> Vec<CaseResult> {
    let cases: Vec<Case> = vec![
        (
            "query at the probe centre",
            "every method returns the query direction bit for bit; runtime = probe radiance",
            Box::new(probe_centre),
        ),
        ("query 1e-6 from a wall", "finite unit fetch directions, finite runtime answers ≥ 0", Box::new(near_wall)),
        ("query outside the grid", "finite answers; the nearest cell's corrective is used", Box::new(outside_grid)),
        (
            "octahedral seams, poles, diagonals",
            "round trip < 1e-5 rad; finite unit fetches; finite runtime",
            Box::new(seams),
        ),
        ("infinite depth (sky)", "depth warps return the query direction exactly where A sees only sky", Box::new(sky)),
        ("zero depth (probe on a surface)", "bake, warps, fit and runtime stay finite", Box::new(zero_depth)),
        (
            "scene scaled by 1e-4",
            "rel RMSE of every method within 2% of the unscaled scene",
            Box::new(|m| scaled(m, 1e-4)),
        ),
        (
            "scene scaled by 1e4",
            "rel RMSE of every method within 2% of the unscaled scene",
            Box::new(|m| scaled(m, 1e4)),
        ),
        ("grazing rays over a large plane", "no ray above the plane hits it; finite unit fetches", Box::new(grazing)),
        ("thin feature (1e-3 thick wall)", "no ray leaks through it", Box::new(thin_feature)),
        (
            "cells inside geometry",
            "exactly the 4 cells whose centres are in the block are flagged, fitted and stored nowhere",
            Box::new(inside_cells),
        ),
        (
            "a cell that sees only sky",
            "flat objective: level 0 everywhere, finite errors, the grid loads",
            Box::new(sky_only),
        ),
        (
            "stiff fit (scales 1e-3 and 1e3)",
            "log-scale parameters within 0.05, relative errors within 2%",
            Box::new(stiff_fit),
        ),
        (
            "near-singular secant step",
            "finite unit fetches for rays 1e-7 from parallel to the wall",
            Box::new(near_singular_secant),
        ),
        (
            "HDR range 1e6 (sun vs dim walls)",
            "finite everywhere; f16 layers above 65504 kept f32, no saturation",
            Box::new(hdr),
        ),
        ("degenerate triangles", "skipped and counted (3 of 4), the scene loads", Box::new(degenerate_triangles)),
        ("empty and non-finite scenes", "clear errors naming the file, no panic", Box::new(bad_scenes)),
    ];
    let mut rows = Vec::new();
    for (case, expectation, f) in cases {
        let t0 = Instant::now();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(mode)));
        let (measured, pass) = match outcome {
            Ok(Ok((m, p))) => (m, p),
            Ok(Err(e)) => (format!("error: {e}"), false),
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                (format!("panicked: {msg}"), false)
            }
        };
        let row = CaseResult {
            case: case.into(),
            expectation: expectation.into(),
            measured,
            pass,
            seconds: t0.elapsed().as_secs_f64(),
        };
        on_row(&row);
        rows.push(row);
    }
    rows
}

/// Writes `stability.json` and `stability.md` into `dir`.
pub fn write(dir: &Path, rows: &[CaseResult], mode: Mode, command: &str) -> Result<(), crate::format::FormatError> {
    use crate::format::{FormatError, write_atomic};
    std::fs::create_dir_all(dir).map_err(|source| FormatError::Io { path: dir.to_path_buf(), source })?;
    let value = serde_json::json!({
        "mode": format!("{mode:?}").to_lowercase(),
        "command": command,
        "passed": rows.iter().filter(|r| r.pass).count(),
        "failed": rows.iter().filter(|r| !r.pass).count(),
        "cases": rows,
    });
    let jpath = dir.join("stability.json");
    let bytes = serde_json::to_vec_pretty(&value)
        .map_err(|e| FormatError::Json { path: jpath.clone(), message: e.to_string() })?;
    write_atomic(&jpath, &bytes).map_err(|source| FormatError::Io { path: jpath.clone(), source })?;
    let md = format!("# Stability suite ({mode:?} mode)\n\nProduced by `{command}`.\n\n{}", table(rows));
    let mpath = dir.join("stability.md");
    write_atomic(&mpath, md.as_bytes()).map_err(|source| FormatError::Io { path: mpath.clone(), source })
}

/// Markdown table of the rows.
pub fn table(rows: &[CaseResult]) -> String {
    let mut s = String::from("| case | expectation | measured | result |\n|---|---|---|---|\n");
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} |\n",
            r.case,
            r.expectation,
            r.measured.replace('|', "/"),
            if r.pass { "pass" } else { "**FAIL**" }
        );
    }
    s
}

fn tiny(mode: Mode) -> Result<Scene, String> {
    let mut s = parse(TINY, "tiny")?;
    if mode == Mode::Full {
        s.config.probe.resolution = 64;
    }
    Ok(s)
}

fn probe_centre(mode: Mode) -> Outcome {
    let fx = Fixture::new(tiny(mode)?);
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let a = fx.bake.probe.position;
    let dirs = directions(if mode == Mode::Quick { 1024 } else { 8192 });
    let mut differ = 0;
    for m in Method::PER_LOOKUP {
        differ += dirs.iter().filter(|&&d| fx.warp.fetch_dir(m, a, d) != d).count();
    }
    let runtime_differ = dirs
        .iter()
        .filter(|&&d| g.fetch_vector(a, d) != d || g.specular(a, d, 0.0) != g.warp.probe.radiance(d))
        .count();
    let n = dirs.len() * Method::PER_LOOKUP.len();
    Ok((
        format!("{differ} of {n} method fetches differ; {runtime_differ} of {} runtime lookups differ", dirs.len()),
        differ == 0 && runtime_differ == 0 && bake_is_clean(&fx.bake),
    ))
}

fn near_wall(mode: Mode) -> Outcome {
    let fx = Fixture::new(tiny(mode)?);
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let dirs = directions(512);
    // the room's −x wall is at x = −2, its floor at y = 0
    let points =
        [Vec3::new(-2.0 + 1e-6, 1.2, 0.3), Vec3::new(0.5, 1e-6, -0.7), Vec3::new(-2.0 + 1e-6, 1e-6, -2.0 + 1e-6)];
    let bad: usize = points.iter().map(|&b| bad_fetches(&fx.warp, b, &dirs)).sum();
    let bad_rt: usize = points.iter().map(|&b| bad_runtime(&g, b, &dirs)).sum();
    Ok((format!("{bad} bad method fetches, {bad_rt} bad runtime answers at 3 points"), bad == 0 && bad_rt == 0))
}

fn outside_grid(mode: Mode) -> Outcome {
    let fx = Fixture::new(tiny(mode)?);
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let dirs = directions(256);
    let points =
        [Vec3::new(50.0, 1.0, 0.0), Vec3::new(-1e6, 0.0, 0.0), Vec3::new(0.0, 1e30, 0.0), Vec3::new(3.0, -5.0, 3.0)];
    let bad: usize = points.iter().map(|&b| bad_fetches(&fx.warp, b, &dirs)).sum();
    let mut bad_rt: usize = points.iter().map(|&b| bad_runtime(&g, b, &dirs)).sum();
    bad_rt += bad_runtime(&g, Vec3::NAN, &dirs);
    let geo = &g.correctives.geometry;
    let far = Vec3::new(50.0, 1.0, 0.0);
    let clamped = far.clamp(geo.min, geo.max - geo.cell_size() * 1e-3);
    let same_cell = geo.cell_of(far) == geo.cell_of(clamped);
    Ok((
        format!("{bad} bad method fetches, {bad_rt} bad runtime answers; nearest cell used: {same_cell}"),
        bad == 0 && bad_rt == 0 && same_cell,
    ))
}

fn seams(mode: Mode) -> Outcome {
    let fx = Fixture::new(tiny(mode)?);
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let dirs = seam_directions();
    let worst = dirs.iter().map(|&d| octa::decode(octa::encode(d)).angle_between(d)).fold(0.0f32, f32::max);
    let b = Vec3::new(-0.9, 1.5, -1.1);
    let bad = bad_fetches(&fx.warp, b, &dirs);
    let bad_rt = bad_runtime(&g, b, &dirs);
    Ok((
        format!(
            "{} directions: worst round trip {worst:.2e} rad, {bad} bad fetches, {bad_rt} bad runtime answers",
            dirs.len()
        ),
        worst < 1e-5 && bad == 0 && bad_rt == 0,
    ))
}

fn sky(mode: Mode) -> Outcome {
    let fx = Fixture::new(parse(OPEN_FLOOR, "open_floor")?);
    let opts = WarpOptions::default();
    let b = Vec3::new(0.7, 1.4, -0.5);
    let up: Vec<Vec3> =
        directions(if mode == Mode::Quick { 1024 } else { 8192 }).into_iter().filter(|d| d.y > 0.3).collect();
    let depth_methods = [Method::Warp1, Method::Warp2Fixed, Method::Warp2New, Method::Secant, Method::Raymarch];
    let mut differ = 0;
    let mut sky_texels = 0;
    for &d in &up {
        if fx.warp.probe.inv_dist(d, opts.depth_lod) == 0.0 {
            sky_texels += 1;
            differ += depth_methods.iter().filter(|&&m| fx.warp.fetch_dir(m, b, d) != d).count();
        }
    }
    let inf_depth = fx.bake.probe.depth.levels[0].texels.iter().filter(|d| d.is_infinite()).count();
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let bad_rt = bad_runtime(&g, b, &up);
    Ok((
        format!(
            "{inf_depth} sky texels in the probe; {differ} of {} depth-warp fetches towards sky differ; {bad_rt} bad runtime answers",
            sky_texels * depth_methods.len()
        ),
        differ == 0 && sky_texels > 0 && bad_rt == 0 && bake_is_clean(&fx.bake),
    ))
}

fn zero_depth(mode: Mode) -> Outcome {
    let mut s = tiny(mode)?;
    s.config.probe.position = [0.3, 0.0, -0.4]; // on the floor
    let fx = Fixture::new(s);
    let d0 = &fx.bake.probe.depth.levels[0].texels;
    let min_d = d0.iter().copied().fold(f32::INFINITY, f32::min);
    let max_w = fx.warp.probe.inv_depth.levels[0].texels.iter().copied().fold(0.0f32, f32::max);
    let dirs = directions(512);
    let bad = bad_fetches(&fx.warp, Vec3::new(0.0, 0.6, 0.2), &dirs);
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let bad_rt = bad_runtime(&g, Vec3::new(0.0, 0.6, 0.2), &dirs);
    Ok((
        format!(
            "min probe distance {min_d:.2e}, max inverse distance {max_w:.2e}; {bad} bad fetches, {bad_rt} bad runtime answers"
        ),
        bake_is_clean(&fx.bake) && max_w.is_finite() && bad == 0 && bad_rt == 0,
    ))
}

/// rel RMSE of the per-lookup methods on a small validation set.
fn method_errors(fx: &Fixture, mode: Mode) -> Vec<(String, f64)> {
    let settings = EvalSettings {
        positions: if mode == Mode::Quick { 24 } else { 96 },
        dirs_per_position: if mode == Mode::Quick { 64 } else { 128 },
        reference_spp: 2,
        ..EvalSettings::default()
    };
    let set = eval::validation_set(&fx.scene, &fx.tracer, &fx.bake.grid, fx.bake.probe.position, &settings);
    Method::PER_LOOKUP
        .iter()
        .map(|&m| {
            let est: Vec<Vec3> =
                eval::methods::fetch_dirs(&fx.warp, &set, m).iter().map(|&d| fx.warp.probe.radiance(d)).collect();
            (m.name().to_string(), eval::error_stats(&est, &set.reference).rel_rmse)
        })
        .collect()
}

fn scaled(mode: Mode, factor: f32) -> Outcome {
    let base = tiny(mode)?;
    let a = Fixture::new(base.clone());
    let b = Fixture::new(base.scaled(factor));
    let (ea, eb) = (method_errors(&a, mode), method_errors(&b, mode));
    let worst = ea.iter().zip(&eb).map(|((_, x), (_, y))| (x - y).abs() / x.abs().max(1e-9)).fold(0.0f64, f64::max);
    let worst_name = ea
        .iter()
        .zip(&eb)
        .max_by(|p, q| ((p.0.1 - p.1.1).abs() / p.0.1).total_cmp(&((q.0.1 - q.1.1).abs() / q.0.1)))
        .map(|p| p.0.0.clone())
        .unwrap_or_default();
    let finite_all = ea.iter().chain(&eb).all(|(_, e)| e.is_finite());
    Ok((
        format!("largest relative change {:.3}% ({worst_name}); warp1 {:.4} vs {:.4}", 100.0 * worst, ea[3].1, eb[3].1),
        worst <= 0.02 && finite_all && bake_is_clean(&b.bake),
    ))
}

fn grazing(_mode: Mode) -> Outcome {
    let fx = Fixture::new(parse(OPEN_FLOOR, "open_floor")?);
    let b = Vec3::new(3.0, 1e-4, 2.0);
    let mut dirs = Vec::new();
    for k in 0..256 {
        let phi = k as f32 * std::f32::consts::TAU / 256.0;
        for y in [1e-7f32, 1e-5, 1e-3, 0.0, -1e-7] {
            dirs.push(Vec3::new(phi.cos(), y, phi.sin()).normalize());
        }
    }
    // rays leaving above the plane (y ≥ 0) must not hit it
    let wrong = dirs.iter().filter(|d| d.y >= 0.0 && fx.tracer.closest_hit(b, **d, f32::INFINITY).is_some()).count();
    let bad = bad_fetches(&fx.warp, b, &dirs);
    let bad_far = bad_fetches(&fx.warp, Vec3::new(40.0, 1e-5, -40.0), &dirs);
    Ok((
        format!("{wrong} rays above the plane hit it; {} bad fetches", bad + bad_far),
        wrong == 0 && bad + bad_far == 0,
    ))
}

fn thin_feature(mode: Mode) -> Outcome {
    let scene = parse(&block_room(5.0, 0.6), "block_room")?;
    let tracer = Tracer::new(&scene);
    // the wall spans x ∈ [1, 1.001], y ∈ [0, 1.8], z ∈ [−1.5, 1.5]; shoot at it from x = 0.5
    let n = if mode == Mode::Quick { 4096 } else { 65536 };
    let mut leaks = 0;
    for k in 0..n {
        let mut s = Sampler::new(9, 3, k);
        let target = Vec3::new(1.0005, 0.05 + 1.7 * s.next_1d(), -1.45 + 2.9 * s.next_1d());
        let from = Vec3::new(0.5, 0.05 + 1.7 * s.next_1d(), -1.45 + 2.9 * s.next_1d());
        let d = (target - from).normalize();
        match tracer.closest_hit(from, d, f32::INFINITY) {
            Some(h) if h.position.x <= 1.0 + 1e-4 => {}
            _ => leaks += 1,
        }
    }
    Ok((format!("{leaks} of {n} rays leak"), leaks == 0))
}

fn inside_cells(mode: Mode) -> Outcome {
    let fx = Fixture::new(parse(&block_room(5.0, 0.6), "block_room")?);
    let geo = fx.bake.grid.geometry;
    let expected: Vec<usize> = (0..geo.cell_count())
        .filter(|&c| {
            let p = geo.cell_centre(c);
            p.x < 0.0 && p.y < 1.0 && p.z < 0.0
        })
        .collect();
    let flagged: Vec<usize> = (0..geo.cell_count()).filter(|&c| fx.bake.grid.inside[c]).collect();
    let (fit, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let stored_inside = flagged.iter().filter(|&&c| fit.correctives.stores_map(c)).count()
        + flagged.iter().filter(|&&c| g.irradiance.slot[c] != u32::MAX).count();
    let bad_rt = bad_runtime(&g, Vec3::new(-1.0, 1.05, -1.0), &directions(128));
    Ok((
        format!(
            "flagged {flagged:?}, expected {expected:?}; {stored_inside} stored; {bad_rt} bad runtime answers above the block"
        ),
        flagged == expected && stored_inside == 0 && bad_rt == 0,
    ))
}

fn sky_only(mode: Mode) -> Outcome {
    let text = "name = \"sky_only\"\n[probe]\nposition = [0.0, 1.0, 0.0]\nresolution = 16\nsamples_per_texel = 1\nggx_samples = 8\n[grid]\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\ncounts = [2, 1, 2]\nirradiance_resolution = 4\ndepth_resolution = 8\n[sky]\ncolor = [0.5, 0.6, 0.9]\n[[geometry]]\ntype = \"sphere\"\ncenter = [500.0, 500.0, 500.0]\nradius = 0.01\n";
    let fx = Fixture::new(parse(text, "sky_only")?);
    let (fit, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let level0 = fit.cells.iter().all(|c| c.level == 0);
    let finite_errs = fit
        .cells
        .iter()
        .all(|c| c.check_err_fitted.is_finite() && c.check_err_fallback.is_finite() && c.check_err_warp1.is_finite());
    let bad_rt = bad_runtime(&g, Vec3::new(0.2, 0.9, -0.3), &directions(128));
    Ok((
        format!(
            "{} cells, all level 0: {level0}; errors finite: {finite_errs}; {} maps stored; {bad_rt} bad runtime answers",
            fit.cells.len(),
            fit.correctives.stored_cells()
        ),
        level0 && finite_errs && fit.correctives.stored_cells() == 0 && bad_rt == 0,
    ))
}

/// Texture on the wall z = 5·scale.
fn wall_radiance(p: Vec3, scale: f32) -> Vec3 {
    let (x, y) = (p.x / scale, p.y / scale);
    Vec3::new(0.5 + 0.4 * (1.3 * x).sin() * (1.1 * y).cos(), 0.5 + 0.3 * (0.9 * x + 0.4 * y).sin(), 0.4)
}

/// Closed-form fixture: a probe at the origin (`res`² map) before an infinite textured wall
/// at z = 5·scale.
pub fn wall_probe(scale: f32, res: u32) -> WarpProbe {
    let z = 5.0 * scale;
    let rad = OctMap::from_fn(res, |_, _, d| if d.z > 0.0 { wall_radiance(d * (z / d.z), scale) } else { Vec3::ZERO });
    let dist = OctMap::from_fn(res, |_, _, d| if d.z > 0.0 { z / d.z } else { f32::INFINITY });
    WarpProbe::from_distance_mips(Vec3::ZERO, &octa::build_distance_mips(dist, 8), OctMips { levels: vec![rad] })
}

/// The wall's cell problem: a cell centred 1·scale before the probe whose 8×8 map starts 30%
/// too near, and `samples` queries in the cell with exact references. Returns the starting
/// map, the queries, the cell centre and the true map.
pub fn wall_problem(scale: f32, samples: u32) -> (Vec<f32>, Vec<Sample>, Vec3, Vec<f32>) {
    let z = 5.0 * scale;
    let c = Vec3::new(0.8, -0.5, 1.0) * scale;
    let res = 8;
    let truth: Vec<f32> = (0..res * res)
        .map(|t| {
            let d = octa::texel_dir(res, t % res, t / res);
            if d.z > 0.0 { d.z / (z - c.z) } else { 0.0 }
        })
        .collect();
    let init = truth.iter().map(|w| w * 1.3).collect();
    let qs = (0..samples)
        .map(|k| {
            let mut s = Sampler::new(5, 7, k);
            let b = c + (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
            let mut d = uniform_sphere(s.next_2d());
            d.z = d.z.abs().max(0.2);
            let d = d.normalize();
            Sample { b, dir: d, reference: wall_radiance(b + d * ((z - b.z) / d.z), scale), taps: [(0, 0.0); 4] }
        })
        .collect();
    (init, qs, c, truth)
}

/// Fits the wall problem with Brent: log-scale parameters and the held-in relative error.
fn fit_wall(scale: f32, samples: u32) -> (Vec<f64>, f64) {
    let probe = wall_probe(scale, 128);
    let (init, qs, c, _) = wall_problem(scale, samples);
    let mut problem = CellProblem::new(&probe, c, 8, init, qs, 1e-4, 0.0);
    let out = problem.solve(Solver::Brent, 2);
    let err = problem.relative_error_map(&problem.map_with_relax(&out.params, 0.0));
    (out.params, err)
}

fn stiff_fit(mode: Mode) -> Outcome {
    let n = if mode == Mode::Quick { 1500 } else { 4000 };
    let (s_small, e_small) = fit_wall(1e-3, n);
    let (s_large, e_large) = fit_wall(1e3, n);
    let max_diff = s_small.iter().zip(&s_large).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let rel = (e_small - e_large).abs() / e_small.max(1e-9);
    let finite_all =
        s_small.iter().chain(&s_large).all(|x| x.is_finite()) && e_small.is_finite() && e_large.is_finite();
    Ok((
        format!("log-scales differ by {max_diff:.2e}; relative errors {e_small:.4} vs {e_large:.4}"),
        finite_all && max_diff < 0.05 && rel < 0.02,
    ))
}

fn near_singular_secant(_mode: Mode) -> Outcome {
    let probe = wall_probe(1.0, 128);
    let proxies = warp::Proxies {
        aabb: warp::proxy::BoxProxy::aabb(Vec3::splat(-10.0), Vec3::splat(5.0)),
        kdop: warp::proxy::Kdop::fit(Vec3::ZERO, &probe_distance(&probe)),
    };
    let warp = Warp { probe, proxies, options: WarpOptions::standard() };
    let mut bad = 0;
    let mut n = 0;
    for b in [Vec3::new(0.5, 0.2, 1.0), Vec3::new(-2.0, 1.0, 4.99), Vec3::new(3.0, -1.0, 0.0)] {
        for k in 0..64 {
            let phi = k as f32 * std::f32::consts::TAU / 64.0;
            for dz in [1e-7f32, -1e-7, 1e-5, 1e-3, 0.0] {
                let d = Vec3::new(phi.cos(), phi.sin(), dz).normalize();
                for m in [Method::Secant, Method::Warp2New, Method::Warp1, Method::Raymarch] {
                    let f = warp.fetch_dir(m, b, d);
                    n += 1;
                    if !unit_and_finite(f) || !warp.probe.radiance(f).is_finite() {
                        bad += 1;
                    }
                }
            }
        }
    }
    Ok((format!("{bad} of {n} fetches not finite unit vectors"), bad == 0))
}

/// The probe's level-0 distances, for fitting a k-DOP.
fn probe_distance(p: &WarpProbe) -> OctMap<f32> {
    let l = &p.inv_depth.levels[0];
    OctMap::new(l.res, l.texels.iter().map(|&w| if w > 0.0 { 1.0 / w } else { f32::INFINITY }).collect())
}

fn hdr(mode: Mode) -> Outcome {
    let fx = Fixture::new(parse(&block_room(1e6, 0.02), "hdr")?);
    let max_rad = fx.bake.probe.radiance.levels[0].texels.iter().map(|v| v.max_element()).fold(0.0f32, f32::max);
    let dim = fx.bake.probe.radiance.levels[0]
        .texels
        .iter()
        .map(|v| v.max_element())
        .filter(|&x| x > 0.0)
        .fold(f32::INFINITY, f32::min);
    let (fit, g, _dir) = fx.fit_and_load(mode, StoreOptions { precision: Precision::F16, ..Default::default() })?;
    let kept_f32: Vec<String> = g
        .manifest
        .payloads
        .iter()
        .flat_map(|p| &p.layers)
        .filter(|l| l.name.starts_with("radiance_mip") && l.precision == Precision::F32)
        .map(|l| l.name.clone())
        .collect();
    let loaded_max = g.warp.probe.radiance.levels[0].texels.iter().map(|v| v.max_element()).fold(0.0f32, f32::max);
    let fit_finite = fit.cells.iter().all(|c| c.check_err_fitted.is_finite() && c.check_err_fallback.is_finite())
        && fit.correctives.maps.iter().all(|w| w.is_finite());
    let bad_rt = bad_runtime(&g, Vec3::new(0.5, 1.2, 0.5), &directions(256));
    let errs = method_errors(&fx, Mode::Quick);
    let errs_finite = errs.iter().all(|(_, e)| e.is_finite());
    let no_saturation = max_rad <= crate::format::grid_io::F16_MAX || loaded_max == max_rad;
    Ok((
        format!(
            "radiance {dim:.1e}..{max_rad:.1e}; layers kept f32: {kept_f32:?}; loaded max {loaded_max:.3e}; {bad_rt} bad runtime answers; fit finite: {fit_finite}; warp1 rel RMSE {:.3}",
            errs[3].1
        ),
        bake_is_clean(&fx.bake) && max_rad / dim >= 1e6 && fit_finite && bad_rt == 0 && errs_finite && no_saturation,
    ))
}

fn degenerate_triangles(_mode: Mode) -> Outcome {
    let dir = TempDir::new("degenerate");
    std::fs::create_dir_all(&dir.0).map_err(|e| e.to_string())?;
    // one good triangle; a repeated vertex, a collinear triple, a zero-area sliver
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 1e-30 1e-30 0\nf 1 2 3\nf 1 1 2\nf 1 2 4\nf 1 5 1\n";
    std::fs::write(dir.0.join("degenerate.obj"), obj).map_err(|e| e.to_string())?;
    let scene_text = "[probe]\nposition = [0.3, 0.3, 1.0]\nresolution = 16\nsamples_per_texel = 1\nggx_samples = 8\n[grid]\nmin = [-1.0, -1.0, 0.5]\nmax = [1.0, 1.0, 1.5]\ncounts = [2, 2, 1]\nirradiance_resolution = 4\ndepth_resolution = 8\n[[geometry]]\ntype = \"obj\"\npath = \"degenerate.obj\"\n";
    let path = dir.0.join("degenerate.toml");
    std::fs::write(&path, scene_text).map_err(|e| e.to_string())?;
    let scene = Scene::load(&path).map_err(|e| e.to_string())?;
    let fx = Fixture::new(scene);
    Ok((
        format!(
            "{} triangle(s) kept, {} skipped; bake clean: {}",
            fx.scene.triangles.len(),
            fx.scene.degenerate_skipped,
            bake_is_clean(&fx.bake)
        ),
        fx.scene.triangles.len() == 1 && fx.scene.degenerate_skipped == 3 && bake_is_clean(&fx.bake),
    ))
}

fn bad_scenes(_mode: Mode) -> Outcome {
    let header = "[probe]\nposition = [0.0, 1.0, 0.0]\nresolution = 16\n[grid]\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\ncounts = [2, 2, 2]\n";
    let cases = [
        ("empty", header.to_string()),
        ("nan", format!("{header}[[geometry]]\ntype = \"box\"\nmin = [nan, 0.0, 0.0]\nmax = [1.0, 1.0, 1.0]\n")),
        (
            "inf_probe",
            header.replace("position = [0.0, 1.0, 0.0]", "position = [inf, 1.0, 0.0]")
                + "[[geometry]]\ntype = \"box\"\nmin = [0.0, 0.0, 0.0]\nmax = [1.0, 1.0, 1.0]\n",
        ),
    ];
    let mut msgs = Vec::new();
    let mut ok = true;
    for (name, text) in cases {
        match parse(&text, name) {
            Ok(_) => {
                ok = false;
                msgs.push(format!("{name}: accepted"));
            }
            Err(e) => {
                ok &= e.contains(&format!("{name}.toml"));
                msgs.push(e);
            }
        }
    }
    Ok((msgs.join("; "), ok))
}
