//! The run folder (`fits/<scene>/` by default): the one place that names its files. The
//! fitted grid's own files (`manifest.json`, payloads) are named by `gridfile`, the bake's by
//! `bakefile`; this names everything else a run leaves and where the bake lives.

use std::path::{Path, PathBuf};

/// `name` as a single safe path component.
#[must_use]
pub fn safe_name(name: &str) -> String {
    let s: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') { c } else { '_' }).collect();
    let s = s.trim_start_matches('.').to_string();
    if s.is_empty() { "scene".into() } else { s }
}

/// A run's output folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunFolder {
    pub dir: PathBuf,
}

impl RunFolder {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        RunFolder { dir: dir.into() }
    }

    /// The default folder of a scene: `fits/<scene name>`, the name made a safe folder name
    /// (letters, digits, `-`, `_`, `.`; no leading dot; others become `_`), so a name such as
    /// `../..` or `/etc` cannot write outside `fits/`.
    pub fn for_scene(scene_name: &str) -> Self {
        RunFolder::new(Path::new("fits").join(safe_name(scene_name)))
    }

    /// Whether `file` (a top-level name) is written by the evaluation.
    pub fn written_by_eval(file: &str) -> bool {
        file.starts_with("eval") || file.starts_with("flip_")
    }

    /// Whether `file` is written by the run report.
    pub fn written_by_report(file: &str) -> bool {
        file.starts_with("report.")
    }

    fn file(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Whether `file` belongs to a farm: the shards' parts and the cluster scripts and logs
    /// (kept when a merge rewrites the folder).
    pub fn written_by_farm(file: &str) -> bool {
        file == "parts" || file == "farm"
    }

    /// The parts the shards of a bake or fit write (`warpfit-part`).
    pub fn parts(&self) -> PathBuf {
        self.file("parts")
    }

    /// Cluster job scripts and their logs (`warpfit farm`).
    pub fn farm(&self) -> PathBuf {
        self.file("farm")
    }

    /// The bake folder (`warpfit-bake`).
    pub fn bake(&self) -> PathBuf {
        self.file("bake")
    }
    /// The fitted grid's manifest (`warpfit-grid`; its payloads sit beside it).
    pub fn grid_manifest(&self) -> PathBuf {
        self.file(crate::gridfile::MANIFEST_FILE)
    }
    pub fn eval_json(&self) -> PathBuf {
        self.file("eval.json")
    }
    pub fn eval_md(&self) -> PathBuf {
        self.file("eval.md")
    }
    pub fn eval_plot(&self) -> PathBuf {
        self.file("eval_error_vs_cost.png")
    }
    pub fn eval_views(&self) -> PathBuf {
        self.file("eval_views.png")
    }
    /// Error (mean ꟻLIP) against cost per roughness bucket.
    pub fn eval_rough_plot(&self) -> PathBuf {
        self.file("eval_rough.png")
    }
    /// The camera view of roughness bucket `r` with a few rows' images and ꟻLIP maps.
    /// `flip_diffuse.png`: the diffuse camera view and its ꟻLIP maps.
    pub fn flip_diffuse(&self) -> PathBuf {
        self.file("flip_diffuse.png")
    }

    /// `flip_surface{k}_r{r}.png`: the camera across surface-probe patch k at roughness r.
    pub fn flip_surface(&self, k: usize, r: f32) -> PathBuf {
        self.file(&format!("flip_surface{k}_r{r:.3}.png"))
    }
    /// `surface{k}/`: surface-probe patch k's atlas as a game loads it (`warpfit-surface`).
    pub fn surface_atlas_dir(&self, k: usize) -> PathBuf {
        self.file(&format!("surface{k}"))
    }
    /// `surface_atlas{k}.png`: the mirror tiles of surface-probe patch k, as packed.
    pub fn surface_atlas(&self, k: usize) -> PathBuf {
        self.file(&format!("surface_atlas{k}.png"))
    }
    pub fn flip_figure(&self, r: f32) -> PathBuf {
        self.file(&format!("flip_r{r:.3}.png"))
    }
    pub fn residuals(&self) -> PathBuf {
        self.file("residuals.json")
    }
    pub fn fit_md(&self) -> PathBuf {
        self.file("fit.md")
    }
    pub fn residual_slices(&self) -> PathBuf {
        self.file("residual_slices.png")
    }
    pub fn fit_convergence(&self) -> PathBuf {
        self.file("fit_convergence.png")
    }
    pub fn report_json(&self) -> PathBuf {
        self.file("report.json")
    }
    pub fn report_md(&self) -> PathBuf {
        self.file("report.md")
    }
    pub fn report_html(&self) -> PathBuf {
        self.file("report.html")
    }
    pub fn sweep_json(&self) -> PathBuf {
        self.file("sweep.json")
    }
    pub fn sweep_plot(&self) -> PathBuf {
        self.file("sweep.png")
    }
    pub fn sweep_convergence(&self) -> PathBuf {
        self.file("sweep_convergence.png")
    }
    pub fn stability_json(&self) -> PathBuf {
        self.file("stability.json")
    }
    pub fn stability_md(&self) -> PathBuf {
        self.file("stability.md")
    }
    pub fn roughness_json(&self) -> PathBuf {
        self.file("roughness.json")
    }
    pub fn roughness_plot(&self) -> PathBuf {
        self.file("roughness.png")
    }
}
