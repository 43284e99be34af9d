//! `warpfit` command line: argument types, dispatch to `warpfit::jobs`, printing. No logic
//! lives here.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use warpfit::bakefile;
use warpfit::eval::{EvalSettings, RenderSettings};
use warpfit::files;
use warpfit::fit::{FitSettings, MapSets, Solver};
use warpfit::jobs::run::{self as job, Output, RunSettings, StoreOptions};
use warpfit::jobs::{cluster, farm, stability, sweep};
use warpfit::progress::Progress;
use warpfit::report::{self, folder::RunFolder};
use warpfit::runtime::{FittedGrid, Precision};
use warpfit::warp::{Method, WarpOptions};

/// Offline parallax correction for reflection probes.
#[derive(Parser)]
#[command(name = "warpfit", version, about)]
struct Cli {
    /// No progress bars and only warnings in the log.
    #[arg(long, global = true)]
    quiet: bool,
    /// Worker threads (default: all cores). Results are identical at any count.
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Check a scene before baking: probe A inside geometry or outside the scene, a grid
    /// that misses it, no light, mixed winding; bounds and counts. Exits non-zero on errors.
    Check {
        /// Scene file (TOML).
        #[arg(long, default_value = "data/scenes/torture.toml")]
        scene: PathBuf,
    },
    /// Write a scene file for a level mesh to standard output: grid over its bounds, probe A
    /// at the most open point, the file's lights (or a daylight sky and sun).
    Init {
        /// The level: .gltf, .glb or .obj.
        #[arg(long)]
        mesh: PathBuf,
        /// Grid cell size in scene units (grown if the grid would exceed 20,000 cells).
        #[arg(long, default_value_t = 1.0)]
        cell_size: f32,
    },
    /// Raytrace the scene and write the specular probe, the probe grid and previews.
    Bake {
        #[command(flatten)]
        scene: SceneArgs,
        /// Bake only shard K of N (grid cells; the probe with shard 0) into <out>/parts/;
        /// `warpfit merge` makes the bake of all N.
        #[arg(long, value_name = "K/N")]
        shard: Option<farm::Shard>,
    },
    /// Measure every warp method against raytraced references on held-out positions and
    /// directions; writes eval.json, eval.md and an error-against-cost plot.
    Eval {
        #[command(flatten)]
        scene: SceneArgs,
        /// Comma-separated methods, or "all".
        #[arg(long, default_value = "all")]
        methods: String,
        #[command(flatten)]
        eval: EvalArgs,
    },
    /// Fit per-cell correctives (baking first if needed) and write the fitted grid.
    Fit {
        #[command(flatten)]
        scene: SceneArgs,
        #[command(flatten)]
        fit: FitArgs,
        /// Fit only shard K of N (of the active cells) on the bake in <out> into
        /// <out>/parts/; `warpfit merge` writes the grid of all N.
        #[arg(long, value_name = "K/N")]
        shard: Option<farm::Shard>,
    },
    /// Merge the parts of a sharded bake or fit (every shard exactly once) into <out>: the
    /// bake, or the fitted grid, byte for byte what one machine writes.
    Merge {
        /// The run folder.
        #[arg(long)]
        out: PathBuf,
        /// The parts (`<out>/parts/*.part` of one job).
        #[arg(required = true)]
        parts: Vec<PathBuf>,
    },
    /// Write (and with --submit, submit) a sharded bake and fit as cluster jobs.
    Farm {
        #[command(subcommand)]
        target: FarmTarget,
    },
    /// Fit the GGX distance-ratio roughness correction (seed 002) and write
    /// roughness.json and roughness.png.
    Roughness {
        #[arg(long, default_value = "fits/roughness")]
        out: PathBuf,
    },
    /// Sample a fitted grid at one position and direction, as the runtime does.
    Sample {
        #[arg(long, default_value = "fits/torture")]
        fit: PathBuf,
        /// Shading position x,y,z.
        #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
        pos: glam::Vec3,
        /// Reflected direction x,y,z (need not be unit length).
        #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
        dir: glam::Vec3,
        /// Perceptual roughness in [0, 1].
        #[arg(long, default_value_t = 0.0)]
        roughness: f32,
        /// Surface normal x,y,z for the irradiance (default: the direction).
        #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
        normal: Option<glam::Vec3>,
        /// What a rough lookup reads: "blended" (probe A and the cells' irradiance, the
        /// lowest error) or "probe-only" (probe A alone, cheaper).
        #[arg(long, default_value = "blended")]
        read: warpfit::runtime::SpecularRead,
    },
    /// Run the stability suite of stiff and extreme cases; exits non-zero on any failure.
    Stability {
        /// Smaller bakes and fewer queries (the mode the tests run).
        #[arg(long)]
        quick: bool,
        /// Where stability.json and stability.md go.
        #[arg(long, default_value = "fits/stability")]
        out: PathBuf,
    },
    /// Write report.json, report.md and a self-contained report.html from a run's folder.
    Report {
        #[arg(long, default_value = "fits/torture")]
        out: PathBuf,
    },
    /// Error against fit effort: refit with one knob changed at a time (probe resolution,
    /// training directions, iterations, solver); writes sweep.json, sweep.png.
    Sweep {
        #[command(flatten)]
        job: RunArgs,
    },
    /// Write a fitted grid in the layout engines load: KTX2 textures (probe mips, guttered
    /// atlases), export.json (grid, tile tables, conventions) and the reference shader
    /// (WGSL, HLSL, GLSL) with its two buffers.
    Export {
        /// The fitted grid folder.
        #[arg(long, default_value = "fits/torture")]
        fit: PathBuf,
        /// Texture container (KTX 2.0).
        #[arg(long, value_enum, default_value = "ktx2")]
        format: ExportFormat,
        /// Where the textures and export.json go.
        #[arg(long)]
        out: PathBuf,
        /// What the shader's rough lookups read: "blended" (probe A and the cells'
        /// irradiance) or "probe-only" (probe A alone, cheaper; no blend nodes exported).
        #[arg(long, default_value = "blended")]
        read: warpfit::runtime::SpecularRead,
    },
    /// Summarise a fitted grid: contents, bytes per layer, residuals, what was left out.
    Inspect {
        #[arg(default_value = "fits/torture")]
        fit: PathBuf,
    },
    /// The main job: bake (or reuse a matching bake), fit, evaluate every method including
    /// the fitted correctives, and report; on the default scene unless one is given.
    Run {
        #[command(flatten)]
        job: RunArgs,
    },
}

