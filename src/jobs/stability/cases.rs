//! The stability suite's cases: each a function from the mode to a measured value and a
//! verdict, run through the real code paths.

use super::Mode;
use super::scenes::*;
use crate::eval::{self, EvalSettings};
use crate::fit::Solver;
use crate::fit::fixtures::{fit_wall, wall_probe};
use crate::jobs::run::StoreOptions;
use crate::octa::{self, OctMap};
use crate::runtime::Precision;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::{self, Method, Warp, WarpOptions, WarpProbe};
use glam::Vec3;

/// What a case returns: the measured value in words and whether it passes; an error when the
/// case could not run.
pub type Outcome = Result<(String, bool), String>;

pub fn tiny(mode: Mode) -> Result<Scene, String> {
    let mut s = parse(TINY, "tiny")?;
    if mode == Mode::Full {
        s.config.probe.resolution = 64;
    }
    Ok(s)
}

pub fn probe_centre(mode: Mode) -> Outcome {
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
        .filter(|&&d| g.fetch_vector(a, d) != d || g.specular(a, d, 0.0) != g.warp().probe.radiance(d))
        .count();
    let n = dirs.len() * Method::PER_LOOKUP.len();
    Ok((
        format!("{differ} of {n} method fetches differ; {runtime_differ} of {} runtime lookups differ", dirs.len()),
        differ == 0 && runtime_differ == 0 && bake_is_clean(&fx.bake),
    ))
}

