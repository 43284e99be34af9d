//! `warpfit eval` end to end on a small configuration: the files, their keys, the ordering
//! the report promises (oracle is the bound), and a validation set that is held out.

mod common;
use common::*;
use warpfit::eval::EvalSettings;
use warpfit::jobs::run::{self as job, Output};
use warpfit::progress::Progress;
use warpfit::report::folder::RunFolder;
use warpfit::trace::Tracer;
use warpfit::warp::Method;

/// The Cornell box with a small probe and grid: an evaluation in seconds.
fn small_cornell() -> warpfit::scene::Scene {
    let mut scene = load("cornell");
    scene.config.probe.resolution = 64;
    scene.config.probe.samples_per_texel = 4;
    scene.config.grid.counts = [4, 4, 4];
    scene
}

#[test]
fn eval_writes_json_markdown_and_plot_with_the_promised_keys() {
    let scene = small_cornell();
    let tracer = Tracer::new(&scene);
    let dir = tmp_dir("eval");
    let folder = RunFolder::new(&dir);
    let (probe, _, grid, baked) =
        job::load_or_bake(&scene, &tracer, (&folder, &folder), warpfit::bakefile::Hits::WithGrid, &Progress::quiet())
            .unwrap();
    assert!(baked);
    // a second call reuses the bake
    let (_, _, _, baked_again) =
        job::load_or_bake(&scene, &tracer, (&folder, &folder), warpfit::bakefile::Hits::WithGrid, &Progress::quiet())
            .unwrap();
    assert!(!baked_again);
    let settings = EvalSettings { positions: 16, dirs_per_position: 64, reference_spp: 4, ..EvalSettings::quick() };
    let baked =
        job::Baked { scene: &scene, tracer: &tracer, probe: &probe, others: &[], grid: &grid, references: None };
    let warp = baked.warp(settings.options);
    let out = Output { folder: &folder, command: "test", progress: &Progress::quiet() };
    let report = job::evaluate(baked, &warp, &settings, &Method::ALL, None, out).unwrap();
    assert_eq!(report.positions, 16);
    assert_eq!(report.lookups, 16 * 64);
    for f in ["eval.json", "eval.md", "eval_error_vs_cost.png"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("eval.json")).unwrap()).unwrap();
    assert!(json["hidden_fraction"].as_f64().is_some());
    let methods = json["methods"].as_array().unwrap();
    // every bucket has every row: each method at roughness 0; each but reproject (no rough
    // variant) with each of the four mip rules at every rough bucket
    let buckets = warpfit::eval::ROUGHNESS_BUCKETS;
    assert_eq!(report.buckets.len(), buckets.len());
    assert!(report.buckets.iter().all(|b| (0.0..=1.0).contains(&b.emitter_queries)));
    // every bucket's ꟻLIP claim against the best seed method, with its tile standard error
    for b in &report.buckets {
        let c = b.flip_claim.as_ref().expect("views were rendered: a ꟻLIP claim");
        assert!(c.difference.is_finite() && c.se.is_finite() && c.se > 0.0, "{c:?}");
        assert!(warpfit::warp::Method::parse(c.challenger.split('/').next().unwrap()).is_some(), "{c:?}");
    }
    // every view judged on its own: its share on geometry, each row's ꟻLIP on it (the
    // pixel-weighted mean of which is the row's), the champion against its rivals on it;
    // and the seams at cell faces, the references' own beside each row's
    let md = std::fs::read_to_string(dir.join("eval.md")).unwrap();
    assert!(md.contains("## The views one by one") && md.contains("## Seams at cell faces"), "{md}");
    for b in &report.buckets {
        assert!(!b.views.is_empty());
        let pixels: usize = b.views.iter().map(|v| v.pixels).sum();
        assert_eq!(pixels, b.view_pixels);
        for v in &b.views {
            assert!(v.coverage > 0.0 && v.coverage <= 1.0 && v.noise_flip.is_finite(), "{v:?}");
            assert!(!v.against.is_empty() && v.against.iter().all(|c| c.difference.is_finite() && c.se.is_finite()));
        }
        assert!(b.seam_reference.is_some_and(|x| x.is_finite() && x > 0.0), "{b:?}");
        for m in report.methods.iter().filter(|m| m.roughness == b.roughness && m.flip.is_some()) {
            assert_eq!(m.flip_views.len(), b.views.len(), "{m:?}");
            let mean: f64 =
                m.flip_views.iter().zip(&b.views).map(|(f, v)| f * v.pixels as f64).sum::<f64>() / pixels as f64;
            assert_eq!(mean, m.flip.unwrap(), "{m:?}");
            assert!(m.seam.is_some_and(f64::is_finite), "{m:?}");
        }
    }
    // the mirror bucket's references' own noise, measured on its first queries traced again
    // with quieter references: the bounds, chosen on the bucket's noisy references, lose
    // most of their lead against the quiet ones; the rough buckets do not measure it
    let c = report.buckets[0].noise_ceiling.as_ref().expect("the mirror bucket's noise ceiling");
    assert_eq!((c.queries, c.spp), (settings.quiet_positions as usize * 64, settings.quiet_spp));
    for (on_set, on_quiet) in [c.none, c.best_fetch, c.best_aim] {
        assert!(on_set.is_finite() && on_quiet.is_finite() && on_set >= 0.0 && on_quiet >= 0.0, "{c:?}");
    }
    assert!(c.best_fetch.1 > 2.0 * c.best_fetch.0, "best-fetch fits the references' noise: {c:?}");
    assert!(c.reference_vs_quiet > 0.0 && c.ceiling_fetch.is_finite() && c.ceiling_fetch <= 1.0, "{c:?}");
    // (best-aim only searches the query's own ray: a lookup with no error can beat it, and
    // its ceiling can pass 1)
    assert!(c.ceiling_aim.is_finite(), "{c:?}");
    // the exact fetch towards the true hit, scored the same way
    let (o, (f, g)) = (c.oracle.expect("the oracle's row"), c.oracle_gap_quiet.expect("the oracle's shares"));
    assert!(o.0.is_finite() && o.1.is_finite() && f.is_finite() && g.is_finite(), "{c:?}");
    assert!(report.buckets[1..].iter().all(|b| b.noise_ceiling.is_none()));
    assert!(std::fs::read_to_string(dir.join("eval.md")).unwrap().contains("The references' own noise at r = 0"));
    // plus reproject-dilate at roughness 0, and the renormalized box row and the two bounds
    // at every bucket (no fitted grid here, so no runtime rows)
    assert_eq!(
        methods.len(),
        Method::ALL.len() + 1 + (buckets.len() - 1) * (Method::ALL.len() - 1) * 4 + 3 * buckets.len()
    );
    // the bounds: one of each per bucket, no row below best-fetch in tone-mapped RMSE, no warp
    // of the seeds beyond best-aim (every row's share of the none → best-aim gap at most 1)
    for &r in &buckets {
        let rows: Vec<&serde_json::Value> =
            methods.iter().filter(|m| m["roughness"].as_f64() == Some(r as f64)).collect();
        let bound: Vec<_> = rows.iter().filter(|m| m["name"] == "best-fetch").collect();
        assert_eq!(bound.len(), 1, "roughness {r}");
        let b = bound[0]["tm_rmse"].as_f64().unwrap();
        assert_eq!(rows.iter().filter(|m| m["name"] == "best-aim").count(), 1, "roughness {r}");
        for m in rows.iter().filter(|m| m["name"] != "best-aim") {
            assert!(m["tm_rmse"].as_f64().unwrap() >= b, "{m} below the bound {b}");
            let gap = m["gap_closed"].as_f64().expect("gap closed");
            assert!(gap.is_finite() && (gap <= 1.0 + 1e-9 || m["name"] == "best-fetch"), "{m}");
        }
    }
    assert_eq!(methods.iter().filter(|m| m["name"] == "box+renorm").count(), buckets.len());
    for &r in &buckets {
        let rows: Vec<&serde_json::Value> =
            methods.iter().filter(|m| m["roughness"].as_f64() == Some(r as f64)).collect();
        for method in Method::ALL.iter().filter(|&&m| r == 0.0 || m != Method::Reproject) {
            let n = rows.iter().filter(|m| m["name"] == method.name()).count();
            assert_eq!(n, if r == 0.0 { 1 } else { 4 }, "{} at roughness {r}", method.name());
        }
    }
    for m in methods {
        for key in ["name", "roughness", "rel_rmse", "tm_rmse", "mae", "p95", "max", "angular_deg", "ns_per_lookup"] {
            assert!(m.get(key).is_some(), "{key} missing in {m}");
        }
        assert!(m["rel_rmse"].as_f64().unwrap().is_finite() && m["tm_rmse"].as_f64().unwrap().is_finite());
        // the relative RMSE with the emitters apart, for every row but the bounds (searches)
        let apart = m["rel_rmse_emitters_apart"].as_f64();
        if matches!(m["name"].as_str(), Some("best-fetch" | "best-aim")) {
            assert!(apart.is_none(), "{m}");
        } else {
            assert!(apart.is_some_and(|x| x.is_finite() && x >= 0.0), "{m}");
        }
        assert!(m["ns_per_lookup"].as_f64().unwrap() > 0.0);
        // every row but reproject and the bound renders the views for ꟻLIP, in [0, 1]
        if !matches!(m["name"].as_str(), Some("reproject" | "reproject-dilate" | "best-fetch" | "best-aim")) {
            assert!(m["flip"].as_f64().is_some_and(|f| (0.0..=1.0).contains(&f)), "{m}");
        }
        // warp1's mirror row is also timed through its batch API; no other row has one
        let batched = m["ns_per_lookup_batched"].as_f64();
        if m["name"] == "warp1" && m["roughness"] == 0.0 {
            assert!(batched.is_some_and(|ns| ns > 0.0 && ns.is_finite()), "{m}");
        } else {
            assert!(batched.is_none(), "{m}");
        }
    }
    for f in ["eval_rough.png", "flip_r0.500.png"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    // the diffuse table: every method, finite errors, ꟻLIP in [0, 1]
    let diffuse = report.diffuse.as_ref().expect("a diffuse evaluation");
    assert!(diffuse.points > 0);
    assert_eq!(diffuse.rows.len(), 7, "five blend steps, probe A, voxel GI");
    for row in &diffuse.rows {
        assert!(row.rel_rmse.is_finite() && row.tm_rmse.is_finite() && row.ns_per_lookup > 0.0, "{row:?}");
        assert!(row.flip.is_some_and(|f| (0.0..=1.0).contains(&f)), "{row:?}");
    }
    assert!(std::fs::read_to_string(dir.join("eval.md")).unwrap().contains("## Diffuse lighting"));
    let get = |name: &str| report.methods.iter().find(|m| m.name == name && m.roughness == 0.0).unwrap().rel_rmse;
    // In a closed box room the box proxy (scene bounds) is near the oracle, and both beat
    // no correction at all.
    assert!(get("oracle") < get("none"));
    assert!(get("box") < get("none"));
    assert!(get("oracle") <= get("warp1") * 1.05);
}

