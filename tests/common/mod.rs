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

pub fn tmp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("warpfit-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
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
