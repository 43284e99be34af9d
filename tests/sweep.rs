//! The fit-effort sweep on a small scene: every knob at three values, each row a real bake,
//! fit, written grid and runtime measurement; the rows at the given settings agree with one
//! another (the same fit four times), and every other row's ꟻLIP difference from its knob's
//! given row carries a standard error.

mod common;
use common::*;
use warpfit::eval::EvalSettings;
use warpfit::fit::FitSettings;
use warpfit::jobs::sweep;
use warpfit::progress::Progress;
use warpfit::report::folder::RunFolder;
use warpfit::report::sweep::Knob;

#[test]
fn every_knob_has_three_rows_the_given_ones_agree_and_the_others_carry_an_error() {
    let mut scene = load("torture");
    scene.config.probe.resolution = 64;
    scene.config.probe.samples_per_texel = 2;
    scene.config.grid.counts = [4, 2, 4];
    let dir = tmp_dir("sweep");
    let folder = RunFolder::new(&dir);
    let eval = EvalSettings::quick();
    let sw = sweep::sweep(&scene, &FitSettings::quick(), &eval, &folder, "test", &Progress::quiet()).unwrap();
    assert_eq!(sw.rows.len(), 12);
    for knob in Knob::ALL {
        let rows: Vec<_> = sw.rows.iter().filter(|r| r.knob == knob).collect();
        assert_eq!(rows.len(), 3, "{knob:?}");
        // the quick settings' values are 64² probes, 32 directions, 1 sweep, Brent: one row
        // of each knob is at them and has no difference to carry an error
        assert_eq!(rows.iter().filter(|r| r.flip_r0_se.is_none()).count(), 1, "{knob:?}");
        for r in rows {
            assert!((0.0..=1.0).contains(&r.flip_r0) && (0.0..=1.0).contains(&r.flip_r05), "{r:?}");
            assert!(r.rel_rmse.is_finite() && r.tm_rmse.is_finite() && r.tm_rmse > 0.0, "{r:?}");
            assert!(r.flip_r0_se.is_none_or(|se| se.is_finite() && se >= 0.0), "{r:?}");
        }
    }
    // the given settings fitted once per knob: the same grid, the same errors, bit for bit
    let given: Vec<_> = sw.rows.iter().filter(|r| r.flip_r0_se.is_none()).collect();
    for r in &given[1..] {
        let key = |r: &&warpfit::report::sweep::SweepRow| {
            (r.rel_rmse.to_bits(), r.tm_rmse.to_bits(), r.flip_r0.to_bits(), r.stored_cells, r.payload_bytes)
        };
        assert_eq!(key(r), key(&given[0]), "{r:?} vs {:?}", given[0]);
    }
    for f in ["sweep.json", "sweep.png", "sweep_convergence.png"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
