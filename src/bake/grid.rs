//! The dense probe grid (Black Ops 3 / DDGI style): per cell probe, a cosine-convolved
//! irradiance octahedral map and distance moments (mean, mean of squares, hit fraction) on a
//! separate octahedral map. Cells whose probe is inside geometry are flagged.
//!
//! A cell's probe sits at its centre unless the centre is inside geometry or nearer to it
//! than `relocate_clearance` of the cell: then it moves, within its cell, to the nearest
//! candidate of a 5×5×5 lattice (±0.19, ±0.38 of the cell per axis) that is visible from the
//! centre (when the centre is outside geometry: a probe never moves through a wall), outside
//! geometry by the one inside rule (`trace::truth::is_inside`) and clear by that distance (DDGI's probe
//! relocation, Majercik et al. 2021; Unity's virtual offset). No clear candidate: the most
//! open one outside geometry, if at least a quarter of that clear; else the centre (flagged
//! inside if it is).
//!
//! Each cell traces `depth_resolution² × depth_samples` rays, stratified inside the distance
//! texels; the same rays' radiance is convolved with the clamped cosine for irradiance, each
//! weighted by its texel's exact solid angle.

use crate::octa::{self, texel_solid_angles};
use crate::progress::Progress;
use crate::sampling::{Sampler, hash_pair};
use crate::trace::Renderer;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

pub const DOMAIN_GRID: u64 = 0x4752_4944; // "GRID"

pub use crate::grid::GridGeometry;

/// Baked grid as plain arrays, cell-major (`cell · res² + texel`).
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeGrid {
    pub geometry: GridGeometry,
    pub irradiance_resolution: u32,
    pub depth_resolution: u32,
    pub depth_samples: u32,
    /// Irradiance E(n) (W/m²-like units of the scene's radiance × sr) for each texel normal.
    pub irradiance: Vec<Vec3>,
    /// Mean distance per depth texel, misses counted as `far_distance`.
    pub depth_mean: Vec<f32>,
    /// Mean squared distance per depth texel (same convention).
    pub depth_mean_sq: Vec<f32>,
    /// Rays of the texel (of `depth_samples`) that hit geometry: a byte, not the fraction
    /// (a quarter of the memory; [`hit_fraction`] gives the fraction the bake files store).
    /// Empty when a bake was read without them (`bakefile::Hits::Later`): only a fit's cells
    /// stage reads them.
    pub hits: Vec<u8>,
    /// Cell probe inside geometry (too many back-face hits).
    pub inside: Vec<bool>,
    /// Per cell: the probe's offset from the cell centre (zero where it was not moved).
    pub probe_offset: Vec<Vec3>,
    /// Distance standing in for "miss" in the moments: 4 × the scene's bounds diagonal.
    pub far_distance: f32,
}

impl ProbeGrid {
    /// Whether the grid holds its hit counts (a bake read with `bakefile::Hits::Later` does
    /// not until they are read).
    #[must_use]
    pub fn holds_hits(&self) -> bool {
        self.hits.len() == self.geometry.cell_count() * (self.depth_resolution * self.depth_resolution) as usize
    }

    pub fn active_cells(&self) -> usize {
        self.inside.iter().filter(|x| !**x).count()
    }

    /// Each cell's slot in the grid's dense arrays: the cell itself, or
    /// [`NO_MAP`](crate::warp::corrective::NO_MAP) inside geometry (for
    /// [`ProbeGrid::irradiance_view`]).
    #[must_use]
    pub fn dense_slots(&self) -> Vec<u32> {
        self.inside
            .iter()
            .enumerate()
            .map(|(c, &inside)| if inside { crate::warp::corrective::NO_MAP } else { c as u32 })
            .collect()
    }

    /// The cells outside geometry as the runtime's blend reads them, borrowed from the bake
    /// (the same values a grid written from it holds, without copying them): `slots` from
    /// [`ProbeGrid::dense_slots`].
    #[must_use]
    pub fn irradiance_view<'a>(&'a self, slots: &'a [u32]) -> crate::runtime::IrradianceView<'a> {
        crate::runtime::IrradianceView {
            geometry: self.geometry,
            resolution: self.irradiance_resolution,
            depth_resolution: self.depth_resolution,
            slot: slots,
            irradiance: &self.irradiance,
            depth_mean: &self.depth_mean,
            depth_mean_sq: &self.depth_mean_sq,
            probe_offset: &self.probe_offset,
        }
    }
}