#[derive(Subcommand)]
enum FarmTarget {
    /// SLURM: array jobs for the bake and fit shards, merges chained with
    /// --dependency=afterok; scripts in <out>/farm/.
    Slurm {
        #[command(flatten)]
        farm: FarmArgs,
        /// Submit the chain with sbatch (else only write it; <out>/farm/submit.sh submits).
        #[arg(long)]
        submit: bool,
    },
    /// Kubernetes: an Indexed Job per step (shard = JOB_COMPLETION_INDEX), JSON manifests
    /// and a run.sh in <out>/farm/k8s/.
    K8s {
        #[command(flatten)]
        farm: FarmArgs,
        /// Container image with `warpfit` on its PATH.
        #[arg(long)]
        image: String,
        /// PersistentVolumeClaim holding the scene and the run folder.
        #[arg(long, default_value = "warpfit-work")]
        volume: String,
        /// Where the volume is mounted in the container.
        #[arg(long, default_value = "/work")]
        mount: PathBuf,
    },
}

/// A farm job: scene, run folder, shards, threads per shard and the fit's settings.
#[derive(clap::Args)]
struct FarmArgs {
    /// Scene file (TOML).
    #[arg(long, default_value = "data/scenes/torture.toml")]
    scene: PathBuf,
    /// Run folder (default: fits/<scene name>), on storage every node sees.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Shards of the bake and of the fit.
    #[arg(long)]
    shards: u32,
    /// Threads (CPUs) per shard.
    #[arg(long, default_value_t = 2)]
    cpus: u32,
    #[command(flatten)]
    fit: FitArgs,
}

/// The scene and the run folder.
#[derive(clap::Args)]
struct SceneArgs {
    /// Scene file (TOML).
    #[arg(long, default_value = "data/scenes/torture.toml")]
    scene: PathBuf,
    /// Output folder (default: fits/<scene name>); a matching bake there is reused.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Bake even when the estimate exceeds the machine's available memory.
    #[arg(long)]
    force: bool,
}

/// A whole job: scene, output folder, fit and eval settings. Shared by `run` and `sweep`.
#[derive(clap::Args)]
struct RunArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    eval: EvalArgs,
    #[command(flatten)]
    fit: FitArgs,
}

