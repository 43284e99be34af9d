//! Nothing lost, nothing hung: fit folders are replaced whole (killed at every rename, the
//! folder still loads the old fit or the new one), a second writer is refused, leftovers of
//! killed runs are cleaned, bakes are reused only for identical inputs, and the grid loader
//! and the scene loader meet bombs, FIFOs, /dev/zero and edited manifests with errors that
//! name the file, within a time budget.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};
use warpfit::gridfile::exr::{ExrLayer, Samples};
use warpfit::gridfile::{GridManifest, MANIFEST_FILE};
use warpfit::runtime::FittedGrid;

fn warpfit(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_warpfit"));
    c.args(args).current_dir(repo());
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("warpfit runs")
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// A fit of `tiny` into `out` with `train_dirs` (different values give different grids).
fn fit_tiny(out: &Path, train_dirs: u32, env: &[(&str, &str)]) -> Output {
    let out = out.to_string_lossy().into_owned();
    let dirs = train_dirs.to_string();
    warpfit(
        &[
            "--quiet",
            "--threads",
            "2",
            "fit",
            "--scene",
            "data/scenes/tiny.toml",
            "--out",
            &out,
            "--train-positions",
            "4",
            "--train-dirs",
            &dirs,
        ],
        env,
    )
}

/// What identifies a fit's content: its payloads' checksums (the manifest also records the
/// fit's timing, which differs from run to run).
fn manifest_checksum(dir: &Path) -> String {
    let m: GridManifest = serde_json::from_slice(&std::fs::read(dir.join(MANIFEST_FILE)).unwrap()).unwrap();
    payload_sums(&m)
}

fn payload_sums(m: &GridManifest) -> String {
    m.payloads.iter().map(|p| p.checksum.clone()).collect::<Vec<_>>().join(",")
}

/// Entries beside `dir` whose names start with `.<name>.` (locks, staging folders).
fn leftovers(dir: &Path) -> Vec<String> {
    let name = dir.file_name().unwrap().to_string_lossy().into_owned();
    std::fs::read_dir(dir.parent().unwrap())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&format!(".{name}.")))
        .collect()
}

#[test]
fn a_run_killed_at_any_rename_leaves_the_old_fit_or_the_new_one() {
    let root = tmp_dir("kill");
    let out = root.join("fit");
    assert!(fit_tiny(&out, 16, &[]).status.success());
    let old = manifest_checksum(&out);
    // the new fit, made elsewhere, to recognise it
    let reference = root.join("reference");
    assert!(fit_tiny(&reference, 32, &[]).status.success());
    let new = manifest_checksum(&reference);
    assert_ne!(old, new);

    let mut killed = 0;
    for n in 1..200u32 {
        let fault = format!("{n}:abort");
        let o = fit_tiny(&out, 32, &[("WARPFIT_TEST_FAULT_RENAME", &fault)]);
        let grid =
            FittedGrid::load(&out).unwrap_or_else(|e| panic!("killed at rename {n}: the folder does not load: {e}"));
        let now = payload_sums(grid.manifest());
        assert!(now == old || now == new, "killed at rename {n}: a grid that is neither the old nor the new one");
        if o.status.success() {
            assert_eq!(now, new, "the run that was not killed committed the new fit");
            break;
        }
        killed += 1;
        assert_eq!(now, old, "killed at rename {n}, before the commit: the old fit stays");
        // with an I/O error at the same rename the run fails cleanly and keeps the old fit;
        // or, where the rename was a traced reference set's (kept for later runs, not part of
        // the fit), it goes on without keeping that set, says so, and commits the new fit
        let o = fit_tiny(&out, 32, &[("WARPFIT_TEST_FAULT_RENAME", &n.to_string())]);
        assert!(text(&o).contains("injected failure"), "{}", text(&o));
        if o.status.success() {
            assert!(text(&o).contains("traced references not kept"), "rename {n}: {}", text(&o));
            assert_eq!(payload_sums(FittedGrid::load(&out).unwrap().manifest()), new);
            assert!(fit_tiny(&out, 16, &[]).status.success(), "the old fit again");
            assert_eq!(manifest_checksum(&out), old);
        } else {
            assert_eq!(manifest_checksum(&out), old);
        }
        assert!(leftovers(&out).is_empty(), "a failed run cleans up after itself: {:?}", leftovers(&out));
    }
    assert!(killed >= 5, "the fit renames files more than a few times ({killed} kill points)");
    // the killed runs' staging folders and locks are gone after the next successful run
    assert!(leftovers(&out).is_empty(), "{:?}", leftovers(&out));
}

#[test]
fn a_second_writer_is_refused_and_stale_leftovers_are_removed() {
    let root = tmp_dir("lock");
    let out = root.join("fit");
    assert!(fit_tiny(&out, 16, &[]).status.success());
    let old = manifest_checksum(&out);
    {
        // this process holds the folder, as a concurrent run would
        let _lock = warpfit::files::staged::FolderLock::acquire(&out).unwrap();
        let o = fit_tiny(&out, 32, &[]);
        assert!(!o.status.success());
        assert!(text(&o).contains("another warpfit process"), "{}", text(&o));
        assert_eq!(manifest_checksum(&out), old);
    }
    // a killed run's lock, staging folder and temporary file (pid 4000000 does not exist)
    std::fs::write(root.join(".fit.lock"), format!("4000000 {}", hostname())).unwrap();
    std::fs::create_dir_all(root.join(".fit.staging-4000000")).unwrap();
    std::fs::write(out.join(".eval.json.tmp-4000000"), b"half").unwrap();
    let o = fit_tiny(&out, 32, &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(leftovers(&out).is_empty(), "{:?}", leftovers(&out));
    assert!(!out.join(".eval.json.tmp-4000000").exists());
}

fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname").map(|s| s.trim().to_string()).unwrap_or_default()
}

