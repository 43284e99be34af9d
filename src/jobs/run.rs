//! The main job, `warpfit run`, and the stages it chains, each callable alone (`bake`, `fit`,
//! `eval`): bake the scene or reuse a matching bake, fit the correctives and write the fitted
//! grid with its diagnostics, evaluate every method (the fitted grid as loaded back from
//! disk among them), and write the run report.

use super::JobError;
pub use crate::bake::Baked;
use crate::bake::{self, Bake, ProbeGrid, SpecularProbe};
use crate::bakefile;
use crate::eval::{self, CorrectiveRow, CorrectiveVariant, EvalReport, EvalSettings};
use crate::files::FileError;
use crate::fit::MapSets;
use crate::fit::{Fit, FitSettings};
use crate::gridfile::write::{GridContents, IrradianceSource, ProbeData, Provenance};
use crate::gridfile::{GridManifest, Precision};
use crate::progress::Progress;
use crate::report::{self, folder::RunFolder};
use crate::runtime::FittedGrid;
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::trace::store::ReferenceStore;
use crate::warp::corrective::Blend;
use crate::warp::glossy::Glossy;
use crate::warp::{Method, Warp};
use std::path::Path;

/// A scene loaded, with its tracer and its bake (fresh or reused), and its run folder.
pub struct Prepared {
    pub scene: Scene,
    pub tracer: Tracer,
    pub probe: SpecularProbe,
    /// The other specular probes (`[probes]`), after probe A.
    pub others: Vec<SpecularProbe>,
    pub grid: ProbeGrid,
    /// The bake was made now (not reused).
    pub baked_now: bool,
    pub folder: RunFolder,
    /// The references traced against this bake, kept beside it for later runs.
    pub references: ReferenceStore,
}

impl Prepared {
    pub fn baked(&self) -> Baked<'_> {
        Baked {
            scene: &self.scene,
            tracer: &self.tracer,
            probe: &self.probe,
            others: &self.others,
            grid: &self.grid,
            references: Some(&self.references),
        }
    }
}

/// How a fitted grid is stored.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StoreOptions {
    pub precision: Precision,
    /// Store the GGX roughness correction (left out anyway when the probe has no rough mips).
    pub roughness: bool,
    /// How a lookup combines neighbouring cells (the manifest's `blend`).
    pub blend: Blend,
}

impl Default for StoreOptions {
    fn default() -> Self {
        StoreOptions { precision: Precision::F32, roughness: true, blend: Blend::Cell }
    }
}

/// Where a stage writes and how it reports: the run folder, the command recorded in every
/// output, and the progress display.
#[derive(Clone, Copy)]
pub struct Output<'a> {
    pub folder: &'a RunFolder,
    pub command: &'a str,
    pub progress: &'a Progress,
}

/// Everything `run` needs besides the scene.
#[derive(Clone, Debug, Default)]
pub struct RunSettings {
    pub eval: EvalSettings,
    pub fit: FitSettings,
    pub store: StoreOptions,
}

/// Loads a scene file and names its run folder (`out`, or `fits/<scene name>`).
pub fn load_scene(path: &Path, out: Option<&Path>) -> Result<(Scene, RunFolder), JobError> {
    let scene = Scene::load(path)?;
    let folder = out.map_or_else(|| RunFolder::for_scene(&scene.name), RunFolder::new);
    Ok((scene, folder))
}

