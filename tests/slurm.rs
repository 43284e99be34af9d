//! The farm on a real SLURM cluster: `warpfit farm slurm --submit` on `tiny` submits array
//! jobs for the bake and fit shards and their merges; the merged grid must equal a local
//! `warpfit fit` byte for byte. Needs a running cluster: `.ci/run` installs Debian's
//! `slurm-wlm` and `munge` and starts a single-node one with `.ci/slurm/start`; without it
//! the test fails in CI (`WARPFIT_REQUIRE_EXTERNAL=1`) and says SKIPPED elsewhere.

mod common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_warpfit");
const FIT_FLAGS: [&str; 2] = ["--train-positions=4", "--train-dirs=32"];

fn cluster_up() -> bool {
    Command::new("scontrol").arg("ping").output().is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("UP"))
        && Command::new("sinfo").args(["-h", "-o", "%T"]).output().is_ok_and(|o| {
            ["idle", "mixed", "allocated"].iter().any(|s| String::from_utf8_lossy(&o.stdout).contains(s))
        })
}

fn payload_checksums(dir: &Path) -> Vec<String> {
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    m["payloads"].as_array().unwrap().iter().map(|p| format!("{} {}", p["file"], p["checksum"])).collect()
}

/// `scontrol show job` fields of a job (the first record: an array's first task).
fn job_field(id: &str, field: &str) -> Option<String> {
    let out = Command::new("scontrol").args(["show", "job", id]).output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    text.split_whitespace().find_map(|w| w.strip_prefix(&format!("{field}=")).map(str::to_string))
}

fn logs(dir: &Path) -> String {
    let mut s = String::new();
    if let Ok(entries) = std::fs::read_dir(dir.join("farm/logs")) {
        for e in entries.flatten() {
            s += &format!("--- {}\n{}\n", e.path().display(), std::fs::read_to_string(e.path()).unwrap_or_default());
        }
    }
    s
}

#[test]
fn a_slurm_array_job_merges_into_the_grid_a_local_fit_writes() {
    if !cluster_up() {
        common::tool_missing(
            "the SLURM farm test",
            "a running SLURM cluster (sinfo, scontrol)",
            "apt-get install slurm-wlm munge, then .ci/slurm/start as root",
        );
        return;
    }
    let base = common::tmp_dir("slurm");
    let scene = common::scene_file("tiny");
    let local = base.join("local");
    let st = Command::new(BIN)
        .args(["--quiet", "fit", "--scene"])
        .arg(&scene)
        .arg("--out")
        .arg(&local)
        .args(FIT_FLAGS)
        .status()
        .unwrap();
    assert!(st.success(), "local fit");

    let farm = base.join("farm");
    let out = Command::new(BIN)
        .args(["--quiet", "farm", "slurm", "--scene"])
        .arg(&scene)
        .arg("--out")
        .arg(&farm)
        .args(["--shards", "3", "--cpus", "1", "--submit"])
        .args(FIT_FLAGS)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "farm slurm --submit: {text}{}", String::from_utf8_lossy(&out.stderr));
    let ids: Vec<String> = text
        .lines()
        .filter_map(|l| l.strip_prefix("submitted ").and_then(|l| l.rsplit_once("job ")).map(|(_, id)| id.to_string()))
        .collect();
    assert_eq!(ids.len(), 4, "four jobs submitted: {text}");
    let merge = ids.last().unwrap();

    let t0 = Instant::now();
    loop {
        let state = job_field(merge, "JobState").unwrap_or_default();
        let reason = job_field(merge, "Reason").unwrap_or_default();
        if state == "COMPLETED" {
            break;
        }
        assert!(
            !["FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL", "OUT_OF_MEMORY"].contains(&state.as_str())
                && reason != "DependencyNeverSatisfied",
            "the merge job {merge} ended {state} ({reason}); logs:\n{}",
            logs(&farm)
        );
        assert!(t0.elapsed() < Duration::from_secs(600), "the farm job did not finish in 10 min ({state}, {reason})");
        std::thread::sleep(Duration::from_millis(500));
    }
    assert_eq!(payload_checksums(&farm), payload_checksums(&local), "logs:\n{}", logs(&farm));
    for f in ["probe.exr", "grid.exr"] {
        assert_eq!(
            std::fs::read(farm.join("bake").join(f)).unwrap(),
            std::fs::read(local.join("bake").join(f)).unwrap()
        );
    }
    // every shard's log shows its progress
    let l = logs(&farm);
    assert!(l.contains("fit shard 2/3") && l.contains("ETA"), "{l}");
    let _ = std::fs::remove_dir_all(&base);
}