#[test]
fn a_fit_replaces_what_described_the_old_one() {
    let root = tmp_dir("stale-eval");
    let out = root.join("fit");
    assert!(fit_tiny(&out, 16, &[]).status.success());
    std::fs::write(out.join("eval.json"), b"{}").unwrap();
    std::fs::write(out.join("report.html"), b"old").unwrap();
    assert!(fit_tiny(&out, 32, &[]).status.success());
    assert!(!out.join("eval.json").exists() && !out.join("report.html").exists(), "old evaluation left behind");
    assert!(out.join("bake").join("manifest.json").is_file(), "the bake is carried over");
}

/// A copy of `tiny` whose geometry comes from an OBJ file beside it.
fn obj_scene(dir: &Path, y_top: f32) -> PathBuf {
    let obj = format!(
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -1 {y_top} -1\nv 1 {y_top} -1\nv 1 {y_top} 1\nv -1 {y_top} 1\n\
         f 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\nf 1 5 6\nf 1 6 2\nf 2 6 7\nf 2 7 3\nf 3 7 8\nf 3 8 4\nf 4 8 5\nf 4 5 1\n"
    );
    std::fs::write(dir.join("room.obj"), obj).unwrap();
    let scene = dir.join("room.toml");
    std::fs::write(&scene, format!("{HEADER}\n[[geometry]]\ntype = \"obj\"\npath = \"room.obj\"\n")).unwrap();
    scene
}

#[test]
fn a_bake_is_reused_only_for_the_same_input_files() {
    let root = tmp_dir("content-key");
    let scene = obj_scene(&root, 2.0);
    let out = root.join("out");
    let quiet = warpfit::progress::Progress::quiet();
    let folder = warpfit::report::folder::RunFolder::new(&out);
    let s = warpfit::scene::Scene::load(&scene).unwrap();
    assert_eq!(s.inputs.len(), 1, "the OBJ is an input");
    let key = s.content_key();
    let p = warpfit::jobs::run::prepare(s, folder.clone(), &quiet).unwrap();
    assert!(p.baked_now);
    let p = warpfit::jobs::run::prepare(warpfit::scene::Scene::load(&scene).unwrap(), folder.clone(), &quiet).unwrap();
    assert!(!p.baked_now, "same files: reused");
    // the mesh changes, the scene file does not
    obj_scene(&root, 2.2);
    let s = warpfit::scene::Scene::load(&scene).unwrap();
    assert_ne!(s.content_key(), key);
    let p = warpfit::jobs::run::prepare(s, folder.clone(), &quiet).unwrap();
    assert!(p.baked_now, "an edited mesh is baked again");
    // a damaged bake file is not reused
    let probe = out.join("bake/probe.exr");
    let mut bytes = std::fs::read(&probe).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 1;
    std::fs::write(&probe, bytes).unwrap();
    let p = warpfit::jobs::run::prepare(warpfit::scene::Scene::load(&scene).unwrap(), folder, &quiet).unwrap();
    assert!(p.baked_now, "a bake whose checksum fails is baked again");
}

// ---- the grid loader ---------------------------------------------------------------------

fn copy_tiny(tag: &str) -> TestDir {
    let dir = tmp_dir(tag);
    for f in ["manifest.json", "probe.exr", "correctives.exr", "irradiance.exr"] {
        std::fs::copy(repo().join("fits/tiny").join(f), dir.join(f)).unwrap();
    }
    dir
}

/// Loads `dir` on another thread; an error within `budget`, or the test fails (a hang).
fn load_error_within(dir: &Path, budget: Duration) -> String {
    let d = dir.to_path_buf();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(FittedGrid::load(&d).map(|_| ()).map_err(|e| e.to_string()));
    });
    match rx.recv_timeout(budget) {
        Ok(Err(e)) => e,
        Ok(Ok(())) => panic!("{} loaded", dir.display()),
        Err(_) => panic!("loading {} hung for {budget:?}", dir.display()),
    }
}

/// Edits the manifest and re-seals its checksum, so the edit meets the structural rules.
fn edit_sealed(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let p = dir.join(MANIFEST_FILE);
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
    edit(&mut v);
    let mut m: GridManifest = serde_json::from_value(v).unwrap();
    m.manifest_checksum = m.canonical_checksum();
    std::fs::write(&p, serde_json::to_vec_pretty(&m).unwrap()).unwrap();
}

fn reseal_payload(dir: &Path, file: &str, len: u64, sum: String) {
    edit_sealed(dir, |v| {
        for p in v["payloads"].as_array_mut().unwrap() {
            if p["file"] == file {
                p["bytes"] = len.into();
                p["checksum"] = sum.clone().into();
            }
        }
    });
}

#[test]
fn an_edited_manifest_is_refused() {
    let d = copy_tiny("edited");
    let p = d.join(MANIFEST_FILE);
    let text = std::fs::read_to_string(&p).unwrap();
    // one digit of the probe position changed, nothing else
    let edited = text.replacen("\"position\": [\n      0.3", "\"position\": [\n      0.4", 1);
    assert_ne!(edited, text, "the edit applies");
    std::fs::write(&p, edited).unwrap();
    let e = load_error_within(&d, Duration::from_secs(10));
    assert!(e.contains("manifest.json") && e.contains("checksum"), "{e}");
    // reformatting alone is not an edit
    let d = copy_tiny("reformatted");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join(MANIFEST_FILE)).unwrap()).unwrap();
    std::fs::write(d.join(MANIFEST_FILE), serde_json::to_vec(&v).unwrap()).unwrap();
    assert!(FittedGrid::load(&d).is_ok());
}

