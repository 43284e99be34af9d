//! The data flows one way: every `crate::` path in both crates' sources (`src/` and
//! `crates/warpfit-runtime/src/`) is checked against the layering ARCHITECTURE.md states. A
//! module may only name modules on a lower floor, the runtime layer never names the offline
//! tool, and the pairs listed under `NEVER` stay apart. The runtime crate depends on glam,
//! libm, serde, serde_json and exr alone.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Floors, bottom first: a module may use modules on lower floors only (and itself).
const FLOORS: &[&[&str]] = &[
    &["octa", "files", "progress", "tonemap"],
    &["sampling"],
    &["grid", "sh", "roughness", "scene"],
    &["warp"],
    &["gridfile"],
    &["runtime"],
    &["trace"],
    &["bake", "perceptual"],
    &["fit", "eval"],
    &["bakefile", "export", "partfile", "preview"],
    &["render"],
    &["report"],
    &["jobs"],
    &["cli"],
];

/// What a game links (the crate `warpfit-runtime`): never imports the offline tool.
const RUNTIME_LAYER: &[&str] = &["octa", "sh", "tonemap", "grid", "files", "roughness", "warp", "gridfile", "runtime"];

/// The runtime crate's only dependencies.
const RUNTIME_DEPENDENCIES: &[&str] = &["exr", "glam", "libm", "serde", "serde_json"];

/// Pairs the floors would allow but the design forbids: (module, what it never uses, why).
const NEVER: &[(&str, &str, &str)] = &[
    ("bake", "gridfile", "baking computes; the files are bakefile's and gridfile's"),
    ("bake", "files", "baking computes; it writes nothing"),
    ("fit", "gridfile", "the fit hands plain data to the grid writer; it knows no file format"),
    ("fit", "files", "the fit writes nothing; report writes its diagnostics"),
    ("eval", "files", "judging writes nothing; report writes eval.json"),
    ("eval", "gridfile", "eval reads a fitted grid only through the runtime sampler"),
    ("trace", "bake", "ground truth never depends on a bake"),
];

fn floor_of(module: &str) -> Option<usize> {
    FLOORS.iter().position(|f| f.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a file of `src/` belongs to (`None` for lib.rs and main.rs).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let first = rel.components().next()?.as_os_str().to_string_lossy().into_owned();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main").then_some(name)
}

/// The top-level modules a line names through `crate::` (grouped imports included).
fn named_modules(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(k) = rest.find("crate::") {
        rest = &rest[k + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let name: String = item.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                if !name.is_empty() {
                    out.push(name);
                }
            }
        } else {
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            out.push(name);
        }
    }
    out
}

/// The sources of both crates: the offline tool's, then the runtime's.
fn source_dirs() -> [PathBuf; 2] {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    [root.join("src"), root.join("crates/warpfit-runtime/src")]
}

/// Every (module, named module, file:line) in both crates' sources, comments left out.
fn arrows() -> Vec<(String, String, String)> {
    source_dirs().iter().flat_map(|src| arrows_in(src)).collect()
}

/// [`arrows`] of one crate's source folder.
fn arrows_in(src: &Path) -> Vec<(String, String, String)> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut out = Vec::new();
    for f in &files {
        let Some(module) = module_of(src, f) else { continue };
        let text = std::fs::read_to_string(f).unwrap();
        for (n, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("//") {
                continue;
            }
            for named in named_modules(line) {
                if named != module {
                    let at = format!("{}:{}", f.strip_prefix(src).unwrap().display(), n + 1);
                    out.push((module.clone(), named, at));
                }
            }
        }
    }
    out
}

#[test]
fn every_module_is_on_a_floor() {
    let unknown: Vec<_> = arrows()
        .into_iter()
        .flat_map(|(a, b, at)| [(a, at.clone()), (b, at)])
        .filter(|(m, _)| floor_of(m).is_none())
        .collect();
    assert!(unknown.is_empty(), "modules missing from FLOORS (add them, and to ARCHITECTURE.md): {unknown:?}");
}

#[test]
fn imports_only_run_downwards() {
    let upward: Vec<String> = arrows()
        .into_iter()
        .filter(|(a, b, _)| matches!((floor_of(a), floor_of(b)), (Some(fa), Some(fb)) if fb >= fa))
        .map(|(a, b, at)| format!("{at}: {a} uses {b}"))
        .collect();
    assert!(upward.is_empty(), "imports that run sideways or up:\n{}", upward.join("\n"));
}

#[test]
fn the_runtime_layer_never_names_the_offline_tool() {
    let leaks: Vec<String> = arrows_in(&source_dirs()[1])
        .into_iter()
        .filter(|(a, b, _)| RUNTIME_LAYER.contains(&a.as_str()) && !RUNTIME_LAYER.contains(&b.as_str()))
        .map(|(a, b, at)| format!("{at}: {a} uses {b}"))
        .collect();
    assert!(leaks.is_empty(), "runtime modules naming offline ones:\n{}", leaks.join("\n"));
}

#[test]
fn forbidden_pairs_stay_apart() {
    let mut hits: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (a, b, at) in arrows() {
        if let Some((_, _, why)) = NEVER.iter().find(|(x, y, _)| *x == a && *y == b) {
            hits.entry(format!("{a} → {b} ({why})")).or_default().push(at);
        }
    }
    assert!(hits.is_empty(), "forbidden imports: {hits:#?}");
}

#[test]
fn the_scanner_sees_grouped_and_inline_paths() {
    assert_eq!(named_modules("use crate::{octa, warp::Warp};"), ["octa", "warp"]);
    assert_eq!(named_modules("let x = crate::octa::encode(d) + crate::grid::f();"), ["octa", "grid"]);
}

#[test]
fn the_runtime_crate_holds_only_runtime_modules() {
    let src = &source_dirs()[1];
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let strays: Vec<String> =
        files.iter().filter_map(|f| module_of(src, f)).filter(|m| !RUNTIME_LAYER.contains(&m.as_str())).collect();
    assert!(strays.is_empty(), "offline modules in the runtime crate: {strays:?}");
}

#[test]
fn the_runtime_crate_depends_on_glam_libm_serde_serde_json_and_exr_alone() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("crates/warpfit-runtime/Cargo.toml");
    let manifest: toml::Table = std::fs::read_to_string(&path).unwrap().parse().unwrap();
    let names = |section: &str| -> Vec<String> {
        manifest.get(section).and_then(|d| d.as_table()).map(|t| t.keys().cloned().collect()).unwrap_or_default()
    };
    assert_eq!(names("dependencies"), RUNTIME_DEPENDENCIES, "the runtime's dependencies");
    assert!(names("build-dependencies").is_empty(), "the runtime has no build script dependencies");
    assert!(manifest.get("target").is_none(), "no platform-specific dependencies");
    // default features only where they are off (exr's threads are the offline tool's)
    let exr = &manifest["dependencies"]["exr"];
    assert_eq!(exr.get("default-features").and_then(|v| v.as_bool()), Some(false), "exr without rayon");
}