#[derive(clap::Args)]
struct FitArgs {
    /// N of each cell's N×N shift map (8..=16).
    #[arg(long, default_value_t = FitSettings::standard().map_res)]
    map_res: u32,
    /// Relative error at or below which a cell keeps the plain warp.
    #[arg(long, default_value_t = FitSettings::standard().tol)]
    tol: f32,
    /// Solver refining the shift maps.
    #[arg(long, value_enum, default_value_t = FitSettings::standard().solver)]
    solver: Solver,
    /// Sweeps (Brent) or iteration budget multiplier (L-BFGS, Nelder-Mead).
    #[arg(long, default_value_t = FitSettings::standard().iterations)]
    iterations: u32,
    /// Training positions per cell.
    #[arg(long, default_value_t = FitSettings::standard().train_positions)]
    train_positions: u32,
    /// Training directions per position.
    #[arg(long, default_value_t = FitSettings::standard().train_dirs)]
    train_dirs: u32,
    /// Held-out check positions per cell (model selection).
    #[arg(long, default_value_t = FitSettings::standard().check_positions)]
    check_positions: u32,
    /// Check directions per position.
    #[arg(long, default_value_t = FitSettings::standard().check_dirs)]
    check_dirs: u32,
    /// Check positions a cell adds when its first ones cannot tell its fitted maps from the
    /// proxy alone (their per-position difference within two standard errors of 0); 0: never.
    #[arg(long, default_value_t = FitSettings::standard().extra_check_positions)]
    extra_check_positions: u32,
    /// Samples per training and check reference (`--reference-spp` is the evaluation's).
    #[arg(long, default_value_t = FitSettings::standard().reference_spp)]
    fit_reference_spp: u32,
    /// Charbonnier ε of the fit's loss as a fraction of a cell's mean reference radiance.
    #[arg(long, default_value_t = FitSettings::standard().robust_scale)]
    robust_scale: f64,
    /// Storage of the radiance layers of the fitted grid (distances and shift maps are f32).
    #[arg(long, value_enum, default_value = "f32")]
    precision: PrecisionArg,
    /// Leave the GGX roughness correction out of the fitted grid.
    #[arg(long)]
    no_roughness: bool,
    /// Also fit every cell's level-1 corrective (origin offset, depth mip, relaxation) and
    /// report its held-out error beside the stored model's in fit.md (not stored).
    #[arg(long)]
    level1: bool,
    /// Also fit every cell's map at 4², 8², 16² and 32² texels and report in fit.md what a
    /// per-cell choice of resolution would give, judged by two-fold cross-validation over
    /// each cell's check positions (not stored).
    #[arg(long)]
    resolution_study: bool,
    /// A cell stores its map only when the map's held-out error is below this fraction of
    /// the fallback's (at most 1).
    #[arg(long, default_value_t = FitSettings::standard().selection_margin)]
    selection_margin: f64,
    /// Weight of the pull of every map towards its anchor (mean squared log-scale of the
    /// shifted distance over the anchor's).
    #[arg(long, default_value_t = FitSettings::standard().size_weight)]
    size_weight: f64,
    /// Fraction of each cell's training and check queries that are rough lookups (the rest
    /// mirror lookups), in [0, 1].
    #[arg(long, default_value_t = FitSettings::standard().rough_fraction)]
    rough_fraction: f32,
    /// Where the maps' anchor lies: this fraction of the way (in log-scale) from the proxy
    /// (0) to the grid's raytraced distances (1).
    #[arg(long, default_value_t = FitSettings::standard().depth_prior)]
    depth_prior: f64,
    /// Store one map per cell for every roughness, as version-4 grids did, instead of a
    /// map and a rough map.
    #[arg(long)]
    one_map: bool,
    /// Where the rough maps' anchor lies (as --depth-prior).
    #[arg(long, default_value_t = FitSettings::standard().rough_depth_prior)]
    rough_depth_prior: f64,
    /// Fraction of each cell's training and check positions on the surfaces around it
    /// (reflection directions), the rest in its volume (in [0, 1]).
    #[arg(long, default_value_t = FitSettings::standard().surface_fraction)]
    surface_fraction: f32,
    /// The proxy the maps shift: measured (the cheapest of box, kdop and warp1 within 5% of
    /// the best), or one of them.
    #[arg(long, value_enum, default_value = "measured")]
    proxy: warpfit::fit::proxy::ProxyChoice,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ExportFormat {
    Ktx2,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum PrecisionArg {
    F32,
    F16,
}

impl FitArgs {
    fn store(&self) -> StoreOptions {
        let precision = match self.precision {
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F16 => Precision::F16,
        };
        StoreOptions { precision, roughness: !self.no_roughness }
    }

    /// The flags that give these settings to `warpfit fit` (for farm jobs).
    fn flags(&self) -> Vec<String> {
        use clap::ValueEnum;
        let name = |v: Option<clap::builder::PossibleValue>| v.map(|v| v.get_name().to_string()).unwrap_or_default();
        let mut f = vec![
            format!("--map-res={}", self.map_res),
            format!("--tol={}", self.tol),
            format!("--solver={}", name(self.solver.to_possible_value())),
            format!("--iterations={}", self.iterations),
            format!("--train-positions={}", self.train_positions),
            format!("--train-dirs={}", self.train_dirs),
            format!("--check-positions={}", self.check_positions),
            format!("--check-dirs={}", self.check_dirs),
            format!("--extra-check-positions={}", self.extra_check_positions),
            format!("--fit-reference-spp={}", self.fit_reference_spp),
            format!("--robust-scale={}", self.robust_scale),
            format!("--precision={}", name(self.precision.to_possible_value())),
            format!("--selection-margin={}", self.selection_margin),
            format!("--size-weight={}", self.size_weight),
            format!("--depth-prior={}", self.depth_prior),
            format!("--rough-depth-prior={}", self.rough_depth_prior),
            format!("--rough-fraction={}", self.rough_fraction),
            format!("--surface-fraction={}", self.surface_fraction),
            format!("--proxy={}", name(self.proxy.to_possible_value())),
        ];
        if self.no_roughness {
            f.push("--no-roughness".into());
        }
        if self.one_map {
            f.push("--one-map".into());
        }
        if self.level1 {
            f.push("--level1".into());
        }
        if self.resolution_study {
            f.push("--resolution-study".into());
        }
        f
    }

    fn settings(&self) -> Result<FitSettings> {
        anyhow::ensure!(
            (8..=16).contains(&self.map_res) && self.map_res.is_power_of_two(),
            "--map-res must be 8 or 16"
        );
        anyhow::ensure!(self.robust_scale.is_finite() && self.robust_scale > 0.0, "--robust-scale must be > 0");
        anyhow::ensure!(
            self.selection_margin > 0.0 && self.selection_margin <= 1.0,
            "--selection-margin must be in (0, 1]"
        );
        anyhow::ensure!(self.size_weight.is_finite() && self.size_weight >= 0.0, "--size-weight must be ≥ 0");
        anyhow::ensure!((0.0..=1.0).contains(&self.depth_prior), "--depth-prior must be in [0, 1]");
        anyhow::ensure!((0.0..=1.0).contains(&self.rough_depth_prior), "--rough-depth-prior must be in [0, 1]");
        anyhow::ensure!((0.0..=1.0).contains(&self.rough_fraction), "--rough-fraction must be in [0, 1]");
        anyhow::ensure!((0.0..=1.0).contains(&self.surface_fraction), "--surface-fraction must be in [0, 1]");
        Ok(FitSettings {
            map_res: self.map_res,
            tol: self.tol.max(0.0),
            solver: self.solver,
            iterations: self.iterations.max(1),
            train_positions: self.train_positions.max(1),
            train_dirs: self.train_dirs.max(1),
            check_positions: self.check_positions.max(1),
            check_dirs: self.check_dirs.max(1),
            extra_check_positions: self.extra_check_positions,
            reference_spp: self.fit_reference_spp.max(1),
            robust_scale: self.robust_scale,
            level1: self.level1,
            resolution_study: self.resolution_study,
            selection_margin: self.selection_margin,
            size_weight: self.size_weight,
            depth_prior: self.depth_prior,
            rough_map: !self.one_map,
            rough_depth_prior: self.rough_depth_prior,
            rough_fraction: self.rough_fraction,
            surface_fraction: self.surface_fraction,
            proxy: self.proxy,
            ..FitSettings::standard()
        })
    }
}

#[derive(clap::Args)]
struct EvalArgs {
    /// Validation positions.
    #[arg(long, default_value_t = EvalSettings::standard().positions)]
    positions: u32,
    /// Validation directions per position.
    #[arg(long, default_value_t = EvalSettings::standard().dirs_per_position)]
    dirs: u32,
    /// Samples per reference ray.
    #[arg(long, default_value_t = EvalSettings::standard().reference_spp)]
    reference_spp: u32,
    /// Lobe samples per rough (r > 0) reference: heavier references for quieter rough
    /// buckets (eval.md says per bucket whether their noise is under a quarter of the
    /// difference it reports).
    #[arg(long, default_value_t = EvalSettings::standard().rough_reference_spp)]
    rough_reference_spp: u32,
    /// A rough bucket whose references' noise exceeds a quarter of the difference it
    /// reports is traced again with twice the samples, up to this many per reference
    /// (at or below --rough-reference-spp: never).
    #[arg(long, default_value_t = EvalSettings::standard().rough_reference_spp_max)]
    rough_reference_spp_max: u32,
    /// Lobe samples per pixel of the rendered views' references (the views behind each
    /// row's ꟻLIP; eval.md states the ꟻLIP their own noise scores).
    #[arg(long, default_value_t = RenderSettings::standard().reference_spp)]
    view_reference_spp: u32,
    /// Depth mip the depth-based warps read.
    #[arg(long, default_value_t = WarpOptions::standard().depth_lod)]
    depth_mip: f32,
    /// UV relaxation radius in probe texels (0 = off).
    #[arg(long, default_value_t = WarpOptions::standard().relax_texels)]
    relax: f32,
    /// Seed of the validation set.
    #[arg(long, default_value_t = EvalSettings::standard().seed)]
    eval_seed: u64,
}

impl EvalArgs {
    fn settings(&self) -> EvalSettings {
        EvalSettings {
            positions: self.positions.max(1),
            dirs_per_position: self.dirs.max(1),
            reference_spp: self.reference_spp.max(1),
            rough_reference_spp: self.rough_reference_spp.max(1),
            rough_reference_spp_max: self.rough_reference_spp_max,
            renders: Some(RenderSettings {
                reference_spp: self.view_reference_spp.max(1),
                ..RenderSettings::standard()
            }),
            seed: self.eval_seed,
            options: WarpOptions { depth_lod: self.depth_mip, relax_texels: self.relax, ..WarpOptions::standard() },
            ..EvalSettings::standard()
        }
    }
}

fn parse_methods(list: &str) -> Result<Vec<Method>> {
    if list == "all" {
        return Ok(Method::ALL.to_vec());
    }
    list.split(',')
        .map(|n| {
            Method::parse(n.trim()).with_context(|| {
                let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
                format!("unknown method {n:?}; known: {}", names.join(", "))
            })
        })
        .collect()
}

fn parse_vec3(text: &str) -> std::result::Result<glam::Vec3, String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(glam::Vec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers x,y,z, got {text:?}")),
    }
}

fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!("warpfit {}", args.join(" "))
}

