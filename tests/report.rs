//! The run report: built from a real (small) bake + fit + eval, it is self-contained HTML
//! (every image inlined, nothing fetched), its JSON has every section, and, where Chromium is
//! installed (`apt-get install chromium`, or `WARPFIT_CHROMIUM=/path/to/chrome`), the page
//! loads headless without console errors. Without Chromium that last check says SKIPPED, and
//! in CI (`WARPFIT_REQUIRE_EXTERNAL=1`, set by `.ci/run`) it fails.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use warpfit::eval::EvalSettings;
use warpfit::fit::FitSettings;
use warpfit::jobs::run as job;
use warpfit::progress::Progress;
use warpfit::report::folder::RunFolder;

fn small_run(dir: &Path) {
    let scene = load("tiny");
    let mut p = job::prepare(scene, RunFolder::new(dir), &Progress::quiet()).unwrap();
    let settings = job::RunSettings { eval: EvalSettings::quick(), fit: FitSettings::quick(), ..Default::default() };
    job::run(&mut p, &settings, "test", &Progress::quiet()).unwrap();
}

fn chromium() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("WARPFIT_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    ["/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
}

#[test]
fn report_is_self_contained_complete_and_opens_in_chromium() {
    let dir = std::env::temp_dir().join(format!("warpfit-report-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    small_run(&dir);
    let r = warpfit::report::page::write_report(&RunFolder::new(&dir), "test").unwrap();

    // every section present, the Pareto front marked, fitted per level on the validation set
    assert!(r.methods.iter().any(|m| m.name == "fitted") && r.methods.iter().any(|m| m.pareto));
    assert!(!r.methods.iter().any(|m| m.name == "oracle" && m.pareto), "the oracle is a bound, not a method");
    assert!(!r.eval_levels.is_empty() && r.eval_levels.iter().all(|l| l.fitted_rel_rmse.is_finite()));
    assert!(r.stages.iter().any(|s| s.stage.starts_with("bake") && s.rays > 0));
    assert!(r.stages.iter().any(|s| s.stage.starts_with("eval") && s.rays > 0 && s.seconds > 0.0));
    assert!(r.layers.iter().any(|l| l.layer == "radiance_mip0" && l.raw_bytes > 0));
    assert!(
        r.images.iter().any(|i| i == "eval_error_vs_cost.png") && r.images.iter().any(|i| i == "residual_slices.png")
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap();
    for key in ["methods", "levels", "eval_levels", "worst_cells", "stages", "layers", "left_out", "images"] {
        assert!(json.get(key).is_some(), "report.json lacks {key}");
    }

    // self-contained: images inlined, nothing external
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(html.matches("<img ").count(), r.images.len());
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), r.images.len());
    assert!(!html.contains("http://") && !html.contains("https://") && !html.contains("<script"));
    // the page opens with the verdict and the pictures, the tables below
    assert_eq!(r.verdict.len(), 3, "{:?}", r.verdict);
    for (line, start) in r.verdict.iter().zip(["Wins:", "Loses:", "Even"]) {
        assert!(line.starts_with(start), "{line}");
    }
    let (verdict, figure, table) =
        (html.find("<h2>Verdict</h2>").unwrap(), html.find("<img ").unwrap(), html.find("<table>").unwrap());
    assert!(verdict < figure && figure < table, "verdict, pictures, then tables");
    assert!(html.find("flip_r0.000.png").unwrap() < table, "the frames come before the tables");

    // the verdict sorts buckets by their claims: one made a clear loss, one a clear win
    let mut ev: warpfit::eval::EvalReport =
        serde_json::from_slice(&std::fs::read(dir.join("eval.json")).unwrap()).unwrap();
    let lose = ev.buckets[0].roughness;
    let win = ev.buckets[1].roughness;
    for (k, sign) in [(0, -1.0), (1, 1.0)] {
        let b = &mut ev.buckets[k];
        for c in b.flip_claim.iter_mut().chain(b.flip_against.iter_mut()) {
            c.difference = sign * 0.01;
            c.se = 0.001;
        }
    }
    let v = warpfit::report::verdict(&ev);
    // the roughnesses a line lists ("at r = 0, 0.125 and 0.5 the …")
    let listed = |line: &str| -> Vec<f32> {
        let Some((_, rest)) = line.split_once("at r = ") else { return Vec::new() };
        let list = rest
            .split([' ', ';', ')'])
            .take_while(|w| w.chars().next().is_some_and(|c| c.is_ascii_digit()) || *w == "and");
        list.filter_map(|w| w.trim_end_matches(',').parse().ok()).collect()
    };
    assert!(listed(&v[0]).contains(&win) && !listed(&v[0]).contains(&lose), "{v:?}");
    assert_eq!(listed(&v[1]), vec![lose], "{v:?}");

    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(md.contains("| roughness | method | ꟻLIP | tone-mapped RMSE | rel RMSE |"), "{md}");
    assert!(md.contains("Diffuse: irradiance at"), "the diffuse table is in the report");

    // once `warpfit render` has drawn frames through the exported shader, they lead
    match warpfit::render::gpu::Gpu::new() {
        Err(e) => tool_missing("frames drawn through the shader in the report", "a graphics adapter", &e.to_string()),
        Ok(_) => {
            use warpfit::render::frames::{self, RenderOptions};
            let scene = load("tiny");
            let tracer = warpfit::trace::Tracer::new(&scene);
            let grid = warpfit::runtime::FittedGrid::load(&dir).unwrap();
            let out = frames::folder(&dir);
            warpfit::export::export(&grid, &out.join("export")).unwrap();
            let opts = RenderOptions {
                size: (32, 20),
                cameras: 1,
                roughness: vec![0.0],
                diffuse: false,
                spp: 4,
                ..Default::default()
            };
            frames::render((&scene, &tracer), &grid, &out.join("export"), &out, &opts).unwrap();
            let r = warpfit::report::page::write_report(&RunFolder::new(&dir), "test").unwrap();
            assert_eq!(r.images.first().map(String::as_str), Some("render/frame_c0_r0.png"), "{:?}", r.images);
            let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
            assert_eq!(html.matches("src=\"data:image/png;base64,").count(), r.images.len());
            let (frame, flip) = (html.find("render/frame_c0_r0.png").unwrap(), html.find("flip_r0.000.png").unwrap());
            assert!(frame < flip, "the shader's frames come first");
            assert!(html.contains("drawn as an engine draws it"));
        }
    }

    match chromium() {
        None => {
            tool_missing("report opens in a browser", "Chromium", "apt-get install chromium, or WARPFIT_CHROMIUM=path")
        }
        Some(exe) => {
            let profile = dir.join("chromium-profile");
            let out = std::process::Command::new(&exe)
                .args([
                    "--headless",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--disable-quic",
                    "--no-first-run",
                    "--disable-background-networking",
                    "--disable-component-update",
                    "--disable-sync",
                    "--enable-logging=stderr",
                    "--v=0",
                    "--dump-dom",
                ])
                .arg(format!("--user-data-dir={}", profile.display()))
                .arg(format!("file://{}", dir.join("report.html").display()))
                .output()
                .expect("chromium starts");
            let stdout = String::from_utf8_lossy(&out.stdout);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(out.status.success(), "chromium failed: {stderr}");
            assert!(stdout.contains("<h1>warpfit report: tiny</h1>"), "page did not render: {stdout:.500}");
            let console: Vec<&str> =
                stderr.lines().filter(|l| l.contains("CONSOLE") || l.contains("Uncaught")).collect();
            assert!(console.is_empty(), "console messages: {console:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The evaluation's references are traced once: a second run of the same scene and settings
/// reads every set back from beside the bake and answers exactly as the first.
#[test]
fn a_second_run_traces_no_reference_and_answers_the_same() {
    let dir = tmp_dir("references-once");
    // the evaluation, the sets the whole run traced and read back, the fitted grid's payloads
    let run = || {
        let mut p = job::prepare(load("tiny"), RunFolder::new(&dir), &Progress::quiet()).unwrap();
        let settings =
            job::RunSettings { eval: EvalSettings::quick(), fit: FitSettings::quick(), ..Default::default() };
        let out = job::run(&mut p, &settings, "test", &Progress::quiet()).unwrap();
        let payloads: Vec<String> = out.manifest.payloads.iter().map(|x| x.checksum.clone()).collect();
        (out.eval, p.references.counts(), payloads)
    };
    let (first, counts, grid) = run();
    assert!(first.times.reference_sets_traced > 0 && first.times.reference_sets_reused == 0, "{:?}", first.times);
    assert!(counts.0 > first.times.reference_sets_traced, "the fit's sets are kept too: {counts:?}");
    let (second, counts_again, grid_again) = run();
    assert_eq!(counts_again, (0, counts.0), "a second run traces no reference set");
    assert_eq!(second.times.reference_sets_reused, first.times.reference_sets_traced);
    assert_eq!(grid, grid_again, "the fitted grid is byte for byte the same");
    // everything but what was timed (the stages, each row's cost per lookup)
    fn untimed(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.retain(|k, _| !(k == "times" || k == "seconds" || k.contains("ns_per")));
                m.values_mut().for_each(untimed);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(untimed),
            _ => {}
        }
    }
    let answers = |e: &warpfit::eval::EvalReport| {
        let mut v = serde_json::to_value(e).unwrap();
        untimed(&mut v);
        v
    };
    let (a, b) = (answers(&first), answers(&second));
    if a != b {
        fn diff(a: &serde_json::Value, b: &serde_json::Value, path: String, out: &mut Vec<String>) {
            match (a, b) {
                (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
                    for (k, v) in x {
                        diff(v, &y[k], format!("{path}.{k}"), out);
                    }
                }
                (serde_json::Value::Array(x), serde_json::Value::Array(y)) if x.len() == y.len() => {
                    for (i, (v, w)) in x.iter().zip(y).enumerate() {
                        diff(v, w, format!("{path}[{i}]"), out);
                    }
                }
                _ if a != b => out.push(format!("{path}: {a} vs {b}")),
                _ => {}
            }
        }
        let mut out = Vec::new();
        diff(&a, &b, String::new(), &mut out);
        panic!("a reused reference set changed an answer: {:?}", &out[..out.len().min(12)]);
    }
    // a damaged set is traced again, not believed
    let refs = dir.join("bake/references");
    let file = std::fs::read_dir(&refs).unwrap().flatten().map(|e| e.path()).max().unwrap();
    let mut bytes = std::fs::read(&file).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 0x40;
    std::fs::write(&file, bytes).unwrap();
    let (third, counts_third, grid_third) = run();
    assert_eq!(counts_third.0, 1, "the damaged set is traced again: {counts_third:?}");
    assert!(answers(&first) == answers(&third) && grid == grid_third);
    // asked to (`--force`), every set is traced again
    let mut p = job::prepare(load("tiny"), RunFolder::new(&dir), &Progress::quiet()).unwrap();
    p.references.retrace();
    let settings = job::RunSettings { eval: EvalSettings::quick(), fit: FitSettings::quick(), ..Default::default() };
    job::run(&mut p, &settings, "test", &Progress::quiet()).unwrap();
    assert_eq!(p.references.counts(), (counts.0, 0));
}