pub struct GridSettings {
    pub geometry: GridGeometry,
    pub irradiance_resolution: u32,
    pub depth_resolution: u32,
    pub depth_samples: u32,
    pub inside_backface_fraction: f32,
    pub relocate_clearance: f32,
    pub far_distance: f32,
    pub seed: u64,
}

/// The fraction `hits` of `samples` rays: the value the bake files store.
#[must_use]
pub fn hit_fraction(hits: u8, samples: u32) -> f32 {
    f32::from(hits) / samples.max(1) as f32
}

/// One cell's bake: what a shard of a bake hands to the merge.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CellBake {
    pub irradiance: Vec<Vec3>,
    pub mean: Vec<f32>,
    pub mean_sq: Vec<f32>,
    /// Rays per texel that hit geometry (of `depth_samples`).
    pub hits: Vec<u8>,
    pub inside: bool,
    pub offset: Vec3,
    pub rays: u64,
}

impl CellBake {
    /// Whether the cell's maps have the sizes `s` gives and hold finite values.
    pub fn fits(&self, s: &GridSettings) -> bool {
        let (i2, d2) = ((s.irradiance_resolution.pow(2)) as usize, (s.depth_resolution.pow(2)) as usize);
        self.irradiance.len() == i2
            && self.mean.len() == d2
            && self.mean_sq.len() == d2
            && self.hits.len() == d2
            && self.hits.iter().all(|&h| u32::from(h) <= s.depth_samples)
            && self.irradiance.iter().all(|e| e.is_finite())
            && self.mean.iter().chain(&self.mean_sq).all(|x| x.is_finite())
            && self.offset.is_finite()
    }
}

/// Bakes every cell; returns the grid and the number of rays traced. Each cell writes its
/// maps straight into the grid's arrays (no per-cell copies: the bake's memory is the grid's).
pub fn bake_grid(renderer: &Renderer, s: &GridSettings, progress: &Progress) -> (ProbeGrid, u64) {
    let cells = s.geometry.cell_count();
    let (i2, d2) = ((s.irradiance_resolution.pow(2)) as usize, (s.depth_resolution.pow(2)) as usize);
    let mut grid = ProbeGrid {
        geometry: s.geometry,
        irradiance_resolution: s.irradiance_resolution,
        depth_resolution: s.depth_resolution,
        depth_samples: s.depth_samples,
        irradiance: vec![Vec3::ZERO; cells * i2],
        depth_mean: vec![0.0; cells * d2],
        depth_mean_sq: vec![0.0; cells * d2],
        hits: vec![0; cells * d2],
        inside: vec![false; cells],
        probe_offset: vec![Vec3::ZERO; cells],
        far_distance: s.far_distance,
    };
    let tables = CellTables::new(s);
    let bar = progress.bar(cells as u64, "grid cells");
    let rays = grid
        .irradiance
        .par_chunks_mut(i2)
        .zip(grid.depth_mean.par_chunks_mut(d2))
        .zip(grid.depth_mean_sq.par_chunks_mut(d2))
        .zip(grid.hits.par_chunks_mut(d2))
        .zip(grid.inside.par_iter_mut())
        .zip(grid.probe_offset.par_iter_mut())
        .enumerate()
        .map(|(cell, (((((irradiance, mean), mean_sq), hits), inside), offset))| {
            let rest = bake_cell(renderer, s, cell, &tables, CellMaps { irradiance, mean, mean_sq, hits });
            (*inside, *offset) = (rest.inside, rest.offset);
            bar.inc(1);
            rest.rays
        })
        .sum();
    bar.finish_and_clear();
    (grid, rays)
}

/// Bakes the cells `cells`, in order (each cell on its own streams: any split bakes the
/// same values).
pub fn bake_cells(
    renderer: &Renderer,
    s: &GridSettings,
    cells: std::ops::Range<usize>,
    progress: &Progress,
) -> Vec<CellBake> {
    let (i2, d2) = ((s.irradiance_resolution.pow(2)) as usize, (s.depth_resolution.pow(2)) as usize);
    let tables = CellTables::new(s);
    let bar = progress.bar(cells.len() as u64, "grid cells");
    let baked: Vec<CellBake> = cells
        .into_par_iter()
        .map(|cell| {
            let (mut irradiance, mut mean, mut mean_sq, mut hits) =
                (vec![Vec3::ZERO; i2], vec![0.0; d2], vec![0.0; d2], vec![0; d2]);
            let maps =
                CellMaps { irradiance: &mut irradiance, mean: &mut mean, mean_sq: &mut mean_sq, hits: &mut hits };
            let CellRest { inside, offset, rays } = bake_cell(renderer, s, cell, &tables, maps);
            bar.inc(1);
            CellBake { irradiance, mean, mean_sq, hits, inside, offset, rays }
        })
        .collect();
    bar.finish_and_clear();
    baked
}

