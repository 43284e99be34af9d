//! Shards and their merge: a bake or a fit split over machines, and merged into exactly
//! what one machine writes.
//!
//! A bake shard bakes a contiguous range of grid cells (shard 0 also the probe; ranges of
//! equal estimated rays, `bake::shard_cells`). A fit shard reads the merged bake and fits a
//! contiguous range of the active cells (equal numbers of active cells: inside cells cost
//! nothing) and traces its part of the diffuse fit's surface-point references. Each writes
//! one part (`partfile`) into the run folder's `parts/`, atomically; a failed shard re-runs
//! alone. `merge` checks that the parts belong together (scene key, settings, bake, shard
//! count) and cover every cell exactly once, then runs the steps that need the whole grid
//! through the same functions a single-machine run calls (`bake::grid::assemble`,
//! `fit::assemble`), so the merged grid's payloads equal a single run's byte for byte.

use super::JobError;
use super::run::{self, Output, StoreOptions};
use crate::bake::{self, Baked, grid::CellBake};
use crate::bakefile;
use crate::files::FileError;
use crate::fit::irradiance::{self, References};
use crate::fit::{self, CellOutcome, Fit, FitSettings};
use crate::gridfile::GridManifest;
use crate::partfile::{self, BakePart, FitPart, PartBody, PartHeader, PartKind};
use crate::progress::Progress;
use crate::report::folder::RunFolder;
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer};
use crate::warp::WarpOptions;
use crate::warp::glossy::Glossy;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Shard `k` of `n` (0-based), written `K/N` on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub k: u32,
    pub n: u32,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let (k, n) = s.split_once('/').ok_or_else(|| format!("expected K/N (shard K of N, 0 ≤ K < N), got {s:?}"))?;
        let k: u32 = k.trim().parse().map_err(|e| format!("shard {k:?}: {e}"))?;
        let n: u32 = n.trim().parse().map_err(|e| format!("shard count {n:?}: {e}"))?;
        if n == 0 || k >= n {
            return Err(format!("shard {k}/{n}: need 0 ≤ K < N"));
        }
        Ok(Shard { k, n })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

/// Everything a fit's shards must share besides the scene and the bake.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitJob {
    pub fit: FitSettings,
    pub options: WarpOptions,
    pub store: StoreOptions,
}

/// Logs a shard's progress as it goes (cells done, rate, ETA): a farm's logs are files,
/// not terminals.
struct ShardLog {
    what: String,
    total: usize,
    t0: Instant,
}

impl ShardLog {
    fn new(what: String, total: usize) -> ShardLog {
        tracing::info!("{what}: {total} cells");
        ShardLog { what, total, t0: Instant::now() }
    }
    fn done(&self, done: usize) {
        let s = self.t0.elapsed().as_secs_f64();
        let eta = if done > 0 { s / done as f64 * (self.total - done) as f64 } else { f64::NAN };
        tracing::info!(
            "{}: {done}/{} cells done in {:.1} s ({:.1} cells/s), ETA {:.0} s",
            self.what,
            self.total,
            s,
            done as f64 / s.max(1e-9),
            eta
        );
    }
}

/// Runs `f` over `items` in chunks of about a twentieth (at least 32), logging after each.
fn in_chunks<T: Copy, R>(items: &[T], log: &ShardLog, mut f: impl FnMut(&[T]) -> Vec<R>) -> Vec<R> {
    let chunk = items.len().div_ceil(20).max(32);
    let mut out = Vec::with_capacity(items.len());
    for part in items.chunks(chunk) {
        out.extend(f(part));
        log.done(out.len());
    }
    out
}

fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname").map(|h| h.trim().to_string()).unwrap_or_default()
}

fn header(scene: &Scene, kind: PartKind, shard: Shard, settings: serde_json::Value) -> PartHeader {
    PartHeader {
        format: partfile::PART_FORMAT.into(),
        version: partfile::PART_VERSION,
        tool_version: env!("CARGO_PKG_VERSION").into(),
        kind,
        scene: scene.name.clone(),
        scene_file: std::path::absolute(&scene.source).unwrap_or_else(|_| scene.source.clone()),
        scene_key: scene.content_key(),
        bake_checksums: Vec::new(),
        settings,
        shard: shard.k,
        shards: shard.n,
        cells: 0..0,
        points: None,
        seconds: 0.0,
        fit_times: None,
        host: host(),
        body_bytes: 0,
        body_checksum: String::new(),
    }
}