#[test]
fn every_structural_rule_of_the_manifest_is_checked() {
    type Edit = fn(&mut serde_json::Value);
    let cases: [(&str, Edit, &str); 23] = [
        ("probe-resolution", |v| v["probe"]["resolution"] = 8192.into(), "probe.resolution"),
        ("mip-halving", |v| v["probe"]["radiance_mips"][1]["resolution"] = 15.into(), "radiance_mips[1].resolution"),
        ("mip-name", |v| v["probe"]["radiance_mips"][0]["layer"] = "distance_mip0".into(), "radiance_mips[0].layer"),
        (
            "mip-roughness",
            |v| v["probe"]["radiance_mips"][1]["perceptual_roughness"] = 0.0.into(),
            "perceptual_roughness",
        ),
        ("distance-name", |v| v["probe"]["distance_mips"][0] = "x".into(), "distance_mips[0]"),
        ("map-res", |v| v["correctives"]["map_res"] = 128.into(), "correctives.map_res"),
        ("columns", |v| v["correctives"]["atlas_columns"] = 0.into(), "correctives.atlas_columns"),
        (
            "duplicate-cell",
            |v| {
                let c = v["correctives"]["stored_cells"].as_array_mut().unwrap();
                c[1] = c[0].clone();
            },
            "sorted and unique",
        ),
        ("tile-res", |v| v["irradiance"]["resolution"] = 3.into(), "irradiance"),
        (
            "corrected-not-stored",
            |v| {
                v["irradiance"]["corrected_cells"] = serde_json::json!([32]);
                v["irradiance"]["correction_columns"] = 1.into();
            },
            "irradiance.corrected_cells",
        ),
        ("correction-res", |v| v["irradiance"]["correction_resolution"] = 5.into(), "irradiance.correction_resolution"),
        ("surface-bias", |v| v["irradiance"]["surface_bias"] = 2.5.into(), "irradiance.surface_bias"),
        ("relocated-far", |v| v["grid"]["relocated"] = serde_json::json!([[3, [0.0, 0.0, 50.0]]]), "grid.relocated"),
        (
            "relocated-order",
            |v| v["grid"]["relocated"] = serde_json::json!([[5, [0.1, 0.0, 0.0]], [3, [0.1, 0.0, 0.0]]]),
            "sorted and unique",
        ),
        ("listing", |v| v["payloads"][0]["layers"][0]["width"] = 16384.into(), "payloads.probe.exr"),
        // values no writer produces, in the manifest
        ("relax", |v| v["warp"]["options"]["relax_texels"] = 1e30.into(), "warp.options"),
        ("depth-lod", |v| v["warp"]["options"]["depth_lod"] = 50.0.into(), "warp.options"),
        ("box-extent", |v| v["warp"]["box_proxy"]["half_extents"][1] = (-1.0).into(), "warp.box_proxy"),
        (
            "kdop-normal",
            |v| v["warp"]["kdop"][0]["normal"] = serde_json::json!([30.0, 0.0, 0.0]),
            "warp.kdop[0].normal",
        ),
        ("kdop-far", |v| v["warp"]["kdop"][1]["offset"] = 3e37.into(), "warp.kdop[1].offset"),
        (
            "f16-distance",
            |v| v["payloads"][0]["layers"][3]["precision"] = "f16".into(),
            "payloads.probe.exr.distance_mip0.precision",
        ),
        (
            "extra-payload",
            |v| {
                let extra = v["payloads"][0].clone();
                v["payloads"].as_array_mut().unwrap().push(extra);
            },
            "payloads",
        ),
        (
            "budget",
            |v| {
                v["grid"]["counts"] = serde_json::json!([256, 256, 256]);
                v["grid"]["relocated"] = serde_json::json!([]);
                let cells: Vec<u32> = (0..1 << 20).collect();
                v["irradiance"]["stored_cells"] = serde_json::json!(cells);
                v["irradiance"]["resolution"] = 64.into();
            },
            "more than the",
        ),
    ];
    for (tag, edit, field) in cases {
        let d = copy_tiny(tag);
        edit_sealed(&d, edit);
        let e = load_error_within(&d, Duration::from_secs(20));
        assert!(e.contains("manifest.json") && e.contains(field), "{tag}: {e}");
    }
}

