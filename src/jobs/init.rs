//! `warpfit init --mesh level.glb [--cell-size 1.0]`: a scene file for a level, written from
//! the mesh alone. Its name comes from the level (the glTF's scene name, else the file's
//! stem, else its folder when the stem says nothing: `cornell/scene.gltf` is `cornell`). The
//! grid covers the mesh's bounds with cells of the asked size, or without one a size
//! proposed from the level's scale (half the typical distance from an open point to the
//! walls). Probe A stands at a player's eye height above a walkable floor, at the most open
//! such point of a coarse candidate lattice (largest mean distance to what 64 directions
//! hit, escaping rays counting zero, not inside geometry). The file's own lights are used
//! (glTF `KHR_lights_punctual`, emissive materials); nodes and materials that look like
//! lamps but carry no light are named in warnings. When it must invent light, the light
//! reaches the level: a daylight sky and sun for an open level, a light under the ceiling
//! for a closed one. The output says in comments what it chose and why.

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
/// A player's eye above a walkable floor, in scene units (metres: glTF's unit, and the
/// scene loader's after a file's `units`).
const EYE_HEIGHT: f32 = 1.6;
/// A surface is a walkable floor when its normal is within 45° of up.
const WALKABLE: f32 = std::f32::consts::FRAC_1_SQRT_2;
/// Below this share of escaping rays from probe A the level is (mostly) closed: light from
/// outside alone would leave its rooms dark (a Cornell box open at the front lets 17% out).
const CLOSED: f32 = 0.25;

/// What `init` proposes, the scene text and what it warns about.
pub struct Init {
    pub text: String,
    pub name: String,
    pub probe: Vec3,
    pub counts: [u32; 3],
    /// The cell size used (asked or proposed).
    pub cell_size: f32,
    pub warnings: Vec<String>,
}

/// Names that say nothing about a level (exporters' defaults, generic folders).
fn generic(name: &str) -> bool {
    const GENERIC: [&str; 16] = [
        "scene", "untitled", "model", "models", "level", "levels", "export", "exports", "mesh", "meshes", "main",
        "default", "assets", "asset", "gltf", "obj",
    ];
    let n = name.trim().to_ascii_lowercase();
    let n = n.trim_end_matches(|c: char| c.is_ascii_digit() || c == '_' || c == '.' || c == '-');
    n.is_empty() || GENERIC.contains(&n)
}

/// The level's name: the glTF's scene name, else the file's stem, else the first folder
/// above it whose name says something (`cornell/scene.gltf` → `cornell`); the stem with its
/// folder when nothing does.
fn level_name(mesh: &Path, gltf_scene: Option<&str>) -> String {
    let stem = mesh.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    if let Some(n) = gltf_scene.filter(|n| !generic(n)) {
        return n.to_string();
    }
    if !generic(&stem) {
        return stem;
    }
    let abs = std::path::absolute(mesh).unwrap_or_else(|_| mesh.to_path_buf());
    let folder = abs.ancestors().skip(1).filter_map(|a| a.file_name()).map(|f| f.to_string_lossy().into_owned());
    let mut folders = folder.peekable();
    let first = folders.peek().cloned();
    match folders.find(|f| !generic(f)) {
        Some(f) => f,
        None => {
            format!("{}-{}", first.unwrap_or_else(|| "level".into()), if stem.is_empty() { "level" } else { &stem })
        }
    }
}

/// What a glTF says about itself beyond its geometry: its scene's name, and warnings for
/// nodes and materials that look like lamps but carry no light the loader reads (Blender
/// exports a lamp as a light node only with "Punctual Lights" on, and an emission shader
/// only as `emissiveFactor`).
fn gltf_facts(mesh: &Path) -> (Option<String>, Vec<String>) {
    let Ok(bytes) = crate::files::read_regular(mesh, crate::scene::MAX_MESH_FILE_BYTES) else {
        return (None, Vec::new());
    };
    let Ok(g) = gltf::Gltf::from_slice(&bytes) else { return (None, Vec::new()) };
    let doc = &g.document;
    let name = doc.default_scene().or_else(|| doc.scenes().next()).and_then(|s| s.name().map(str::to_string));
    let lamp = |n: &str| {
        let n = n.to_ascii_lowercase();
        ["light", "lamp", "emissi", "bulb"].iter().any(|w| n.contains(w))
    };
    let mut warnings = Vec::new();
    for node in doc.nodes() {
        let n = node.name().unwrap_or("");
        if lamp(n) && node.light().is_none() && node.mesh().is_none() {
            warnings.push(format!(
                "{}: node {n:?} looks like a lamp but carries no KHR_lights_punctual light, so it gives no light: export with punctual lights on (Blender: Include › Punctual Lights), or add a [[sphere_lights]] entry",
                mesh.display()
            ));
        }
    }
    for m in doc.materials() {
        let n = m.name().unwrap_or("");
        if lamp(n) && m.emissive_factor().iter().all(|&e| e <= 0.0) {
            warnings.push(format!(
                "{}: material {n:?} looks like a lamp but emits nothing (emissiveFactor 0): give it an emission colour and strength in the exporter, or add a [[sphere_lights]] entry",
                mesh.display()
            ));
        }
    }
    (name, warnings)
}