/// Bakes shard `shard` of the scene (its grid cells; the probe with shard 0) and writes its
/// part into `folder`'s `parts/`; returns the part's path.
pub fn bake_shard(scene: &Scene, folder: &RunFolder, shard: Shard, progress: &Progress) -> Result<PathBuf, FileError> {
    let t0 = Instant::now();
    let tracer = Tracer::new(scene);
    let renderer = Renderer::new(scene, &tracer);
    let probe = (shard.k == 0).then(|| {
        tracing::info!("bake shard {shard}: probe A");
        bake::probe::bake_probe(&renderer, &bake::probe_settings(scene), progress)
    });
    // every shard places the probes alike (a pure function of the scene) and bakes its
    // share of them: probe k ≥ 1 on shard k mod n
    let placement = bake::placement::place(&renderer, &bake::grid_settings(scene));
    let others: Vec<(usize, bake::SpecularProbe, u64)> = (1..placement.positions.len())
        .filter(|k| k % shard.n as usize == shard.k as usize)
        .map(|k| {
            tracing::info!("bake shard {shard}: probe {k}");
            let settings = bake::probe_settings_at(scene, k, placement.positions[k]);
            let (p, rays) = bake::probe::bake_probe(&renderer, &settings, progress);
            (k, p, rays)
        })
        .collect();
    let cells = bake::shard_cells(scene, shard.k as usize, shard.n as usize);
    let settings = bake::grid_settings(scene);
    let log = ShardLog::new(format!("bake shard {shard}"), cells.len());
    let ids: Vec<usize> = cells.clone().collect();
    let baked: Vec<CellBake> = in_chunks(&ids, &log, |part| {
        // a chunk of a contiguous range is itself one
        let range = part.first().map_or(0..0, |&first| first..first + part.len());
        bake::grid::bake_cells(&renderer, &settings, range, &Progress::quiet())
    });
    let mut h = header(scene, PartKind::Bake, shard, serde_json::Value::Null);
    h.cells = cells;
    h.seconds = t0.elapsed().as_secs_f64();
    let path = folder.parts().join(partfile::part_name(PartKind::Bake, shard.k, shard.n));
    partfile::write_part(&path, h, &PartBody::Bake(BakePart { probe, others, placement, cells: baked }))?;
    Ok(path)
}

/// The bake in `folder`, which must have been made from exactly this scene; `hits`: whether
/// its hit counts are read.
fn read_matching_bake(
    scene: &Scene,
    folder: &RunFolder,
    hits: bakefile::Hits,
) -> Result<(bakefile::manifest::BakeManifest, bake::SpecularProbe, Vec<bake::SpecularProbe>, bake::ProbeGrid), FileError>
{
    let dir = folder.bake();
    if !dir.join(bakefile::MANIFEST_FILE).is_file() {
        return Err(FileError::invalid(
            &dir,
            "bake",
            format!(
                "no bake here: bake first (`warpfit bake --scene {} --out {}`, or its shards and `warpfit merge`)",
                scene.source.display(),
                folder.dir.display()
            ),
        ));
    }
    let (m, probe, grid) = bakefile::read_bake_with(&dir, hits)?;
    let others = bakefile::read_others(&dir, &m)?;
    if m.key != scene.content_key() {
        return Err(FileError::invalid(
            &dir.join(bakefile::MANIFEST_FILE),
            "key",
            format!(
                "the bake was made from other settings or input files than {} (key {}, the scene's is {}): bake and merge it first",
                scene.source.display(),
                m.key,
                scene.content_key()
            ),
        ));
    }
    Ok((m, probe, others, grid))
}

