//! `warpfit check`: what makes a bake or a fit of a scene meaningless, found before anything
//! is baked (bake, fit and run call it first). Errors: probe A inside geometry or outside
//! the scene, a grid that does not overlap the scene, a scene with no light. Warnings:
//! mixed or inverted winding (back faces of one-sided surfaces seen from probe A), a grid
//! reaching far beyond the scene, skipped degenerate and duplicate triangles. Every finding
//! names the scene file and the element.

use crate::sampling::{Sampler, hash_pair, uniform_sphere};
use crate::scene::Scene;
use crate::trace::{Tracer, truth};
use glam::Vec3;

/// Rays traced from probe A for the winding check.
const WINDING_RAYS: u32 = 1024;
/// Share of one-sided back faces seen from probe A above which the winding is suspect.
const WINDING_WARN: f32 = 0.05;
/// Rays from the grid's cells, and as many from around the level, for the light check.
const LIGHT_RAYS: u32 = 256;
/// Cells whose rays carry less than this share of what rays around the level carry are dim:
/// the light is outside a (nearly) closed level.
const DIM: f64 = 0.05;

/// What the check found.
#[derive(Clone, Debug, Default)]
pub struct Check {
    pub errors: Vec<String>,
    pub warnings: Vec<String>,
    /// Facts worth printing: bounds, triangle counts, lights.
    pub facts: Vec<String>,
}

impl Check {
    pub fn ok(&self) -> bool {
        self.errors.is_empty()
    }
}

/// Checks `scene` (traced with `tracer`).
pub fn check(scene: &Scene, tracer: &Tracer) -> Check {
    let mut c = Check::default();
    let file = scene.source.display().to_string();
    let (lo, hi) = scene.bounds();
    let cfg = &scene.config;
    c.facts.push(format!(
        "{} triangles ({} degenerate and {} duplicate skipped), {} spheres; bounds ({:.3}, {:.3}, {:.3}) – ({:.3}, {:.3}, {:.3})",
        scene.triangles.len(),
        scene.degenerate_skipped,
        scene.duplicates_skipped,
        scene.spheres.len(),
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z
    ));
    // the probes: probe A and the explicit positions
    for (k, a) in crate::bake::placement::fixed_positions(scene).into_iter().enumerate() {
        let field = if k == 0 { "probe.position".to_string() } else { format!("probes.positions[{}]", k - 1) };
        check_probe_position(scene, tracer, &field, a, &mut c);
    }
    if c.errors.is_empty() {
        let renderer = crate::trace::Renderer::new(scene, tracer);
        let p = crate::bake::placement::place(&renderer, &crate::bake::grid_settings(scene));
        c.facts.push(format!(
            "probes: {} ({} placed automatically); of {} sampled reflection hits, {:.1}% are hidden from probe A alone and {:.1}% from every probe",
            p.positions.len(),
            p.placed,
            p.hits,
            100.0 * p.hidden_probe_a,
            100.0 * p.hidden
        ));
        if p.hidden > 0.05 {
            let probes = &cfg.probes;
            let cure = if !probes.auto {
                "add [probes] positions, or set [probes] auto = true".to_string()
            } else if p.positions.len() >= probes.max as usize {
                if probes.max >= crate::scene::config::MAX_PROBES {
                    format!(
                        "the automatic placement stopped at [probes] max = {}, the most a grid holds; reflections of what they miss will be wrong",
                        probes.max
                    )
                } else {
                    format!(
                        "the automatic placement stopped at [probes] max = {}: raise it (at most {})",
                        probes.max,
                        crate::scene::config::MAX_PROBES
                    )
                }
            } else {
                format!(
                    "the automatic placement stopped where the next probe would see less than [probes] min_gain = {}: lower it, or add [probes] positions",
                    probes.min_gain
                )
            };
            c.warnings.push(format!(
                "{file}: {:.0}% of the sampled reflection hits are hidden from every probe: {cure}",
                100.0 * p.hidden
            ));
        }
    }
    // the grid
    let (gmin, gmax) = (Vec3::from_array(cfg.grid.min), Vec3::from_array(cfg.grid.max));
    let overlap = gmin.max(lo);
    let overlap_hi = gmax.min(hi);
    if !(overlap_hi.cmpgt(overlap).all()) {
        c.errors.push(format!("{file}: grid [{gmin} – {gmax}] does not overlap the scene's bounds"));
    } else {
        let inside_share = (overlap_hi - overlap).element_product() / (gmax - gmin).element_product();
        if inside_share < 0.5 {
            c.warnings.push(format!(
                "{file}: only {:.0}% of the grid's volume lies inside the scene's bounds",
                100.0 * inside_share
            ));
        }
    }
    // light
    let emissive = scene.triangles.material.iter().any(|&m| scene.materials[m as usize].emission.max_element() > 0.0)
        || scene.spheres.material.iter().any(|&m| scene.materials[m as usize].emission.max_element() > 0.0);
    let sky = scene.sky.zenith.max(scene.sky.horizon).max(scene.sky.ground).max_element() > 0.0;
    let sun = scene.lights.sun.is_some_and(|s| s.irradiance.max_element() > 0.0);
    let spheres = scene.lights.sphere_lights.iter().any(|l| l.radiance.max_element() > 0.0);
    if !(emissive || sky || sun || spheres) {
        c.errors.push(format!(
            "{file}: the scene has no light (no sun, sky, sphere light or emissive surface): every method would score a perfect 0"
        ));
    }
    c.facts.push(format!(
        "light: sun {}, sky {}, {} sphere light(s), emissive surfaces {}",
        if sun { "yes" } else { "no" },
        if sky { "yes" } else { "no" },
        scene.lights.sphere_lights.len(),
        if emissive { "yes" } else { "no" }
    ));
    if c.errors.is_empty() {
        check_light_in_cells(scene, tracer, &mut c);
    }
    check_surface_probes(scene, tracer, &mut c);
    if scene.degenerate_skipped > 0 {
        c.warnings.push(format!("{file}: {} degenerate triangle(s) skipped", scene.degenerate_skipped));
    }
    if scene.duplicates_skipped > 0 {
        c.warnings.push(format!("{file}: {} duplicate triangle(s) dropped", scene.duplicates_skipped));
    }
    c
}

