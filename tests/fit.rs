//! The fitter: recovers a known correction, is scale-invariant (stiff scales converge the
//! same), stores nothing where the plain warp is exact, never keeps a worse map, and is
//! bit-identical at any thread count.

mod common;
use common::*;
use warpfit::fit::{self, FitSettings, Solver};
use warpfit::fit::{Level, Selection};
use warpfit::octa;
use warpfit::progress::Progress;
use warpfit::roughness::{RoughnessCorrection, RowRule};
use warpfit::trace::Tracer;

fn fit_wall(scale: f32, solver: Solver) -> (Vec<f64>, f64, f64, Vec<f32>, Vec<f32>) {
    let w = fit::fixtures::fit_wall(scale, 256, 4000, solver, 4);
    (w.params, w.before, w.after, w.fitted, w.truth)
}

#[test]
fn flat_wall_correction_is_recovered() {
    let w = fit::fixtures::fit_wall(1.0, 256, 4000, Solver::Brent, 4);
    let (before, after, fitted) = (w.before, w.after, &w.fitted);
    // the proxy alone (its far face 1.5 behind the wall) is far off; the fit finds the wall
    assert!(after < 0.7 * before, "error {before} → {after}");
    // The fit does at least as well as the true map, whose error is not zero: the lookup
    // interpolates an 8×8 map bilinearly, and the queries fill the cell's volume.
    assert!(after <= w.truth_err * 1.001, "fitted {after} vs true map {}", w.truth_err);
    // Texels looking at the wall head-on come back near the wall's distance (within what
    // trading texel exactness for lower error between texel centres costs).
    let res = 8;
    let mut checked = 0;
    for (t, shift) in fitted.iter().enumerate() {
        let d = octa::texel_dir(res, t as u32 % res, t as u32 / res);
        if d.z > 0.8 {
            let (got, want) = (w.proxy_distance[t] + shift, w.distance[t]);
            let rel = (got / want - 1.0).abs();
            assert!(rel < 0.15, "texel {t} ({d}): fitted distance {got} vs true {want} ({rel})");
            assert!((w.truth[t] - (want - w.proxy_distance[t])).abs() <= 1e-5 * want, "the true shift");
            checked += 1;
        }
    }
    assert!(checked >= 4);
}

#[test]
fn stiff_scales_converge_to_the_same_answer() {
    // The same wall at scales 1e-3 and 1e3 (natural scales of distances 1e6 apart): the
    // log-scale parameters and the relative errors must agree.
    let (s_small, _, e_small, _, _) = fit_wall(1e-3, Solver::Brent);
    let (s_large, _, e_large, _, _) = fit_wall(1e3, Solver::Brent);
    assert!((e_small - e_large).abs() < 0.02 * e_small.max(1e-3), "{e_small} vs {e_large}");
    let max_diff = s_small.iter().zip(&s_large).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(max_diff < 0.05, "log-scales differ by {max_diff}");
}

#[test]
fn gradient_and_simplex_solvers_also_improve_the_wall() {
    for solver in [Solver::Lbfgs, Solver::NelderMead] {
        let (_, before, after, _, _) = fit_wall(1.0, solver);
        assert!(after < before, "{solver:?}: {before} → {after}");
    }
}

#[test]
fn fallback_never_keeps_a_worse_map() {
    assert_eq!(fit::choose_level(0.3, 0.31, 0.02, fit::SELECTION_MARGIN), Selection::KeptFallback);
    assert_eq!(fit::choose_level(0.3, 0.31, 0.02, fit::SELECTION_MARGIN).level(), Level::Fallback);
    assert_eq!(fit::choose_level(0.3, 0.3, 0.02, fit::SELECTION_MARGIN).level(), Level::Fallback);
    assert_eq!(fit::choose_level(0.3, 0.2, 0.02, fit::SELECTION_MARGIN), Selection::MapBeatsFallback);
    assert_eq!(fit::choose_level(0.3, 0.2, 0.02, fit::SELECTION_MARGIN).level(), Level::Map);
    assert_eq!(fit::choose_level(0.01, 0.001, 0.02, fit::SELECTION_MARGIN), Selection::FallbackMeetsTolerance);
}