/// The grid of every cell's bake (in cell order); returns it with the rays traced.
pub fn assemble(s: &GridSettings, baked: Vec<CellBake>) -> (ProbeGrid, u64) {
    let cells = baked.len();
    let (dres, ires) = (s.depth_resolution, s.irradiance_resolution);
    let mut grid = ProbeGrid {
        geometry: s.geometry,
        irradiance_resolution: ires,
        depth_resolution: dres,
        depth_samples: s.depth_samples,
        irradiance: Vec::with_capacity(cells * (ires * ires) as usize),
        depth_mean: Vec::with_capacity(cells * (dres * dres) as usize),
        depth_mean_sq: Vec::with_capacity(cells * (dres * dres) as usize),
        hits: Vec::with_capacity(cells * (dres * dres) as usize),
        inside: Vec::with_capacity(cells),
        probe_offset: Vec::with_capacity(cells),
        far_distance: s.far_distance,
    };
    let mut rays = 0;
    for c in baked {
        grid.irradiance.extend(c.irradiance);
        grid.depth_mean.extend(c.mean);
        grid.depth_mean_sq.extend(c.mean_sq);
        grid.hits.extend(c.hits);
        grid.inside.push(c.inside);
        grid.probe_offset.push(c.offset);
        rays += c.rays;
    }
    (grid, rays)
}

/// What every cell's bake shares: the depth texels' solid angles and the irradiance texels'
/// normals.
struct CellTables {
    depth_omega: Vec<f32>,
    irr_normals: Vec<Vec3>,
}

impl CellTables {
    fn new(s: &GridSettings) -> CellTables {
        let ires = s.irradiance_resolution;
        CellTables {
            depth_omega: texel_solid_angles(s.depth_resolution),
            irr_normals: (0..ires * ires).map(|t| octa::texel_dir(ires, t % ires, t / ires)).collect(),
        }
    }
}

/// One cell's maps, written in place (zeroed on entry): its slices of the grid's arrays, or a
/// [`CellBake`]'s.
struct CellMaps<'a> {
    irradiance: &'a mut [Vec3],
    mean: &'a mut [f32],
    mean_sq: &'a mut [f32],
    hits: &'a mut [u8],
}

/// The rest of a cell's bake.
struct CellRest {
    inside: bool,
    offset: Vec3,
    rays: u64,
}

fn bake_cell(renderer: &Renderer, s: &GridSettings, cell: usize, tables: &CellTables, maps: CellMaps) -> CellRest {
    let CellTables { depth_omega, irr_normals } = tables;
    let CellMaps { irradiance, mean, mean_sq, hits: hit_counts } = maps;
    let dres = s.depth_resolution;
    let cell_stream = hash_pair(DOMAIN_GRID, cell as u64);
    let mut rays = 0u64;
    let offset = relocate(renderer, s, cell, &mut rays);
    let centre = s.geometry.cell_centre(cell) + offset;
    let mut cosine_sum = vec![0.0f32; irr_normals.len()];
    let mut backfaces = crate::trace::truth::Backfaces::default();
    let spp = s.depth_samples;
    for t in 0..dres * dres {
        let weight = depth_omega[t as usize] / spp as f32;
        let (mut d1, mut d2, mut hits) = (0.0f64, 0.0f64, 0u8);
        for k in 0..spp {
            let (mut sampler, dir) = texel_ray(s, cell_stream, t, k);
            let r = renderer.sample(centre, dir, &mut sampler, &mut rays);
            let d = if r.distance.is_finite() {
                hits = hits.saturating_add(1); // depth_samples ≤ 255 (scene validation)
                r.distance.min(s.far_distance)
            } else {
                s.far_distance
            };
            d1 += d as f64;
            d2 += (d as f64) * (d as f64);
            backfaces.add(r.backface || r.backface_two_sided, r.backface_two_sided);
            splat_cosine(irradiance, &mut cosine_sum, irr_normals, dir, r.radiance, weight);
        }
        mean[t as usize] = (d1 / spp as f64) as f32;
        mean_sq[t as usize] = (d2 / spp as f64) as f32;
        hit_counts[t as usize] = hits;
    }
    normalise_cosine(irradiance, &cosine_sum);
    let inside = crate::trace::truth::inside_by_backfaces(backfaces, s.inside_backface_fraction);
    // a probe the bake's own rays find inside is dropped: it keeps no offset
    let offset = if inside { Vec3::ZERO } else { offset };
    CellRest { inside, offset, rays }
}

