//! The command line's argument types (clap) and their conversion into the library's
//! settings: what a user can type, nothing that runs.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use warpfit::eval::{EvalSettings, RenderSettings};
use warpfit::fit::{FitSettings, Solver};
use warpfit::jobs::farm;
use warpfit::jobs::run::StoreOptions;
use warpfit::runtime::Precision;
use warpfit::warp::corrective::Blend;
use warpfit::warp::{Method, WarpOptions};

/// Offline parallax correction for reflection probes.
#[derive(Parser)]
#[command(name = "warpfit", version, about)]
pub struct Cli {
    /// No progress bars and only warnings in the log.
    #[arg(long, global = true)]
    pub quiet: bool,
    /// Worker threads (default: all cores). Results are identical at any count.
    #[arg(long, global = true)]
    pub threads: Option<usize>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
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
        /// Grid cell size in scene units (grown if the grid would exceed 20,000 cells);
        /// without it, half the typical distance from an open point to the walls, rounded.
        #[arg(long)]
        cell_size: Option<f32>,
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
    Sample(SampleArgs),
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
    /// Draw frames of the level the way an engine does: its triangles rasterised with wgpu
    /// and every pixel shaded by the exported WGSL over the fitted grid in <out>, each beside
    /// a traced reference, box projection and the CPU sampler's frame, with ꟻLIP; writes
    /// <out>/render/ (PNG strips, render.json, render.md, the export drawn from).
    Render {
        #[command(flatten)]
        scene: SceneArgs,
        #[command(flatten)]
        render: RenderArgs,
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
pub enum FarmTarget {
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
pub struct FarmArgs {
    /// Scene file (TOML).
    #[arg(long, default_value = "data/scenes/torture.toml")]
    pub scene: PathBuf,
    /// Run folder (default: fits/<scene name>), on storage every node sees.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Shards of the bake and of the fit.
    #[arg(long)]
    pub shards: u32,
    /// Threads (CPUs) per shard.
    #[arg(long, default_value_t = 2)]
    pub cpus: u32,
    #[command(flatten)]
    pub fit: FitArgs,
}

/// The scene and the run folder.
#[derive(clap::Args)]
pub struct SceneArgs {
    /// Scene file (TOML).
    #[arg(long, default_value = "data/scenes/torture.toml")]
    pub scene: PathBuf,
    /// Output folder (default: fits/<scene name>); a matching bake there is reused.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Bake even when the estimate exceeds the machine's available memory, and trace every
    /// reference again instead of reading it back from beside the bake.
    #[arg(long)]
    pub force: bool,
}

/// What `warpfit render` draws.
#[derive(clap::Args)]
pub struct RenderArgs {
    /// Frame width and height in pixels.
    #[arg(long, default_value = "320x200", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Comma-separated roughness of the specular frames.
    #[arg(long, default_value = "0,0.5", value_delimiter = ',')]
    pub roughness: Vec<f32>,
    /// No diffuse frames (irradiance × base colour / π).
    #[arg(long)]
    pub no_diffuse: bool,
    /// Cameras placed when the scene sets no [[cameras]].
    #[arg(long, default_value_t = 2)]
    pub cameras: u32,
    /// Samples per reference pixel.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
}

impl RenderArgs {
    /// The options, checked: roughness in [0, 1], at least one sample.
    pub fn options(&self) -> anyhow::Result<warpfit::render::frames::RenderOptions> {
        if let Some(r) = self.roughness.iter().find(|r| !(0.0..=1.0).contains(*r)) {
            anyhow::bail!("--roughness {r}: every roughness must lie in [0, 1]");
        }
        if self.spp == 0 {
            anyhow::bail!("--spp 0: a reference needs at least one sample per pixel");
        }
        Ok(warpfit::render::frames::RenderOptions {
            size: self.size,
            cameras: self.cameras,
            roughness: self.roughness.clone(),
            diffuse: !self.no_diffuse,
            spp: self.spp,
            ..Default::default()
        })
    }
}

/// `WxH`, each between 1 and 4096 pixels.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once('x').ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 320x200"))?;
    let side = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=4096).contains(&n) => Ok(n),
        _ => Err(format!("{s:?}: each side must be a whole number of pixels from 1 to 4096")),
    };
    Ok((side(w)?, side(h)?))
}

/// A whole job: scene, output folder, fit and eval settings. Shared by `run` and `sweep`.
#[derive(clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub eval: EvalArgs,
    #[command(flatten)]
    pub fit: FitArgs,
}