fn small_torture() -> warpfit::scene::Scene {
    let mut s = load("torture");
    s.config.probe.resolution = 64;
    s.config.probe.samples_per_texel = 2;
    s.config.grid.counts = [5, 2, 5];
    s
}

fn quick_settings() -> FitSettings {
    FitSettings::quick()
}

/// Every roughness of the fit's mix has a row, rendered (ꟻLIP in (0, 1)), holding the scene
/// fit unless another rule's views are clearly better, and the stored table holds that
/// rule's α' at every k node.
fn scene_rows_hold_their_chosen_rules(corr: &RoughnessCorrection, lobes: &RoughnessCorrection) {
    let cmp = corr.heldout_scene.as_ref().expect("the comparison is recorded");
    assert_eq!(cmp.rows.iter().map(|r| r.roughness).collect::<Vec<_>>(), fit::ROUGH_MIX.to_vec());
    for (row, choice) in cmp.rows.iter().enumerate() {
        for rule in RowRule::ALL {
            let (f, t) = (choice.flip.get(rule), choice.tm_rmse.get(rule));
            assert!(f > 0.0 && f < 1.0 && t.is_finite() && t > 0.0, "{choice:?}");
        }
        assert_eq!(choice.chosen, choice.flip.chosen_with(&choice.flip_se));
        if choice.chosen != RowRule::SceneFit {
            let clear = choice.flip.get(choice.chosen) + 2.0 * choice.flip_se.get(choice.chosen);
            assert!(clear < choice.flip.scene_fit, "{choice:?}");
        }
        let r = choice.roughness;
        let [up, down] = cmp.scene_exponents[row];
        for &k in &corr.ratios {
            let expected = match choice.chosen {
                RowRule::SceneFit => {
                    let e = if k > 1.0 { up } else { down };
                    (corr.c0 as f64 * (r * r) as f64 * libm::exp(-(e as f64) * libm::log(k as f64))) as f32
                }
                RowRule::Lobes => lobes.corrected_alpha(r * r, k),
                RowRule::Engine => warpfit::warp::glossy::engine_roughness(r, k).powi(2),
                RowRule::Plain => r * r,
            }
            .clamp(1e-3, 1.0);
            let stored = corr.from_table(r * r, k);
            assert!((stored - expected).abs() <= 1e-5 * expected.max(1e-3), "r {r} k {k}: {stored} vs {expected}");
        }
    }
}