#[test]
fn a_roughness_table_no_fit_makes_is_refused() {
    for (tag, field, value) in [("table", "table", -5.0), ("alphas", "alphas", 7.0), ("c0", "c0", -1.0)] {
        let d = copy_tiny(&format!("rough-{tag}"));
        let p = d.join(MANIFEST_FILE);
        let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
        match &mut v["roughness"][field] {
            serde_json::Value::Array(a) => a[0] = value.into(),
            x => *x = value.into(),
        }
        std::fs::write(&p, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
        let e = load_error_within(&d, Duration::from_secs(10));
        assert!(e.contains("manifest.json") && e.contains(field), "{tag}: {e}");
    }
}

#[test]
fn a_layer_stored_at_another_precision_than_listed_is_refused() {
    let d = copy_tiny("half-as-f32");
    let path = d.join("probe.exr");
    let layers = warpfit::gridfile::exr::read(&path).unwrap();
    let (len, sum) =
        warpfit::gridfile::exr::write_payload(&path, layers, |name| name.starts_with("radiance_mip")).unwrap();
    reseal_payload(&d, "probe.exr", len, sum);
    let e = load_error_within(&d, Duration::from_secs(10));
    assert!(e.contains("probe.exr") && e.contains("radiance_mip0") && e.contains("F16"), "{e}");
}

#[test]
fn absurd_values_in_a_payload_are_refused() {
    for (tag, file, layer, value) in [
        ("shift", "correctives.exr", "shift_maps", 3e38),
        ("moments", "irradiance.exr", "depth_moments", 3e38),
        ("scale", "irradiance.exr", "irradiance_scale", 0.0),
    ] {
        let d = copy_tiny(tag);
        let path = d.join(file);
        let mut layers = warpfit::gridfile::exr::read(&path).unwrap();
        let l = layers.iter_mut().find(|l| l.name == layer).unwrap();
        l.channels[0].1[3] = value;
        warpfit::gridfile::exr::write(&path, &layers).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        reseal_payload(&d, file, bytes.len() as u64, warpfit::files::checksum(&bytes));
        let e = load_error_within(&d, Duration::from_secs(10));
        assert!(e.contains(file) && e.contains(layer) && e.contains("sample 3"), "{tag}: {e}");
    }
}

/// The bytes of `path` with the EXR header's `dataWindow` and `displayWindow` claiming a
/// `side × side` image (the pixel data is not touched: a decoder that believed the header
/// would allocate for the claim).
fn claim_size(bytes: &[u8], side: i32) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let mut at = 0;
        while let Some(k) = out[at..].windows(name.len()).position(|w| w == name) {
            let v = at + k + name.len() + 4; // after the attribute's size
            out[v + 8..v + 12].copy_from_slice(&(side - 1).to_le_bytes());
            out[v + 12..v + 16].copy_from_slice(&(side - 1).to_le_bytes());
            at = v + 16;
        }
    }
    out
}

#[test]
fn a_payload_bomb_a_fifo_and_dev_zero_are_refused_quickly() {
    // an EXR header claiming a 16384² layer, resealed in the manifest
    let d = copy_tiny("bomb");
    let path = d.join("probe.exr");
    let bomb = claim_size(&std::fs::read(&path).unwrap(), 16384);
    std::fs::write(&path, &bomb).unwrap();
    reseal_payload(&d, "probe.exr", bomb.len() as u64, warpfit::files::checksum(&bomb));
    let e = load_error_within(&d, Duration::from_secs(10));
    assert!(e.contains("probe.exr") && e.contains("16384"), "{e}");

    // a FIFO as a payload and as the manifest
    for file in ["probe.exr", MANIFEST_FILE] {
        let d = copy_tiny(&format!("fifo-{}", file.replace('.', "-")));
        std::fs::remove_file(d.join(file)).unwrap();
        let ok = Command::new("mkfifo").arg(d.join(file)).status().map(|s| s.success()).unwrap_or(false);
        assert!(ok, "mkfifo works");
        let e = load_error_within(&d, Duration::from_secs(10));
        assert!(e.contains(file) && e.contains("not a regular file"), "{e}");
    }
    // /dev/zero linked in as a payload
    let d = copy_tiny("dev-zero");
    std::fs::remove_file(d.join("irradiance.exr")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("irradiance.exr")).unwrap();
    let e = load_error_within(&d, Duration::from_secs(10));
    assert!(e.contains("irradiance.exr") && e.contains("not a regular file"), "{e}");
}

// ---- scene inputs ------------------------------------------------------------------------

/// Loads a scene file on another thread: an error within `budget` that names `names`.
fn scene_error_within(path: &Path, budget: Duration) -> String {
    let p = path.to_path_buf();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(warpfit::scene::Scene::load(&p).map(|_| ()).map_err(|e| e.to_string()));
    });
    match rx.recv_timeout(budget) {
        Ok(Err(e)) => e,
        Ok(Ok(())) => panic!("{} loaded", path.display()),
        Err(_) => panic!("loading {} hung for {budget:?}", path.display()),
    }
}

fn write_scene(dir: &Path, body: &str) -> PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, format!("{HEADER}\n{body}")).unwrap();
    p
}

const ROOM: &str = "[[geometry]]\ntype = \"room\"\nmin = [-1.0, 0.0, -1.0]\nmax = [1.0, 2.0, 1.0]\n";

#[test]
fn scene_values_that_would_overflow_are_refused_with_their_bound() {
    let d = tmp_dir("overflow");
    for (body, field) in [
        (format!("{ROOM}material = {{ emission = [3e38, 0.0, 0.0] }}\n"), "material.emission"),
        (format!("[sky]\nzenith = [3e38, 1.0, 1.0]\n{ROOM}"), "sky.zenith"),
        (format!("[sun]\ndirection = [0.0, 1.0, 0.0]\nirradiance = [3e38, 1.0, 1.0]\n{ROOM}"), "sun.irradiance"),
        (
            format!("[[sphere_lights]]\nposition = [0.0, 1.0, 0.0]\nradius = 0.1\nradiance = [1e30, 1.0, 1.0]\n{ROOM}"),
            "sphere_lights[0].radiance",
        ),
        ("[[geometry]]\ntype = \"box\"\nmin = [0.0, 0.0, 0.0]\nmax = [1e30, 1.0, 1.0]\n".to_string(), "max"),
    ] {
        let p = write_scene(&d, &body);
        let e = scene_error_within(&p, Duration::from_secs(10));
        assert!(e.contains("scene.toml") && e.contains(field) && e.contains("e"), "{field}: {e}");
    }
    // sample counts have an upper bound
    let text = std::fs::read_to_string(write_scene(&d, ROOM))
        .unwrap()
        .replace("samples_per_texel = 1", "samples_per_texel = 1000000000");
    let p = d.join("samples.toml");
    std::fs::write(&p, text).unwrap();
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("probe.samples_per_texel") && e.contains("65536"), "{e}");
    // an array longer than its field is not cut silently
    let text = std::fs::read_to_string(write_scene(&d, ROOM))
        .unwrap()
        .replace("position = [0.0, 1.0, 0.0]", "position = [0.0, 1.0, 0.0, 5.0]");
    let p = d.join("four.toml");
    std::fs::write(&p, text).unwrap();
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("probe.position") && e.contains("4 elements, expected 3"), "{e}");
}

