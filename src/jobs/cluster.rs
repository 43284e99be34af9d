//! Farm jobs for cluster schedulers: the four steps of a sharded run (bake shards, bake
//! merge, fit shards, fit merge) as a SLURM array-job chain or as Kubernetes Indexed Jobs.
//!
//! SLURM: `bake.sbatch` and `fit.sbatch` are `--array=0-(N-1)` jobs whose task K runs
//! shard K/N (`SLURM_ARRAY_TASK_ID`); `bake-merge.sbatch` and `merge.sbatch` run the merges.
//! Each step depends on the one before with `--dependency=afterok`, so a failed shard stops
//! the chain; re-running it alone (`sbatch --array=K fit.sbatch`) and then the merge
//! finishes the job. Kubernetes: one Indexed Job per step (`completionMode: Indexed`,
//! shard K = `JOB_COMPLETION_INDEX`, a failed index retried alone with
//! `backoffLimitPerIndex`), run in order by `run.sh` with `kubectl wait`.

use crate::files::{FileError, write_atomic};
use crate::partfile::{PartKind, part_name};
use crate::report::folder::RunFolder;
use serde_json::json;
use std::path::{Path, PathBuf};

/// What a farm job runs: the binary, the scene, the run folder, the shard count and the
/// fit's command-line flags.
#[derive(Clone, Debug)]
pub struct FarmJob {
    /// The `warpfit` binary as the nodes see it.
    pub binary: PathBuf,
    pub scene: PathBuf,
    pub folder: RunFolder,
    pub shards: u32,
    /// Flags of `warpfit fit` (the fit settings), passed to every fit shard.
    pub fit_flags: Vec<String>,
    /// Threads per shard (SLURM `--cpus-per-task`, Kubernetes CPU request).
    pub cpus: u32,
}