/// Fits shard `shard` of the scene on the bake in `folder` (which a merged bake or a plain
/// `warpfit bake` wrote) and writes its part into `folder`'s `parts/`; returns its path.
pub fn fit_shard(
    scene: &Scene,
    folder: &RunFolder,
    job: &FitJob,
    shard: Shard,
    progress: &Progress,
) -> Result<PathBuf, FileError> {
    let t0 = Instant::now();
    let (m, probe, others, mut grid) = read_matching_bake(scene, folder, bakefile::Hits::WithGrid)?;
    let tracer = Tracer::new(scene);
    let baked = Baked { scene, tracer: &tracer, probe: &probe, others: &others, grid: &grid, references: None };
    let warp = baked.warp(job.options);
    let lobes = run::fit_lobes(baked);
    let glossy = Glossy { warp: &warp, correction: lobes.as_ref() };
    let active = fit::active_cells(&grid);
    let (k, n) = (shard.k as usize, shard.n as usize);
    let range = active.len() * k / n..active.len() * (k + 1) / n;
    let log = ShardLog::new(format!("fit shard {shard}"), range.len());
    // every shard measures the proxy the same way (seeded), so they all fit for the same one
    let proxy = fit::proxy::choose(baked, glossy, &job.fit).method;
    let t_cells = Instant::now();
    let cells: Vec<CellOutcome> = in_chunks(&active[range.clone()], &log, |part| {
        fit::fit_cells(baked, glossy, &job.fit, proxy, part, fit::MapSets::Stored, progress)
    });
    let mut times = fit::FitTimes { cells: t_cells.elapsed().as_secs_f64(), ..fit::FitTimes::default() };
    // only the cells read the hit counts: not held while the references are traced
    grid.hits = Vec::new();
    let baked = Baked { scene, tracer: &tracer, probe: &probe, others: &others, grid: &grid, references: None };
    let t_points = Instant::now();
    let points = irradiance::SurfacePoints::draw(baked, job.fit.seed);
    times.surface_points = t_points.elapsed().as_secs_f64();
    let ranges = points.part(k, n);
    tracing::info!(
        "fit shard {shard}: irradiance references of {} + {} surface points",
        ranges.train.len(),
        ranges.check.len()
    );
    let t_references = Instant::now();
    let references = irradiance::trace_references(baked, &points, job.fit.seed, &ranges);
    times.irradiance_references = t_references.elapsed().as_secs_f64();
    let settings = serde_json::to_value(job).map_err(|e| FileError::invalid(&folder.dir, "settings", e.to_string()))?;
    let mut h = header(scene, PartKind::Fit, shard, settings);
    h.bake_checksums = m.files.iter().map(|f| f.checksum.clone()).collect();
    h.cells = range;
    h.points = Some(ranges);
    h.seconds = t0.elapsed().as_secs_f64();
    h.fit_times = Some(times);
    let path = folder.parts().join(partfile::part_name(PartKind::Fit, shard.k, shard.n));
    partfile::write_part(&path, h, &PartBody::Fit(FitPart { cells, references }))?;
    Ok(path)
}

/// How the shards of a merge went.
#[derive(Clone, Debug)]
pub struct MergeReport {
    pub kind: PartKind,
    pub scene: String,
    /// Per shard: (host, seconds).
    pub shards: Vec<(String, f64)>,
    /// Slowest shard's time over the median's (1 = perfectly balanced).
    pub straggler_ratio: f64,
    pub merge_seconds: f64,
}

/// What a merge wrote.
pub enum Merged {
    Bake(Box<bake::Bake>),
    Fit(Box<(Fit, GridManifest)>),
}

/// The header fields every part of one job shares.
const SAME_IN_EVERY_PART: [&str; 7] =
    ["kind", "scene", "scene_key", "tool_version", "settings", "bake_checksums", "shards"];

fn json(path: &Path, h: &PartHeader) -> Result<serde_json::Value, FileError> {
    serde_json::to_value(h).map_err(|e| FileError::Json { path: path.to_path_buf(), message: e.to_string() })
}

/// Checks that `headers` (read from `paths`) are the N shards of one job, each once, and
/// returns them in shard order.
fn check_set(paths: &[PathBuf], headers: Vec<PartHeader>) -> Result<Vec<(PathBuf, PartHeader)>, FileError> {
    let Some(first) = headers.first().cloned() else {
        return Err(FileError::invalid(Path::new("parts"), "parts", "no part given"));
    };
    let first_path = &paths[0];
    let mut by_shard: Vec<Option<(PathBuf, PartHeader)>> = vec![None; first.shards as usize];
    for (path, h) in paths.iter().zip(headers) {
        // what must agree: everything but the shard's own work (shard, cells, time, body)
        let (mine, theirs) = (json(path, &h)?, json(first_path, &first)?);
        for field in SAME_IN_EVERY_PART {
            if mine[field] != theirs[field] {
                return Err(FileError::invalid(
                    path,
                    field,
                    format!(
                        "{} differs from {} in {}: the parts are not of one job",
                        mine[field],
                        theirs[field],
                        first_path.display()
                    ),
                ));
            }
        }
        let slot = by_shard
            .get_mut(h.shard as usize)
            .ok_or_else(|| FileError::invalid(path, "shard", format!("{} is not below {}", h.shard, h.shards)))?;
        if let Some((other, _)) = slot {
            return Err(FileError::invalid(
                path,
                "shard",
                format!("shard {}/{} is given twice (also {})", h.shard, h.shards, other.display()),
            ));
        }
        *slot = Some((path.clone(), h));
    }
    let missing: Vec<String> = by_shard
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_none())
        .map(|(k, _)| format!("{k}/{}", first.shards))
        .collect();
    if !missing.is_empty() {
        return Err(FileError::invalid(
            first_path,
            "shards",
            format!(
                "the {} job has {} shards; missing: {} (re-run `warpfit {} --shard K/N` for each)",
                first.kind.name(),
                first.shards,
                missing.join(", "),
                first.kind.name()
            ),
        ));
    }
    Ok(by_shard.into_iter().flatten().collect())
}

