//! The stability suite's quick mode: every stiff and extreme case passes; failed rows are
//! marked in the table and counted in stability.json.

use warpfit::jobs::stability::{self, CaseResult, Mode};
use warpfit::report::folder::RunFolder;

#[test]
fn quick_stability_suite_passes() {
    let rows = stability::run(Mode::Quick, |_| {});
    assert!(rows.len() >= 17, "only {} cases", rows.len());
    let failed: Vec<&CaseResult> = rows.iter().filter(|r| !r.pass).collect();
    assert!(failed.is_empty(), "failed cases:\n{}", stability::table(&rows));
    for r in &rows {
        assert!(!r.measured.is_empty() && !r.expectation.is_empty(), "{}", r.case);
        assert!(!r.measured.contains("NaN") || r.case.contains("non-finite"), "{}: {}", r.case, r.measured);
    }
}

#[test]
fn the_table_marks_failures_and_the_files_are_written() {
    let rows = vec![
        CaseResult { case: "a".into(), expectation: "x".into(), measured: "1 | 2".into(), pass: true, seconds: 0.0 },
        CaseResult { case: "b".into(), expectation: "y".into(), measured: "3".into(), pass: false, seconds: 0.0 },
    ];
    let t = stability::table(&rows);
    assert!(t.contains("| a | x | 1 / 2 | pass |"), "{t}");
    assert!(t.contains("| b | y | 3 | **FAIL** |"), "{t}");
    let dir = std::env::temp_dir().join(format!("warpfit-stability-test-{}", std::process::id()));
    stability::write(&RunFolder::new(&dir), &rows, Mode::Quick, "test").unwrap();
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("stability.json")).unwrap()).unwrap();
    assert_eq!(v["failed"], 1);
    assert_eq!(v["cases"][1]["pass"], false);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn seam_directions_are_unit_and_cover_poles_and_diagonals() {
    let d = stability::seam_directions();
    assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-6));
    assert!(d.contains(&glam::Vec3::Z) && d.contains(&glam::Vec3::NEG_Z));
    assert!(d.iter().any(|v| (v.x - v.y).abs() < 1e-7 && (v.y - v.z).abs() < 1e-7 && v.x > 0.0));
}

#[test]
fn the_command_prints_every_row_and_writes_its_files() {
    let out = std::env::temp_dir().join(format!("warpfit-stability-cli-{}", std::process::id()));
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_warpfit"))
        .args(["--quiet", "stability", "--quick", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(stdout.lines().filter(|l| l.starts_with("pass ")).count(), 18, "{stdout}");
    assert!(stdout.contains("all 18 stability cases pass"));
    let md = std::fs::read_to_string(out.join("stability.md")).unwrap();
    assert!(md.contains("| query at the probe centre |"));
    let _ = std::fs::remove_dir_all(&out);
}