#[test]
fn files_a_scene_reads_must_be_regular_and_inside_its_folder() {
    let d = tmp_dir("scene-files");
    // the scene file itself as a FIFO
    let fifo = d.join("fifo.toml");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let e = scene_error_within(&fifo, Duration::from_secs(10));
    assert!(e.contains("fifo.toml") && e.contains("not a regular file"), "{e}");
    // an OBJ that is /dev/zero, an OBJ that is a FIFO
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.obj")).unwrap();
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"zero.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("zero.obj") && e.contains("not a regular file"), "{e}");
    assert!(Command::new("mkfifo").arg(d.join("pipe.obj")).status().unwrap().success());
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"pipe.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("pipe.obj") && e.contains("not a regular file"), "{e}");
    // an MTL that is a FIFO
    std::fs::write(d.join("lib.obj"), "mtllib pipe.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n").unwrap();
    assert!(Command::new("mkfifo").arg(d.join("pipe.mtl")).status().unwrap().success());
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"lib.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("pipe.mtl") && e.contains("not a regular file"), "{e}");
    // an MTL outside the scene's folder
    std::fs::write(d.join("out.obj"), "mtllib ../outside.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(d.parent().unwrap().join("outside.mtl"), "newmtl a\nKd 0.5 0.5 0.5\n").unwrap();
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"out.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("out.obj") && e.contains("outside the folder"), "{e}");
    // glTF buffers: outside, absolute, file://
    for (tag, uri) in [("up", "../../etc/passwd"), ("abs", "/etc/passwd"), ("scheme", "file:///etc/passwd")] {
        let gltf = format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{uri}","byteLength":36}}],"bufferViews":[{{"buffer":0,"byteLength":36}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#
        );
        std::fs::write(d.join(format!("{tag}.gltf")), gltf).unwrap();
        let p = write_scene(&d, &format!("[[geometry]]\ntype = \"gltf\"\npath = \"{tag}.gltf\"\n"));
        let e = scene_error_within(&p, Duration::from_secs(10));
        assert!(
            e.contains(&format!("{tag}.gltf")) && (e.contains("outside") || e.contains("only relative")),
            "{tag}: {e}"
        );
    }
}

