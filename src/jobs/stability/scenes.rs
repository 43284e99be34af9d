//! The stability suite's scenes and fixtures: the committed tiny scene, a room with a solid
//! block and a 1e-3 wall, an open floor, special directions, and a bake + fit + load fixture
//! with its scratch folder. Also the checks every case applies to outputs (finite, unit).

use super::Mode;
use crate::bake::{self, Bake};
use crate::fit::FitSettings;
use crate::fit::MapSets;
use crate::jobs::run::{self, Baked, Output, StoreOptions};
use crate::progress::Progress;
use crate::report::folder::RunFolder;
use crate::runtime::FittedGrid;
use crate::sampling::{Sampler, uniform_sphere};
use crate::scene::Scene;
use crate::trace::Tracer;
use crate::warp::{Method, Warp, WarpOptions};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// The committed small scene every case starts from (a room open to the sky, a block, a
/// column, a sun).
pub const TINY: &str = include_str!("../../../data/scenes/tiny.toml");

/// Two closed rooms side by side split by a wall 1e-3 thick at x = 0.24, 0.01 before the
/// centres of the cells at x = 0.25 (grid cells of 0.5): a sphere light in the left room,
/// no light at all in the right one, whose true irradiance is therefore zero. `relocate`
/// is `grid.relocate_clearance`.
pub fn two_rooms(relocate: f32) -> String {
    format!(
        r#"
name = "two_rooms"
seed = 7
bounces = 1
[probe]
position = [-1.0, 1.0, 0.0]
resolution = 32
samples_per_texel = 2
ggx_samples = 16
[grid]
min = [-2.0, 0.0, -1.0]
max = [2.0, 2.0, 1.0]
counts = [8, 4, 4]
irradiance_resolution = 8
depth_resolution = 16
depth_samples = 4
relocate_clearance = {relocate}
[sky]
color = [0.0, 0.0, 0.0]
[[sphere_lights]]
position = [-1.2, 1.5, 0.3]
radius = 0.1
radiance = [60.0, 55.0, 50.0]
[[geometry]]
type = "room"
min = [-2.0, 0.0, -1.0]
max = [2.0, 2.0, 1.0]
material = {{ albedo = [0.7, 0.7, 0.7] }}
[[geometry]]
type = "box"
min = [0.24, 0.0, -1.0]
max = [0.241, 2.0, 1.0]
material = {{ albedo = [0.7, 0.7, 0.7] }}
"#
    )
}

/// A room 4×2×4 with a solid block filling the cells x<0, y<1, z<0 of a 4×2×4 grid, a wall
/// 1e-3 thick across it, a window, and a sun of irradiance `sun`.
pub fn block_room(sun: f32, albedo: f32) -> String {
    format!(
        r#"
name = "block_room"
seed = 5
bounces = 1
[probe]
position = [0.6, 1.3, 0.7]
resolution = 32
samples_per_texel = 2
ggx_samples = 16
[grid]
min = [-2.0, 0.0, -2.0]
max = [2.0, 2.0, 2.0]
counts = [4, 2, 4]
irradiance_resolution = 4
depth_resolution = 8
depth_samples = 2
[sky]
color = [0.2, 0.3, 0.5]
[sun]
direction = [0.3, 0.9, 0.2]
angular_radius_deg = 0.27
irradiance = [{sun}, {sun}, {sun}]
[[geometry]]
type = "room"
min = [-2.0, 0.0, -2.0]
max = [2.0, 2.0, 2.0]
open = ["+y"]
material = {{ albedo = [{albedo}, {albedo}, {albedo}] }}
[[geometry]]
type = "box"
min = [-2.0, 0.0, -2.0]
max = [0.0, 1.0, 0.0]
[[geometry]]
type = "box"
min = [1.0, 0.0, -1.5]
max = [1.001, 1.8, 1.5]
"#
    )
}

/// A floor 100 units wide under an open sky.
pub const OPEN_FLOOR: &str = r#"
name = "open_floor"
seed = 2
[probe]
position = [0.0, 1.0, 0.0]
resolution = 32
samples_per_texel = 2
ggx_samples = 16
[grid]
min = [-2.0, 0.1, -2.0]
max = [2.0, 2.1, 2.0]
counts = [2, 1, 2]
irradiance_resolution = 4
depth_resolution = 8
depth_samples = 2
[sky]
zenith = [0.3, 0.5, 1.0]
horizon = [0.9, 0.9, 1.0]
ground = [0.2, 0.2, 0.2]
[[geometry]]
type = "box"
min = [-50.0, -1.0, -50.0]
max = [50.0, 0.0, 50.0]
"#;

pub fn parse(text: &str, name: &str) -> Result<Scene, String> {
    Scene::parse(text, Path::new(&format!("<stability>/{name}.toml"))).map_err(|e| e.to_string())
}