#[test]
fn fit_is_bit_identical_at_any_thread_count_and_never_worse_where_stored() {
    let scene = small_torture();
    let tracer = Tracer::new(&scene);
    let baked = warpfit::bake::bake(&scene, &tracer, &Progress::quiet());
    let warp = warpfit::bake::warp(&scene, &baked.probe, warpfit::warp::WarpOptions::standard());
    let b = warpfit::bake::Baked { others: &[], ..baked.baked(&scene, &tracer) };
    let lobes = warpfit::roughness::fit_correction();
    let glossy = warpfit::warp::glossy::Glossy { warp: &warp, correction: Some(&lobes) };
    // `moderate`, not `quick`: quick's selection (4 check positions, 1-sample references)
    // keeps maps that lose on held-out positions about as often as not
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| fit::fit(b, glossy, &FitSettings::moderate(), fit::MapSets::WithUnfitted, &Progress::quiet()))
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.correctives, b.correctives);
    assert_eq!(a.unfitted, b.unfitted);
    assert!(a.unfitted.is_some());
    assert_eq!(a.roughness, b.roughness, "the scene's roughness correction is deterministic too");
    scene_rows_hold_their_chosen_rules(a.roughness.as_ref().expect("rough queries: a scene correction"), &lobes);
    let strip = |f: &fit::Fit| {
        f.cells
            .iter()
            .map(|c| (c.cell, c.level, c.check_err_fitted.to_bits(), c.evaluations, c.check_positions))
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&a), strip(&b));
    // a cell is judged on its check positions, or on more where they could not decide
    let s = FitSettings::moderate();
    let first = s.check_positions;
    assert!(a.cells.iter().all(|c| c.check_positions >= first), "{:?}", strip(&a));
    assert!(a.cells.iter().all(|c| c.check_positions <= first + s.extra_check_positions));
    assert!(a.cells.iter().any(|c| c.check_positions > first), "no cell was undecided on its first check positions");
    assert!(a.correctives.maps.iter().all(|d| d.is_finite()));
    // Stored maps beat the fallback where it can fail: on the evaluation's held-out
    // validation set (other positions, other directions, other references than the check
    // set selection used), over the lookups whose cell stores a map.
    let settings =
        warpfit::eval::EvalSettings { positions: 96, dirs_per_position: 64, reference_spp: 2, ..Default::default() };
    let set = warpfit::eval::validation_set(&scene, &tracer, &baked.grid, &baked.positions(), &settings, None);
    let levels = warpfit::eval::metrics::level_errors(&warp, &set, &a.correctives, 1.0);
    let stored = levels.iter().find(|l| l.level == 2).expect("validation lookups in stored cells");
    assert!(stored.lookups > 500, "only {} held-out lookups in stored cells", stored.lookups);
    // judged by the fit's own measure, tone-mapped RMSE (relative RMSE is ruled by the few
    // brightest references: the emitters)
    assert!(
        stored.fitted_tm_rmse < stored.fallback_tm_rmse,
        "stored maps lose to the fallback on held-out lookups: {stored:?}"
    );
    assert!(a.correctives.stored_cells() > 0, "some torture cell should need a map");
    // the diffuse correctives: deterministic, bounded, stored only where they helped the
    // check points, and better than the blend alone on the evaluation's held-out points
    assert_eq!(a.irradiance.correction, b.irradiance.correction);
    assert!(a.irradiance.correction.scale.iter().all(|k| (0.2..=5.0).contains(k)));
    for c in &a.irradiance.cells {
        assert_eq!(c.stored, a.irradiance.correction.slot[c.cell as usize] != u32::MAX);
        assert!(!c.stored || c.check_after < 0.95 * c.check_before, "{c:?}");
    }
    let mut ir = warpfit::runtime::IrradianceGrid::from_cells(
        baked.grid.geometry,
        (baked.grid.irradiance_resolution, baked.grid.depth_resolution),
        (&baked.grid.irradiance, &baked.grid.depth_mean, &baked.grid.depth_mean_sq, &baked.grid.probe_offset),
        |c| !baked.grid.inside[c],
    );
    let held_out = warpfit::eval::diffuse::diffuse_set((&scene, &tracer, None), &ir, 256, 256, 7);
    let tm_rmse = |ir: &warpfit::runtime::IrradianceGrid| {
        let sq: f32 = (0..held_out.points.len())
            .map(|i| {
                let e = ir.irradiance(held_out.points[i], held_out.normals[i]);
                let tm = |v: glam::Vec3| v / (v + glam::Vec3::ONE);
                (tm(e) - tm(held_out.reference[i])).length_squared() / 3.0
            })
            .sum();
        (sq / held_out.points.len() as f32).sqrt()
    };
    let before = tm_rmse(&ir);
    ir.correction = a.irradiance.correction.clone();
    let after = tm_rmse(&ir);
    assert!(a.irradiance.correction.stored_cells() > 0, "some torture cell should need a diffuse correction");
    assert!(after < before, "diffuse correctives lose on held-out surface points: {after} vs {before}");
    // cells inside geometry are left out entirely
    for (cell, inside) in baked.grid.inside.iter().enumerate() {
        if *inside {
            assert!(!a.correctives.stores_map(cell));
            assert!(a.cells.iter().all(|c| c.cell as usize != cell));
        }
    }
}