#[derive(clap::Args)]
pub struct FitArgs {
    /// N of each cell's N×N shift map (8..=16).
    #[arg(long, default_value_t = FitSettings::standard().map_res)]
    pub map_res: u32,
    /// Relative error at or below which a cell keeps the plain warp.
    #[arg(long, default_value_t = FitSettings::standard().tol)]
    pub tol: f32,
    /// Solver refining the shift maps.
    #[arg(long, value_enum, default_value_t = FitSettings::standard().solver)]
    pub solver: Solver,
    /// Sweeps (Brent) or iteration budget multiplier (L-BFGS, Nelder-Mead).
    #[arg(long, default_value_t = FitSettings::standard().iterations)]
    pub iterations: u32,
    /// Training positions per cell.
    #[arg(long, default_value_t = FitSettings::standard().train_positions)]
    pub train_positions: u32,
    /// Training directions per position.
    #[arg(long, default_value_t = FitSettings::standard().train_dirs)]
    pub train_dirs: u32,
    /// Held-out check positions per cell (model selection).
    #[arg(long, default_value_t = FitSettings::standard().check_positions)]
    pub check_positions: u32,
    /// Check directions per position.
    #[arg(long, default_value_t = FitSettings::standard().check_dirs)]
    pub check_dirs: u32,
    /// Check positions a cell adds when its first ones cannot tell its fitted maps from the
    /// proxy alone (their per-position difference within two standard errors of 0); 0: never.
    #[arg(long, default_value_t = FitSettings::standard().extra_check_positions)]
    pub extra_check_positions: u32,
    /// Samples per training and check reference (`--reference-spp` is the evaluation's).
    #[arg(long, default_value_t = FitSettings::standard().reference_spp)]
    pub fit_reference_spp: u32,
    /// Charbonnier ε of the fit's loss as a fraction of a cell's mean reference radiance.
    #[arg(long, default_value_t = FitSettings::standard().robust_scale)]
    pub robust_scale: f64,
    /// Storage of the radiance layers of the fitted grid (distances and shift maps are f32).
    #[arg(long, value_enum, default_value = "f32")]
    pub precision: PrecisionArg,
    /// How a lookup combines neighbouring cells: `cell` reads the containing cell alone;
    /// `faces` blends the lookups of the near cells it links to (not through walls) across
    /// the last eighth of a cell before each face, so far fewer cell-sized tiles show, for
    /// about twice a lookup's cost (format version 7).
    #[arg(long, value_enum, default_value = "cell")]
    pub blend: BlendArg,
    /// Leave the GGX roughness correction out of the fitted grid.
    #[arg(long)]
    pub no_roughness: bool,
    /// Also fit every cell's level-1 corrective (origin offset, depth mip, relaxation) and
    /// report its held-out error beside the stored model's in fit.md (not stored).
    #[arg(long)]
    level1: bool,
    /// Also fit every cell's map at 4², 8², 16² and 32² texels and report in fit.md what a
    /// per-cell choice of resolution would give, judged by two-fold cross-validation over
    /// each cell's check positions (not stored).
    #[arg(long)]
    pub resolution_study: bool,
    /// A cell stores its map only when the map's held-out error is below this fraction of
    /// the fallback's (at most 1).
    #[arg(long, default_value_t = FitSettings::standard().selection_margin)]
    pub selection_margin: f64,
    /// Weight of the pull of every map towards its anchor (mean squared log-scale of the
    /// shifted distance over the anchor's).
    #[arg(long, default_value_t = FitSettings::standard().size_weight)]
    pub size_weight: f64,
    /// Fraction of each cell's training and check queries that are rough lookups (the rest
    /// mirror lookups), in [0, 1].
    #[arg(long, default_value_t = FitSettings::standard().rough_fraction)]
    pub rough_fraction: f32,
    /// Where the maps' anchor lies: this fraction of the way (in log-scale) from the proxy
    /// (0) to the grid's raytraced distances (1).
    #[arg(long, default_value_t = FitSettings::standard().depth_prior)]
    pub depth_prior: f64,
    /// Weight of the aim pull: each mirror training query's aim drawn towards its true hit
    /// where the probe it reads sees it (≥ 0; 0: the pointwise error alone).
    #[arg(long, default_value_t = FitSettings::standard().aim_pull)]
    pub aim_pull: f64,
    /// Store one map per cell for every roughness, as version-4 grids did, instead of a
    /// map and a rough map.
    #[arg(long)]
    pub one_map: bool,
    /// Where the rough maps' anchor lies (as --depth-prior).
    #[arg(long, default_value_t = FitSettings::standard().rough_depth_prior)]
    pub rough_depth_prior: f64,
    /// Fraction of each cell's training and check positions on the surfaces around it
    /// (reflection directions), the rest in its volume (in [0, 1]).
    #[arg(long, default_value_t = FitSettings::standard().surface_fraction)]
    pub surface_fraction: f32,
    /// The proxy the maps shift: measured (the cheapest of box, kdop and warp1 within 5% of
    /// the best), or one of them.
    #[arg(long, value_enum, default_value = "measured")]
    pub proxy: warpfit::fit::proxy::ProxyChoice,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ExportFormat {
    Ktx2,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum BlendArg {
    Cell,
    Faces,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PrecisionArg {
    F32,
    F16,
}

impl FitArgs {
    pub fn store(&self) -> StoreOptions {
        let precision = match self.precision {
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F16 => Precision::F16,
        };
        let blend = match self.blend {
            BlendArg::Cell => Blend::Cell,
            BlendArg::Faces => Blend::Faces,
        };
        StoreOptions { precision, roughness: !self.no_roughness, blend }
    }

    /// The flags that give these settings to `warpfit fit` (for farm jobs).
    pub fn flags(&self) -> Vec<String> {
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
            format!("--blend={}", name(self.blend.to_possible_value())),
            format!("--selection-margin={}", self.selection_margin),
            format!("--size-weight={}", self.size_weight),
            format!("--depth-prior={}", self.depth_prior),
            format!("--aim-pull={}", self.aim_pull),
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

    pub fn settings(&self) -> Result<FitSettings> {
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
        anyhow::ensure!(self.aim_pull.is_finite() && self.aim_pull >= 0.0, "--aim-pull must be ≥ 0");
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
            aim_pull: self.aim_pull,
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
pub struct EvalArgs {
    /// Validation positions.
    #[arg(long, default_value_t = EvalSettings::standard().positions)]
    pub positions: u32,
    /// Validation directions per position.
    #[arg(long, default_value_t = EvalSettings::standard().dirs_per_position)]
    pub dirs: u32,
    /// Samples per reference ray.
    #[arg(long, default_value_t = EvalSettings::standard().reference_spp)]
    pub reference_spp: u32,
    /// Lobe samples per rough (r > 0) reference: heavier references for quieter rough
    /// buckets (eval.md says per bucket whether their noise is under a quarter of the
    /// difference it reports).
    #[arg(long, default_value_t = EvalSettings::standard().rough_reference_spp)]
    pub rough_reference_spp: u32,
    /// A rough bucket whose references' noise exceeds a quarter of the difference it
    /// reports is traced again with twice the samples, up to this many per reference
    /// (at or below --rough-reference-spp: never).
    #[arg(long, default_value_t = EvalSettings::standard().rough_reference_spp_max)]
    pub rough_reference_spp_max: u32,
    /// Lobe samples per pixel of the rendered views' references (the views behind each
    /// row's ꟻLIP; eval.md states the ꟻLIP their own noise scores).
    #[arg(long, default_value_t = RenderSettings::standard().reference_spp)]
    pub view_reference_spp: u32,
    /// Depth mip the depth-based warps read.
    #[arg(long, default_value_t = WarpOptions::standard().depth_lod)]
    pub depth_mip: f32,
    /// UV relaxation radius in probe texels (0 = off).
    #[arg(long, default_value_t = WarpOptions::standard().relax_texels)]
    pub relax: f32,
    /// Seed of the validation set.
    #[arg(long, default_value_t = EvalSettings::standard().seed)]
    pub eval_seed: u64,
}

impl EvalArgs {
    pub fn settings(&self) -> EvalSettings {
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

pub fn parse_methods(list: &str) -> Result<Vec<Method>> {
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

pub fn parse_vec3(text: &str) -> std::result::Result<glam::Vec3, String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(glam::Vec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers x,y,z, got {text:?}")),
    }
}

/// One lookup of a fitted grid (`warpfit sample`).
#[derive(clap::Args)]
pub struct SampleArgs {
    #[arg(long, default_value = "fits/torture")]
    pub fit: PathBuf,
    /// Shading position x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub pos: glam::Vec3,
    /// Reflected direction x,y,z (need not be unit length).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub dir: glam::Vec3,
    /// Perceptual roughness in [0, 1].
    #[arg(long, default_value_t = 0.0)]
    pub roughness: f32,
    /// Surface normal x,y,z for the irradiance (default: the direction).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub normal: Option<glam::Vec3>,
    /// What a rough lookup reads: "blended" (probe A and the cells' irradiance, the
    /// lowest error) or "probe-only" (probe A alone, cheaper).
    #[arg(long, default_value = "blended")]
    pub read: warpfit::runtime::SpecularRead,
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
