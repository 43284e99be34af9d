//! `warpfit` command line: parses arguments, calls the library, prints. No logic lives here.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use warpfit::{bake, format::bake_io, progress::Progress, scene::Scene, trace::Tracer};

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
}

fn main() {
    let cli = Cli::parse();
    let level = if cli.quiet { "warn" } else { "info" };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| level.into()),
        )
        .with_writer(std::io::stderr)
        .init();
    if let Err(e) = run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("setting up threads")?;
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
    }
    Ok(())
}
