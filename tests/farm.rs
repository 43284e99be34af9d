//! Sharded bake and fit: merged results equal a single machine's byte for byte, for any
//! shard count; a set of parts that does not belong together, or a damaged part, is refused
//! by name and leaves the run folder as it was; the cluster scripts are well formed.

mod common;

use std::path::{Path, PathBuf};
use warpfit::fit::FitSettings;
use warpfit::jobs::cluster::{self, FarmJob};
use warpfit::jobs::farm::{self, FitJob, Shard};
use warpfit::jobs::run::{self, Output, StoreOptions};
use warpfit::partfile::{self, PartKind};
use warpfit::progress::Progress;
use warpfit::report::folder::RunFolder;
use warpfit::runtime::FittedGrid;
use warpfit::scene::Scene;
use warpfit::warp::WarpOptions;

fn job() -> FitJob {
    FitJob { fit: FitSettings::quick(), options: WarpOptions::standard(), store: StoreOptions::default() }
}

/// (file, checksum) of every payload of the fitted grid in `dir`, and the bake's files.
fn payloads(dir: &Path) -> Vec<(String, String)> {
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    let mut out: Vec<(String, String)> = m["payloads"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p["file"].as_str().unwrap().to_string(), p["checksum"].as_str().unwrap().to_string()))
        .collect();
    for f in ["probe.exr", "probe_1.exr", "grid.exr"] {
        let Ok(bytes) = std::fs::read(dir.join("bake").join(f)) else { continue };
        out.push((format!("bake/{f}"), warpfit::files::checksum(&bytes)));
    }
    out
}

/// The single-machine fit of `scene` in `dir`.
fn single(scene: &Scene, dir: &Path) {
    let progress = Progress::quiet();
    let p = run::prepare(scene.clone(), RunFolder::new(dir), &progress).unwrap();
    let j = job();
    let warp = p.baked().warp(j.options);
    let out = Output { folder: &p.folder, command: "test", progress: &progress };
    run::fit(p.baked(), &warp, &j.fit, j.store, warpfit::fit::MapSets::Stored, out).unwrap();
}

/// The fit `warpfit fit` runs on the bake of `from` brought into `dir`: stage by stage,
/// the bake's hit counts read from disk only for the cells stage.
fn staged(scene: &Scene, from: &Path, dir: &Path) {
    let progress = Progress::quiet();
    let (previous, folder) = (RunFolder::new(from), RunFolder::new(dir));
    let mut p = run::prepare_from(scene.clone(), &previous, folder, warpfit::bakefile::Hits::Later, &progress).unwrap();
    assert!(!p.baked_now && !p.grid.holds_hits(), "the bake is reused without its hit counts");
    let j = job();
    let warp = p.baked().warp(j.options);
    run::fit_staged(&mut p, &warp, &j.fit, j.store, warpfit::fit::MapSets::Stored, "test", &progress).unwrap();
}

/// Bakes and fits `scene` in `n` shards into `dir`, merging each step.
fn sharded(scene: &Scene, dir: &Path, n: u32) -> Vec<PathBuf> {
    let progress = Progress::quiet();
    let folder = RunFolder::new(dir);
    let bake_parts: Vec<PathBuf> =
        (0..n).map(|k| farm::bake_shard(scene, &folder, Shard { k, n }, &progress).unwrap()).collect();
    farm::merge(&folder, &bake_parts, "test", &progress).unwrap();
    // shards run in any order
    let fit_parts: Vec<PathBuf> =
        (0..n).rev().map(|k| farm::fit_shard(scene, &folder, &job(), Shard { k, n }, &progress).unwrap()).collect();
    let (farm::Merged::Fit(merged), _) = farm::merge(&folder, &fit_parts, "test", &progress).unwrap() else {
        panic!("a merge of fit parts makes a fit");
    };
    // the merged fit's time line counts the shards' steps (summed), not zeros
    let shards: Vec<_> = fit_parts.iter().map(|p| partfile::read_header(p).unwrap().fit_times.unwrap()).collect();
    let t = merged.0.times;
    assert_eq!(t.shards, n);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
    assert!(close(t.cells, shards.iter().map(|s| s.cells).sum::<f64>()), "{t:?}");
    assert!(close(t.irradiance_references, shards.iter().map(|s| s.irradiance_references).sum::<f64>()), "{t:?}");
    assert!(t.cells > 0.0 && t.irradiance_references > 0.0 && t.cells_cpu > 0.0, "{t:?}");
    assert!(t.counted().contains(&format!("{n} shards")) || n == 1);
    fit_parts
}