/// One ray's part of a cell's irradiance map: `radiance` from `dir`, weighted by
/// `weight` (its texel's solid angle per ray) and each texel normal's clamped cosine, with
/// the cosines summed beside it for [`normalise_cosine`].
#[inline]
fn splat_cosine(
    irradiance: &mut [Vec3],
    cosine_sum: &mut [f32],
    normals: &[Vec3],
    dir: Vec3,
    radiance: Vec3,
    weight: f32,
) {
    for ((e, cs), n) in irradiance.iter_mut().zip(cosine_sum).zip(normals) {
        let c = n.dot(dir);
        if c > 0.0 {
            *e += radiance * (c * weight);
            *cs += c * weight;
        }
    }
}

/// Ratio estimator: normalise by the quadrature of ∫cos = π itself, which makes a constant
/// environment exact and removes the quadrature's bias elsewhere.
fn normalise_cosine(irradiance: &mut [Vec3], cosine_sum: &[f32]) {
    for (e, cs) in irradiance.iter_mut().zip(cosine_sum) {
        *e = if *cs > 0.0 { *e * (std::f32::consts::PI / *cs) } else { Vec3::ZERO };
    }
}

/// Ray `k` of distance texel `t` of the cell with stream `cell_stream`: its sampler, past
/// the two numbers that placed it in the texel, and its direction.
#[inline]
fn texel_ray(s: &GridSettings, cell_stream: u64, t: u32, k: u32) -> (Sampler, Vec3) {
    let dres = s.depth_resolution;
    let mut sampler = Sampler::new(s.seed, hash_pair(cell_stream, t as u64), k);
    let uv = (Vec2::new((t % dres) as f32, (t / dres) as f32) + sampler.next_2d()) / dres as f32;
    (sampler, octa::decode(uv))
}

/// The part of every cell's irradiance map seen straight from an emitter next-event
/// estimation samples (a sphere light, an emissive triangle): the bake's own rays again,
/// from where the bake put each probe (`grid.probe_offset`), weighted as the bake weighs
/// them, with [`Renderer::emitted_along`] for their radiance. The convolution is linear, so
/// this is exactly the emitted part of `grid.irradiance` (what the evaluation takes out of
/// a lookup that blends the irradiance in, to measure the light apart from the emitters).
/// Cell-major as `grid.irradiance`; zero for cells inside geometry, and everywhere, with
/// no ray traced, in a scene without such emitters.
pub fn emitted_irradiance(renderer: &Renderer, s: &GridSettings, grid: &ProbeGrid) -> (Vec<Vec3>, u64) {
    let i2 = (s.irradiance_resolution.pow(2)) as usize;
    let mut out = vec![Vec3::ZERO; grid.inside.len() * i2];
    if !renderer.has_emitters() {
        return (out, 0);
    }
    let tables = CellTables::new(s);
    let rays: u64 = out
        .par_chunks_mut(i2)
        .enumerate()
        .map(|(cell, irradiance)| {
            if grid.inside[cell] {
                return 0;
            }
            let centre = s.geometry.cell_centre(cell) + grid.probe_offset.get(cell).copied().unwrap_or(Vec3::ZERO);
            let cell_stream = hash_pair(DOMAIN_GRID, cell as u64);
            let mut cosine_sum = vec![0.0f32; i2];
            let mut rays = 0u64;
            let dres = s.depth_resolution;
            for t in 0..dres * dres {
                let weight = tables.depth_omega[t as usize] / s.depth_samples as f32;
                for k in 0..s.depth_samples {
                    let (_, dir) = texel_ray(s, cell_stream, t, k);
                    let seen =
                        renderer.first_hit(centre, dir, &mut rays).map_or(Vec3::ZERO, |f| renderer.emitted_along(&f));
                    splat_cosine(irradiance, &mut cosine_sum, &tables.irr_normals, dir, seen, weight);
                }
            }
            normalise_cosine(irradiance, &cosine_sum);
            rays
        })
        .collect::<Vec<u64>>()
        .iter()
        .sum();
    (out, rays)
}

