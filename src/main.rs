//! `warpfit` command line: parses arguments, calls the library, prints. No logic lives here.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use warpfit::eval::EvalSettings;
use warpfit::fit::{Blend, FitSettings, Solver};
use warpfit::warp::{Method, WarpOptions};
use warpfit::{bake, format::bake_io, pipeline, progress::Progress, report, scene::Scene, trace::Tracer};

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
    /// Raytrace the scene and write the specular probe, the probe grid and previews.
    Bake {
        /// Scene file (TOML).
        #[arg(long, default_value = "data/scenes/torture.toml")]
        scene: PathBuf,
        /// Output folder (default: fits/<scene name>).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Measure every warp method against raytraced references on held-out positions and
    /// directions; writes eval.json, eval.md and an error-against-cost plot.
    Eval {
        #[arg(long, default_value = "data/scenes/torture.toml")]
        scene: PathBuf,
        /// Bake folder to reuse (baked there first if missing or stale) and where reports go.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Comma-separated methods, or "all".
        #[arg(long, default_value = "all")]
        methods: String,
        #[command(flatten)]
        eval: EvalArgs,
    },
    /// Fit per-cell correctives (baking first if needed) and write the fit files.
    Fit {
        #[arg(long, default_value = "data/scenes/torture.toml")]
        scene: PathBuf,
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        fit: FitArgs,
    },
    /// Fit the GGX distance-ratio roughness correction (seed 002) and write
    /// roughness.json and roughness.png.
    Roughness {
        #[arg(long, default_value = "fits/roughness")]
        out: PathBuf,
    },
    /// The main job: bake (or reuse a matching bake), fit, evaluate every method including
    /// the fitted correctives, and report; on the default scene unless one is given.
    Run {
        #[arg(long, default_value = "data/scenes/torture.toml")]
        scene: PathBuf,
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        eval: EvalArgs,
        #[command(flatten)]
        fit: FitArgs,
    },
}

#[derive(clap::Args)]
struct FitArgs {
    /// N of each cell's N×N warp map (8..=16).
    #[arg(long, default_value_t = 8)]
    map_res: u32,
    /// Relative error at or below which a cell keeps the plain warp.
    #[arg(long, default_value_t = 0.02)]
    tol: f32,
    /// Solver refining the warp maps.
    #[arg(long, value_enum, default_value_t = Solver::Brent)]
    solver: Solver,
    /// Sweeps (Brent) or iteration budget multiplier (L-BFGS, Nelder-Mead).
    #[arg(long, default_value_t = 2)]
    iterations: u32,
    /// Training positions per cell.
    #[arg(long, default_value_t = 16)]
    train_positions: u32,
    /// Training directions per position.
    #[arg(long, default_value_t = 128)]
    train_dirs: u32,
}

impl FitArgs {
    fn settings(&self) -> Result<FitSettings> {
        anyhow::ensure!(
            (8..=16).contains(&self.map_res) && self.map_res.is_power_of_two(),
            "--map-res must be 8 or 16"
        );
        Ok(FitSettings {
            map_res: self.map_res,
            tol: self.tol.max(0.0),
            solver: self.solver,
            iterations: self.iterations.max(1),
            train_positions: self.train_positions.max(1),
            train_dirs: self.train_dirs.max(1),
            ..FitSettings::default()
        })
    }
}

#[derive(clap::Args)]
struct EvalArgs {
    /// Validation positions.
    #[arg(long, default_value_t = 256)]
    positions: u32,
    /// Validation directions per position.
    #[arg(long, default_value_t = 256)]
    dirs: u32,
    /// Samples per reference ray.
    #[arg(long, default_value_t = 16)]
    reference_spp: u32,
    /// Depth mip the depth-based warps read.
    #[arg(long, default_value_t = 2.0)]
    depth_mip: f32,
    /// UV relaxation radius in probe texels (0 = off).
    #[arg(long, default_value_t = 0.0)]
    relax: f32,
    /// Seed of the validation set.
    #[arg(long, default_value_t = 0xE7A1)]
    eval_seed: u64,
}