/// Levels of sparse bricks [`bricks`] plans with: cells of the grid's size, 3× and 9×.
pub const BRICK_LEVELS: u32 = 3;

/// How many of the grid's cells sparse bricks would keep ([`crate::bake::bricks`], the
/// seen-distance rule, [`BRICK_LEVELS`] levels, the finest cell the grid's smallest side),
/// as a fact line: what nested volumes and sparse bricks would save on this level. Traces
/// up to 2,160 rays per brick it visits (432 at the finest level), so `warpfit check`
/// prints it and the stages that check a scene first do not.
pub fn bricks(scene: &Scene, tracer: &Tracer) -> String {
    let settings = crate::bake::grid_settings(scene);
    let g = settings.geometry;
    let finest = g.cell_size().min_element();
    let p = crate::bake::bricks::plan(
        scene,
        tracer,
        (g.min, g.max),
        finest,
        BRICK_LEVELS,
        crate::bake::bricks::Rule::CHECK,
        settings.inside_backface_fraction,
    );
    let kept: Vec<String> = p.kept.iter().map(u64::to_string).collect();
    format!(
        "sparse bricks of {}³ cells at {finest:.3} and coarser (×3, ×9, split where a cell is over half the distance its air sees) would keep {} of {} cells ({:.1}%): {} bricks per level, finest first, {} inside geometry dropped",
        crate::bake::bricks::BRICK_CELLS,
        p.cells(),
        p.uniform_cells,
        100.0 * p.share(),
        kept.join(" / "),
        p.solid.iter().sum::<u64>()
    )
}