fn merge_report(kind: PartKind, scene: &str, set: &[(PathBuf, PartHeader)], t0: Instant) -> MergeReport {
    let shards: Vec<(String, f64)> = set.iter().map(|(_, h)| (h.host.clone(), h.seconds)).collect();
    let mut times: Vec<f64> = shards.iter().map(|s| s.1).collect();
    times.sort_by(f64::total_cmp);
    let median = times.get(times.len() / 2).copied().unwrap_or(0.0);
    let max = times.last().copied().unwrap_or(0.0);
    MergeReport {
        kind,
        scene: scene.to_string(),
        shards,
        straggler_ratio: if median > 0.0 { max / median } else { 1.0 },
        merge_seconds: t0.elapsed().as_secs_f64(),
    }
}

/// Loads the scene a part was made from and checks it is still the same (content key).
fn scene_of(path: &Path, h: &PartHeader) -> Result<Scene, JobError> {
    let scene = Scene::load(&h.scene_file)?;
    if scene.content_key() != h.scene_key {
        return Err(FileError::invalid(
            path,
            "scene_key",
            format!(
                "{} has changed since the shards ran (key {}, the parts say {}): run the shards again",
                h.scene_file.display(),
                scene.content_key(),
                h.scene_key
            ),
        )
        .into());
    }
    Ok(scene)
}

/// Merges the parts `paths` (all N shards of one bake or one fit) into `folder`: a bake
/// folder, or the fitted grid with its diagnostics. The folder is rewritten as a whole (its
/// bake, parts and farm files kept); a fit's grid is committed only after it loads back.
pub fn merge(
    folder: &RunFolder,
    paths: &[PathBuf],
    command: &str,
    progress: &Progress,
) -> Result<(Merged, MergeReport), JobError> {
    let t0 = Instant::now();
    let headers = paths.iter().map(|p| partfile::read_header(p)).collect::<Result<Vec<_>, _>>()?;
    let set = check_set(paths, headers)?;
    let (path0, h0) = &set[0];
    let scene = scene_of(path0, h0)?;
    let kind = h0.kind;
    let tx = run::Transaction::begin(folder)?;
    let merged = match kind {
        PartKind::Bake => {
            let bake = merge_bake(&scene, &set)?;
            let same_bake = bakefile::manifest_key(&folder.bake()).as_deref() == Some(&scene.content_key());
            let dir = tx.out.bake();
            bakefile::write_bake(&dir, &scene, &bake)?;
            crate::preview::write_bake_previews(&dir, &bake)?;
            // the same inputs bake the same bits: a fit made from the old bake still holds
            tx.keep(|name| same_bake || RunFolder::written_by_farm(name))?;
            tx.commit(false)?;
            Merged::Bake(Box::new(bake))
        }
        PartKind::Fit => {
            // the grid-wide steps never read the hit counts: they stay on disk
            let (m, probe, others, grid) = read_matching_bake(&scene, &tx.previous, bakefile::Hits::Later)?;
            let checksums: Vec<String> = m.files.iter().map(|f| f.checksum.clone()).collect();
            if checksums != h0.bake_checksums {
                return Err(FileError::invalid(
                    path0,
                    "bake_checksums",
                    format!("the parts were fitted on another bake than the one in {}", folder.bake().display()),
                )
                .into());
            }
            let job: FitJob = serde_json::from_value(h0.settings.clone())
                .map_err(|e| FileError::invalid(path0, "settings", e.to_string()))?;
            let tracer = Tracer::new(&scene);
            let baked =
                Baked { scene: &scene, tracer: &tracer, probe: &probe, others: &others, grid: &grid, references: None };
            let warp = baked.warp(job.options);
            let lobes = run::fit_lobes(baked);
            let glossy = Glossy { warp: &warp, correction: lobes.as_ref() };
            let points = irradiance::SurfacePoints::draw(baked, job.fit.seed);
            let (cells, references) = gather_fit(&set, &fit::active_cells(&grid), &points, &job.fit)?;
            let proxy = fit::proxy::choose(baked, glossy, &job.fit);
            let mut fitted = fit::assemble(baked, glossy, &job.fit, proxy, cells, &points, references);
            drop(points);
            fitted.seconds += set.iter().map(|(_, h)| h.seconds).sum::<f64>();
            // the shards' steps, summed (the cells' CPU seconds come with their outcomes)
            let t = &mut fitted.times;
            for shard in set.iter().filter_map(|(_, h)| h.fit_times.as_ref()) {
                t.cells += shard.cells;
                t.surface_points += shard.surface_points;
                t.irradiance_references += shard.irradiance_references;
            }
            t.shards = set.len() as u32;
            crate::files::staged::link_or_copy_dir(&tx.previous.bake(), &tx.out.bake())?;
            let out = Output { folder: &tx.out, command, progress };
            let manifest = run::write_fit(baked, &warp, &fitted, job.store, out)?;
            tx.keep(RunFolder::written_by_farm)?;
            // the merged grid loads back before it is committed: without the bake beside it
            drop((warp, lobes, tracer, probe, others, grid));
            tx.commit(true)?;
            Merged::Fit(Box::new((fitted, manifest)))
        }
    };
    Ok((merged, merge_report(kind, &scene.name, &set, t0)))
}

