//! One function per command: each loads what it needs, calls the library and prints.

use super::args::{EvalArgs, FarmTarget, FitArgs, RenderArgs, RunArgs, SampleArgs, SceneArgs, parse_methods};
use super::print::{FitLines, print_eval, print_fit};
use anyhow::{Context as _, Result};
use std::path::{Path, PathBuf};
use warpfit::bakefile;
use warpfit::files;
use warpfit::fit::MapSets;
use warpfit::jobs::run::{self as job, Output, RunSettings};
use warpfit::jobs::{cluster, farm, stability, sweep};
use warpfit::progress::Progress;
use warpfit::report::{self, folder::RunFolder};
use warpfit::runtime::{FittedGrid, SpecularRead};
use warpfit::warp::WarpOptions;

/// What every command may use: the progress display and the command line as typed (for
/// the provenance a run records).
pub struct Context {
    pub progress: Progress,
    pub command: String,
}

/// `warpfit check`: the scene checks, printed; an error when any fails.
pub fn check(scene: &Path) -> Result<()> {
    let scene = warpfit::scene::Scene::load(scene)?;
    let tracer = warpfit::trace::Tracer::new(&scene);
    let mut c = warpfit::jobs::check::check(&scene, &tracer);
    if c.ok() {
        c.facts.push(warpfit::jobs::check::bricks(&scene, &tracer));
    }
    println!("{}: {}", scene.source.display(), c.facts.join("; "));
    for w in &c.warnings {
        println!("warning: {w}");
    }
    for e in &c.errors {
        println!("error: {e}");
    }
    anyhow::ensure!(c.ok(), "{} error(s)", c.errors.len());
    println!("ok: {} warning(s)", c.warnings.len());
    Ok(())
}

/// `warpfit init`: a scene file for a level mesh, to standard output.
pub fn init(mesh: &Path, cell_size: Option<f32>) -> Result<()> {
    let i = warpfit::jobs::init::init(mesh, mesh, cell_size)?;
    for w in &i.warnings {
        tracing::warn!("{w}");
    }
    print!("{}", i.text);
    Ok(())
}

/// `warpfit bake --shard K/N`: one shard of the bake into the folder's parts.
pub fn bake_shard(scene: &SceneArgs, shard: farm::Shard, cx: &Context) -> Result<()> {
    let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
    check_scene(&scene)?;
    let path = farm::bake_shard(&scene, &folder, shard, &cx.progress)?;
    println!("baked shard {shard} of {} → {}", scene.name, path.display());
    Ok(())
}

/// `warpfit bake`: probe A and the probe grid, written into the run folder.
pub fn bake(scene: &SceneArgs, cx: &Context) -> Result<()> {
    let force = scene.force;
    let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
    check_scene(&scene)?;
    job::check_bake_estimate(&scene, force)?;
    tracing::info!("scene {}: {} triangles, {} spheres", scene.name, scene.triangles.len(), scene.spheres.len());
    let tracer = warpfit::trace::Tracer::new(&scene);
    let tx = job::Transaction::begin(&folder)?;
    let same_bake = warpfit::bakefile::manifest_key(&folder.bake()).as_deref() == Some(&scene.content_key());
    let baked = job::bake(&scene, &tracer, &tx.out, &cx.progress)?;
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
    Ok(())
}

/// `warpfit eval`: every method against references, on the folder's bake.
pub fn eval(scene: &SceneArgs, methods: &str, eval: &EvalArgs, cx: &Context) -> Result<()> {
    let methods = parse_methods(methods)?;
    // the evaluation never reads the grid's hit counts: a reused bake's stay on disk
    let (p, tx, folder) = prepare(scene, bakefile::Hits::Later, &cx.progress)?;
    let settings = eval.settings();
    let warp = p.baked().warp(settings.options);
    let out = Output { folder: &p.folder, command: &cx.command, progress: &cx.progress };
    let r = job::evaluate(p.baked(), &warp, &settings, &methods, None, out)?;
    if !p.baked_now {
        // same bake: the fitted grid and its diagnostics still hold; the old report
        // described the old evaluation
        tx.keep(|name| !RunFolder::written_by_eval(name) && !RunFolder::written_by_report(name))?;
    }
    tx.commit(false)?;
    print_eval(&r, &folder);
    Ok(())
}

/// `warpfit fit --shard K/N`: one shard of the fit, on the folder's bake.
pub fn fit_shard(scene: &SceneArgs, fit: &FitArgs, shard: farm::Shard, cx: &Context) -> Result<()> {
    let job = farm::FitJob { fit: fit.settings()?, options: WarpOptions::standard(), store: fit.store() };
    let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
    let path = farm::fit_shard(&scene, &folder, &job, shard, &cx.progress)?;
    println!("fitted shard {shard} of {} → {}", scene.name, path.display());
    Ok(())
}