#[test]
fn validation_positions_avoid_cell_centres_and_geometry() {
    let scene = load("torture");
    let mut s = scene.clone();
    s.config.probe.resolution = 32;
    s.config.probe.samples_per_texel = 1;
    let tracer = Tracer::new(&s);
    let baked = warpfit::bake::bake(&s, &tracer, &Progress::quiet());
    let settings = EvalSettings { positions: 64, dirs_per_position: 4, reference_spp: 1, ..EvalSettings::default() };
    let set = warpfit::eval::validation_set(&s, &tracer, &baked.grid, &[baked.probe.position], &settings, None);
    assert_eq!(set.positions.len(), 64);
    let g = &baked.grid.geometry;
    for p in &set.positions {
        let cell = g.cell_index(g.cell_of(*p));
        assert!(!baked.grid.inside[cell], "{p} is in a cell inside geometry");
        assert!((*p - g.cell_centre(cell)).length() > 1e-4, "{p} sits on a cell centre");
    }
    // seeded: the same settings give the same set
    let again = warpfit::eval::validation_set(&s, &tracer, &baked.grid, &[baked.probe.position], &settings, None);
    assert_eq!(set.positions, again.positions);
    assert_eq!(set.reference, again.reference);
}

/// A rough bucket whose references are too noisy for the difference it reports is traced
/// again with twice the samples, up to the cap: every bucket ends quiet enough or at the
/// cap, and a refined bucket's errors are those of an evaluation asked for that many
/// samples from the start.
#[test]
fn noisy_rough_buckets_are_traced_again_with_more_samples() {
    let scene = small_cornell();
    let tracer = Tracer::new(&scene);
    let baked = warpfit::bake::bake(&scene, &tracer, &Progress::quiet());
    let (probe, grid) = (baked.probe, baked.grid);
    let baked =
        job::Baked { scene: &scene, tracer: &tracer, probe: &probe, others: &[], grid: &grid, references: None };
    let methods = [Method::None, Method::Box, Method::Kdop, Method::Warp1];
    let eval = |spp: u32, max: u32| {
        let settings = EvalSettings {
            positions: 16,
            dirs_per_position: 32,
            reference_spp: 2,
            rough_reference_spp: spp,
            rough_reference_spp_max: max,
            renders: None,
            diffuse_points: 0,
            surface_points: 0,
            quiet_positions: 0,
            ..EvalSettings::quick()
        };
        let dir = tmp_dir("eval-refine");
        let folder = RunFolder::new(&dir);
        let out = Output { folder: &folder, command: "test", progress: &Progress::quiet() };
        job::evaluate(baked, &baked.warp(settings.options), &settings, &methods, None, out).unwrap()
    };
    let (base, cap) = (2, 16);
    let report = eval(base, cap);
    let rough = &report.buckets[1..];
    for b in rough {
        assert!(b.reference_ok || b.reference_spp == cap, "{b:?}");
        assert!(b.reference_spp.is_power_of_two() && (base..=cap).contains(&b.reference_spp), "{b:?}");
    }
    let refined = rough.iter().find(|b| b.reference_spp > base).expect("two-sample references are too noisy somewhere");
    let again = eval(refined.reference_spp, refined.reference_spp);
    let bucket = |r: &warpfit::eval::EvalReport| {
        let b = r.buckets.iter().find(|b| b.roughness == refined.roughness).unwrap().clone();
        let rows: Vec<_> = r
            .methods
            .iter()
            .filter(|m| m.roughness == refined.roughness)
            .map(|m| {
                (m.label(), m.rel_rmse.to_bits(), m.tm_rmse.to_bits(), m.p95.to_bits(), m.gap_closed.map(f64::to_bits))
            })
            .collect();
        (b.reference_spp, b.query_se_rel.to_bits(), rows)
    };
    assert_eq!(bucket(&report), bucket(&again));
}