/// Whether light reaches the grid's cells, and whether the cells are small enough for the
/// level's rooms, from [`LIGHT_RAYS`] path-traced rays from cell centres against as many
/// from points around the level: cells that see much less light than the level's
/// surroundings sit in a closed level lit from outside (a lamp exported as a plain
/// material, a sky and sun added outside a box); cells larger than the typical distance
/// from a cell centre to what it sees blur reflections across rooms.
fn check_light_in_cells(scene: &Scene, tracer: &Tracer, c: &mut Check) {
    let file = scene.source.display().to_string();
    let geometry = crate::bake::grid_settings(scene).geometry;
    let renderer = crate::trace::Renderer::new(scene, tracer);
    let (lo, hi) = scene.bounds();
    let (centre, radius) = ((lo + hi) * 0.5, 0.75 * (hi - lo).length());
    let cells = geometry.cell_count() as u64;
    let (mut inside, mut outside, mut rays) = (0.0f64, 0.0f64, 0u64);
    let mut distances = Vec::new();
    for k in 0..LIGHT_RAYS {
        let mut s = Sampler::new(scene.config.seed, hash_pair(0x11C7, 0), k);
        let cell = (hash_pair(k as u64, 0x5E11) % cells.max(1)) as usize;
        let p = geometry.cell_centre(cell);
        let seen = renderer.sample(p, uniform_sphere(s.next_2d()), &mut s, &mut rays);
        inside += crate::tonemap::luminance(seen.radiance) as f64;
        if seen.distance.is_finite() && !seen.backface {
            distances.push(seen.distance);
        }
        let q = centre + uniform_sphere(s.next_2d()) * radius;
        let around = renderer.sample(q, uniform_sphere(s.next_2d()), &mut s, &mut rays);
        outside += crate::tonemap::luminance(around.radiance) as f64;
    }
    let share = inside / outside.max(1e-300);
    c.facts.push(format!(
        "light in the cells: rays from {LIGHT_RAYS} cell centres carry {} what rays around the level carry",
        if share < 1.0 { format!("{:.0}% of", 100.0 * share) } else { format!("{:.1}×", share.min(1e6)) }
    ));
    if inside <= 0.0 {
        c.warnings.push(format!(
            "{file}: no light reaches the grid's cells (none of {LIGHT_RAYS} rays from them carries any): the scene's lights are outside a closed level or behind its walls; add a light inside ([[sphere_lights]] or an emissive material)"
        ));
    } else if outside > 0.0 && share < DIM {
        c.warnings.push(format!(
            "{file}: little light reaches the grid's cells (rays from them carry {:.1}% of what rays around the level carry): the light is outside a nearly closed level; add a light inside ([[sphere_lights]] or an emissive material), or check that the file's lamps were exported as lights",
            100.0 * share
        ));
    }
    distances.sort_by(f32::total_cmp);
    if let Some(&typical) = distances.get(distances.len() / 2) {
        let cell = geometry.cell_size().max_element();
        if distances.len() >= LIGHT_RAYS as usize / 4 && cell > typical {
            c.warnings.push(format!(
                "{file}: cells of {cell:.3} are coarse for this level's rooms (a cell centre typically sees surfaces {typical:.3} away): reflections will blur across rooms; raise grid.counts for cells near {:.3} (`warpfit init` proposes a size)",
                0.5 * typical
            ));
        }
    }
}