/// The body of the part at `path`, whose header `h` the set was checked with (a part
/// replaced since is refused).
fn read_body(path: &Path, h: &PartHeader) -> Result<PartBody, FileError> {
    let (header, body) = partfile::read_part(path)?;
    if header != *h {
        return Err(FileError::invalid(path, "header", "changed while the merge read the parts"));
    }
    Ok(body)
}

/// The bake of a set of bake parts, checked against the scene's settings.
fn merge_bake(scene: &Scene, set: &[(PathBuf, PartHeader)]) -> Result<bake::Bake, FileError> {
    let settings = bake::grid_settings(scene);
    let n = set.len();
    let mut cells: Vec<CellBake> = Vec::with_capacity(settings.geometry.cell_count());
    let (mut probe, mut placement) = (None, None);
    let mut others: Vec<Option<bake::SpecularProbe>> = Vec::new();
    let mut other_rays = 0;
    let (mut probe_s, mut grid_s) = (0.0, 0.0);
    let s = bake::probe_settings(scene);
    for (k, (path, h)) in set.iter().enumerate() {
        let expected = bake::shard_cells(scene, k, n);
        if h.cells != expected {
            return Err(FileError::invalid(path, "cells", format!("{:?}, shard {k}/{n} bakes {expected:?}", h.cells)));
        }
        let body = read_body(path, h)?;
        let PartBody::Bake(part) = body else {
            return Err(FileError::invalid(path, "kind", "is no longer a bake part"));
        };
        if part.cells.len() != expected.len() || !part.cells.iter().all(|c| c.fits(&settings)) {
            return Err(FileError::invalid(path, "cells", "cell maps of the wrong size or with non-finite values"));
        }
        // every shard placed the same probes, and baked probe k ≥ 1 when k mod n is its own
        let count = part.placement.positions.len();
        match &placement {
            None => {
                placement = Some(part.placement.clone());
                others = vec![None; count.saturating_sub(1)];
            }
            Some(p) if *p != part.placement => {
                return Err(FileError::invalid(
                    path,
                    "placement",
                    "differs from shard 0's: the parts were baked from other scenes or builds",
                ));
            }
            Some(_) => {}
        }
        for (i, p, rays) in part.others {
            let slot = (i >= 1 && i % n == k).then(|| others.get_mut(i - 1)).flatten();
            let Some(slot) = slot.filter(|s| s.is_none()) else {
                return Err(FileError::invalid(path, "others", format!("probe {i} is not shard {k}/{n}'s to bake")));
            };
            if p.resolution() != s.resolution || p.depth.levels.len() != p.radiance.levels.len() {
                return Err(FileError::invalid(
                    path,
                    "others",
                    format!("probe {i} does not have the scene's probe resolution"),
                ));
            }
            other_rays += rays;
            *slot = Some(p);
        }
        match (k, part.probe) {
            (0, Some((p, rays))) => {
                if p.resolution() != s.resolution || p.depth.levels.len() != p.radiance.levels.len() {
                    return Err(FileError::invalid(path, "probe", "does not have the scene's probe resolution"));
                }
                probe_s = h.seconds;
                probe = Some((p, rays));
            }
            (0, None) => return Err(FileError::invalid(path, "probe", "shard 0 holds no probe")),
            (_, Some(_)) => return Err(FileError::invalid(path, "probe", "only shard 0 holds the probe")),
            (_, None) => grid_s += h.seconds,
        }
        cells.extend(part.cells);
    }
    let Some(others) = others.into_iter().collect::<Option<Vec<_>>>() else {
        return Err(FileError::invalid(Path::new("parts"), "others", "a placed probe is in no part"));
    };
    let Some((probe, probe_rays)) = probe else {
        return Err(FileError::invalid(Path::new("parts"), "probe", "no part holds the probe"));
    };
    // counted as a single machine counts them: the placement's rays once
    let probe_rays = probe_rays + other_rays + placement.as_ref().map_or(0, |p| p.rays);
    let (grid, grid_rays) = bake::grid::assemble(&settings, cells);
    let total_s = probe_s + grid_s;
    let stats = bake::BakeStats {
        probe_rays,
        grid_rays,
        bvh_build_s: 0.0,
        probe_s,
        grid_s,
        total_s,
        rays_per_s: (probe_rays + grid_rays) as f64 / total_s.max(1e-9),
        threads: rayon::current_num_threads(),
        hidden_probe_a: placement.as_ref().map_or(0.0, |p| p.hidden_probe_a),
        hidden_probes: placement.as_ref().map_or(0.0, |p| p.hidden),
        placed_probes: placement.as_ref().map_or(0, |p| p.placed),
    };
    Ok(bake::Bake { probe, others, grid, stats })
}

