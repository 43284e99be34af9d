//! Shared test helpers: small scenes built from TOML text.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use warpfit::scene::{Scene, SceneError};

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn scene_file(name: &str) -> PathBuf {
    repo().join("data/scenes").join(format!("{name}.toml"))
}

pub fn load(name: &str) -> Scene {
    Scene::load(&scene_file(name)).expect("built-in scene loads")
}

/// Minimal probe/grid header so test scenes only need geometry.
pub const HEADER: &str = r#"
[probe]
position = [0.0, 1.0, 0.0]
resolution = 16
samples_per_texel = 1
ggx_samples = 8
[grid]
min = [-1.0, 0.0, -1.0]
max = [1.0, 2.0, 1.0]
counts = [2, 2, 2]
irradiance_resolution = 4
depth_resolution = 8
depth_samples = 1
"#;

/// Parses a scene from `HEADER + body`, as if it lived in tests/fixtures/.
pub fn parse(body: &str) -> Result<Scene, SceneError> {
    let text = format!("{HEADER}\n{body}");
    Scene::parse(&text, &repo().join("tests/fixtures/inline.toml"))
}

pub fn fixture(name: &str) -> PathBuf {
    repo().join("tests/fixtures").join(name)
}

/// A test's scratch folder under the system's temp folder, removed when the test ends,
/// passed or failed (it is dropped while unwinding too), so repeated runs leave nothing
/// behind. `WARPFIT_KEEP_TEST_DIRS=1` keeps them for a look.
pub struct TestDir(PathBuf);

impl std::ops::Deref for TestDir {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<Path> for TestDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl From<&TestDir> for PathBuf {
    fn from(d: &TestDir) -> PathBuf {
        d.0.clone()
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        if !std::env::var("WARPFIT_KEEP_TEST_DIRS").is_ok_and(|v| v == "1") {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

pub fn tmp_dir(tag: &str) -> TestDir {
    let d = std::env::temp_dir().join(format!("warpfit-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TestDir(d)
}

/// The scratch folder of a fixture kept for the whole test process (a `static`, which is
/// never dropped, so [`TestDir`]'s clean-up never runs): under cargo's per-target scratch
/// folder, and the folders of the same tag left by earlier processes (no longer running)
/// are removed first, so repeated runs keep one.
pub fn fixture_dir(tag: &str) -> TestDir {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let prefix = format!("warpfit-fixture-{tag}-");
    if let Ok(entries) = std::fs::read_dir(root) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let stale = name
                .strip_prefix(&prefix)
                .and_then(|pid| pid.parse::<u32>().ok())
                .is_some_and(|pid| pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists());
            if stale {
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
    }
    let d = root.join(format!("{prefix}{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TestDir(d)
}

pub fn exists(p: &Path) -> bool {
    p.exists()
}

/// Whether checks that need an external tool (the OpenEXR Python binding, Chromium, …) must
/// run: `.ci/run` sets `WARPFIT_REQUIRE_EXTERNAL=1`, so in CI a missing tool fails the test
/// instead of skipping it.
pub fn external_required() -> bool {
    std::env::var("WARPFIT_REQUIRE_EXTERNAL").is_ok_and(|v| v == "1")
}

/// A check's external tool is missing: fails where tools are required, else says loudly
/// that the check was SKIPPED (and how to get the tool).
pub fn tool_missing(check: &str, tool: &str, how: &str) {
    assert!(!external_required(), "{check}: {tool} is required (WARPFIT_REQUIRE_EXTERNAL=1) but missing; {how}");
    // straight to the process's stderr, past the test harness's capture, so it is seen
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "\n*** SKIPPED: {check}: {tool} is not installed ({how}) ***\n");
}

/// A lit torture grid small enough for a test: 64² probe, 5 × 2 × 5 cells, the quick fit,
/// written as a fitted grid folder. It stores warp maps, relocated probes and diffuse
/// corrections.
pub struct SmallTorture {
    pub scene: Scene,
    pub tracer: warpfit::trace::Tracer,
    pub probe: warpfit::bake::SpecularProbe,
    pub grid: warpfit::bake::ProbeGrid,
    pub fit: warpfit::fit::Fit,
    pub warp: warpfit::warp::Warp,
}

impl SmallTorture {
    /// Bakes and fits it, writing the grid (f32) into `dir`.
    pub fn fit_into(dir: &Path) -> SmallTorture {
        use warpfit::jobs::run::{self as job, Output, StoreOptions};
        let mut scene = load("torture");
        scene.config.probe.resolution = 64;
        scene.config.probe.samples_per_texel = 2;
        scene.config.grid.counts = [5, 2, 5];
        let tracer = warpfit::trace::Tracer::new(&scene);
        let quiet = warpfit::progress::Progress::quiet();
        let baked = warpfit::bake::bake(&scene, &tracer, &quiet);
        let (probe, grid) = (baked.probe, baked.grid);
        let b =
            job::Baked { scene: &scene, tracer: &tracer, probe: &probe, others: &[], grid: &grid, references: None };
        let warp = b.warp(warpfit::warp::WarpOptions::standard());
        let out = Output { folder: &warpfit::report::folder::RunFolder::new(dir), command: "test", progress: &quiet };
        let (fit, _) = job::fit(
            b,
            &warp,
            &warpfit::fit::FitSettings::quick(),
            StoreOptions::default(),
            warpfit::fit::MapSets::WithUnfitted,
            out,
        )
        .unwrap();
        SmallTorture { scene, tracer, probe, grid, fit, warp }
    }

    /// The bake, as the jobs take it.
    pub fn baked(&self) -> warpfit::jobs::run::Baked<'_> {
        warpfit::jobs::run::Baked {
            scene: &self.scene,
            tracer: &self.tracer,
            probe: &self.probe,
            others: &[],
            grid: &self.grid,
            references: None,
        }
    }
}