/// Directions of the clearance test: a Fibonacci sphere (the same for every candidate).
const CLEARANCE_RAYS: u32 = 64;

/// How far `p` is from geometry (the nearest hit over [`CLEARANCE_RAYS`] directions, up to
/// `limit`), and whether it is inside geometry by the one inside rule.
fn clearance(renderer: &Renderer, s: &GridSettings, p: Vec3, stream: u64, limit: f32, rays: &mut u64) -> (f32, bool) {
    let tracer = renderer.tracer;
    let mut nearest = limit;
    for k in 0..CLEARANCE_RAYS {
        let z = 1.0 - (2 * k + 1) as f32 / CLEARANCE_RAYS as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = k as f32 * 2.399_963_2;
        let d = Vec3::new(r * libm::cosf(phi), z, r * libm::sinf(phi));
        *rays += 1;
        if let Some(h) = tracer.closest_hit(p, d, limit) {
            nearest = nearest.min(h.t);
        }
    }
    *rays += u64::from(crate::trace::truth::INSIDE_PROBE_RAYS);
    let inside = crate::trace::truth::is_inside(renderer.scene, tracer, p, s.inside_backface_fraction, |j| {
        Sampler::new(s.seed, stream, j)
    });
    (nearest, inside)
}

/// Where a probe of cell `cell` may stand: its centre, relocated as the cell's probe is;
/// `None` when that is inside geometry or closer to it than a quarter of the clearance the
/// relocation asks for.
pub(crate) fn open_position(renderer: &Renderer, s: &GridSettings, cell: usize, rays: &mut u64) -> Option<Vec3> {
    let p = s.geometry.cell_centre(cell) + relocate(renderer, s, cell, rays);
    let need = s.relocate_clearance.max(0.05) * s.geometry.cell_size().min_element();
    let stream = hash_pair(hash_pair(DOMAIN_GRID, 0x0BE4), cell as u64);
    let (c, inside) = clearance(renderer, s, p, stream, 2.0 * need, rays);
    (!inside && c >= need / 4.0).then_some(p)
}

/// The offset of cell `cell`'s probe from its centre (see the module's documentation).
fn relocate(renderer: &Renderer, s: &GridSettings, cell: usize, rays: &mut u64) -> Vec3 {
    if s.relocate_clearance <= 0.0 {
        return Vec3::ZERO;
    }
    let size = s.geometry.cell_size();
    let need = s.relocate_clearance * size.min_element();
    let centre = s.geometry.cell_centre(cell);
    let stream = hash_pair(hash_pair(DOMAIN_GRID, 0x4E10), cell as u64);
    let (c0, inside0) = clearance(renderer, s, centre, stream, 2.0 * need, rays);
    if !inside0 && c0 >= need {
        return Vec3::ZERO;
    }
    // candidates nearest first (ties in lattice order): the probe never leaves its cell
    // off the round fractions where authored surfaces tend to lie (a candidate exactly on a
    // face would see through it)
    let steps = [-0.38f32, -0.19, 0.0, 0.19, 0.38];
    let mut candidates: Vec<Vec3> = Vec::with_capacity(124);
    for z in steps {
        for y in steps {
            for x in steps {
                let o = Vec3::new(x, y, z) * size;
                if o != Vec3::ZERO {
                    candidates.push(o);
                }
            }
        }
    }
    candidates.sort_by(|a, b| (a / size).length_squared().total_cmp(&(b / size).length_squared()));
    let mut best: Option<(f32, Vec3)> = (!inside0).then_some((c0, Vec3::ZERO));
    for (k, o) in candidates.into_iter().enumerate() {
        // a probe outside geometry moves only where it can see from its centre: never
        // through a wall into the room behind it
        if !inside0 {
            *rays += 1;
            let len = o.length();
            if renderer.tracer.occluded(centre, o / len, len) {
                continue;
            }
        }
        let (c, inside) = clearance(renderer, s, centre + o, hash_pair(stream, 1 + k as u64), 2.0 * need, rays);
        if inside {
            continue;
        }
        if c >= need {
            return o;
        }
        if c >= need / 4.0 && best.is_none_or(|(b, _)| c > b) {
            best = Some((c, o));
        }
    }
    best.map_or(Vec3::ZERO, |(_, o)| o)
}