/// Memory this process may still take, and what limits it: the least of the machine's
/// available memory (`MemAvailable` of /proc/meminfo), the address space left under
/// `RLIMIT_AS` (its limit less the process's `VmSize`), and the room left in its cgroup
/// (v2 `memory.max` less `memory.current`, or v1 `memory.limit_in_bytes` less
/// `memory.usage_in_bytes`). `None` when none is known.
pub fn available_memory() -> Option<(u64, &'static str)> {
    let kb_field = |file: &str, key: &str| -> Option<u64> {
        let text = std::fs::read_to_string(file).ok()?;
        let line = text.lines().find(|l| l.starts_with(key))?;
        line.split_whitespace().nth(1)?.parse::<u64>().ok().map(|kb| kb * 1024)
    };
    let mut limits: Vec<(u64, &'static str)> = Vec::new();
    limits.extend(kb_field("/proc/meminfo", "MemAvailable:").map(|m| (m, "the machine's available memory")));
    // SAFETY: getrlimit writes the struct it is given and nothing else
    let mut rl = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut rl) } == 0 && rl.rlim_cur != libc::RLIM_INFINITY {
        let used = kb_field("/proc/self/status", "VmSize:").unwrap_or(0);
        limits.push((rl.rlim_cur.saturating_sub(used), "the address space left under the process's limit (ulimit -v)"));
    }
    limits.extend(cgroup_room().map(|m| (m, "the room left in the process's cgroup (memory.max)")));
    limits.into_iter().min_by_key(|l| l.0)
}

/// The memory left in this process's cgroup, if it has a limit (cgroup v2, else v1).
fn cgroup_room() -> Option<u64> {
    let read = |p: &str| std::fs::read_to_string(p).ok().map(|t| t.trim().to_string());
    let number = |p: &str| read(p).and_then(|t| t.parse::<u64>().ok());
    let cgroups = read("/proc/self/cgroup").unwrap_or_default();
    // v2: "0::/path"
    if let Some(path) = cgroups.lines().find_map(|l| l.strip_prefix("0::")) {
        let dir = format!("/sys/fs/cgroup{}", path.trim_end_matches('/'));
        if let Some(max) = number(&format!("{dir}/memory.max")) {
            return Some(max.saturating_sub(number(&format!("{dir}/memory.current")).unwrap_or(0)));
        }
        return None;
    }
    // v1: "N:memory:/path"
    let path = cgroups.lines().find_map(|l| l.split_once(":memory:").map(|(_, p)| p.to_string()))?;
    let dir = format!("/sys/fs/cgroup/memory{}", path.trim_end_matches('/'));
    let limit = number(&format!("{dir}/memory.limit_in_bytes"))?;
    // (v1 says "no limit" with a huge number)
    (limit < 1 << 60).then(|| limit.saturating_sub(number(&format!("{dir}/memory.usage_in_bytes")).unwrap_or(0)))
}

/// Says what baking `scene` will take and refuses a bake that needs more memory than the
/// machine has available, unless `force`.
pub fn check_bake_estimate(scene: &Scene, force: bool) -> Result<bake::Estimate, JobError> {
    let e = bake::Estimate::of(scene);
    let threads = rayon::current_num_threads().max(1) as f64;
    // about 4 M primary rays per second and thread on the development machine (with shadow
    // and bounce rays behind each)
    let seconds = e.rays as f64 / (4e6 * threads);
    tracing::info!(
        "bake estimate for {}: about {:.0} MB and {:.1} M primary rays (~{:.0} s on {} threads)",
        scene.name,
        e.bytes as f64 / 1e6,
        e.rays as f64 / 1e6,
        seconds,
        threads
    );
    if let Some((avail, what)) = available_memory()
        && e.bytes > avail
        && !force
    {
        return Err(JobError::Scene(crate::scene::SceneError::Invalid {
            path: scene.source.clone(),
            field: "probe/grid".into(),
            message: format!(
                "baking needs about {:.1} GB, more than the {:.1} GB available ({what}; lower probe.resolution, grid.counts or grid.irradiance_resolution, or pass --force)",
                e.bytes as f64 / 1e9,
                avail as f64 / 1e9
            ),
        }));
    }
    Ok(e)
}

/// Bakes the scene and writes the bake folder with its previews into `folder`.
pub fn bake(scene: &Scene, tracer: &Tracer, folder: &RunFolder, progress: &Progress) -> Result<Bake, FileError> {
    let baked = bake::bake(scene, tracer, progress);
    let dir = folder.bake();
    bakefile::write_bake(&dir, scene, &baked)?;
    crate::preview::write_bake_previews(&dir, &baked)?;
    Ok(baked)
}