pub fn near_wall(mode: Mode) -> Outcome {
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

pub fn outside_grid(mode: Mode) -> Outcome {
    let fx = Fixture::new(tiny(mode)?);
    let (_, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let dirs = directions(256);
    let points =
        [Vec3::new(50.0, 1.0, 0.0), Vec3::new(-1e6, 0.0, 0.0), Vec3::new(0.0, 1e30, 0.0), Vec3::new(3.0, -5.0, 3.0)];
    let bad: usize = points.iter().map(|&b| bad_fetches(&fx.warp, b, &dirs)).sum();
    let mut bad_rt: usize = points.iter().map(|&b| bad_runtime(&g, b, &dirs)).sum();
    bad_rt += bad_runtime(&g, Vec3::NAN, &dirs);
    let geo = &g.correctives().geometry;
    let far = Vec3::new(50.0, 1.0, 0.0);
    let clamped = far.clamp(geo.min, geo.max - geo.cell_size() * 1e-3);
    let same_cell = geo.cell_of(far) == geo.cell_of(clamped);
    Ok((
        format!("{bad} bad method fetches, {bad_rt} bad runtime answers; nearest cell used: {same_cell}"),
        bad == 0 && bad_rt == 0 && same_cell,
    ))
}

pub fn seams(mode: Mode) -> Outcome {
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

pub fn sky(mode: Mode) -> Outcome {
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

pub fn zero_depth(mode: Mode) -> Outcome {
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
    let set = eval::validation_set(&fx.scene, &fx.tracer, &fx.bake.grid, &fx.bake.positions(), &settings, None);
    Method::PER_LOOKUP
        .iter()
        .map(|&m| {
            let est: Vec<Vec3> =
                eval::methods::fetch_dirs(&fx.warp, &set, m).iter().map(|&d| fx.warp.probe.radiance(d)).collect();
            (m.name().to_string(), eval::error_stats(&est, &set.reference, 1.0).rel_rmse)
        })
        .collect()
}

pub fn scaled(mode: Mode, factor: f32) -> Outcome {
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

pub fn grazing(_mode: Mode) -> Outcome {
    let fx = Fixture::new(parse(OPEN_FLOOR, "open_floor")?);
    let b = Vec3::new(3.0, 1e-4, 2.0);
    let mut dirs = Vec::new();
    for k in 0..256 {
        let phi = k as f32 * std::f32::consts::TAU / 256.0;
        for y in [1e-7f32, 1e-5, 1e-3, 0.0, -1e-7] {
            dirs.push(Vec3::new(libm::cosf(phi), y, libm::sinf(phi)).normalize());
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

pub fn thin_feature(mode: Mode) -> Outcome {
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

pub fn inside_cells(mode: Mode) -> Outcome {
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
    // not fitted, no irradiance stored; a shift map only as a copy of an open cell's
    let c = &fit.correctives;
    let fitted_inside = fit.cells.iter().filter(|f| flagged.contains(&(f.cell as usize))).count()
        + flagged.iter().filter(|&&cell| g.irradiance_grid().slot[cell] != u32::MAX).count();
    let n2 = (c.map_res * c.map_res) as usize;
    let map_of = |cell: usize| c.slot_of(cell).map(|s| &c.maps[s as usize * n2..(s as usize + 1) * n2]);
    let borrowed = flagged.iter().filter(|&&cell| map_of(cell).is_some()).count();
    let copies = flagged.iter().filter_map(|&cell| map_of(cell)).all(|m| {
        (0..geo.cell_count()).any(|other| !fx.bake.grid.inside[other] && map_of(other).is_some_and(|o| o == m))
    });
    let bad_rt = bad_runtime(&g, Vec3::new(-1.0, 1.05, -1.0), &directions(128));
    Ok((
        format!(
            "flagged {flagged:?}, expected {expected:?}; {fitted_inside} fitted or with irradiance; {borrowed} borrow an open cell's maps (copies: {copies}); {bad_rt} bad runtime answers above the block"
        ),
        flagged == expected && fitted_inside == 0 && copies && bad_rt == 0,
    ))
}

pub fn sky_only(mode: Mode) -> Outcome {
    let text = "name = \"sky_only\"\n[probe]\nposition = [0.0, 1.0, 0.0]\nresolution = 16\nsamples_per_texel = 1\nggx_samples = 8\n[grid]\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\ncounts = [2, 1, 2]\nirradiance_resolution = 4\ndepth_resolution = 8\n[sky]\ncolor = [0.5, 0.6, 0.9]\n[[geometry]]\ntype = \"sphere\"\ncenter = [500.0, 500.0, 500.0]\nradius = 0.01\n";
    let fx = Fixture::new(parse(text, "sky_only")?);
    let (fit, g, _dir) = fx.fit_and_load(mode, StoreOptions::default())?;
    let level0 = fit.cells.iter().all(|c| c.level == crate::fit::Level::Fallback);
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

pub fn stiff_fit(mode: Mode) -> Outcome {
    let n = if mode == Mode::Quick { 1500 } else { 4000 };
    let small = fit_wall(1e-3, 128, n, Solver::Brent, 2);
    let large = fit_wall(1e3, 128, n, Solver::Brent, 2);
    let (s_small, e_small, s_large, e_large) = (small.params, small.after, large.params, large.after);
    let max_diff = s_small.iter().zip(&s_large).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let rel = (e_small - e_large).abs() / e_small.max(1e-9);
    let finite_all =
        s_small.iter().chain(&s_large).all(|x| x.is_finite()) && e_small.is_finite() && e_large.is_finite();
    Ok((
        format!("log-scales differ by {max_diff:.2e}; relative errors {e_small:.4} vs {e_large:.4}"),
        finite_all && max_diff < 0.05 && rel < 0.02,
    ))
}

pub fn near_singular_secant(_mode: Mode) -> Outcome {
    let probe = wall_probe(1.0, 128);
    let proxies = warp::Proxies {
        aabb: warp::proxy::BoxProxy::aabb(Vec3::splat(-10.0), Vec3::splat(5.0)),
        kdop: warp::proxy::Kdop::fit(Vec3::ZERO, &probe_distance(&probe)),
    };
    let warp = Warp { probe, others: Default::default(), proxies, options: WarpOptions::standard() };
    let mut bad = 0;
    let mut n = 0;
    for b in [Vec3::new(0.5, 0.2, 1.0), Vec3::new(-2.0, 1.0, 4.99), Vec3::new(3.0, -1.0, 0.0)] {
        for k in 0..64 {
            let phi = k as f32 * std::f32::consts::TAU / 64.0;
            for dz in [1e-7f32, -1e-7, 1e-5, 1e-3, 0.0] {
                let d = Vec3::new(libm::cosf(phi), libm::sinf(phi), dz).normalize();
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
    OctMap::new(l.res, l.texels.iter().map(|&w| octa::distance_from_inverse(w)).collect())
}

pub fn hdr(mode: Mode) -> Outcome {
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
        .manifest()
        .payloads
        .iter()
        .flat_map(|p| &p.layers)
        .filter(|l| l.name.starts_with("radiance_mip") && l.precision == Precision::F32)
        .map(|l| l.name.clone())
        .collect();
    let loaded_max = g.warp().probe.radiance.levels[0].texels.iter().map(|v| v.max_element()).fold(0.0f32, f32::max);
    let fit_finite = fit.cells.iter().all(|c| c.check_err_fitted.is_finite() && c.check_err_fallback.is_finite())
        && fit.correctives.maps.iter().all(|w| w.is_finite());
    let bad_rt = bad_runtime(&g, Vec3::new(0.5, 1.2, 0.5), &directions(256));
    let errs = method_errors(&fx, Mode::Quick);
    let errs_finite = errs.iter().all(|(_, e)| e.is_finite());
    let no_saturation = max_rad <= crate::gridfile::exr::F16_MAX || loaded_max == max_rad;
    Ok((
        format!(
            "radiance {dim:.1e}..{max_rad:.1e}; layers kept f32: {kept_f32:?}; loaded max {loaded_max:.3e}; {bad_rt} bad runtime answers; fit finite: {fit_finite}; warp1 rel RMSE {:.3}",
            errs[3].1
        ),
        bake_is_clean(&fx.bake) && max_rad / dim >= 1e6 && fit_finite && bad_rt == 0 && errs_finite && no_saturation,
    ))
}

pub fn degenerate_triangles(_mode: Mode) -> Outcome {
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

pub fn bad_scenes(_mode: Mode) -> Outcome {
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

/// Light leaking through a 1e-3 wall into a room with no light (`scenes::two_rooms`): the
/// mean irradiance at the dark room's surface points within one cell of the wall over the
/// lit room's (whose reference is not zero) in the same band, for the DDGI blend at cell
/// centres, with relocated probes, with relocated probes and the fitted surface bias, and
/// through the runtime (relocated probes, the fitted bias and scale maps).
/// Returns (the four leaks, relocated cells).
pub fn leak_figures(mode: Mode) -> Result<([f64; 4], usize), String> {
    use crate::runtime::{IrradianceBlend, IrradianceGrid};
    use crate::trace::{Renderer, truth};
    let spp = if mode == Mode::Quick { 64 } else { 256 };
    let mut out = [0.0; 4];
    let mut relocated = 0;
    for (k, relocate) in [0.0f32, 0.15].into_iter().enumerate() {
        let scene = parse(&two_rooms(relocate), "two_rooms")?;
        let tracer = Tracer::new(&scene);
        let bake = crate::bake::bake(&scene, &tracer, &crate::progress::Progress::quiet());
        let g = &bake.grid;
        if k == 1 {
            relocated = g.probe_offset.iter().filter(|o| **o != Vec3::ZERO).count();
        }
        let mut ir = IrradianceGrid::from_cells(
            g.geometry,
            (g.irradiance_resolution, g.depth_resolution),
            (&g.irradiance, &g.depth_mean, &g.depth_mean_sq, &g.probe_offset),
            |c| !g.inside[c],
        );
        let band = |lo: f32, hi: f32| {
            truth::surface_points(
                &scene,
                &tracer,
                (Vec3::new(lo, 0.0, -1.0), Vec3::new(hi, 2.0, 1.0)),
                256,
                (9, 0x1EA0),
            )
        };
        let (dark, lit) = (band(0.241, 0.741), band(-0.26, 0.24));
        let renderer = Renderer::new(&scene, &tracer);
        let lit_ref: f64 = lit
            .iter()
            .enumerate()
            .map(|(i, &(p, n))| {
                let mut rays = 0;
                let e = truth::irradiance_reference(
                    &renderer,
                    p,
                    n,
                    spp,
                    |j| Sampler::new(9, 0x1EA1 + i as u64, j),
                    &mut rays,
                )
                .0;
                crate::tonemap::luminance(e) as f64
            })
            .sum::<f64>()
            / lit.len().max(1) as f64;
        let leak = |ir: &IrradianceGrid, blend: Option<IrradianceBlend>| {
            dark.iter()
                .map(|&(p, n)| {
                    let e = blend.map_or_else(|| ir.irradiance(p, n), |b| ir.irradiance_blend(p, n, b));
                    crate::tonemap::luminance(e) as f64
                })
                .sum::<f64>()
                / dark.len().max(1) as f64
                / lit_ref.max(1e-30)
        };
        out[k] = leak(&ir, Some(IrradianceBlend::Chebyshev));
        if k == 1 {
            let probe = &bake.probe;
            let baked =
                crate::bake::Baked { scene: &scene, tracer: &tracer, probe, others: &[], grid: g, references: None };
            let exposure = crate::bake::warp(&scene, probe, WarpOptions::standard()).probe.key_exposure();
            let seed = crate::fit::FitSettings::standard().seed;
            ir.correction = crate::fit::irradiance::fit_irradiance(baked, ir.view(), exposure, seed).correction;
            out[2] = leak(&ir, Some(IrradianceBlend::Biased));
            out[3] = leak(&ir, None);
        }
    }
    Ok((out, relocated))
}

pub fn thin_wall_leak(mode: Mode) -> Outcome {
    let ([before, moved, biased, runtime], relocated) = leak_figures(mode)?;
    Ok((
        format!(
            "dark room's irradiance over the lit room's near the wall: DDGI {before:.2e}, relocated ({relocated} cells) {moved:.2e}, + fitted surface bias {biased:.2e}, runtime (+ scale maps) {runtime:.2e}"
        ),
        runtime.is_finite() && runtime * 4.0 <= before,
    ))
}