/// A lattice point brought down to a player's eye height above the walkable floor beneath
/// it (half-way to the ceiling where the room is lower than twice that); `None` where no
/// walkable floor lies beneath it.
fn at_eye_height(tracer: &Tracer, p: Vec3, eps: f32) -> Option<Vec3> {
    let floor = tracer.closest_hit(p, Vec3::NEG_Y, f32::INFINITY)?;
    if floor.normal.y.abs() < WALKABLE {
        return None;
    }
    let base = floor.position + Vec3::Y * eps;
    let headroom = tracer.closest_hit(base, Vec3::Y, f32::INFINITY).map_or(f32::INFINITY, |h| h.t);
    Some(base + Vec3::Y * EYE_HEIGHT.min(0.5 * headroom))
}

/// `x` rounded to 1, 2 or 5 times a power of ten.
fn nice(x: f32) -> f32 {
    let e = libm::floorf(libm::log10f(x));
    let m = x / libm::powf(10.0, e);
    let m = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    m * libm::powf(10.0, e)
}

/// The `[probes]` table of the scene `init` writes: probe A at `probe` and the grid
/// (`min`, `max`, `counts`), more probes placed as a bake's automatic placement places them
/// (`bake::placement`), then each brought to a player's eye height above the floor beneath
/// it where that sees as much (within a point of the hidden share), written out as
/// positions an artist can move; empty when probe A alone sees the level.
fn placed_probes(
    scene: &Scene,
    tracer: &Tracer,
    probe: Vec3,
    (min, max, counts): (Vec3, Vec3, [u32; 3]),
    eps: f32,
) -> String {
    let mut s = scene.clone();
    s.config.probe.position = probe.to_array();
    (s.config.grid.min, s.config.grid.max, s.config.grid.counts) = (min.to_array(), max.to_array(), counts);
    s.config.probes.auto = true;
    let settings = crate::bake::grid_settings(&s);
    let p = crate::bake::placement::place(&crate::trace::Renderer::new(&s, tracer), &settings);
    if p.placed == 0 {
        return String::new();
    }
    let (lo, hi) = scene.bounds();
    let threshold = scene.config.grid.inside_backface_fraction;
    let raised: Vec<Vec3> = p.positions[1..]
        .iter()
        .enumerate()
        .map(|(k, &q)| match at_eye_height(tracer, q, eps) {
            Some(e)
                if (lo.y..=hi.y).contains(&e.y)
                    && !truth::is_inside(&s, tracer, e, threshold, |j| Sampler::new(9, k as u64, j)) =>
            {
                e
            }
            _ => q,
        })
        .collect();
    // the raised set measured as it stands
    s.config.probes.auto = false;
    s.config.probes.positions = raised.iter().map(|q| q.to_array()).collect();
    let r = crate::bake::placement::place(&crate::trace::Renderer::new(&s, tracer), &settings);
    let (positions, hidden, how) = if r.hidden <= p.hidden + 0.01 {
        (&raised, r.hidden, "then brought to eye height above the floor beneath each")
    } else {
        (&p.positions[1..].to_vec(), p.hidden, "left where placed: at eye height they would miss more")
    };
    let list: Vec<String> = positions.iter().map(|q| format!("[{:.4}, {:.4}, {:.4}]", q.x, q.y, q.z)).collect();
    format!(
        "# More specular probes: probe A alone misses {:.0}% of the level's sampled reflection hits;\n# with these {} it misses {:.0}% (placed greedily where they see most of what is missed,\n# {how}).\n[probes]\npositions = [{}]\n\n",
        100.0 * p.hidden_probe_a,
        p.placed,
        100.0 * hidden,
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
pub fn init(mesh: &Path, mesh_as_written: &Path, cell_size: Option<f32>) -> Result<Init, JobError> {
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
    if let Some(c) = cell_size.filter(|c| !(c.is_finite() && *c > 0.0)) {
        return Err(JobError::Scene(SceneError::Invalid {
            path: mesh.to_path_buf(),
            field: "--cell-size".into(),
            message: format!("must be a positive number, got {c}"),
        }));
    }
    let (gltf_scene, mut warnings) = if kind == "gltf" { gltf_facts(mesh) } else { (None, Vec::new()) };
    let name = level_name(mesh, gltf_scene.as_deref());
    // load the mesh with a placeholder probe and grid to learn its bounds and lights
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
    // probe A: the most open candidate at a player's eye height that is not inside geometry
    let diag = extent.length();
    let eps = 1e-4 * diag;
    let n = CANDIDATES_PER_AXIS;
    let scored = candidates(&scene, &tracer, (lo, hi), (gmin, gmax), eps);
    // at eye height where any candidate is: a player stands on floors, not in the air above
    let any_eye = scored.iter().any(|c| c.eye);
    let best = scored.iter().filter(|c| c.eye || !any_eye).max_by(|a, b| a.score.total_cmp(&b.score));
    let Some(best) = best.copied() else {
        return Err(JobError::Scene(SceneError::Mesh {
            path: mesh.to_path_buf(),
            message: "every candidate point for probe A is inside geometry: is the mesh closed inside-out, or one-sided with mixed winding (then set two_sided = true on its geometry)?".into(),
        }));
    };
    let probe = best.p;
    // the level's scale: the typical distance from an open point to what it sees
    let mut distances: Vec<f32> = scored.iter().filter(|c| c.escape < 0.5).map(|c| c.mean_hit).collect();
    distances.sort_by(f32::total_cmp);
    let typical = distances.get(distances.len() / 2).copied().unwrap_or(best.mean_hit);
    let proposed = nice(0.5 * typical);
    let asked = cell_size.unwrap_or(proposed);
    let mut size = asked;
    let counts = loop {
        let c = ((gmax - gmin) / size).ceil().max(Vec3::ONE).as_uvec3();
        if c.x as u64 * c.y as u64 * c.z as u64 <= MAX_CELLS {
            break c.to_array();
        }
        size *= 1.25;
    };
    if size > typical {
        warnings.push(format!(
            "{}: cells of {size:.3} are coarse for this level (typical distance from an open point to the walls {typical:.3}): reflections will blur across rooms; a size near {proposed} suits it",
            mesh.display()
        ));
    }
    let mut t = String::new();
    let _ = writeln!(t, "# Scene for {} written by `warpfit init` (edit freely).", mesh.display());
    let _ = writeln!(t, "# Paths are relative to this file: save it in the folder `init` ran from.");
    for w in &warnings {
        let _ = writeln!(t, "# Warning: {w}");
    }
    let _ = writeln!(t, "name = {name:?}\n");
    let _ = writeln!(
        t,
        "# Probe A: the most open of {} candidate points (a {n}×{n}×{n} lattice over the bounds, each\n# brought down to eye height, {EYE_HEIGHT} above the walkable floor beneath it or half-way up\n# a lower room{}), mean distance {:.3} to what {SCORE_DIRECTIONS} directions hit, escaping rays\n# counting zero.",
        scored.len(),
        if best.eye { "" } else { "; this level has no floor beneath any, so it floats" },
        best.score
    );
    let _ = writeln!(
        t,
        "# Grid: the mesh's bounds ({:.3}, {:.3}, {:.3}) – ({:.3}, {:.3}, {:.3}), cells of about {:.3}\n# scene units ({}{}).",
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        size,
        match cell_size {
            Some(c) => format!("{c} asked"),
            None => format!(
                "proposed from the level's scale: half the typical distance {typical:.3} from an open point to the walls, rounded; --cell-size sets another"
            ),
        },
        if size > asked { format!(", grown to stay within {MAX_CELLS} cells") } else { String::new() }
    );
    t += &probe_text(probe, gmin, gmax, counts);
    t += "\n";
    t += &placed_probes(&scene, &tracer, probe, (gmin, gmax, counts), eps);
    t += &lights_text(&scene, &tracer, (probe, &best), (typical, eps));
    t += &geometry_entry(mesh_as_written, kind);
    Ok(Init { text: t, name, probe, counts, cell_size: size, warnings })
}

/// Probe A's candidates, scored: a lattice of [`CANDIDATES_PER_AXIS`]³ points over the grid
/// `(gmin, gmax)` of a level within `(lo, hi)`, each brought down to eye height where a
/// floor is beneath it, without repeats or points inside geometry; each scored by its mean
/// distance to what [`SCORE_DIRECTIONS`] rays hit (escaping rays count zero).
fn candidates(
    scene: &Scene,
    tracer: &Tracer,
    (lo, hi): (Vec3, Vec3),
    (gmin, gmax): (Vec3, Vec3),
    eps: f32,
) -> Vec<Candidate> {
    let diag = (hi - lo).length();
    let threshold = scene.config.grid.inside_backface_fraction;
    let n = CANDIDATES_PER_AXIS;
    let mut seen = std::collections::HashSet::new();
    let mut scored: Vec<Candidate> = Vec::new();
    for k in 0..n * n * n {
        let f = Vec3::new((k % n) as f32, ((k / n) % n) as f32, (k / (n * n)) as f32);
        let lattice = gmin + (gmax - gmin) * (f + 0.5) / n as f32;
        let (p, eye) = match at_eye_height(tracer, lattice, eps) {
            Some(q) if (lo.y..=hi.y).contains(&q.y) => (q, true),
            _ => (lattice, false),
        };
        if !seen.insert(p.to_array().map(f32::to_bits))
            || truth::is_inside(scene, tracer, p, threshold, |j| Sampler::new(7, k as u64, j))
        {
            continue;
        }
        // rays that escape count nothing: probe A belongs inside the level, not in its doorways
        let (mut free, mut hit_sum, mut hits) = (0.0f32, 0.0f32, 0u32);
        for j in 0..SCORE_DIRECTIONS {
            let d = uniform_sphere(Sampler::new(8, 0, j).next_2d());
            if let Some(h) = tracer.closest_hit(p, d, f32::INFINITY) {
                free += h.t.min(diag);
                hit_sum += h.t.min(diag);
                hits += 1;
            }
        }
        let escape = 1.0 - hits as f32 / SCORE_DIRECTIONS as f32;
        let mean_hit = if hits > 0 { hit_sum / hits as f32 } else { diag };
        scored.push(Candidate { p, eye, score: free / SCORE_DIRECTIONS as f32, escape, mean_hit });
    }
    scored
}

/// The scene text's lights: the level's own with a dim sky, or (none in the file) a daylight
/// sky and sun, and a lamp above probe A (at `probe`, scored `best`) when the level is
/// mostly closed; `typical`: the level's scale, `eps` its ray offset.
fn lights_text(
    scene: &Scene,
    tracer: &Tracer,
    (probe, best): (Vec3, &Candidate),
    (typical, eps): (f32, f32),
) -> String {
    let has_lights = !scene.lights.sphere_lights.is_empty()
        || scene.lights.sun.is_some()
        || scene.materials.iter().any(|m| m.emission.max_element() > 0.0);
    let mut t = String::new();
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
        let _ = writeln!(
            t,
            "# Lights: the file has none, so a daylight sky and sun light it from outside ({:.0}% of probe\n# A's rays reach the sky){}; replace them with yours.",
            100.0 * best.escape,
            if best.escape < CLOSED {
                ", and as the level is mostly closed, a lamp under the ceiling above probe A\n# lights it inside (irradiance about 5 at probe A)"
            } else {
                ""
            }
        );
        t += "[sky]\nzenith = [0.35, 0.55, 1.0]\nhorizon = [0.9, 0.95, 1.0]\nground = [0.25, 0.22, 0.2]\n\n";
        t += "[sun]\ndirection = [0.45, 0.8, 0.35]\nangular_radius_deg = 0.5\nirradiance = [9.0, 8.5, 7.5]\n\n";
        if best.escape < CLOSED {
            // light outside would not reach the cells: a lamp under the ceiling does
            let up = tracer.closest_hit(probe, Vec3::Y, f32::INFINITY).map_or(EYE_HEIGHT, |h| h.t);
            let at = probe + Vec3::Y * (0.7 * up);
            let radius = (0.05 * typical).max(eps * 10.0);
            let d = (at - probe).length().max(radius * 2.0);
            // E ≈ L · π R² / d² at probe A
            let radiance = 5.0 * d * d / (std::f32::consts::PI * radius * radius);
            let _ = writeln!(
                t,
                "[[sphere_lights]]\nposition = [{:.4}, {:.4}, {:.4}]\nradius = {radius:.4}\nradiance = [{radiance:.1}, {radiance:.1}, {radiance:.1}]\n",
                at.x, at.y, at.z
            );
        }
    }
    t
}

/// A candidate for probe A, scored.
#[derive(Clone, Copy)]
struct Candidate {
    p: Vec3,
    /// Brought down to eye height above a walkable floor.
    eye: bool,
    /// Mean distance to what the directions hit, escaping rays counting zero.
    score: f32,
    /// Share of the directions that escape.
    escape: f32,
    /// Mean distance over the directions that hit.
    mean_hit: f32,
}