/// The bake in `previous` if it was made from exactly this scene (same content key: tool
/// version, settings and the bytes of every input file) and its files are intact, brought
/// into `folder` (hard links where possible); else a fresh bake written into `folder`.
/// Returns the probe, the grid and whether it baked. `hits`: when a reused bake's hit
/// counts are read (a fresh bake has them).
pub fn load_or_bake(
    scene: &Scene,
    tracer: &Tracer,
    (previous, folder): (&RunFolder, &RunFolder),
    hits: bakefile::Hits,
    progress: &Progress,
) -> Result<(SpecularProbe, Vec<SpecularProbe>, ProbeGrid, bool), FileError> {
    let dir = previous.bake();
    let key = scene.content_key();
    if dir.join(bakefile::MANIFEST_FILE).is_file() {
        // the key first: a bake of other settings or files is not read at all
        let read = (bakefile::manifest_key(&dir).as_deref() == Some(key.as_str())).then(|| {
            bakefile::read_bake_with(&dir, hits)
                .and_then(|(m, probe, grid)| Ok((bakefile::read_others(&dir, &m)?, m, probe, grid)))
                .and_then(|read| bakefile::agrees_with_scene(&dir, &read.1, scene).map(|()| read))
        });
        match read {
            Some(Ok((others, m, probe, grid))) => {
                tracing::info!("reusing bake in {} (key {})", dir.display(), m.key);
                if previous.dir != folder.dir {
                    crate::files::staged::link_or_copy_dir(&dir, &folder.bake())?;
                }
                return Ok((probe, others, grid, false));
            }
            None => {
                tracing::info!("bake in {} was made from other settings or input files; baking again", dir.display())
            }
            Some(Err(e)) => tracing::warn!("not reusing the bake: {e}"),
        }
    }
    let baked = bake(scene, tracer, folder, progress)?;
    Ok((baked.probe, baked.others, baked.grid, true))
}

/// The scene with its tracer and its bake, reused from `previous` where it matches, written
/// into `folder`; `hits`: when a reused bake's hit counts are read ([`fit_staged`] reads
/// them when it needs them).
pub fn prepare_from(
    scene: Scene,
    previous: &RunFolder,
    folder: RunFolder,
    hits: bakefile::Hits,
    progress: &Progress,
) -> Result<Prepared, FileError> {
    let tracer = Tracer::new(&scene);
    let (probe, others, grid, baked_now) = load_or_bake(&scene, &tracer, (previous, &folder), hits, progress)?;
    let references = ReferenceStore::new(&folder.bake(), &scene.content_key());
    Ok(Prepared { scene, tracer, probe, others, grid, baked_now, folder, references })
}

/// [`prepare_from`] reading and writing the same folder (tests, benches, scratch folders),
/// the bake read whole.
pub fn prepare(scene: Scene, folder: RunFolder, progress: &Progress) -> Result<Prepared, FileError> {
    let previous = folder.clone();
    prepare_from(scene, &previous, folder, bakefile::Hits::WithGrid, progress)
}

/// A run folder rewritten as a whole: the job writes into `out` (a staging folder beside the
/// target), and [`Transaction::commit`] swaps it in only after the fitted grid it wrote, if
/// any, loads back through the runtime loader. Until then the target keeps the previous run,
/// complete; a second writer is refused while this one holds the folder.
pub struct Transaction {
    staged: crate::files::staged::StagedDir,
    /// Where the job writes.
    pub out: RunFolder,
    /// The folder as it was (what a reused bake or kept files are read from).
    pub previous: RunFolder,
}

impl Transaction {
    pub fn begin(folder: &RunFolder) -> Result<Transaction, FileError> {
        let staged = crate::files::staged::StagedDir::begin(&folder.dir)?;
        let out = RunFolder::new(staged.dir());
        Ok(Transaction { staged, out, previous: folder.clone() })
    }