/// `warpfit merge`: a sharded job's parts, merged into the bake or the fitted grid.
pub fn merge(out: PathBuf, parts: &[PathBuf], cx: &Context) -> Result<()> {
    let folder = RunFolder::new(out);
    let (merged, r) = farm::merge(&folder, parts, &cx.command, &cx.progress)?;
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
    Ok(())
}

/// `warpfit farm slurm|k8s`: cluster jobs for a sharded bake and fit.
pub fn farm(target: &FarmTarget) -> Result<()> {
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
                    println!("submitted {}: job {id}", p.file_name().map(|f| f.to_string_lossy()).unwrap_or_default());
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
            println!("wrote {} manifests and run.sh into {}", paths.len(), job.folder.farm().join("k8s").display());
        }
    }
    Ok(())
}

/// `warpfit fit`: the fitted grid, written into the run folder.
pub fn fit(scene: &SceneArgs, fit: &FitArgs, cx: &Context) -> Result<()> {
    let settings = fit.settings()?;
    // a reused bake's hit counts stay on disk until the fit's cells stage reads them
    let (mut p, tx, folder) = prepare(scene, bakefile::Hits::Later, &cx.progress)?;
    let warp = p.baked().warp(WarpOptions::standard());
    let (f, manifest) =
        job::fit_staged(&mut p, &warp, &settings, fit.store(), MapSets::Stored, &cx.command, &cx.progress)?;
    let lines = FitLines::of(&f);
    // the written grid loads back before it is committed: without the fit, the
    // probe and the bake beside it (the peak of a big level's fit)
    drop((f, warp, p));
    tx.commit(true)?;
    print_fit(&lines, &manifest, &folder);
    Ok(())
}

/// `warpfit run`: bake (or reuse), fit, evaluate and report.
pub fn run(RunArgs { scene, eval, fit }: &RunArgs, cx: &Context) -> Result<()> {
    let settings = RunSettings { eval: eval.settings(), fit: fit.settings()?, store: fit.store() };
    // a reused bake's hit counts stay on disk until the fit's cells stage reads them
    let (mut p, tx, folder) = prepare(scene, bakefile::Hits::Later, &cx.progress)?;
    let outcome = job::run(&mut p, &settings, &cx.command, &cx.progress)?;
    tx.commit(true)?;
    print_fit(&FitLines::of(&outcome.fit), &outcome.manifest, &folder);
    print_eval(&outcome.eval, &folder);
    println!(
        "wrote {0}/report.json, report.md, report.html (open report.html: the verdict, the pictures, then every table)",
        folder.dir.display()
    );
    let verdict = warpfit::report::verdict(&outcome.eval);
    if !verdict.is_empty() {
        println!(
            "\nverdict: the fitted grid against its best rival at each roughness (the best classic method costing ≤ 2× warp1, or with several probes their per-cell blend):"
        );
        for line in verdict {
            println!("{line}");
        }
    }
    Ok(())
}