#[test]
fn merged_and_staged_grids_equal_the_single_machine_grid_for_1_3_and_7_shards() {
    // one probe, and two (the second baked by shard 1)
    for name in ["tiny", "tiny_probes"] {
        let scene = common::load(name);
        let base = common::tmp_dir(&format!("farm-equal-{name}"));
        single(&scene, &base.join("single"));
        let want = payloads(&base.join("single"));
        assert_eq!(want.iter().any(|(f, _)| f == "bake/probe_1.exr"), name == "tiny_probes");
        staged(&scene, &base.join("single"), &base.join("staged"));
        assert_eq!(payloads(&base.join("staged")), want, "{name}: staged fit");
        for n in [1, 3, 7] {
            let dir = base.join(format!("shards{n}"));
            sharded(&scene, &dir, n);
            assert_eq!(payloads(&dir), want, "{name}: {n} shards");
            FittedGrid::load(&dir).unwrap();
        }
        let _ = std::fs::remove_dir_all(&base);
    }
}

#[test]
fn bake_shards_cover_every_cell_once_and_balance_the_probe() {
    let scene = common::load("torture");
    let cells = scene.config.grid.counts.iter().map(|&c| c as usize).product::<usize>();
    for n in [1, 2, 3, 7, 64, cells, cells + 5] {
        let ranges: Vec<_> = (0..n).map(|k| warpfit::bake::shard_cells(&scene, k, n)).collect();
        assert_eq!(ranges[0].start, 0);
        assert_eq!(ranges[n - 1].end, cells);
        for w in ranges.windows(2) {
            assert_eq!(w[0].end, w[1].start, "{n} shards: contiguous");
        }
    }
    // shard 0 carries the probe: it bakes fewer cells than the others
    let r: Vec<_> = (0..4).map(|k| warpfit::bake::shard_cells(&scene, k, 4)).collect();
    assert!(r[0].len() < r[1].len(), "{r:?}");
}

#[test]
fn shard_arguments_are_checked() {
    assert_eq!("2/5".parse::<Shard>(), Ok(Shard { k: 2, n: 5 }));
    for bad in ["5/5", "0/0", "1", "a/3", "-1/3", "1/x"] {
        let e = bad.parse::<Shard>().unwrap_err();
        assert!(!e.is_empty(), "{bad}");
    }
}

/// A merge that fails: the error text, and the folder's grid unchanged.
fn refused(dir: &Path, parts: &[PathBuf]) -> String {
    let before = payloads(dir);
    let e = match farm::merge(&RunFolder::new(dir), parts, "test", &Progress::quiet()) {
        Ok(_) => panic!("merge of {parts:?} succeeded"),
        Err(e) => e.to_string(),
    };
    assert_eq!(payloads(dir), before, "a refused merge leaves the folder as it was");
    FittedGrid::load(dir).unwrap();
    e
}