    /// Brings the previous folder's files that `keep` accepts (by file name, top level) into
    /// the new one, unless the new one already has them.
    pub fn keep(&self, keep: impl Fn(&str) -> bool) -> Result<(), FileError> {
        let Ok(entries) = std::fs::read_dir(&self.previous.dir) else { return Ok(()) };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let to = self.out.dir.join(&name);
            if name.starts_with('.') || !keep(&name) || to.exists() {
                continue;
            }
            let t = e.file_type().map_err(FileError::io(&e.path()))?;
            if t.is_dir() {
                crate::files::staged::link_or_copy_dir(&e.path(), &to)?;
            } else if t.is_file() && std::fs::hard_link(e.path(), &to).is_err() {
                std::fs::copy(e.path(), &to).map_err(FileError::io(&e.path()))?;
            }
        }
        Ok(())
    }

    /// Swaps the new folder in; with `wrote_grid`, only after the fitted grid it wrote loads
    /// back through the runtime loader (a grid the loader would refuse is never committed).
    pub fn commit(self, wrote_grid: bool) -> Result<(), FileError> {
        if wrote_grid {
            FittedGrid::load(&self.out.dir)?;
        }
        self.staged.commit()
    }
}

/// Fits the correctives of every active cell and writes the fitted grid (manifest.json +
/// EXR payloads) and the fit's diagnostics into `folder`; `sets`: the map sets the returned
/// fit keeps beside the stored ones.
pub fn fit(
    baked: Baked,
    warp: &Warp,
    settings: &FitSettings,
    store: StoreOptions,
    sets: MapSets,
    out: Output,
) -> Result<(Fit, GridManifest), FileError> {
    // rough queries are fitted with the analytic-lobe correction; the fit then chooses the
    // correction the grid stores (lobes or fitted to this scene)
    let lobes = fit_lobes(baked);
    let glossy = Glossy { warp, correction: lobes.as_ref() };
    crate::trace::streams::set_stage(crate::trace::streams::Stage::Fit);
    let fitted = crate::fit::fit(baked, glossy, settings, sets, out.progress);
    let manifest = write_fit(baked, warp, &fitted, store, out)?;
    Ok((fitted, manifest))
}

/// [`fit`] on a prepared scene, stage by stage, so that the grid's hit counts are held only
/// while the cells stage reads them: read from the bake after the diffuse stage if
/// [`prepare_from`] left them on disk ([`bakefile::Hits::Later`]), dropped before the fit is
/// finished. A big level's fit then never holds them beside the diffuse fit's points and
/// references or beside the finished cells' records. Writes the same grid as [`fit`].
pub fn fit_staged(
    p: &mut Prepared,
    warp: &Warp,
    settings: &FitSettings,
    store: StoreOptions,
    sets: MapSets,
    command: &str,
    progress: &Progress,
) -> Result<(Fit, GridManifest), FileError> {
    crate::trace::streams::set_stage(crate::trace::streams::Stage::Fit);
    let lobes = fit_lobes(p.baked());
    let glossy = Glossy { warp, correction: lobes.as_ref() };
    let diffuse = crate::fit::diffuse_stage(p.baked(), glossy, settings);
    if !p.grid.holds_hits() {
        p.grid.hits = bakefile::read_hits(&p.folder.bake(), &p.scene.content_key(), &p.grid)?;
    }
    let cells = crate::fit::cells_stage(p.baked(), glossy, settings, sets, progress);
    p.grid.hits = Vec::new();
    let fitted = crate::fit::finish(p.baked(), glossy, settings, diffuse, cells);
    let out = Output { folder: &p.folder, command, progress };
    let manifest = write_fit(p.baked(), warp, &fitted, store, out)?;
    Ok((fitted, manifest))
}

/// The roughness correction a fit's rough queries are fitted with: the analytic lobes'
/// (none for a probe without rough mips).
pub fn fit_lobes(baked: Baked) -> Option<crate::roughness::RoughnessCorrection> {
    (baked.probe.radiance.levels.len() > 1).then(crate::roughness::fit_correction)
}