#[test]
fn malformed_meshes_are_errors_naming_them() {
    let d = tmp_dir("meshes");
    // a glTF node that lists itself as its child
    let gltf = r#"{"asset":{"version":"2.0"},"nodes":[{"children":[0]}],"scenes":[{"nodes":[0]}],"scene":0}"#;
    std::fs::write(d.join("cycle.gltf"), gltf).unwrap();
    let p = write_scene(&d, "[[geometry]]\ntype = \"gltf\"\npath = \"cycle.gltf\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("cycle.gltf") && e.contains("node 0"), "{e}");
    // empty and garbage OBJ
    std::fs::write(d.join("empty.obj"), "").unwrap();
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"empty.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("empty.obj") && e.contains("empty"), "{e}");
    std::fs::write(d.join("garbage.obj"), "\u{1}\u{2}this is not an obj\n").unwrap();
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"garbage.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("garbage.obj"), "{e}");
    // Kd nan in the MTL
    std::fs::write(d.join("nan.mtl"), "newmtl a\nKd nan 0.5 0.5\n").unwrap();
    std::fs::write(d.join("nan.obj"), "mtllib nan.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n").unwrap();
    let p = write_scene(&d, "[[geometry]]\ntype = \"obj\"\npath = \"nan.obj\"\n");
    let e = scene_error_within(&p, Duration::from_secs(10));
    assert!(e.contains("nan.obj") && e.contains("Kd"), "{e}");
}

#[test]
fn copies_of_one_triangle_load_in_linear_time() {
    let d = tmp_dir("copies");
    let mut obj = String::from("v -1 0 -1\nv 1 0 -1\nv 0 1 0\n");
    for _ in 0..100_000 {
        obj += "f 1 2 3\n";
    }
    std::fs::write(d.join("copies.obj"), obj).unwrap();
    let p = write_scene(&d, &format!("{ROOM}[[geometry]]\ntype = \"obj\"\npath = \"copies.obj\"\n"));
    let t = Instant::now();
    let s = warpfit::scene::Scene::load(&p).unwrap();
    let _tracer = warpfit::trace::Tracer::new(&s);
    assert_eq!(s.duplicates_skipped, 99_999);
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
}

#[test]
fn a_bake_beyond_the_machine_is_refused_before_it_starts() {
    let d = tmp_dir("huge");
    let body = std::fs::read_to_string(write_scene(&d, &format!("[sky]\ncolor = [1.0, 1.0, 1.0]\n{ROOM}")))
        .unwrap()
        .replace("counts = [2, 2, 2]", "counts = [200, 100, 200]")
        .replace("irradiance_resolution = 4", "irradiance_resolution = 64");
    let p = d.join("huge.toml");
    std::fs::write(&p, body).unwrap();
    let out = d.join("out");
    let t = Instant::now();
    let o = warpfit(&["bake", "--scene", &p.to_string_lossy(), "--out", &out.to_string_lossy()], &[]);
    assert!(!o.status.success());
    assert!(text(&o).contains("huge.toml") && text(&o).contains("--force") && text(&o).contains("GB"), "{}", text(&o));
    assert!(t.elapsed() < Duration::from_secs(20));
    assert!(!out.exists(), "nothing written");
}

#[test]
fn scene_names_stay_inside_fits() {
    for name in ["../..", "/etc", "a/b", ".hidden", ""] {
        let f = warpfit::report::folder::RunFolder::for_scene(name);
        let comps: Vec<_> = f.dir.components().collect();
        assert_eq!(comps.len(), 2, "{name:?} → {}", f.dir.display());
        assert_eq!(comps[0].as_os_str(), "fits");
        let last = comps[1].as_os_str().to_string_lossy();
        assert!(!last.starts_with('.') && !last.is_empty(), "{name:?} → {last}");
    }
}

#[test]
fn any_finite_direction_works_and_a_closed_pipe_ends_quietly() {
    let g = FittedGrid::load(repo().join("fits/tiny")).unwrap();
    let p = glam::Vec3::new(0.1, 1.0, 0.2);
    let want = g.specular(p, glam::Vec3::new(0.0, 0.6, 0.8), 0.3);
    for scale in [1e-30f32, 1e-20, 1e20, 3e38] {
        let got = g.specular(p, glam::Vec3::new(0.0, 0.6, 0.8) * scale, 0.3);
        assert!(
            (got - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-3),
            "scale {scale}: {got} vs {want}"
        );
        let e = g.irradiance(p, glam::Vec3::Y * scale);
        assert!(e.max_element() > 0.0, "scale {scale}");
    }
    // `warpfit inspect fits/tiny | head -c 0`: no panic (exit 101) on the closed pipe
    let mut c = Command::new(env!("CARGO_BIN_EXE_warpfit"));
    c.args(["inspect", "fits/tiny"])
        .current_dir(repo())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    let mut child = c.spawn().unwrap();
    drop(child.stdout.take()); // the reader goes away at once
    let status = child.wait().unwrap();
    let mut err = String::new();
    use std::io::Read;
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert_ne!(status.code(), Some(101), "{err}");
}

/// A payload streamed into its temporary file reports the length and checksum of what it
/// wrote; a writer that fails half-way leaves the old file as it was and no temporary file.
#[test]
fn a_streamed_write_reports_what_it_wrote_and_fails_cleanly() {
    use std::io::Write;
    use warpfit::files::{FileError, checksum, write_atomic_with};
    let dir = tmp_dir("streamed_write");
    let path = dir.join("payload.bin");
    let body: Vec<u8> = (0..3_000_000u32).map(|k| (k.wrapping_mul(2_654_435_761) >> 24) as u8).collect();
    let (len, sum) = write_atomic_with(&path, |f| f.write_all(&body).map_err(FileError::io(&path))).unwrap();
    assert_eq!((len, sum), (body.len() as u64, checksum(&body)));
    assert_eq!(std::fs::read(&path).unwrap(), body);
    let failed = write_atomic_with(&path, |f| {
        f.write_all(b"half a payload").map_err(FileError::io(&path))?;
        Err(FileError::invalid(&path, "layers", "the encoder failed"))
    });
    assert!(failed.is_err());
    assert_eq!(std::fs::read(&path).unwrap(), body, "the old file is untouched");
    let names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["payload.bin"], "no temporary file is left");
}