/// Opens a transaction on the scene's run folder and prepares the scene and its bake
/// (reused from the folder or fresh) in it, saying which; `hits`: when a reused bake's hit
/// counts are read.
fn prepare(
    args: &SceneArgs,
    hits: bakefile::Hits,
    progress: &Progress,
) -> Result<(job::Prepared, job::Transaction, RunFolder)> {
    let (scene, folder) = job::load_scene(&args.scene, args.out.as_deref())?;
    check_scene(&scene)?;
    job::check_bake_estimate(&scene, args.force)?;
    let tx = job::Transaction::begin(&folder)?;
    let p = job::prepare_from(scene, &tx.previous, tx.out.clone(), hits, progress)?;
    if p.baked_now {
        println!("baked {} → {}", p.scene.name, folder.bake().display());
    } else {
        println!(
            "reusing the bake in {} (made from the same settings and input files: key {})",
            folder.bake().display(),
            p.scene.content_key()
        );
    }
    Ok((p, tx, folder))
}

/// Runs the scene checks: warnings logged, errors fail the command.
fn check_scene(scene: &warpfit::scene::Scene) -> Result<()> {
    let tracer = warpfit::trace::Tracer::new(scene);
    let c = warpfit::jobs::check::check(scene, &tracer);
    for w in &c.warnings {
        tracing::warn!("{w}");
    }
    anyhow::ensure!(c.ok(), "the scene check failed:\n  {}", c.errors.join("\n  "));
    Ok(())
}