impl EvalArgs {
    fn settings(&self) -> EvalSettings {
        EvalSettings {
            positions: self.positions.max(1),
            dirs_per_position: self.dirs.max(1),
            reference_spp: self.reference_spp.max(1),
            seed: self.eval_seed,
            options: WarpOptions { depth_lod: self.depth_mip, relax_texels: self.relax, ..WarpOptions::default() },
            ..EvalSettings::default()
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

fn fit_and_print(
    baked: pipeline::Baked,
    settings: &FitSettings,
    out: &std::path::Path,
    progress: &Progress,
) -> Result<warpfit::fit::Fit> {
    let f = pipeline::fit(baked, settings, out, &command_line(), progress)?;
    let s = warpfit::fit::output::summary(&f);
    println!(
        "fitted {} active cells in {:.1} s ({} threads): {} store a warp map ({} bytes), {} use the fallback {} ({} after a failed fit); held-out relative error warp1 {:.4}, fallback {:.4}, celldepth {:.4}, stored {:.4}",
        s.active_cells,
        s.fit_seconds,
        rayon::current_num_threads(),
        s.cells_level2,
        s.bytes_level2,
        s.cells_level0,
        s.fallback_method,
        s.fallbacks,
        s.mean_check_err_warp1,
        s.mean_check_err_fallback,
        s.mean_check_err_celldepth,
        s.mean_check_err_stored
    );
    Ok(f)
}

fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!("warpfit {}", args.join(" "))
}

fn eval_and_print(
    scene_path: &std::path::Path,
    out: Option<PathBuf>,
    methods: &[Method],
    args: &EvalArgs,
    fit_settings: Option<FitSettings>,
    progress: &Progress,
) -> Result<()> {
    let scene = Scene::load(scene_path)?;
    let out = out.unwrap_or_else(|| PathBuf::from("fits").join(&scene.name));
    let tracer = Tracer::new(&scene);
    let (probe, grid, fresh) = pipeline::load_or_bake(&scene, &tracer, &out, progress)?;
    if fresh {
        println!("baked {} → {}", scene.name, out.display());
    }
    let baked = pipeline::Baked { scene: &scene, tracer: &tracer, probe: &probe, grid: &grid };
    let fitted = match &fit_settings {
        Some(f) => Some(fit_and_print(baked, f, &out, progress)?),
        None => None,
    };
    let rows: Vec<pipeline::CorrectiveRow> = match &fitted {
        Some(f) => vec![
            pipeline::CorrectiveRow {
                name: "celldepth",
                note: "unfitted warp maps from the grid's raytraced distances, containing cell",
                correctives: &f.celldepth,
                blend: Blend::Cell,
            },
            pipeline::CorrectiveRow {
                name: "fitted",
                note: "fitted warp maps (levels as stored), containing cell",
                correctives: &f.correctives,
                blend: Blend::Cell,
            },
            pipeline::CorrectiveRow {
                name: "fitted-L2-all",
                note: "level 2 in every active cell (fitted maps before model selection), containing cell",
                correctives: &f.fitted_all,
                blend: Blend::Cell,
            },
            pipeline::CorrectiveRow {
                name: "fitted-trilinear",
                note: "fitted warp maps (levels as stored), trilinear blend of 8 cells",
                correctives: &f.correctives,
                blend: Blend::Trilinear,
            },
        ],
        None => Vec::new(),
    };
    let r = pipeline::evaluate(baked, &args.settings(), methods, &rows, &out, &command_line(), progress)?;
    println!(
        "{}: {} lookups at {} positions, hidden fraction {:.1}%, reference ray {:.0} ns",
        r.scene,
        r.lookups,
        r.positions,
        100.0 * r.hidden_fraction,
        r.reference_ns_per_ray
    );
    print!("{}", report::methods_table(&r));
    println!("wrote {}/eval.json, eval.md, eval_error_vs_cost.png", out.display());
    Ok(())
}

fn main() {
    let cli = Cli::parse();
    let level = if cli.quiet { "warn" } else { "info" };
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| level.into()))
        .with_writer(std::io::stderr)
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
    match cli.command {
        Command::Bake { scene, out } => {
            let scene = Scene::load(&scene)?;
            let out = out.unwrap_or_else(|| PathBuf::from("fits").join(&scene.name));
            tracing::info!(
                "scene {}: {} triangles, {} spheres",
                scene.name,
                scene.triangles.len(),
                scene.spheres.len()
            );
            let tracer = Tracer::new(&scene);
            let baked = bake::bake(&scene, &tracer, &progress);
            bake_io::write_bake(&out, &scene, &baked)?;
            let s = &baked.stats;
            println!(
                "baked {} → {}: probe {}² ({} mips), grid {:?} ({} active cells), {:.2} Mrays in {:.2} s ({:.2} Mrays/s, {} threads)",
                scene.name,
                out.display(),
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
        Command::Eval { scene, out, methods, eval } => {
            let methods = parse_methods(&methods)?;
            eval_and_print(&scene, out, &methods, &eval, None, &progress)?;
        }
        Command::Fit { scene, out, fit } => {
            let settings = fit.settings()?;
            let scene = Scene::load(&scene)?;
            let out = out.unwrap_or_else(|| PathBuf::from("fits").join(&scene.name));
            let tracer = Tracer::new(&scene);
            let (probe, grid, _) = pipeline::load_or_bake(&scene, &tracer, &out, &progress)?;
            let baked = pipeline::Baked { scene: &scene, tracer: &tracer, probe: &probe, grid: &grid };
            fit_and_print(baked, &settings, &out, &progress)?;
        }
        Command::Roughness { out } => {
            let c = warpfit::roughness::fit_correction();
            warpfit::roughness::write_report(&out, &c)?;
            println!(
                "roughness correction: analytic α' = min(1, {:.4}·α·k^-{:.4}); held-out RMS error in α': table {:.5}, analytic {:.5} → {} (wrote {}/roughness.json, roughness.png)",
                c.c0,
                c.c1,
                c.heldout_rms_table,
                c.heldout_rms_analytic,
                c.chosen,
                out.display()
            );
        }
        Command::Run { scene, out, eval, fit } => {
            eval_and_print(&scene, out, &Method::ALL, &eval, Some(fit.settings()?), &progress)?;
        }
    }
    Ok(())
}