/// `warpfit export`: a fitted grid as KTX2 textures, buffers and the shader.
pub fn export(fit: &Path, out: &Path, read: SpecularRead) -> Result<()> {
    let grid = FittedGrid::load(fit)?.with_read(read);
    let surfaces = warpfit::runtime::load_surface_atlases(fit)?;
    let _lock = files::staged::FolderLock::acquire(out)?;
    let s = warpfit::export::export_with_surfaces(&grid, &surfaces, out)?;
    let mut bytes = 0u64;
    for e in std::fs::read_dir(out).with_context(|| format!("{}", out.display()))?.flatten() {
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
    Ok(())
}

/// `warpfit roughness`: the GGX roughness correction fitted alone.
pub fn roughness(out: PathBuf) -> Result<()> {
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
    Ok(())
}

/// `warpfit sample`: one lookup of a fitted grid, printed.
pub fn sample(s: &SampleArgs) -> Result<()> {
    let SampleArgs { fit, pos, dir, roughness, normal, read } = s;
    let (pos, dir, roughness, read) = (*pos, *dir, *roughness, *read);
    let grid = FittedGrid::load(fit)?.with_read(read);
    let spec = grid.specular(pos, dir, roughness);
    let v = grid.fetch_vector(pos, dir.normalize_or_zero());
    let g = &grid.correctives().geometry;
    let cell = g.cell_index(g.cell_of(pos));
    let n = normal.unwrap_or(dir);
    let irr = grid.irradiance(pos, n);
    println!("specular {:.6} {:.6} {:.6}", spec.x, spec.y, spec.z);
    println!("irradiance {:.6} {:.6} {:.6} (normal {:?})", irr.x, irr.y, irr.z, n.normalize_or_zero().to_array());
    let stores = if grid.correctives().stores_map(cell) {
        "stores a shift map".to_string()
    } else {
        format!("uses the fallback {}", grid.correctives().fallback.name())
    };
    println!("fetch direction {:?}; cell {cell} {stores}", v.normalize_or_zero().to_array());
    Ok(())
}

/// `warpfit stability`: the stiff and extreme cases; an error when any fails.
pub fn stability(quick: bool, out: PathBuf, cx: &Context) -> Result<()> {
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
    stability::write(&folder, &rows, mode, &cx.command)?;
    let failed = rows.iter().filter(|r| !r.pass).count();
    println!("wrote {}/stability.json, stability.md", folder.dir.display());
    anyhow::ensure!(failed == 0, "{failed} of {} stability cases failed", rows.len());
    println!("all {} stability cases pass", rows.len());
    Ok(())
}

/// `warpfit report`: report.json, .md and .html rebuilt from a run folder.
pub fn report(out: PathBuf, cx: &Context) -> Result<()> {
    let folder = RunFolder::new(out);
    let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
    let r = report::page::write_report(&folder, &cx.command)?;
    println!(
        "wrote {0}/report.json, report.md, report.html ({1} methods, {2} images)",
        folder.dir.display(),
        r.methods.len(),
        r.images.len()
    );
    Ok(())
}

/// `warpfit sweep`: the fit refitted one knob at a time, printed and written.
pub fn sweep(RunArgs { scene, eval, fit }: &RunArgs, cx: &Context) -> Result<()> {
    let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
    let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
    let sw = sweep::sweep(&scene, &fit.settings()?, &eval.settings(), &folder, &cx.command, &cx.progress)?;
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
    Ok(())
}

/// `warpfit inspect`: a summary of a fitted grid.
/// `warpfit render`: the fitted grid in the run folder exported, and the level's frames
/// drawn through the export's shader, judged and written to `<out>/render/`.
pub fn render(scene: &SceneArgs, args: &RenderArgs) -> Result<()> {
    let opts = args.options()?;
    let (scene, folder) = job::load_scene(&scene.scene, scene.out.as_deref())?;
    let _lock = files::staged::FolderLock::acquire(&folder.dir)?;
    let grid = FittedGrid::load(&folder.dir).with_context(|| {
        format!(
            "no fitted grid to draw in {}: run `warpfit fit --scene {}` first",
            folder.dir.display(),
            scene.source.display()
        )
    })?;
    let tracer = warpfit::trace::Tracer::new(&scene);
    let out = warpfit::render::frames::folder(&folder.dir);
    let export = out.join("export");
    warpfit::export::export(&grid, &export)?;
    let r = warpfit::render::frames::render((&scene, &tracer), &grid, &export, &out, &opts)?;
    print!("{}", warpfit::render::frames::markdown(&r));
    println!(
        "wrote {0}/render.json, render.md and {1} PNG strips; the export drawn from is {0}/export",
        out.display(),
        r.frames.len()
    );
    // a run's report shows the frames first: written again with them, under the command
    // that made it
    if folder.eval_json().is_file() && folder.report_json().is_file() {
        let made_by = std::fs::read(folder.report_json())
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .and_then(|v| v["command"].as_str().map(str::to_string))
            .unwrap_or_else(command_line);
        report::page::write_report(&folder, &made_by)?;
        println!("wrote {}/report.html again, the frames first", folder.dir.display());
    }
    Ok(())
}

pub fn inspect(fit: &Path) -> Result<()> {
    let grid = FittedGrid::load(fit)?;
    print!("{}", grid.manifest().describe());
    println!("loaded in memory: {} bytes", grid.memory_bytes());
    for (k, a) in warpfit::runtime::load_surface_atlases(fit)?.iter().enumerate() {
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
    Ok(())
}

pub fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!("warpfit {}", args.join(" "))
}

/// Opens a transaction on the scene's run folder and prepares the scene and its bake
/// (reused from the folder or fresh) in it, saying which; `hits`: when a reused bake's hit
/// counts are read.
pub fn prepare(
    args: &SceneArgs,
    hits: bakefile::Hits,
    progress: &Progress,
) -> Result<(job::Prepared, job::Transaction, RunFolder)> {
    let (scene, folder) = job::load_scene(&args.scene, args.out.as_deref())?;
    check_scene(&scene)?;
    job::check_bake_estimate(&scene, args.force)?;
    let tx = job::Transaction::begin(&folder)?;
    let mut p = job::prepare_from(scene, &tx.previous, tx.out.clone(), hits, progress)?;
    if args.force {
        p.references.retrace();
    }
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
pub fn check_scene(scene: &warpfit::scene::Scene) -> Result<()> {
    let tracer = warpfit::trace::Tracer::new(scene);
    let c = warpfit::jobs::check::check(scene, &tracer);
    for w in &c.warnings {
        tracing::warn!("{w}");
    }
    anyhow::ensure!(c.ok(), "the scene check failed:\n  {}", c.errors.join("\n  "));
    Ok(())
}