/// The cell outcomes and irradiance references of a set of fit parts, in order, checked
/// against the active cells and surface points they must cover.
fn gather_fit(
    set: &[(PathBuf, PartHeader)],
    active: &[usize],
    points: &irradiance::SurfacePoints,
    s: &FitSettings,
) -> Result<(Vec<CellOutcome>, References), FileError> {
    let n = set.len();
    let n2 = (s.map_res * s.map_res) as usize;
    let mut cells = Vec::with_capacity(active.len());
    let mut references = References::default();
    for (k, (path, h)) in set.iter().enumerate() {
        let expected = active.len() * k / n..active.len() * (k + 1) / n;
        let ranges = points.part(k, n);
        if h.cells != expected || h.points.as_ref() != Some(&ranges) {
            return Err(FileError::invalid(
                path,
                "cells",
                format!("covers active cells {:?}; shard {k}/{n} of this bake fits {expected:?}", h.cells),
            ));
        }
        let body = read_body(path, h)?;
        let PartBody::Fit(part) = body else {
            return Err(FileError::invalid(path, "kind", "is no longer a fit part"));
        };
        let right_cells = part.cells.len() == expected.len()
            && part.cells.iter().zip(&active[expected]).all(|(c, &a)| {
                let stored = c.fit.level == fit::Level::Map;
                c.fit.cell as usize == a
                    && c.fit.level == c.fit.selection.level()
                    && c.fitted.len() == if stored { n2 } else { 0 }
                    && c.init.is_empty()
                    && c.fitted.iter().all(|x| x.is_finite())
            });
        if !right_cells {
            return Err(FileError::invalid(path, "cells", "cells or maps that do not match the bake and the settings"));
        }
        if part.references.train.len() != ranges.train.len() || part.references.check.len() != ranges.check.len() {
            return Err(FileError::invalid(path, "references", "not as many as its surface points"));
        }
        if !part.references.train.iter().chain(&part.references.check).all(|r| r.is_finite()) {
            return Err(FileError::invalid(path, "references", "a reference that is not finite"));
        }
        cells.extend(part.cells);
        references.append(part.references);
    }
    Ok((cells, references))
}