/// Writes a fit: the fitted grid and the fit's diagnostics.
pub fn write_fit(
    baked: Baked,
    warp: &Warp,
    fitted: &Fit,
    store: StoreOptions,
    out: Output,
) -> Result<GridManifest, FileError> {
    let manifest = write_grid(baked, warp, fitted, store, out.folder)?;
    report::fit::write_fit_diagnostics(out.folder, fitted, out.command)?;
    Ok(manifest)
}

/// Writes the fitted grid of `fitted` (with the roughness correction unless `store` leaves
/// it out) into `folder`.
pub fn write_grid(
    baked: Baked,
    warp: &Warp,
    fitted: &Fit,
    store: StoreOptions,
    folder: &RunFolder,
) -> Result<GridManifest, FileError> {
    let roughness = if store.roughness { fitted.roughness.as_ref() } else { None };
    let g = baked.grid;
    let contents = GridContents {
        scene: &baked.scene.name,
        geometry: g.geometry,
        probe: ProbeData {
            position: baked.probe.position,
            radiance: &baked.probe.radiance,
            mip_roughness: &baked.probe.roughness,
            distance: &baked.probe.depth,
        },
        others: baked
            .others
            .iter()
            .map(|p| ProbeData {
                position: p.position,
                radiance: &p.radiance,
                mip_roughness: &p.roughness,
                distance: &p.depth,
            })
            .collect(),
        warp,
        correctives: &fitted.correctives,
        blend: store.blend,
        irradiance: IrradianceSource {
            resolution: g.irradiance_resolution,
            depth_resolution: g.depth_resolution,
            irradiance: &g.irradiance,
            depth_mean: &g.depth_mean,
            depth_mean_sq: &g.depth_mean_sq,
            inside: &g.inside,
            correction: &fitted.irradiance.correction,
        },
        roughness,
        probe_offset: &g.probe_offset,
        precision: store.precision,
        provenance: provenance(fitted),
    };
    crate::gridfile::write::write(&folder.dir, &contents)
}

/// What the grid's manifest records about the fit that made it.
pub fn provenance(f: &Fit) -> Provenance {
    Provenance {
        fit_settings: serde_json::to_value(&f.settings).unwrap_or_default(),
        residuals: serde_json::to_value(crate::fit::summary::summary(f)).unwrap_or_default(),
        level0_cells: f.cells.iter().filter(|c| c.level == crate::fit::Level::Fallback).count(),
    }
}

/// The corrective rows of a fit, in table order.
/// (`celldepth` and `fitted-L2-all` only when the fit kept its unfitted map sets).
pub fn corrective_rows(f: &Fit) -> Vec<CorrectiveRow<'_>> {
    CorrectiveVariant::ALL
        .iter()
        .filter_map(|&variant| {
            let correctives = match variant {
                CorrectiveVariant::Celldepth => &f.unfitted.as_ref()?.celldepth,
                CorrectiveVariant::Fitted | CorrectiveVariant::FittedTrilinear | CorrectiveVariant::FittedFaces => {
                    &f.correctives
                }
                CorrectiveVariant::FittedL2All => &f.unfitted.as_ref()?.fitted_all,
                CorrectiveVariant::PerCell => f.unfitted.as_ref()?.per_cell.as_ref()?,
                // (fitted on the evaluation's own queries: `evaluate` adds it)
                CorrectiveVariant::InSample => return None,
            };
            Some(CorrectiveRow { variant, correctives })
        })
        .collect()
}