/// Quotes `s` for a POSIX shell.
fn sh(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

fn shp(p: &Path) -> String {
    sh(&p.to_string_lossy())
}

/// `a` for a shell, its `{K}` (the shard index: `K/N` holds nothing else) standing for the
/// variable `var`.
fn arg(a: &str, var: &str) -> String {
    if a.contains("{K}") { format!("\"{}\"", a.replace("{K}", &format!("${{{var}}}"))) } else { sh(a) }
}

/// The steps of a farm job: (name, array, arguments after the binary). `{K}` stands for the
/// shard index.
fn steps(job: &FarmJob) -> Vec<(&'static str, bool, Vec<String>)> {
    let n = job.shards;
    let (scene, out) = (job.scene.to_string_lossy().into_owned(), job.folder.dir.to_string_lossy().into_owned());
    let parts = |kind| {
        (0..n)
            .map(|k| job.folder.parts().join(part_name(kind, k, n)).to_string_lossy().into_owned())
            .collect::<Vec<_>>()
    };
    let threads = job.cpus.max(1).to_string();
    let base = |cmd: &str| vec!["--threads".to_string(), threads.clone(), cmd.to_string()];
    let mut bake = base("bake");
    bake.extend(["--scene".into(), scene.clone(), "--out".into(), out.clone(), "--shard".into(), format!("{{K}}/{n}")]);
    let mut bake_merge = base("merge");
    bake_merge.extend(["--out".into(), out.clone()]);
    bake_merge.extend(parts(PartKind::Bake));
    let mut fit = base("fit");
    fit.extend(["--scene".into(), scene, "--out".into(), out.clone(), "--shard".into(), format!("{{K}}/{n}")]);
    fit.extend(job.fit_flags.iter().cloned());
    let mut merge = base("merge");
    merge.extend(["--out".into(), out]);
    merge.extend(parts(PartKind::Fit));
    vec![("bake", true, bake), ("bake-merge", false, bake_merge), ("fit", true, fit), ("merge", false, merge)]
}

/// The SLURM scripts of a job, in submission order: (file name, script).
pub fn slurm_scripts(job: &FarmJob) -> Vec<(String, String)> {
    let logs = job.folder.farm().join("logs");
    steps(job)
        .into_iter()
        .map(|(name, array, args)| {
            let mut s = String::from("#!/bin/bash\n");
            s += &format!(
                "# warpfit farm: {name} step of a {}-shard job (written by `warpfit farm slurm`)\n",
                job.shards
            );
            s += &format!("#SBATCH --job-name=warpfit-{name}\n");
            s += &format!("#SBATCH --cpus-per-task={}\n", job.cpus.max(1));
            if array {
                s += &format!("#SBATCH --array=0-{}\n", job.shards - 1);
                s += &format!("#SBATCH --output={}\n", shp(&logs.join(format!("{name}-%A_%a.log"))));
            } else {
                s += &format!("#SBATCH --output={}\n", shp(&logs.join(format!("{name}-%j.log"))));
            }
            s += "set -euo pipefail\n";
            let mut line = shp(&job.binary);
            for a in &args {
                line.push(' ');
                line += &arg(a, "SLURM_ARRAY_TASK_ID");
            }
            s += &format!("exec {line}\n");
            (format!("{name}.sbatch"), s)
        })
        .collect()
}

/// Kubernetes Job manifests of a job (JSON, which `kubectl apply -f` reads), in order:
/// (file name, manifest). The image must hold `warpfit` on its PATH and see the scene and
/// the run folder at the same paths (a shared volume `volume` mounted at `mount`).
pub fn k8s_manifests(job: &FarmJob, image: &str, volume: &str, mount: &Path) -> Vec<(String, serde_json::Value)> {
    let n = job.shards;
    steps(job)
        .into_iter()
        .map(|(name, array, args)| {
            let command: Vec<String> = args.iter().map(|a| arg(a, "JOB_COMPLETION_INDEX")).collect();
            let script = format!("exec warpfit {}", command.join(" "));
            let mut spec = json!({
                "backoffLimit": if array { 3 * n } else { 2 },
                "template": {
                    "spec": {
                        "restartPolicy": "Never",
                        "containers": [{
                            "name": name,
                            "image": image,
                            "command": ["/bin/sh", "-c", script],
                            "resources": { "requests": { "cpu": job.cpus.max(1).to_string() } },
                            "volumeMounts": [{ "name": "work", "mountPath": mount.to_string_lossy() }],
                        }],
                        "volumes": [{ "name": "work", "persistentVolumeClaim": { "claimName": volume } }],
                    }
                }
            });
            if array {
                spec["completionMode"] = json!("Indexed");
                spec["completions"] = json!(n);
                spec["parallelism"] = json!(n);
                spec["backoffLimitPerIndex"] = json!(2);
                spec.as_object_mut().map(|o| o.remove("backoffLimit"));
            } else {
                spec["completions"] = json!(1);
            }
            let manifest = json!({
                "apiVersion": "batch/v1",
                "kind": "Job",
                "metadata": { "name": format!("warpfit-{name}"), "labels": { "app": "warpfit", "warpfit-step": name } },
                "spec": spec,
            });
            (format!("{name}.json"), manifest)
        })
        .collect()
}

/// Writes the SLURM scripts and a `submit.sh` that chains them into `folder`'s `farm/`;
/// returns the scripts' paths in order.
pub fn write_slurm(job: &FarmJob) -> Result<Vec<PathBuf>, FileError> {
    let dir = job.folder.farm();
    std::fs::create_dir_all(dir.join("logs")).map_err(FileError::io(&dir))?;
    let mut paths = Vec::new();
    let mut submit = String::from(
        "#!/bin/bash\n# Submits the farm job: each step starts after the one before succeeded.\nset -euo pipefail\ncd \"$(dirname \"$0\")\"\ndep=\"\"\n",
    );
    for (file, script) in slurm_scripts(job) {
        let path = dir.join(&file);
        write_atomic(&path, script.as_bytes())?;
        submit += &format!(
            "id=$(sbatch --parsable $dep {file}); id=${{id%%;*}}; echo \"{file}: job $id\"; dep=\"--dependency=afterok:$id\"\n"
        );
        paths.push(path);
    }
    write_atomic(&dir.join("submit.sh"), submit.as_bytes())?;
    Ok(paths)
}

/// Writes the Kubernetes manifests and a `run.sh` that applies them in order into
/// `folder`'s `farm/k8s/`; returns the manifests' paths in order.
pub fn write_k8s(job: &FarmJob, image: &str, volume: &str, mount: &Path) -> Result<Vec<PathBuf>, FileError> {
    let dir = job.folder.farm().join("k8s");
    let mut paths = Vec::new();
    let mut run = String::from(
        "#!/bin/bash\n# Runs the farm job's steps in order, each after the one before completed.\nset -euo pipefail\ncd \"$(dirname \"$0\")\"\n",
    );
    for (file, manifest) in k8s_manifests(job, image, volume, mount) {
        let path = dir.join(&file);
        crate::files::write_json(&path, &manifest)?;
        let name = manifest["metadata"]["name"].as_str().unwrap_or_default().to_string();
        run += &format!(
            "kubectl delete job {name} --ignore-not-found\nkubectl apply -f {file}\nkubectl wait --for=condition=complete --timeout=48h job/{name}\n"
        );
        paths.push(path);
    }
    write_atomic(&dir.join("run.sh"), run.as_bytes())?;
    Ok(paths)
}

/// Submits the scripts `paths` with `sbatch`, each after the one before succeeded; returns
/// the job ids.
pub fn submit_slurm(paths: &[PathBuf]) -> Result<Vec<String>, String> {
    let mut ids: Vec<String> = Vec::new();
    for p in paths {
        let mut cmd = std::process::Command::new("sbatch");
        cmd.arg("--parsable");
        if let Some(prev) = ids.last() {
            cmd.arg(format!("--dependency=afterok:{prev}"));
        }
        cmd.arg(p);
        let out = cmd.output().map_err(|e| format!("running sbatch for {}: {e} (is SLURM installed?)", p.display()))?;
        if !out.status.success() {
            return Err(format!("sbatch refused {}: {}", p.display(), String::from_utf8_lossy(&out.stderr).trim()));
        }
        let text = String::from_utf8_lossy(&out.stdout);
        let id = text.trim().split(';').next().unwrap_or_default().to_string();
        if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
            return Err(format!("sbatch gave no job id for {}: {text:?}", p.display()));
        }
        ids.push(id);
    }
    Ok(ids)
}
