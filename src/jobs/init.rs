//! `warpfit init --mesh level.glb [--cell-size 1.0]`: a scene file for a level, written from
//! the mesh alone. The grid covers the mesh's bounds with cells of about the asked size;
//! probe A goes to the most open point of a coarse candidate lattice (largest mean distance
//! to what 64 directions hit, escaping rays counting zero, not inside geometry); the file's own lights are used (glTF
//! `KHR_lights_punctual`), and a daylight sky and sun are added only when it has none. The
//! output says in comments what it chose and why.

use super::JobError;
use crate::sampling::{Sampler, uniform_sphere};
use crate::scene::{Scene, SceneError};
use crate::trace::{Tracer, truth};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;

/// Candidates per axis of the lattice probe A is chosen from.
const CANDIDATES_PER_AXIS: u32 = 9;
/// Directions each candidate is scored with.
const SCORE_DIRECTIONS: u32 = 64;
/// Most grid cells `init` proposes (the cell size grows to stay below).
const MAX_CELLS: u64 = 20_000;

/// What `init` proposes, and the scene text.
pub struct Init {
    pub text: String,
    pub probe: Vec3,
    pub counts: [u32; 3],
}

/// The `[probes]` table of the scene `init` writes: probe A at `probe` and the grid
/// (`min`, `max`, `counts`), more probes placed as a bake's automatic placement places them
/// (`bake::placement`), written out as positions an artist can move; empty when probe A
/// alone sees the level.
fn placed_probes(scene: &Scene, tracer: &Tracer, probe: Vec3, (min, max, counts): (Vec3, Vec3, [u32; 3])) -> String {
    let mut s = scene.clone();
    s.config.probe.position = probe.to_array();
    (s.config.grid.min, s.config.grid.max, s.config.grid.counts) = (min.to_array(), max.to_array(), counts);
    s.config.probes.auto = true;
    let renderer = crate::trace::Renderer::new(&s, tracer);
    let p = crate::bake::placement::place(&renderer, &crate::bake::grid_settings(&s));
    if p.placed == 0 {
        return String::new();
    }
    let list: Vec<String> = p.positions[1..].iter().map(|q| format!("[{:.4}, {:.4}, {:.4}]", q.x, q.y, q.z)).collect();
    format!(
        "# More specular probes: probe A alone misses {:.0}% of the level's sampled reflection hits;\n# with these {} it misses {:.0}% (placed greedily where they see most of what is missed).\n[probes]\npositions = [{}]\n\n",
        100.0 * p.hidden_probe_a,
        p.placed,
        100.0 * p.hidden,
        list.join(", ")
    )
}

/// The TOML line that loads `mesh`, as the scene file refers to it.
fn geometry_entry(mesh: &Path, kind: &str) -> String {
    format!("[[geometry]]\ntype = \"{kind}\"\npath = {:?}\n", mesh.display().to_string())
}