/// A bake larger than the process may allocate is refused before it starts, naming the
/// limit, under an address-space limit (`ulimit -v`, 2 GiB) below the machine's free memory:
/// not aborted by a failed allocation.
#[test]
fn a_bake_beyond_the_address_space_limit_is_refused_naming_it() {
    use std::os::unix::process::CommandExt;
    let d = tmp_dir("rlimit-as");
    let scene = d.join("huge.toml");
    let tiny = std::fs::read_to_string(repo().join("data/scenes/tiny.toml")).unwrap();
    let huge = tiny
        .lines()
        .map(|l| match l.split(" =").next() {
            // about 3.8 GB by the bake's estimate
            Some("counts") => "counts = [1000, 1000, 1]",
            Some("irradiance_resolution") => "irradiance_resolution = 16",
            _ => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&scene, huge).unwrap();
    let mut c = Command::new(env!("CARGO_BIN_EXE_warpfit"));
    c.args(["--quiet", "--threads", "2", "bake", "--scene"]).arg(&scene).arg("--out").arg(d.join("out"));
    // SAFETY: setrlimit between fork and exec touches only the child
    unsafe {
        c.pre_exec(|| {
            let limit = libc::rlimit { rlim_cur: 2 << 30, rlim_max: 2 << 30 };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let t0 = Instant::now();
    let o = c.output().expect("warpfit runs");
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("huge.toml") && all.contains("ulimit -v") && all.contains("GB"), "{all}");
    assert!(t0.elapsed() < Duration::from_secs(60), "{:?}", t0.elapsed());
}

/// A lock is written whole or not at all; one that names no owner (left by a writer that
/// failed half-way, e.g. on a full disk) is taken over once it is old, refused while fresh;
/// a killed taker's owner file is cleaned.
#[test]
fn an_empty_lock_left_by_a_failed_writer_is_taken_over_once_old() {
    use warpfit::files::staged::{FolderLock, UNOWNED_LOCK_SECONDS, clean_leftovers};
    let root = tmp_dir("empty-lock");
    let out = root.join("fit");
    let lock = root.join(".fit.lock");
    {
        let _held = FolderLock::acquire(&out).unwrap();
        let owner = std::fs::read_to_string(&lock).unwrap();
        assert!(owner.starts_with(&format!("{} ", std::process::id())), "{owner:?}");
        let e = FolderLock::acquire(&out).unwrap_err().to_string();
        assert!(e.contains("another warpfit process") && e.contains(".fit.lock"), "{e}");
    }
    assert!(!lock.exists(), "released on drop");
    // an empty lock, just written: perhaps a writer between its create and its write
    std::fs::write(&lock, b"").unwrap();
    let e = FolderLock::acquire(&out).unwrap_err().to_string();
    assert!(e.contains("another warpfit process (unknown)"), "{e}");
    // the same lock, old: taken over
    let old = std::time::SystemTime::now() - Duration::from_secs(UNOWNED_LOCK_SECONDS + 5);
    std::fs::File::options().write(true).open(&lock).unwrap().set_modified(old).unwrap();
    drop(FolderLock::acquire(&out).expect("an old lock without an owner is stale"));
    // a taker killed between writing its owner file and linking it
    let tmp = root.join(".fit.lock.tmp-4000000");
    std::fs::write(&tmp, b"4000000 host").unwrap();
    clean_leftovers(&out);
    assert!(!tmp.exists());
    assert!(leftovers(&out).is_empty(), "{:?}", leftovers(&out));
}

// ---- what a rejected grid costs ----------------------------------------------------------

/// Peak resident memory (bytes) of `warpfit inspect <dir>`, its exit code and its stderr.
fn inspect_peak(dir: &Path) -> (u64, i32, String) {
    warpfit_peak(&["--quiet".as_ref(), "inspect".as_ref(), dir.as_os_str()])
}

/// Peak resident memory (bytes) of `warpfit <args>`, its exit code and its stderr.
#[allow(clippy::zombie_processes)] // reaped by `wait4`, which also gives its peak memory
fn warpfit_peak(args: &[&std::ffi::OsStr]) -> (u64, i32, String) {
    use std::io::Read as _;
    let mut child = Command::new(env!("CARGO_BIN_EXE_warpfit"))
        .args(args)
        .current_dir(repo())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("warpfit runs");
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let mut status = 0;
    // SAFETY: an all-zero rusage is valid; wait4 reaps this child only
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32, "wait4");
    assert!(libc::WIFEXITED(status), "{status} {err}");
    (usage.ru_maxrss as u64 * 1024, libc::WEXITSTATUS(status), err)
}

/// Rewrites payload `file` of `dir` with `layers` (each channel computed on demand, so the
/// test never holds them) and reseals the manifest's listing of it.
fn rewrite_payload(dir: &Path, file: &str, layers: Vec<ExrLayer<Samples<'static>>>) {
    let listing: Vec<serde_json::Value> = layers
        .iter()
        .map(|l| {
            let channels: Vec<&str> = l.channels.iter().map(|(n, _)| n.as_str()).collect();
            serde_json::json!({"name": l.name, "width": l.width, "height": l.height, "channels": channels, "precision": "f32"})
        })
        .collect();
    let (len, sum) = warpfit::gridfile::exr::write_payload(&dir.join(file), layers, |_| false).unwrap();
    edit_sealed(dir, |v| {
        for p in v["payloads"].as_array_mut().unwrap() {
            if p["file"] == file {
                p["bytes"] = len.into();
                p["checksum"] = sum.clone().into();
                p["layers"] = listing.clone().into();
            }
        }
    });
}

/// An `n²` layer of ones, computed as it is written, its last sample −1 when `bad_last`.
fn constant(name: String, n: usize, channels: &[&str], bad_last: bool) -> ExrLayer<Samples<'static>> {
    ExrLayer {
        name,
        width: n,
        height: n,
        channels: channels
            .iter()
            .map(|c| {
                let f: Samples<'static> =
                    Samples::Computed(Box::new(move |i| if bad_last && i == n * n - 1 { -1.0 } else { 1.0 }));
                (c.to_string(), f)
            })
            .collect(),
    }
}

/// `dir` with probe A replaced by an `n²` probe of constant values (three mips), its very
/// last radiance sample −1 when `damaged`.
fn big_probe(dir: &Path, n: usize, damaged: bool) {
    let mut layers = Vec::new();
    for k in 0..3 {
        layers.push(constant(format!("radiance_mip{k}"), n >> k, &["R", "G", "B"], damaged && k == 0));
    }
    for k in 0..3 {
        layers.push(constant(format!("distance_mip{k}"), n >> k, &["Z"], false));
    }
    edit_sealed(dir, |v| {
        v["probe"]["resolution"] = n.into();
        for k in 0..3 {
            v["probe"]["radiance_mips"][k]["resolution"] = (n >> k).into();
        }
    });
    rewrite_payload(dir, "probe.exr", layers);
}

/// A grid whose damage shows only in its last values costs at most 64 MB to refuse, however
/// large it claims to be: a big grid's values are streamed through the writer's rules before
/// it is decoded into memory. (Before, a 385 KB probe file of 4096² texels cost 536 MB, a
/// grid of 2^24 cells 327 MB, the same probe in a bake was reused at 1,365 MB, and a part
/// was read whole before its checksum was checked.)
#[test]
fn a_refused_grid_costs_at_most_64_mb() {
    const BUDGET: u64 = 64 << 20;
    // a 4096² probe of constant values but its very last radiance sample
    let d = copy_tiny("rss-probe");
    big_probe(&d, 4096, true);
    let (peak, code, err) = inspect_peak(&d);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("probe.exr") && err.contains("radiance_mip0") && err.contains("sample 16777215"), "{err}");
    assert!(peak <= BUDGET, "refusing the probe took {} MB", peak >> 20);

    // a grid of 2^24 cells (its probes relocated) whose irradiance holds a negative distance
    let d = copy_tiny("rss-cells");
    edit_sealed(&d, |v| {
        v["grid"]["counts"] = serde_json::json!([256, 256, 256]);
        v["grid"]["relocated"] = serde_json::json!([[17, [0.0, 0.0, 0.001]]]);
    });
    let path = d.join("irradiance.exr");
    let mut layers = warpfit::gridfile::exr::read(&path).unwrap();
    let l = layers.iter_mut().find(|l| l.name == "depth_moments").unwrap();
    l.channels[0].1[40] = -1.0;
    warpfit::gridfile::exr::write(&path, &layers).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    reseal_payload(&d, "irradiance.exr", bytes.len() as u64, warpfit::files::checksum(&bytes));
    let (peak, code, err) = inspect_peak(&d);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("irradiance.exr") && err.contains("depth_moments.mean"), "{err}");
    assert!(peak <= BUDGET, "refusing the grid of 2^24 cells took {} MB", peak >> 20);

    // a bake whose probe claims 4096² texels, its last one damaged: refused and baked again
    let d = tmp_dir("rss-bake");
    let out = d.join("fit");
    assert!(fit_tiny(&out, 8, &[]).status.success());
    let bake = out.join("bake");
    let mut layers = Vec::new();
    for k in 0..3 {
        layers.push(constant(format!("radiance_mip{k}"), 4096 >> k, &["R", "G", "B"], k == 0));
    }
    for k in 0..3 {
        layers.push(constant(format!("distance_mip{k}"), 4096 >> k, &["Z"], false));
    }
    let (len, sum) = warpfit::gridfile::exr::write_payload(&bake.join("probe.exr"), layers, |_| false).unwrap();
    let mpath = bake.join("manifest.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&mpath).unwrap()).unwrap();
    v["probe"]["resolution"] = 4096.into();
    for k in 0..3 {
        v["probe"]["radiance_mips"][k]["resolution"] = (4096 >> k).into();
    }
    v["files"][0]["bytes"] = len.into();
    v["files"][0]["checksum"] = sum.into();
    std::fs::write(&mpath, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
    let o = out.to_string_lossy().into_owned();
    let args = [
        "--threads",
        "2",
        "fit",
        "--scene",
        "data/scenes/tiny.toml",
        "--out",
        &o,
        "--train-positions",
        "4",
        "--train-dirs",
        "8",
    ];
    let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
    let (peak, code, err) = warpfit_peak(&args);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("not reusing the bake") && err.contains("probe.exr") && err.contains("radiance_mip0"),
        "{err}"
    );
    assert!(peak <= BUDGET, "refusing the bake and baking again took {} MB", peak >> 20);

    // a shard's part grown to 512 MB (sparse) with its header saying so: refused on its
    // checksum, read through in pieces, not loaded whole (before: 512 MB)
    let d = tmp_dir("rss-part");
    let o = d.join("run").to_string_lossy().into_owned();
    let made = warpfit(&["--quiet", "bake", "--scene", "data/scenes/tiny.toml", "--out", &o, "--shard", "0/1"], &[]);
    assert!(made.status.success(), "{}", text(&made));
    let part = std::fs::read_dir(d.join("run/parts")).unwrap().flatten().map(|e| e.path()).next().unwrap();
    let bytes = std::fs::read(&part).unwrap();
    let magic = b"warpfit-part\n".len();
    let head_len = u64::from_le_bytes(bytes[magic..magic + 8].try_into().unwrap()) as usize;
    let mut head: serde_json::Value = serde_json::from_slice(&bytes[magic + 8..magic + 8 + head_len]).unwrap();
    let body = &bytes[magic + 8 + head_len..];
    let grown = body.len() as u64 + (512 << 20);
    head["body_bytes"] = grown.into();
    let head = serde_json::to_vec(&head).unwrap();
    let mut out = bytes[..magic].to_vec();
    out.extend((head.len() as u64).to_le_bytes());
    out.extend(&head);
    out.extend(body);
    std::fs::write(&part, &out).unwrap();
    std::fs::File::options().write(true).open(&part).unwrap().set_len(out.len() as u64 + (512 << 20)).unwrap();
    let args: Vec<&std::ffi::OsStr> = vec!["merge".as_ref(), "--out".as_ref(), o.as_ref(), part.as_os_str()];
    let (peak, code, err) = warpfit_peak(&args);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(".part") && err.contains("checksum"), "{err}");
    assert!(peak <= BUDGET, "refusing the part took {} MB", peak >> 20);

    // the same grids undamaged load (the scan refuses nothing the writer makes)
    let d = copy_tiny("rss-probe-ok");
    big_probe(&d, 2048, false);
    let (_, code, err) = inspect_peak(&d);
    assert_eq!(code, 0, "{err}");
}
