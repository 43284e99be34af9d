//! `warpfit`: the command line over the `warpfit` library (see `cli`).

mod cli;

use anyhow::{Context as _, Result};
use clap::Parser;
use cli::args::{Cli, Command, ExportFormat};
use cli::commands::{self as cmd, Context};
use warpfit::files;
use warpfit::progress::Progress;

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
    // every ray traced, kept per stream for measuring the tracer on them (trace::streams)
    let dump = warpfit::trace::streams::start_from_env();
    let result = run(cli);
    if let Some(dir) = dump {
        match warpfit::trace::streams::write(&dir) {
            Ok(streams) => {
                for (name, n) in streams {
                    eprintln!("{}: {n} rays", dir.join(name).display());
                }
            }
            Err(e) => eprintln!("error: writing the ray streams to {}: {e}", dir.display()),
        }
    }
    if let Err(e) = result {
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

/// Sets up the threads, then runs the command.
fn run(cli: Cli) -> Result<()> {
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build_global().context("setting up threads")?;
    }
    let cx = Context { progress: Progress { quiet: cli.quiet }, command: cmd::command_line() };
    match cli.command {
        Command::Check { scene } => cmd::check(&scene),
        Command::Init { mesh, cell_size } => cmd::init(&mesh, cell_size),
        Command::Bake { scene, shard: Some(shard) } => cmd::bake_shard(&scene, shard, &cx),
        Command::Bake { scene, shard: None } => cmd::bake(&scene, &cx),
        Command::Eval { scene, methods, eval } => cmd::eval(&scene, &methods, &eval, &cx),
        Command::Fit { scene, fit, shard: Some(shard) } => cmd::fit_shard(&scene, &fit, shard, &cx),
        Command::Fit { scene, fit, shard: None } => cmd::fit(&scene, &fit, &cx),
        Command::Merge { out, parts } => cmd::merge(out, &parts, &cx),
        Command::Farm { target } => cmd::farm(&target),
        Command::Run { job } => cmd::run(&job, &cx),
        Command::Export { fit, format: ExportFormat::Ktx2, out, read } => cmd::export(&fit, &out, read),
        Command::Roughness { out } => cmd::roughness(out),
        Command::Sample(s) => cmd::sample(&s),
        Command::Stability { quick, out } => cmd::stability(quick, out, &cx),
        Command::Report { out } => cmd::report(out, &cx),
        Command::Sweep { job } => cmd::sweep(&job, &cx),
        Command::Inspect { fit } => cmd::inspect(&fit),
        Command::Render { scene, render } => cmd::render(&scene, &render),
    }
}
