//! The stability suite: stiff and extreme cases run through the real code paths (scene
//! loading, tracing, bake, warps, fit, the fitted-grid writer and the runtime loader), each
//! with a stated expectation, a measured value and a verdict. `warpfit stability` prints the
//! rows and exits non-zero on any failure; `tests/stability.rs` runs the quick mode.
//!
//! Every case also checks that no NaN or Inf reaches any output it touches. A case that
//! panics is a failed row, not an aborted suite.

pub mod cases;
pub mod scenes;

use crate::files::{FileError, write_atomic, write_json};
use crate::report::folder::RunFolder;
use cases::Outcome;
use serde::Serialize;
use std::time::Instant;

pub use scenes::seam_directions;

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

/// A case: name, expectation, the check.
type Case = (&'static str, &'static str, Box<dyn Fn(Mode) -> Outcome>);

/// Runs the suite; `on_row` sees each row as it finishes.
pub fn run(mode: Mode, mut on_row: impl FnMut(&CaseResult)) -> Vec<CaseResult> {
    let cases: Vec<Case> = vec![
        (
            "query at the probe centre",
            "every method returns the query direction bit for bit; runtime = probe radiance",
            Box::new(cases::probe_centre),
        ),
        (
            "query 1e-6 from a wall",
            "finite unit fetch directions, finite runtime answers ≥ 0",
            Box::new(cases::near_wall),
        ),
        (
            "query outside the grid",
            "finite answers; the nearest cell's corrective is used",
            Box::new(cases::outside_grid),
        ),
        (
            "octahedral seams, poles, diagonals",
            "round trip < 1e-5 rad; finite unit fetches; finite runtime",
            Box::new(cases::seams),
        ),
        (
            "infinite depth (sky)",
            "depth warps return the query direction exactly where A sees only sky",
            Box::new(cases::sky),
        ),
        ("zero depth (probe on a surface)", "bake, warps, fit and runtime stay finite", Box::new(cases::zero_depth)),
        (
            "scene scaled by 1e-4",
            "rel RMSE of every method within 2% of the unscaled scene",
            Box::new(|m| cases::scaled(m, 1e-4)),
        ),
        (
            "scene scaled by 1e4",
            "rel RMSE of every method within 2% of the unscaled scene",
            Box::new(|m| cases::scaled(m, 1e4)),
        ),
        (
            "grazing rays over a large plane",
            "no ray above the plane hits it; finite unit fetches",
            Box::new(cases::grazing),
        ),
        ("thin feature (1e-3 thick wall)", "no ray leaks through it", Box::new(cases::thin_feature)),
        (
            "light through a 1e-3 wall",
            "the runtime (relocated probes, fitted surface bias and corrections) leaks at most 1/4 of the DDGI blend at cell centres",
            Box::new(cases::thin_wall_leak),
        ),
        (
            "cells inside geometry",
            "exactly the 4 cells whose centres are in the block are flagged, never fitted nor given irradiance; a shift map only as a copy of an open cell's",
            Box::new(cases::inside_cells),
        ),
        (
            "a cell that sees only sky",
            "flat objective: level 0 everywhere, finite errors, the grid loads",
            Box::new(cases::sky_only),
        ),
        (
            "stiff fit (scales 1e-3 and 1e3)",
            "log-scale parameters within 0.05, relative errors within 2%",
            Box::new(cases::stiff_fit),
        ),
        (
            "near-singular secant step",
            "finite unit fetches for rays 1e-7 from parallel to the wall",
            Box::new(cases::near_singular_secant),
        ),
        (
            "HDR range 1e6 (sun vs dim walls)",
            "finite everywhere; f16 layers above 65504 kept f32, no saturation",
            Box::new(cases::hdr),
        ),
        (
            "degenerate triangles",
            "skipped and counted (3 of 4), the scene loads",
            Box::new(cases::degenerate_triangles),
        ),
        ("empty and non-finite scenes", "clear errors naming the file, no panic", Box::new(cases::bad_scenes)),
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

/// Writes `stability.json` and `stability.md` into `folder`.
pub fn write(folder: &RunFolder, rows: &[CaseResult], mode: Mode, command: &str) -> Result<(), FileError> {
    let value = serde_json::json!({
        "mode": format!("{mode:?}").to_lowercase(),
        "command": command,
        "passed": rows.iter().filter(|r| r.pass).count(),
        "failed": rows.iter().filter(|r| !r.pass).count(),
        "cases": rows,
    });
    write_json(&folder.stability_json(), &value)?;
    let md = format!("# Stability suite ({mode:?} mode)\n\nProduced by `{command}`.\n\n{}", table(rows));
    write_atomic(&folder.stability_md(), md.as_bytes())
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