#[test]
fn a_cell_seeing_only_sky_stores_nothing() {
    let scene = parse("[sky]\nzenith = [0.3, 0.5, 1.0]\nhorizon = [0.9, 0.9, 1.0]\nground = [0.2, 0.2, 0.2]\n[[geometry]]\ntype = \"sphere\"\ncenter = [500.0, 500.0, 500.0]\nradius = 0.01\n").unwrap();
    let tracer = Tracer::new(&scene);
    let baked = warpfit::bake::bake(&scene, &tracer, &Progress::quiet());
    let warp = warpfit::bake::warp(&scene, &baked.probe, warpfit::warp::WarpOptions::standard());
    let b = warpfit::bake::Baked { others: &[], ..baked.baked(&scene, &tracer) };
    let glossy = warpfit::warp::glossy::Glossy { warp: &warp, correction: None };
    let f = fit::fit(b, glossy, &quick_settings(), fit::MapSets::Stored, &Progress::quiet());
    assert_eq!(f.correctives.stored_cells(), 0);
    assert!(f.correctives.maps.is_empty());
    for c in &f.cells {
        assert_eq!(c.level, Level::Fallback);
        assert_eq!(c.selection, Selection::SeesOnlySky);
        assert_eq!(c.check_err_fitted, c.check_err_warp1, "sky: the map changes nothing");
        assert!(c.check_err_fallback <= c.check_err_warp1);
    }
}

#[test]
fn level_one_and_map_resolutions_are_measured_against_the_stored_model_when_asked() {
    let scene = small_torture();
    let tracer = Tracer::new(&scene);
    let baked = warpfit::bake::bake(&scene, &tracer, &Progress::quiet());
    let warp = warpfit::bake::warp(&scene, &baked.probe, warpfit::warp::WarpOptions::standard());
    let b = warpfit::bake::Baked { others: &[], ..baked.baked(&scene, &tracer) };
    let glossy = warpfit::warp::glossy::Glossy { warp: &warp, correction: None };
    // the level-1 lookup with nothing changed is the plain warp, bit for bit
    let plain =
        warpfit::warp::Level1 { offset: glam::Vec3::ZERO, depth_lod: warp.options.depth_lod, relax_texels: 0.0 };
    for k in 0..64u32 {
        let mut s = warpfit::sampling::Sampler::new(3, 7, k);
        let p = glam::Vec3::new(s.next_1d() * 8.0 - 4.0, s.next_1d() * 4.0 + 0.5, s.next_1d() * 8.0 - 4.0);
        let d = warpfit::sampling::uniform_sphere(s.next_2d());
        assert_eq!(warp.level1_vector(&plain, p, d), warp.fetch_vector(warpfit::warp::Method::Warp1, p, d));
    }
    let fit_with = |s: FitSettings| fit::fit(b, glossy, &s, fit::MapSets::Stored, &Progress::quiet());
    let without = fit_with(quick_settings());
    assert!(without.cells.iter().all(|c| c.level1.is_none()) && fit::summary::summary(&without).level1.is_none());
    let with = fit_with(FitSettings { level1: true, ..quick_settings() });
    // measuring level 1 changes nothing stored
    assert_eq!(with.correctives.maps, without.correctives.maps);
    for c in &with.cells {
        let l = c.level1.as_deref().expect("every active cell measures level 1");
        assert!(l.check_err.is_finite() && l.evaluations > 0);
        assert!(l.params.offset.abs().cmple(b.grid.geometry.cell_size()).all() && l.params.relax_texels <= 3.0);
    }
    let s = fit::summary::summary(&with).level1.expect("a level-1 summary");
    assert_eq!(s.chosen.iter().sum::<usize>(), with.cells.len());
    assert!(s.bytes_chosen <= s.bytes_stored + s.chosen[1] * fit::summary::LEVEL1_BYTES);
    assert!(fit::summary::summary(&without).resolutions.is_none());
    let studied = fit_with(FitSettings { resolution_study: true, ..quick_settings() });
    // studying resolutions changes nothing stored
    assert_eq!(studied.correctives.maps, without.correctives.maps);
    let n = studied.cells.len() as f64;
    let res = fit::STUDY_RESOLUTIONS;
    for c in &studied.cells {
        let r = c.resolutions.as_deref().expect("every active cell studies its map's resolution");
        assert!(r.errors.iter().flatten().all(|e| e.is_finite() && *e >= 0.0), "{r:?}");
    }
    let s = fit::summary::summary(&studied).resolutions.expect("a resolution summary");
    assert_eq!(s.cells, studied.cells.len());
    // the fallback everywhere stores nothing; a map of each size everywhere stores it in every cell
    assert_eq!((s.rows[0].bytes, s.rows[0].cells_per_res.iter().sum::<f64>()), (0.0, 0.0));
    for (k, r) in res.iter().enumerate() {
        assert_eq!(s.rows[1 + k].bytes, n * f64::from(r * r) * 4.0);
        assert_eq!(s.rows[1 + k].cells_per_res[k], n);
    }
    // every selection stores at most a map per cell, the largest at most
    for row in &s.rows {
        assert!(row.mean_err.is_finite() && row.cells_per_res.iter().sum::<f64>() <= n, "{row:?}");
        assert!(row.bytes <= n * f64::from(res[res.len() - 1].pow(2)) * 4.0);
    }
}