/// What [`print_fit`] says of a fit, taken from it so that the fit can be dropped first.
struct FitLines {
    summary: warpfit::fit::summary::FitSummary,
    selection_margin: f64,
    measured: Option<[f64; 3]>,
    check_positions: u32,
    extra_check_positions: u32,
}

impl FitLines {
    fn of(f: &warpfit::fit::Fit) -> FitLines {
        FitLines {
            summary: warpfit::fit::summary::summary(f),
            selection_margin: f.settings.selection_margin,
            measured: f.proxy.measured,
            check_positions: f.settings.check_positions,
            extra_check_positions: f.settings.extra_check_positions,
        }
    }
}

fn print_fit(f: &FitLines, manifest: &warpfit::gridfile::GridManifest, folder: &RunFolder) {
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

fn print_eval(r: &warpfit::eval::EvalReport, folder: &RunFolder) {
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
    if r.diffuse.is_some() {
        println!("\ndiffuse (irradiance at held-out surface points):");
        print!("{}", report::diffuse_table(r));
    }
    for sr in &r.surface {
        print!("{}", report::surface_section(sr));
    }
    let t = &r.times;
    println!(
        "time: {:.1} s in all: mirror references {:.1} s, rough references {:.1} s, views and their references {:.1} s, rows {:.1} s, their views' ꟻLIP {:.1} s, bucket summaries {:.1} s, diffuse and surfaces {:.1} s",
        r.seconds,
        t.mirror_references,
        t.rough_references,
        t.view_references,
        t.rows,
        t.flip,
        t.summaries,
        t.diffuse_and_surfaces
    );
    println!("wrote {}/eval.json, eval.md, eval_error_vs_cost.png", folder.dir.display());
}

fn main() {
    // A closed pipe (`warpfit inspect | head -1`) ends the program quietly, as it ends any
    // Unix filter, instead of a panic in `println!`.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Big arrays (a grid's maps, a bake's atlases) are mapped and unmapped on their own:
    // glibc's default raises this threshold after the first big free, lets later big arrays
    // into the heap and keeps their pages when they are freed between smaller allocations
    // (a 31k-cell fit peaked 47 MB higher with the default).
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: a malloc tunable set before any thread starts or anything is allocated in bulk.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 128 * 1024);
    }
    // Test hook, for the kill-at-every-rename tests: `WARPFIT_TEST_FAULT_RENAME=N` makes the
    // N-th rename fail, `N:abort` kills the process there.
    if let Ok(v) = std::env::var("WARPFIT_TEST_FAULT_RENAME") {
        let (n, abort) = v.split_once(':').map_or((v.as_str(), false), |(n, a)| (n, a == "abort"));
        if let Ok(n) = n.parse::<u64>() {
            let fault = if abort { files::staged::Fault::Abort } else { files::staged::Fault::Error };
            files::staged::set_rename_fault(Some((n, fault)));
        }
    }
    let cli = Cli::parse();
    let level = if cli.quiet { "warn" } else { "info" };
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| level.into()))
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    if let Err(e) = run(cli) {
        // The library's errors already quote their source; print each cause only once.
        let mut text = e.to_string();
        for cause in e.chain().skip(1) {
            let c = cause.to_string();
            if !text.contains(&c) {
                text = format!("{text}: {c}");
            }
        }
        eprintln!("error: {text}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build_global().context("setting up threads")?;
    }
    let progress = Progress { quiet: cli.quiet };
    let command = command_line();
    match cli.command {
        Command::Check { scene } => {
            let scene = warpfit::scene::Scene::load(&scene)?;
            let tracer = warpfit::trace::Tracer::new(&scene);
            let c = warpfit::jobs::check::check(&scene, &tracer);
            println!("{}: {}", scene.source.display(), c.facts.join("; "));
            for w in &c.warnings {
                println!("warning: {w}");
            }
            for e in &c.errors {
                println!("error: {e}");
            }
            anyhow::ensure!(c.ok(), "{} error(s)", c.errors.len());
            println!("ok: {} warning(s)", c.warnings.len());
        }
        Command::Init { mesh, cell_size } => {
            let i = warpfit::jobs::init::init(&mesh, &mesh, cell_size)?;
            print!("{}", i.text);
        }
        Command::Bake { scene, shard: Some(shard) } => {
            let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
            check_scene(&scene)?;
            let path = farm::bake_shard(&scene, &folder, shard, &progress)?;
            println!("baked shard {shard} of {} → {}", scene.name, path.display());
        }
        Command::Bake { scene, shard: None } => {
            let force = scene.force;
            let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
            check_scene(&scene)?;
            job::check_bake_estimate(&scene, force)?;
            tracing::info!(
                "scene {}: {} triangles, {} spheres",
                scene.name,
                scene.triangles.len(),
                scene.spheres.len()
            );
            let tracer = warpfit::trace::Tracer::new(&scene);
            let tx = job::Transaction::begin(&folder)?;
            let same_bake = warpfit::bakefile::manifest_key(&folder.bake()).as_deref() == Some(&scene.content_key());
            let baked = job::bake(&scene, &tracer, &tx.out, &progress)?;
            if same_bake {
                // the same inputs bake the same bits: the fit made from the old bake still holds
                tx.keep(|_| true)?;
            }
            tx.commit(false)?;
            let s = &baked.stats;
            println!(
                "baked {} → {}: probe {}² ({} mips), grid {:?} ({} active cells), {:.2} Mrays in {:.2} s ({:.2} Mrays/s, {} threads)",
                scene.name,
                folder.bake().display(),
                baked.probe.resolution(),
                baked.probe.radiance.levels.len(),
                baked.grid.geometry.counts.to_array(),
                baked.grid.active_cells(),
                (s.probe_rays + s.grid_rays) as f64 / 1e6,
                s.total_s,
                s.rays_per_s / 1e6,
                s.threads
            );
        }
        Command::Eval { scene, methods, eval } => {
            let methods = parse_methods(&methods)?;
            // the evaluation never reads the grid's hit counts: a reused bake's stay on disk
            let (p, tx, folder) = prepare(&scene, bakefile::Hits::Later, &progress)?;
            let settings = eval.settings();
            let warp = p.baked().warp(settings.options);
            let out = Output { folder: &p.folder, command: &command, progress: &progress };
            let r = job::evaluate(p.baked(), &warp, &settings, &methods, None, out)?;
            if !p.baked_now {
                // same bake: the fitted grid and its diagnostics still hold; the old report
                // described the old evaluation
                tx.keep(|name| !RunFolder::written_by_eval(name) && !RunFolder::written_by_report(name))?;
            }
            tx.commit(false)?;
            print_eval(&r, &folder);
        }
        Command::Fit { scene, fit, shard: Some(shard) } => {
            let job = farm::FitJob { fit: fit.settings()?, options: WarpOptions::standard(), store: fit.store() };
            let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
            let path = farm::fit_shard(&scene, &folder, &job, shard, &progress)?;
            println!("fitted shard {shard} of {} → {}", scene.name, path.display());
        }
        Command::Merge { out, parts } => {
            let folder = RunFolder::new(out);
            let (merged, r) = farm::merge(&folder, &parts, &command, &progress)?;
            for (k, (host, s)) in r.shards.iter().enumerate() {
                println!("shard {k}/{}: {s:.1} s on {host}", r.shards.len());
            }
            println!(
                "merged {} {} shards of {} in {:.1} s; straggler ratio (slowest shard / median) {:.2}",
                r.shards.len(),
                r.kind.name(),
                r.scene,
                r.merge_seconds,
                r.straggler_ratio
            );
            match merged {
                farm::Merged::Bake(b) => println!(
                    "wrote the bake {} ({} active cells of {})",
                    folder.bake().display(),
                    b.grid.active_cells(),
                    b.grid.geometry.cell_count()
                ),
                farm::Merged::Fit(f) => print_fit(&FitLines::of(&f.0), &f.1, &folder),
            }
        }
        Command::Farm { target } => {
            let (args, submit) = match &target {
                FarmTarget::Slurm { farm, submit } => (farm, *submit),
                FarmTarget::K8s { farm, .. } => (farm, false),
            };
            anyhow::ensure!(args.shards >= 1, "--shards must be at least 1");
            args.fit.settings()?;
            let (scene, folder) = job::load_scene(&args.scene, args.out.as_deref())?;
            let abs = |p: &std::path::Path| std::path::absolute(p).with_context(|| format!("{}", p.display()));
            let job = cluster::FarmJob {
                binary: std::env::current_exe().context("locating the warpfit binary")?,
                scene: abs(&scene.source)?,
                folder: RunFolder::new(abs(&folder.dir)?),
                shards: args.shards,
                fit_flags: args.fit.flags(),
                cpus: args.cpus,
            };
            match &target {
                FarmTarget::Slurm { .. } => {
                    let paths = cluster::write_slurm(&job)?;
                    println!("wrote {} (and submit.sh)", job.folder.farm().display());
                    if submit {
                        let ids = cluster::submit_slurm(&paths).map_err(anyhow::Error::msg)?;
                        for (p, id) in paths.iter().zip(&ids) {
                            println!(
                                "submitted {}: job {id}",
                                p.file_name().map(|f| f.to_string_lossy()).unwrap_or_default()
                            );
                        }
                        println!(
                            "the fitted grid lands in {} when job {} completes",
                            job.folder.dir.display(),
                            ids.last().map_or("", String::as_str)
                        );
                    }
                }
                FarmTarget::K8s { image, volume, mount, .. } => {
                    let paths = cluster::write_k8s(&job, image, volume, mount)?;
                    println!(
                        "wrote {} manifests and run.sh into {}",
                        paths.len(),
                        job.folder.farm().join("k8s").display()
                    );
                }
            }
        }
        Command::Fit { scene, fit, shard: None } => {
            let settings = fit.settings()?;
            // a reused bake's hit counts stay on disk until the fit's cells stage reads them
            let (mut p, tx, folder) = prepare(&scene, bakefile::Hits::Later, &progress)?;
            let warp = p.baked().warp(WarpOptions::standard());
            let (f, manifest) =
                job::fit_staged(&mut p, &warp, &settings, fit.store(), MapSets::Stored, &command, &progress)?;
            let lines = FitLines::of(&f);
            // the written grid loads back before it is committed: without the fit, the
            // probe and the bake beside it (the peak of a big level's fit)
            drop((f, warp, p));
            tx.commit(true)?;
            print_fit(&lines, &manifest, &folder);
        }
        Command::Run { job: RunArgs { scene, eval, fit } } => {
            let settings = RunSettings { eval: eval.settings(), fit: fit.settings()?, store: fit.store() };
            // a reused bake's hit counts stay on disk until the fit's cells stage reads them
            let (mut p, tx, folder) = prepare(&scene, bakefile::Hits::Later, &progress)?;
            let outcome = job::run(&mut p, &settings, &command, &progress)?;
            tx.commit(true)?;
            print_fit(&FitLines::of(&outcome.fit), &outcome.manifest, &folder);
            print_eval(&outcome.eval, &folder);
            println!(
                "wrote {0}/report.json, report.md, report.html (open report.html: every table, plot and ꟻLIP map of this run)",
                folder.dir.display()
            );
        }
        Command::Export { fit, format: ExportFormat::Ktx2, out, read } => {
            let grid = FittedGrid::load(&fit)?.with_read(read);
            let surfaces = warpfit::runtime::load_surface_atlases(&fit)?;
            let _lock = files::staged::FolderLock::acquire(&out)?;
            let s = warpfit::export::export_with_surfaces(&grid, &surfaces, &out)?;
            let mut bytes = 0u64;
            for e in std::fs::read_dir(&out).with_context(|| format!("{}", out.display()))?.flatten() {
                bytes += e.metadata().map(|m| m.len()).unwrap_or(0);
            }
            println!(
                "exported {} → {}: probe ({} mips), irradiance and moments atlases ({}×{} tiles of {}², 1-texel gutters), {} corrective tiles{}, {} irradiance-scale tiles, {} surface-probe atlas(es), the reference shader ({}) and its buffers; {} in all (export.json describes them)",
                fit.display(),
                out.display(),
                s.probe_mips,
                s.irradiance.columns,
                s.irradiance.height / (s.irradiance.tile_resolution + 2),
                s.irradiance.tile_resolution,
                s.correctives.as_ref().map_or(0, |c| c.cell_tile.iter().filter(|t| **t >= 0).count()),
                if s.correctives.as_ref().is_some_and(|c| c.rough_tile_offset.is_some()) {
                    " (and as many rough-map tiles)"
                } else {
                    ""
                },
                s.irradiance_scale.as_ref().map_or(0, |c| c.cell_tile.iter().filter(|t| **t >= 0).count()),
                s.surfaces.len(),
                s.shader.sources.join(", "),
                files::human_bytes(bytes)
            );
        }
        Command::Roughness { out } => {
            let folder = RunFolder::new(out);
            let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
            let c = job::roughness(&folder)?;
            println!(
                "roughness correction: analytic α' = min(1, {:.4}·α·k^-{:.4}); held-out RMS error in α': table {:.5}, analytic {:.5} → {:?} (wrote {}/roughness.json, roughness.png)",
                c.c0,
                c.c1,
                c.heldout_rms_table,
                c.heldout_rms_analytic,
                c.chosen,
                folder.dir.display()
            );
        }
        Command::Sample { fit, pos, dir, roughness, normal, read } => {
            let grid = FittedGrid::load(&fit)?.with_read(read);
            let spec = grid.specular(pos, dir, roughness);
            let v = grid.fetch_vector(pos, dir.normalize_or_zero());
            let g = &grid.correctives().geometry;
            let cell = g.cell_index(g.cell_of(pos));
            let n = normal.unwrap_or(dir);
            let irr = grid.irradiance(pos, n);
            println!("specular {:.6} {:.6} {:.6}", spec.x, spec.y, spec.z);
            println!(
                "irradiance {:.6} {:.6} {:.6} (normal {:?})",
                irr.x,
                irr.y,
                irr.z,
                n.normalize_or_zero().to_array()
            );
            let stores = if grid.correctives().stores_map(cell) {
                "stores a shift map".to_string()
            } else {
                format!("uses the fallback {}", grid.correctives().fallback.name())
            };
            println!("fetch direction {:?}; cell {cell} {stores}", v.normalize_or_zero().to_array());
        }
        Command::Stability { quick, out } => {
            let mode = if quick { stability::Mode::Quick } else { stability::Mode::Full };
            let rows = stability::run(mode, |r| {
                println!(
                    "{} {:<38} {:>6.2} s  {}\n       expected: {}",
                    if r.pass { "pass" } else { "FAIL" },
                    r.case,
                    r.seconds,
                    r.measured,
                    r.expectation
                );
            });
            let folder = RunFolder::new(out);
            let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
            stability::write(&folder, &rows, mode, &command)?;
            let failed = rows.iter().filter(|r| !r.pass).count();
            println!("wrote {}/stability.json, stability.md", folder.dir.display());
            anyhow::ensure!(failed == 0, "{failed} of {} stability cases failed", rows.len());
            println!("all {} stability cases pass", rows.len());
        }
        Command::Report { out } => {
            let folder = RunFolder::new(out);
            let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
            let r = report::page::write_report(&folder, &command)?;
            println!(
                "wrote {0}/report.json, report.md, report.html ({1} methods, {2} images)",
                folder.dir.display(),
                r.methods.len(),
                r.images.len()
            );
        }
        Command::Sweep { job: RunArgs { scene, eval, fit } } => {
            let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
            let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
            let sw = sweep::sweep(&scene, &fit.settings()?, &eval.settings(), &folder, &command, &progress)?;
            println!(
                "| knob | value | fit s | ꟻLIP r 0 | ± 2 SE of its difference from the given settings | ꟻLIP r 0.5 | tone-mapped RMSE | rel RMSE | stored cells | payload bytes |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
            );
            for r in &sw.rows {
                println!(
                    "| {} | {} | {:.2} | {:.4} | {} | {:.4} | {:.4} | {:.4} | {} | {} |",
                    r.knob.name(),
                    r.value,
                    r.fit_seconds,
                    r.flip_r0,
                    r.flip_r0_se.map_or("–".to_string(), |se| format!("{:.4}", 2.0 * se)),
                    r.flip_r05,
                    r.tm_rmse,
                    r.rel_rmse,
                    r.stored_cells,
                    r.payload_bytes
                );
            }
            println!(
                "wrote {0}/sweep.json, sweep.png, sweep_convergence.png; `warpfit report --out {0}` includes them",
                folder.dir.display()
            );
        }
        Command::Inspect { fit } => {
            let grid = FittedGrid::load(&fit)?;
            print!("{}", grid.manifest().describe());
            println!("loaded in memory: {} bytes", grid.memory_bytes());
            for (k, a) in warpfit::runtime::load_surface_atlases(&fit)?.iter().enumerate() {
                let p = &a.patch;
                println!(
                    "surface{k}/: surface-probe atlas (seed 003), {}×{} probes of {}² texels, {} mips, on the patch {} + s·{} + t·{}; {} as RGBA16F",
                    p.counts[0],
                    p.counts[1],
                    p.resolution,
                    a.roughness.len(),
                    p.corner,
                    p.edge_u,
                    p.edge_v,
                    files::human_bytes(a.bytes())
                );
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    /// Every subcommand's arguments are consistent (no two flattened groups claim one flag):
    /// clap's own check, which otherwise fires only when a user runs the command.
    #[test]
    fn the_command_line_is_consistent() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }

    /// Each command parses with its defaults (two flattened groups claiming one argument
    /// pass clap's check above and fail only here, as they would for a user).
    #[test]
    fn every_command_parses_with_its_defaults() {
        use clap::Parser;
        for args in [
            &["run"][..],
            &["sweep"],
            &["fit"],
            &["fit", "--shard", "1/3", "--fit-reference-spp", "2"],
            &["eval", "--reference-spp", "8"],
            &["bake"],
            &["bake", "--shard", "0/2"],
            &["merge", "--out", "x", "a.part"],
            &["farm", "slurm", "--shards", "2"],
            &["farm", "k8s", "--shards", "2", "--image", "i"],
            &["export", "--out", "x"],
            &["check"],
            &["stability", "--quick"],
            &["inspect"],
            &["report"],
            &["roughness"],
            &["sample", "--pos", "0,1,0", "--dir", "1,0,0"],
        ] {
            let argv = std::iter::once("warpfit").chain(args.iter().copied());
            if let Err(e) = super::Cli::try_parse_from(argv) {
                panic!("warpfit {}: {e}", args.join(" "));
            }
        }
    }
}