pub fn finite3(v: &[Vec3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

pub fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Bake outputs that must be finite (distances may be +inf for sky; never NaN).
pub fn bake_is_clean(b: &Bake) -> bool {
    b.probe.radiance.levels.iter().all(|l| finite3(&l.texels))
        && b.probe.depth.levels.iter().all(|l| l.texels.iter().all(|d| !d.is_nan() && *d >= 0.0))
        && finite3(&b.grid.irradiance)
        && finite(&b.grid.depth_mean)
        && finite(&b.grid.depth_mean_sq)
}

pub fn unit_and_finite(v: Vec3) -> bool {
    v.is_finite() && (v.length() - 1.0).abs() < 1e-3
}

/// Directions on the octahedral map's seams, poles and diagonals, and just beside them.
pub fn seam_directions() -> Vec<Vec3> {
    let mut base = Vec::new();
    for a in [-1.0f32, 0.0, 1.0] {
        for b in [-1.0f32, 0.0, 1.0] {
            for c in [-1.0f32, 0.0, 1.0] {
                if (a, b, c) != (0.0, 0.0, 0.0) {
                    base.push(Vec3::new(a, b, c));
                }
            }
        }
    }
    base.push(Vec3::new(-0.0, -0.0, -1.0));
    base.push(Vec3::new(-0.0, 1.0, -0.0));
    let mut out = Vec::new();
    for d in base {
        out.push(d.normalize());
        for e in [1e-7f32, -1e-7, f32::MIN_POSITIVE, 1e-30] {
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                out.push((d + axis * e).normalize());
            }
        }
    }
    out
}

/// `n` directions: a seeded uniform set plus the seam directions.
pub fn directions(n: u32) -> Vec<Vec3> {
    let mut d: Vec<Vec3> = (0..n).map(|k| uniform_sphere(Sampler::new(0x57AB, 1, k).next_2d())).collect();
    d.extend(seam_directions());
    d
}

/// Every per-lookup method at `b` over `dirs`: how many fetch directions are not finite unit
/// vectors.
pub fn bad_fetches(warp: &Warp, b: Vec3, dirs: &[Vec3]) -> usize {
    let mut bad = 0;
    for m in Method::PER_LOOKUP {
        for &d in dirs {
            let f = warp.fetch_dir(m, b, d);
            let r = warp.lookup(m, b, d);
            if !unit_and_finite(f) || !r.is_finite() {
                bad += 1;
            }
        }
    }
    bad
}

/// Runtime answers at `b` over `dirs` that are not finite and ≥ 0.
pub fn bad_runtime(g: &FittedGrid, b: Vec3, dirs: &[Vec3]) -> usize {
    let mut bad = 0;
    for &d in dirs {
        for r in [0.0, 0.3, 1.0] {
            let s = g.specular(b, d, r);
            if !s.is_finite() || s.min_element() < 0.0 {
                bad += 1;
            }
        }
        let e = g.irradiance(b, d);
        if !e.is_finite() || e.min_element() < 0.0 {
            bad += 1;
        }
    }
    bad
}

/// A scene, its tracer, its bake and the warp context.
pub struct Fixture {
    pub scene: Scene,
    pub tracer: Tracer,
    pub bake: Bake,
    pub warp: Warp,
}

impl Fixture {
    pub fn new(scene: Scene) -> Fixture {
        let tracer = Tracer::new(&scene);
        let bake = bake::bake(&scene, &tracer, &Progress::quiet());
        let warp = bake::warp(&scene, &bake.probe, WarpOptions::standard());
        Fixture { scene, tracer, bake, warp }
    }

    pub fn baked(&self) -> Baked<'_> {
        self.bake.baked(&self.scene, &self.tracer)
    }

    /// Fits, writes the fitted grid to a fresh folder and loads it back.
    pub fn fit_and_load(
        &self,
        mode: Mode,
        store: StoreOptions,
    ) -> Result<(crate::fit::Fit, FittedGrid, TempDir), String> {
        let dir = TempDir::new(&self.scene.name);
        let folder = RunFolder::new(&dir.0);
        let out = Output { folder: &folder, command: "warpfit stability", progress: &Progress::quiet() };
        let (fit, _) = run::fit(self.baked(), &self.warp, &fit_settings(mode), store, MapSets::Stored, out)
            .map_err(|e| e.to_string())?;
        let g = FittedGrid::load(&dir.0).map_err(|e| e.to_string())?;
        Ok((fit, g, dir))
    }
}

pub fn fit_settings(mode: Mode) -> FitSettings {
    match mode {
        Mode::Quick => FitSettings::quick(),
        Mode::Full => FitSettings::moderate(),
    }
}

/// A scratch folder removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> TempDir {
        use std::sync::atomic::{AtomicU32, Ordering};
        static N: AtomicU32 = AtomicU32::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let p = std::env::temp_dir().join(format!("warpfit-stability-{}-{tag}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