/// The in-sample bound: the maps refitted on the evaluation's own mirror queries answer
/// those queries closer than the fit's maps (trained on queries of their own) do, each
/// query looked up through its cell's map as the runtime does; hit counts that do not fit
/// the grid give no bound.
#[test]
fn the_in_sample_maps_answer_their_own_queries_closer_than_the_fitted_ones() {
    use warpfit::eval::{self, EvalSettings};
    use warpfit::tonemap::reinhard;
    use warpfit::warp::corrective::{Blend, Correctives};
    use warpfit::warp::glossy::{Glossy, MipRule};
    let dir = tmp_dir("in-sample");
    let t = SmallTorture::fit_into(&dir);
    let settings = EvalSettings { positions: 32, dirs_per_position: 32, reference_spp: 2, ..EvalSettings::default() };
    let set = eval::validation_set(&t.scene, &t.tracer, &t.grid, &[t.probe.position], &settings, None);
    let in_sample = fit::in_sample(&t.grid, &t.grid.hits, &t.warp, &t.fit, &set).expect("the fit kept its maps");
    let fitted_all = &t.fit.unfitted.as_ref().expect("kept").fitted_all;
    assert!(in_sample.stored_cells() > 0);
    let glossy = Glossy { warp: &t.warp, correction: None };
    let exposure = t.warp.probe.key_exposure();
    let error = |c: &Correctives| {
        let sum: f64 = (0..set.dirs.len())
            .map(|k| {
                let (b, dir) = (set.position_of(k), set.dirs[k]);
                let aim = c.fetch(Blend::Cell, &t.warp, b, dir, 0.0);
                let d = reinhard(glossy.radiance(MipRule::Corrected, b, dir, aim, 0.0), exposure)
                    - reinhard(set.reference[k], exposure);
                f64::from((d.x.abs() + d.y.abs() + d.z.abs()) / 3.0)
            })
            .sum();
        sum / set.dirs.len() as f64
    };
    let (bound, fitted) = (error(&in_sample), error(fitted_all));
    assert!(bound < 0.95 * fitted, "in-sample {bound} against the fitted maps' {fitted}");
    assert!(fit::in_sample(&t.grid, &[], &t.warp, &t.fit, &set).is_none());
}
