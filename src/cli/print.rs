//! What the commands print: the fit's and the evaluation's summaries.

use warpfit::files;
use warpfit::report::{self, folder::RunFolder};

/// What [`print_fit`] says of a fit, taken from it so that the fit can be dropped first.
pub struct FitLines {
    summary: warpfit::fit::summary::FitSummary,
    selection_margin: f64,
    measured: Option<[f64; 3]>,
    check_positions: u32,
    extra_check_positions: u32,
}

impl FitLines {
    pub fn of(f: &warpfit::fit::Fit) -> FitLines {
        FitLines {
            summary: warpfit::fit::summary::summary(f),
            selection_margin: f.settings.selection_margin,
            measured: f.proxy.measured,
            check_positions: f.settings.check_positions,
            extra_check_positions: f.settings.extra_check_positions,
        }
    }
}

pub fn print_fit(f: &FitLines, manifest: &warpfit::gridfile::GridManifest, folder: &RunFolder) {
    let bytes: u64 = manifest.payloads.iter().map(|p| p.bytes).sum();
    let s = &f.summary;
    let margin = match 100.0 * (1.0 - f.selection_margin) {
        m if m > 0.0 => format!(" by {m:.0}%"),
        _ => String::new(),
    };
    let proxy = match f.measured {
        Some([b, k, w]) => format!(" (measured: box {b:.4}, kdop {k:.4}, warp1 {w:.4})"),
        None => " (set)".into(),
    };
    println!(
        "fitted {} active cells in {:.1} s ({} threads): {} store a shift map{}, {} in all; {} keep the proxy {}{} alone ({} of them kept it over a fitted map that did not beat it{}); mean held-out tone-mapped relative error per cell: warp1 {:.4}, proxy {:.4}, unfitted cell maps {:.4}, stored model {:.4}",
        s.active_cells,
        s.fit_seconds,
        rayon::current_num_threads(),
        s.cells_level2,
        if s.rough_maps { " and a rough map" } else { "" },
        files::human_bytes(s.bytes_level2 as u64),
        s.cells_level0,
        s.fallback_method,
        proxy,
        s.kept_fallback,
        margin,
        s.mean_check_err_warp1,
        s.mean_check_err_fallback,
        s.mean_check_err_celldepth,
        s.mean_check_err_stored
    );
    if s.cells_more_checked > 0 {
        println!(
            "selection: {} cells could not tell their maps from the proxy on their first {} check positions and were judged on {} more",
            s.cells_more_checked, f.check_positions, f.extra_check_positions
        );
    }
    let t = &s.times;
    println!(
        "time: cells {:.1} s ({:.0}% of their CPU time tracing references), surface points {:.1} s, their references {:.1} s, roughness correction {:.1} s, diffuse fit {:.1} s{}",
        t.cells,
        100.0 * t.cells_tracing_cpu / t.cells_cpu.max(1e-9),
        t.surface_points,
        t.irradiance_references,
        t.roughness,
        t.irradiance_fit,
        t.counted()
    );
    if s.diffuse_cells_fitted == 0 {
        println!("diffuse: no cell holds enough surface points to fit a correction (none stored)");
    } else {
        println!(
            "diffuse: {} of {} cells with surfaces store a correction; their check points' mean tone-mapped RMSE {:.4} → {:.4}",
            s.diffuse_cells_stored, s.diffuse_cells_fitted, s.diffuse_check_before, s.diffuse_check_after
        );
    }
    if !s.diffuse_bias_trials.is_empty() {
        let trials: Vec<String> = s
            .diffuse_bias_trials
            .iter()
            .map(|t| format!("{} → {:.4}/{:.4}", t.bias, t.blend_check_rmse, t.check_rmse))
            .collect();
        println!(
            "diffuse surface bias {} of the smallest cell extent (check points' tone-mapped RMSE, blend/corrected: {})",
            s.diffuse_surface_bias,
            trials.join(", ")
        );
    }
    println!(
        "wrote the fitted grid {} ({} of payloads; `warpfit inspect {}`)",
        folder.dir.display(),
        files::human_bytes(bytes),
        folder.dir.display()
    );
}

pub fn print_eval(r: &warpfit::eval::EvalReport, folder: &RunFolder) {
    println!(
        "{}: {} lookups at {} positions, hidden fraction {:.1}%, reference ray {:.0} ns",
        r.scene,
        r.lookups,
        r.positions,
        100.0 * r.hidden_fraction,
        r.reference_ns_per_ray
    );
    print!("{}", report::methods_table(r, 0.0));
    if r.buckets.len() > 1 {
        println!("\nper roughness (mean ꟻLIP of rendered views / tone-mapped RMSE / rel RMSE):");
        print!("{}", report::summary_table(r));
        println!("\nreferences' own noise per roughness:");
        print!("{}", report::buckets_table(r));
    }
    let seams = report::seams_table(r);
    if !seams.is_empty() {
        println!("\nseams: how the error jumps at cell faces in the camera views (about 1: no seams):");
        print!("{seams}");
    }
    let worst = report::worst_cameras(r);
    if !worst.is_empty() {
        println!("\nper camera, the worst against each rival (ꟻLIP difference ± 2 SE; eval.md has every view):");
        print!("{worst}");
    }
    if r.diffuse.is_some() {
        println!("\ndiffuse (irradiance at held-out surface points):");
        print!("{}", report::diffuse_table(r));
    }
    for sr in &r.surface {
        print!("{}", report::surface_section(sr));
    }
    let t = &r.times;
    println!(
        "time: {:.1} s in all: mirror references {:.1} s, rough references {:.1} s, views and their references {:.1} s, rows {:.1} s, their views' ꟻLIP {:.1} s, bucket summaries {:.1} s, diffuse and surfaces {:.1} s, the in-sample bound's maps {:.1} s",
        r.seconds,
        t.mirror_references,
        t.rough_references,
        t.view_references,
        t.rows,
        t.flip,
        t.summaries,
        t.diffuse_and_surfaces,
        t.in_sample
    );
    if t.reference_sets_traced + t.reference_sets_reused > 0 {
        println!(
            "references: {} sets traced, {} read back from an earlier run (kept in bake/references/)",
            t.reference_sets_traced, t.reference_sets_reused
        );
    }
    println!("wrote {}/eval.json, eval.md, eval_error_vs_cost.png", folder.dir.display());
}