#[test]
fn merges_of_parts_that_do_not_belong_together_are_refused_by_name() {
    let scene = common::load("tiny");
    let dir = common::tmp_dir("farm-refuse");
    sharded(&scene, &dir, 3);
    let progress = Progress::quiet();
    let folder = RunFolder::new(&dir);
    // the parts by name
    let part = |k: u32| dir.join("parts").join(partfile::part_name(PartKind::Fit, k, 3));

    let e = refused(&dir, &[part(0), part(2)]);
    assert!(e.contains("missing: 1/3"), "{e}");
    let e = refused(&dir, &[part(0), part(1), part(1), part(2)]);
    assert!(e.contains("given twice"), "{e}");

    // another shard count
    let other = farm::fit_shard(&scene, &folder, &job(), Shard { k: 0, n: 2 }, &progress).unwrap();
    let e = refused(&dir, &[part(1), part(2), other.clone()]);
    assert!(e.contains("shards") && e.contains(&other.display().to_string()), "{e}");

    // other settings
    let mut j = job();
    j.fit.train_dirs += 1;
    let odd = dir.join("odd");
    std::fs::create_dir_all(&odd).unwrap();
    let p = farm::fit_shard(&scene, &folder, &j, Shard { k: 1, n: 3 }, &progress).unwrap();
    let moved = odd.join("fit-0001-of-0003.part");
    std::fs::rename(&p, &moved).unwrap();
    let e = refused(&dir, &[part(0), moved.clone(), part(2)]);
    assert!(e.contains("settings") && e.contains(&moved.display().to_string()), "{e}");
    // bring the right shard 1 back
    farm::fit_shard(&scene, &folder, &job(), Shard { k: 1, n: 3 }, &progress).unwrap();

    // a bake part among fit parts
    let bake0 = dir.join("parts").join(partfile::part_name(PartKind::Bake, 0, 3));
    let e = refused(&dir, &[part(0), part(1), bake0]);
    assert!(e.contains("kind"), "{e}");

    // damaged parts: truncated, a flipped byte, a foreign file, a newer version
    let bytes = std::fs::read(part(1)).unwrap();
    let broken = dir.join("broken.part");
    std::fs::write(&broken, &bytes[..bytes.len() - 10]).unwrap();
    let e = refused(&dir, &[part(0), broken.clone(), part(2)]);
    assert!(e.contains("broken.part") && e.contains("truncated"), "{e}");
    let mut flipped = bytes.clone();
    let last = flipped.len() - 20;
    flipped[last] ^= 0x40;
    std::fs::write(&broken, &flipped).unwrap();
    let e = refused(&dir, &[part(0), broken.clone(), part(2)]);
    assert!(e.contains("broken.part") && e.contains("checksum"), "{e}");
    std::fs::write(&broken, b"P6 not a part at all").unwrap();
    let e = refused(&dir, &[part(0), broken.clone(), part(2)]);
    assert!(e.contains("not a warpfit part"), "{e}");
    // a newer part: the header says version 99 (its length prefix rewritten to match)
    let (magic, rest) = bytes.split_at(13);
    let len = u64::from_le_bytes(rest[..8].try_into().unwrap()) as usize;
    let head = String::from_utf8(rest[8..8 + len].to_vec()).unwrap().replacen(
        &format!("\"version\":{}", partfile::PART_VERSION),
        "\"version\":99",
        1,
    );
    let mut newer = magic.to_vec();
    newer.extend_from_slice(&(head.len() as u64).to_le_bytes());
    newer.extend_from_slice(head.as_bytes());
    newer.extend_from_slice(&rest[8 + len..]);
    std::fs::write(&broken, &newer).unwrap();
    let e = refused(&dir, &[part(0), broken.clone(), part(2)]);
    assert!(e.contains("version"), "{e}");
    let e = refused(&dir, &[part(0), dir.join("absent.part"), part(2)]);
    assert!(e.contains("absent.part"), "{e}");
    // a well-formed part whose cells' maps disagree with their models: a stored map missing,
    // or a map kept by a cell that does not store one
    let (header, body) = partfile::read_part(&part(1)).unwrap();
    let partfile::PartBody::Fit(fit_part) = body else { panic!("a fit part") };
    for stored in [true, false] {
        let mut tampered = fit_part.clone();
        let c = tampered.cells.iter_mut().find(|c| (c.fit.level == warpfit::fit::Level::Map) == stored).unwrap();
        c.fitted = if stored { Vec::new() } else { vec![0.0; (job().fit.map_res * job().fit.map_res) as usize] };
        partfile::write_part(&broken, header.clone(), &partfile::PartBody::Fit(tampered)).unwrap();
        let e = refused(&dir, &[part(0), broken.clone(), part(2)]);
        assert!(e.contains("broken.part") && e.contains("maps"), "{e}");
    }

    // and the right set still merges
    farm::merge(&folder, &[part(2), part(0), part(1)], "test", &progress).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_fit_shard_refuses_a_bake_of_other_settings() {
    let scene = common::load("tiny");
    let dir = common::tmp_dir("farm-stale");
    let progress = Progress::quiet();
    let folder = RunFolder::new(&dir);
    let e = farm::fit_shard(&scene, &folder, &job(), Shard { k: 0, n: 2 }, &progress).unwrap_err();
    assert!(e.to_string().contains("bake"), "{e}");
    // a bake of the same scene with another seed, from a copy of its file
    let text = std::fs::read_to_string(common::scene_file("tiny")).unwrap();
    assert!(text.contains("\nseed = "), "tiny.toml sets its seed");
    let copy = dir.join("tiny-seed.toml");
    std::fs::write(&copy, text.replacen("\nseed = ", "\nseed = 1", 1)).unwrap();
    let other = Scene::load(&copy).unwrap();
    assert_ne!(other.content_key(), scene.content_key());
    let p = farm::bake_shard(&other, &folder, Shard { k: 0, n: 1 }, &progress).unwrap();
    farm::merge(&folder, &[p], "test", &progress).unwrap();
    let e = farm::fit_shard(&scene, &folder, &job(), Shard { k: 0, n: 2 }, &progress).unwrap_err();
    assert!(e.to_string().contains("other settings"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn farm_job(dir: &Path) -> FarmJob {
    FarmJob {
        binary: PathBuf::from("/opt/warp fit/bin/warpfit"),
        scene: common::scene_file("tiny"),
        folder: RunFolder::new(dir.join("run")),
        shards: 3,
        fit_flags: vec!["--train-dirs=64".into()],
        cpus: 2,
    }
}

#[test]
fn slurm_scripts_are_array_jobs_chained_by_afterok() {
    let dir = common::tmp_dir("farm-slurm-scripts");
    let job = farm_job(&dir);
    let paths = cluster::write_slurm(&job).unwrap();
    let names: Vec<String> = paths.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["bake.sbatch", "bake-merge.sbatch", "fit.sbatch", "merge.sbatch"]);
    let text = |k: usize| std::fs::read_to_string(&paths[k]).unwrap();
    assert!(text(0).contains("#SBATCH --array=0-2"), "{}", text(0));
    assert!(text(0).contains("--shard \"${SLURM_ARRAY_TASK_ID}/3\""), "{}", text(0));
    assert!(text(2).contains("--train-dirs=64"), "{}", text(2));
    assert!(!text(1).contains("--array"));
    assert!(text(3).contains("fit-0002-of-0003.part"), "{}", text(3));
    assert!(text(0).contains("'/opt/warp fit/bin/warpfit'"), "paths with spaces are quoted: {}", text(0));
    let submit = std::fs::read_to_string(job.folder.farm().join("submit.sh")).unwrap();
    assert!(submit.contains("--dependency=afterok:"), "{submit}");
    // every script is valid shell
    for p in paths.iter().chain([&job.folder.farm().join("submit.sh")]) {
        let st = std::process::Command::new("bash").arg("-n").arg(p).status().unwrap();
        assert!(st.success(), "{} is not valid bash", p.display());
    }
    // the task's shard argument expands as the array index
    let out = std::process::Command::new("bash")
        .arg("-c")
        .arg(format!(
            "SLURM_ARRAY_TASK_ID=2; set -- {}; echo \"$@\"",
            text(0).lines().last().unwrap().trim_start_matches("exec ")
        ))
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("--shard 2/3"), "{}", String::from_utf8_lossy(&out.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn kubernetes_manifests_are_indexed_jobs() {
    let dir = common::tmp_dir("farm-k8s");
    let job = farm_job(&dir);
    let paths = cluster::write_k8s(&job, "registry.example/warpfit:1", "levels", Path::new("/work")).unwrap();
    assert_eq!(paths.len(), 4);
    for (k, p) in paths.iter().enumerate() {
        let m: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
        assert_eq!(m["apiVersion"], "batch/v1");
        assert_eq!(m["kind"], "Job");
        let spec = &m["spec"];
        let c = &spec["template"]["spec"]["containers"][0];
        assert_eq!(c["image"], "registry.example/warpfit:1");
        assert_eq!(spec["template"]["spec"]["restartPolicy"], "Never");
        assert_eq!(spec["template"]["spec"]["volumes"][0]["persistentVolumeClaim"]["claimName"], "levels");
        let script = c["command"][2].as_str().unwrap();
        if k % 2 == 0 {
            assert_eq!(spec["completionMode"], "Indexed");
            assert_eq!(spec["completions"], 3);
            assert_eq!(spec["parallelism"], 3);
            assert!(spec["backoffLimitPerIndex"].as_u64().is_some());
            assert!(script.contains("--shard \"${JOB_COMPLETION_INDEX}/3\""), "{script}");
        } else {
            assert!(spec.get("completionMode").is_none());
            assert!(script.contains("merge"), "{script}");
        }
    }
    let run = std::fs::read_to_string(job.folder.farm().join("k8s/run.sh")).unwrap();
    assert!(run.contains("kubectl wait --for=condition=complete"), "{run}");
    let _ = std::fs::remove_dir_all(&dir);
}