/// A scene file for `mesh` (a .gltf, .glb or .obj), with grid cells of about `cell_size`
/// scene units. `mesh_as_written` is the path the scene file will name (relative to where it
/// is saved).
pub fn init(mesh: &Path, mesh_as_written: &Path, cell_size: f32) -> Result<Init, JobError> {
    let ext = mesh.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let kind = match ext.as_str() {
        "gltf" | "glb" => "gltf",
        "obj" => "obj",
        _ => {
            return Err(JobError::Scene(SceneError::Mesh {
                path: mesh.to_path_buf(),
                message: "init reads .gltf, .glb or .obj files".into(),
            }));
        }
    };
    if !(cell_size.is_finite() && cell_size > 0.0) {
        return Err(JobError::Scene(SceneError::Invalid {
            path: mesh.to_path_buf(),
            field: "--cell-size".into(),
            message: format!("must be a positive number, got {cell_size}"),
        }));
    }
    // load the mesh with a placeholder probe and grid to learn its bounds and lights
    let name = mesh.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "level".into());
    let geometry = geometry_entry(mesh.file_name().map(Path::new).unwrap_or(mesh), kind);
    let probe_text = |p: Vec3, min: Vec3, max: Vec3, counts: [u32; 3]| {
        format!(
            "[probe]\nposition = [{:.4}, {:.4}, {:.4}]\n\n[grid]\nmin = [{:.4}, {:.4}, {:.4}]\nmax = [{:.4}, {:.4}, {:.4}]\ncounts = [{}, {}, {}]\n",
            p.x, p.y, p.z, min.x, min.y, min.z, max.x, max.y, max.z, counts[0], counts[1], counts[2]
        )
    };
    let placeholder = format!(
        "name = {name:?}\n{}\n[sky]\ncolor = [1.0, 1.0, 1.0]\n\n{geometry}",
        probe_text(Vec3::ZERO, Vec3::splat(-1.0), Vec3::ONE, [1, 1, 1])
    );
    let at = mesh.with_file_name(format!(".{name}.init.toml"));
    let scene = Scene::parse(&placeholder, &at)?;
    let (lo, hi) = scene.bounds();
    let extent = hi - lo;
    if !(extent.min_element() > 0.0 && extent.is_finite()) {
        return Err(JobError::Scene(SceneError::Mesh {
            path: mesh.to_path_buf(),
            message: format!("the mesh is flat or empty (bounds {lo} – {hi})"),
        }));
    }
    let tracer = Tracer::new(&scene);
    // the grid: the bounds, shrunk by a hair so cell centres never sit on the outer walls
    let margin = extent * 1e-3;
    let (gmin, gmax) = (lo + margin, hi - margin);
    let mut size = cell_size;
    let counts = loop {
        let c = ((gmax - gmin) / size).ceil().max(Vec3::ONE).as_uvec3();
        if c.x as u64 * c.y as u64 * c.z as u64 <= MAX_CELLS {
            break c.to_array();
        }
        size *= 1.25;
    };
    // probe A: the most open candidate that is not inside geometry
    let diag = extent.length();
    let threshold = scene.config.grid.inside_backface_fraction;
    let mut best: Option<(f32, Vec3)> = None;
    let n = CANDIDATES_PER_AXIS;
    for k in 0..n * n * n {
        let f = Vec3::new((k % n) as f32, ((k / n) % n) as f32, (k / (n * n)) as f32);
        let p = gmin + (gmax - gmin) * (f + 0.5) / n as f32;
        if truth::is_inside(&scene, &tracer, p, threshold, |j| Sampler::new(7, k as u64, j)) {
            continue;
        }
        // rays that escape count nothing: probe A belongs inside the level, not in its doorways
        let mut free = 0.0f32;
        for j in 0..SCORE_DIRECTIONS {
            let d = uniform_sphere(Sampler::new(8, 0, j).next_2d());
            free += tracer.closest_hit(p, d, f32::INFINITY).map_or(0.0, |h| h.t.min(diag));
        }
        let score = free / SCORE_DIRECTIONS as f32;
        if best.is_none_or(|(b, _)| score > b) {
            best = Some((score, p));
        }
    }
    let Some((free, probe)) = best else {
        return Err(JobError::Scene(SceneError::Mesh {
            path: mesh.to_path_buf(),
            message: "every candidate point for probe A is inside geometry: is the mesh closed inside-out?".into(),
        }));
    };
    let has_lights = !scene.lights.sphere_lights.is_empty()
        || scene.lights.sun.is_some()
        || scene.materials.iter().any(|m| m.emission.max_element() > 0.0);

    let mut t = String::new();
    let _ = writeln!(t, "# Scene for {} written by `warpfit init` (edit freely).", mesh.display());
    let _ = writeln!(t, "# Paths are relative to this file: save it in the folder `init` ran from.");
    let _ = writeln!(t, "name = {name:?}\n");
    let _ = writeln!(
        t,
        "# Probe A: the most open of {} candidate points on a {n}×{n}×{n} lattice over the bounds\n# (mean distance {:.3} to what {SCORE_DIRECTIONS} directions hit, escaping rays counting zero;\n# candidates inside geometry skipped).",
        n * n * n,
        free
    );
    let _ = writeln!(
        t,
        "# Grid: the mesh's bounds ({:.3}, {:.3}, {:.3}) – ({:.3}, {:.3}, {:.3}), cells of about {:.3}\n# scene units ({} asked{}).",
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        size,
        cell_size,
        if size > cell_size { format!(", grown to stay within {MAX_CELLS} cells") } else { String::new() }
    );
    t += &probe_text(probe, gmin, gmax, counts);
    t += "\n";
    t += &placed_probes(&scene, &tracer, probe, (gmin, gmax, counts));
    if has_lights {
        let _ = writeln!(
            t,
            "# Lights: the file's own ({} sphere/spot light(s){}{}); a dim sky fills the rest.",
            scene.lights.sphere_lights.len(),
            if scene.lights.sun.is_some() { ", a directional light" } else { "" },
            if scene.materials.iter().any(|m| m.emission.max_element() > 0.0) { ", emissive surfaces" } else { "" }
        );
        t += "[sky]\nzenith = [0.05, 0.07, 0.1]\nhorizon = [0.08, 0.08, 0.08]\nground = [0.02, 0.02, 0.02]\n\n";
    } else {
        t += "# Lights: the file has none, so a daylight sky and sun light it; replace them with yours.\n";
        t += "[sky]\nzenith = [0.35, 0.55, 1.0]\nhorizon = [0.9, 0.95, 1.0]\nground = [0.25, 0.22, 0.2]\n\n";
        t += "[sun]\ndirection = [0.45, 0.8, 0.35]\nangular_radius_deg = 0.5\nirradiance = [9.0, 8.5, 7.5]\n\n";
    }
    t += &geometry_entry(mesh_as_written, kind);
    Ok(Init { text: t, probe, counts })
}