/// Evaluates `methods` on the scene's validation set, with the fit's corrective grids and the
/// fitted grid loaded back from `folder` when a fit is given, and writes eval.json/.md, the
/// error-against-cost plot and the view tiles there.
pub fn evaluate(
    baked: Baked,
    warp: &Warp,
    settings: &EvalSettings,
    methods: &[Method],
    fit: Option<&Fit>,
    out: Output,
) -> Result<EvalReport, FileError> {
    let before = baked.references.map(ReferenceStore::counts).unwrap_or_default();
    crate::trace::streams::set_stage(crate::trace::streams::Stage::Eval);
    // the in-sample bound: the fit's maps refitted on the evaluation's own mirror queries
    // (the validation set made here once, for both)
    let t0 = std::time::Instant::now();
    let probes = warp.probe_positions();
    let mirror = eval::validation_set(baked.scene, baked.tracer, baked.grid, &probes, settings, baked.references);
    let mirror_seconds = t0.elapsed().as_secs_f64();
    let in_sample = match fit.filter(|f| f.unfitted.is_some()) {
        // (a staged fit dropped the hit counts: they are read again)
        Some(f) if baked.grid.holds_hits() => crate::fit::in_sample(baked.grid, &baked.grid.hits, warp, f, &mirror),
        Some(f) => {
            let hits = bakefile::read_hits(&out.folder.bake(), &baked.scene.content_key(), baked.grid)?;
            crate::fit::in_sample(baked.grid, &hits, warp, f, &mirror)
        }
        None => None,
    };
    let in_sample_seconds = t0.elapsed().as_secs_f64() - mirror_seconds;
    let mut rows = fit.map(corrective_rows).unwrap_or_default();
    rows.extend(
        in_sample.as_ref().map(|correctives| CorrectiveRow { variant: CorrectiveVariant::InSample, correctives }),
    );
    let runtime = match fit {
        Some(_) => Some(FittedGrid::load(&out.folder.dir)?),
        None => None,
    };
    // the Corrected rule applies the fitted grid's correction, else the analytic-lobe fit
    let correction = match &runtime {
        Some(g) => g.roughness().cloned(),
        None => Some(crate::roughness::fit_correction()),
    };
    let subject = eval::Subject {
        baked,
        warp,
        methods,
        corrective_rows: &rows,
        runtime: runtime.as_ref(),
        correction: correction.as_ref(),
        mirror: &mirror,
    };
    let mut ev = eval::evaluate(subject, settings, out.command, out.progress);
    ev.report.times.mirror_references = mirror_seconds;
    ev.report.times.in_sample = in_sample_seconds;
    ev.report.seconds += mirror_seconds + in_sample_seconds;
    let after = baked.references.map(ReferenceStore::counts).unwrap_or_default();
    (ev.report.times.reference_sets_traced, ev.report.times.reference_sets_reused) =
        (after.0 - before.0, after.1 - before.1);
    report::write_evaluation(out.folder, &ev)?;
    // each surface-probe atlas as a game loads it, read back before the run is committed
    for (k, atlas) in ev.surface_atlases.iter().enumerate() {
        let dir = out.folder.surface_atlas_dir(k);
        crate::gridfile::surface::write(&dir, atlas)?;
        crate::gridfile::surface::read(&dir)?;
    }
    Ok(ev.report)
}

/// What `run` produced.
pub struct RunOutcome {
    pub fit: Fit,
    pub manifest: GridManifest,
    pub eval: EvalReport,
}

/// The main job on a prepared scene: fit and write the grid, evaluate every method, write
/// the run report. One warp context (the eval settings' options) serves fit and eval. The
/// fit runs in stages ([`fit_staged`]): the grid's hit counts are held only while its cells
/// stage reads them, never beside the evaluation.
pub fn run(p: &mut Prepared, s: &RunSettings, command: &str, progress: &Progress) -> Result<RunOutcome, FileError> {
    let warp = p.baked().warp(s.eval.options);
    // the evaluation compares the stored model with the unfitted map sets
    let (fit, manifest) = fit_staged(p, &warp, &s.fit, s.store, MapSets::WithUnfitted, command, progress)?;
    let out = Output { folder: &p.folder, command, progress };
    let eval = evaluate(p.baked(), &warp, &s.eval, &Method::ALL, Some(&fit), out)?;
    report::page::write_report(&p.folder, command)?;
    Ok(RunOutcome { fit, manifest, eval })
}

/// Fits the GGX roughness correction alone and writes roughness.json/.png into `folder`.
pub fn roughness(folder: &RunFolder) -> Result<crate::roughness::RoughnessCorrection, FileError> {
    let c = crate::roughness::fit_correction();
    report::roughness::write_roughness(folder, &c)?;
    Ok(c)
}