/// A specular probe's position (`field` of the scene file): inside the scene's bounds and
/// not inside geometry.
fn check_probe_position(scene: &Scene, tracer: &Tracer, field: &str, a: Vec3, c: &mut Check) {
    let file = scene.source.display().to_string();
    let cfg = &scene.config;
    let (lo, hi) = scene.bounds();
    if !(a.cmpge(lo).all() && a.cmple(hi).all()) {
        c.errors.push(format!("{file}: {field} {a} lies outside the scene's bounds"));
        return;
    }
    let mut back = truth::Backfaces::default();
    for k in 0..WINDING_RAYS {
        let d = uniform_sphere(Sampler::new(cfg.seed, hash_pair(0xC4EC, 1), k).next_2d());
        match tracer.closest_hit(a, d, f32::INFINITY) {
            Some(h) => back.add(h.backface, scene.materials[h.material as usize].two_sided),
            None => back.add(false, false),
        }
    }
    if truth::inside_by_backfaces(back, cfg.grid.inside_backface_fraction) {
        c.errors.push(format!(
            "{file}: {field} {a} is inside geometry ({} of {} rays from it see back faces): move it into open space, or, if the level's surfaces are one-sided with mixed or inverted winding, set two_sided = true on its geometry",
            back.any, back.rays
        ));
    } else if back.one_sided as f32 > WINDING_WARN * back.rays as f32 {
        c.warnings.push(format!(
            "{file}: {:.0}% of the rays from {field} see back faces of one-sided surfaces: mixed or inverted winding, or surfaces that should be two_sided (set two_sided on the geometry)",
            100.0 * back.one_sided as f32 / back.rays as f32
        ));
    }
}

/// Points per surface-probe patch the check traces down onto the surface.
const SURFACE_CHECK_POINTS: u32 = 64;

/// Surface probes: what each patch holds, and whether it lies on a surface it faces (a
/// patch floating in the air, or facing into the floor, bakes probes that see the wrong
/// hemisphere) and near the grid.
fn check_surface_probes(scene: &Scene, tracer: &Tracer, c: &mut Check) {
    let file = scene.source.display().to_string();
    let cfg = &scene.config;
    let (gmin, gmax) = (Vec3::from_array(cfg.grid.min), Vec3::from_array(cfg.grid.max));
    let cell = (gmax - gmin) / glam::UVec3::from_array(cfg.grid.counts).as_vec3();
    for (k, sp) in scene.surface_probes().iter().enumerate() {
        let n = sp.edge_u.cross(sp.edge_v).normalize_or_zero();
        let probes = sp.counts[0] as u64 * sp.counts[1] as u64;
        let mips = crate::bake::surface::SURFACE_MIPS as u64;
        c.facts.push(format!(
            "surface_probes[{k}]: {}×{} probes {:.3} × {:.3} apart, tiles of {}² texels ({} with {mips} mips as RGBA16F)",
            sp.counts[0],
            sp.counts[1],
            sp.edge_u.length() / sp.counts[0] as f32,
            sp.edge_v.length() / sp.counts[1] as f32,
            sp.resolution,
            crate::files::human_bytes(probes * (sp.resolution * sp.resolution) as u64 * mips * 8)
        ));
        let (mut on, mut facing) = (0u32, 0u32);
        for j in 0..SURFACE_CHECK_POINTS {
            let st = Sampler::new(cfg.seed, hash_pair(0xC4EC, 2 + k as u64), j).next_2d();
            let p = sp.corner + sp.edge_u * st.x + sp.edge_v * st.y;
            let eps = 64.0 * tracer.surface_offset(p);
            if let Some(h) = tracer.closest_hit(p + n * eps, -n, 2.0 * eps) {
                on += 1;
                facing += u32::from(!h.backface || scene.materials[h.material as usize].two_sided);
            }
        }
        if on < SURFACE_CHECK_POINTS / 2 {
            c.warnings.push(format!(
                "{file}: surface_probes[{k}] lies on geometry at only {on} of {SURFACE_CHECK_POINTS} points: a patch in the air, or facing into the surface (its front is edge_u × edge_v = {n}; swap edge_u and edge_v to turn it)"
            ));
        } else if facing < on / 2 {
            c.warnings.push(format!(
                "{file}: surface_probes[{k}] lies on the back of a one-sided surface at {} of {on} points: swap edge_u and edge_v",
                on - facing
            ));
        }
        let centre = sp.corner + (sp.edge_u + sp.edge_v) * 0.5;
        if !(centre.cmpge(gmin - cell).all() && centre.cmple(gmax + cell).all()) {
            c.warnings.push(format!(
                "{file}: surface_probes[{k}] is centred at {centre}, outside the grid: its evaluation has no volume grid to compare with"
            ));
        }
    }
}
