//! The rays the tool traces, kept per stream when `WARPFIT_DUMP_STREAMS=DIR` is set: which
//! stage issued them (the probe bake, the grid bake, the fit, the evaluation) and what kind
//! they are (the first ray of an estimate, a bounce, a shadow or visibility query), in the
//! order they were issued (with `--threads 1`, one thread's order), so the tracer can be
//! measured against another on the very rays the tool traces (`benches/embree_streams.sh`).
//! Off, it costs one relaxed atomic load per ray.

use glam::Vec3;
use std::io::Write as _;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// Which part of the pipeline traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Stage {
    Other = 0,
    ProbeBake = 1,
    GridBake = 2,
    Fit = 3,
    Eval = 4,
}

const STAGES: [&str; 5] = ["other", "probe_bake", "grid_bake", "fit", "eval"];

/// What a ray is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// The first ray of an estimate: a probe or grid texel's, a reference's, a view pixel's.
    Primary = 0,
    /// A path's next ray off a surface.
    Bounce = 1,
    /// Is anything closer than `tmax` (a light's shadow ray, a visibility test)?
    Shadow = 2,
}

const KINDS: [&str; 3] = ["primary", "bounce", "shadow"];

/// Rays kept per stream: the first this many it issues.
pub const CAP: usize = 2_000_000;

static ON: AtomicBool = AtomicBool::new(false);
static STAGE: AtomicU8 = AtomicU8::new(0);
/// Per stream (stage × kind): origin, direction, tmax.
static STREAMS: Mutex<Vec<Vec<[f32; 7]>>> = Mutex::new(Vec::new());
/// The world triangles of the last tracer built while on.
static TRIANGLES: Mutex<Vec<f32>> = Mutex::new(Vec::new());

/// Starts keeping rays when `WARPFIT_DUMP_STREAMS` names a folder; returns it.
pub fn start_from_env() -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("WARPFIT_DUMP_STREAMS").filter(|d| !d.is_empty())?;
    ON.store(true, Ordering::Relaxed);
    Some(dir.into())
}

/// The stage tracing from now on.
pub fn set_stage(stage: Stage) {
    STAGE.store(stage as u8, Ordering::Relaxed);
}

/// Whether rays are being kept.
#[inline]
pub fn on() -> bool {
    ON.load(Ordering::Relaxed)
}

/// Keeps one ray of `kind` (unit `dir`, up to `tmax`) in the current stage's stream.
#[inline]
pub fn record(kind: Kind, origin: Vec3, dir: Vec3, tmax: f32) {
    if on() {
        keep(kind, origin, dir, tmax);
    }
}

#[cold]
fn keep(kind: Kind, o: Vec3, d: Vec3, tmax: f32) {
    let stream = STAGE.load(Ordering::Relaxed) as usize * KINDS.len() + kind as usize;
    let mut s = STREAMS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if s.len() <= stream {
        s.resize_with(STAGES.len() * KINDS.len(), Vec::new);
    }
    if s[stream].len() < CAP {
        s[stream].push([o.x, o.y, o.z, d.x, d.y, d.z, tmax]);
    }
}

/// The scene's world triangles (`v0`, `v1`, `v2` per triangle), when rays are being kept.
pub fn set_triangles(v0: &[Vec3], v1: &[Vec3], v2: &[Vec3]) {
    if on() {
        let tris = v0.iter().zip(v1).zip(v2).flat_map(|((a, b), c)| [*a, *b, *c]).flat_map(|v| v.to_array()).collect();
        *TRIANGLES.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = tris;
    }
}

/// Writes every stream kept into `dir`: `scene.tris.f32` (float32 LE, triangles × 3 corners
/// × xyz), and per stream `<stage>_<kind>.rays.f32` (origin xyz, unit direction xyz),
/// `<stage>_<kind>.tmax.f32` (each ray's reach; infinite as 3.4e38) and a link to the
/// triangles as `<stage>_<kind>.tris.f32`, the layout `examples/ray_rate.rs` and the Embree
/// scripts read. Returns (stream name, rays) of each.
pub fn write(dir: &Path) -> std::io::Result<Vec<(String, usize)>> {
    std::fs::create_dir_all(dir)?;
    let bytes = |v: &mut dyn Iterator<Item = f32>| -> Vec<u8> { v.flat_map(f32::to_le_bytes).collect() };
    let tris = bytes(&mut TRIANGLES.lock().unwrap_or_else(std::sync::PoisonError::into_inner).iter().copied());
    std::fs::write(dir.join("scene.tris.f32"), &tris)?;
    let streams = STREAMS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut out = Vec::new();
    for (k, rays) in streams.iter().enumerate().filter(|(_, r)| !r.is_empty()) {
        let name = format!("{}_{}", STAGES[k / KINDS.len()], KINDS[k % KINDS.len()]);
        std::fs::write(
            dir.join(format!("{name}.rays.f32")),
            bytes(&mut rays.iter().flat_map(|r| r.iter().take(6).copied())),
        )?;
        let tmax = bytes(&mut rays.iter().map(|r| r[6].min(f32::MAX)));
        std::fs::write(dir.join(format!("{name}.tmax.f32")), tmax)?;
        let linked = dir.join(format!("{name}.tris.f32"));
        let _ = std::fs::remove_file(&linked);
        std::fs::hard_link(dir.join("scene.tris.f32"), &linked).or_else(|_| std::fs::write(&linked, &tris))?;
        out.push((name, rays.len()));
    }
    let mut list = std::fs::File::create(dir.join("streams.txt"))?;
    for (name, n) in &out {
        writeln!(list, "{name} {n}")?;
    }
    Ok(out)
}
