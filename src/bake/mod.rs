//! Baking: from a scene to the specular probe A and the dense probe grid. Pure computation;
//! writing files is `bakefile`.

pub mod bricks;
pub mod grid;
pub mod placement;
pub mod probe;
pub mod surface;

pub use grid::{GridGeometry, ProbeGrid};
pub use probe::SpecularProbe;

use crate::progress::Progress;
use crate::scene::Scene;
use crate::trace::{Renderer, Tracer};
use crate::warp::{Proxies, Warp, WarpOptions, proxy};
use glam::{UVec3, Vec3};
use std::time::Instant;

/// A scene with its tracer and bake: what every stage after the bake reads.
#[derive(Clone, Copy)]
pub struct Baked<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a Tracer,
    pub probe: &'a SpecularProbe,
    /// The scene's other specular probes (`[probes]`), after probe A: empty for one probe.
    pub others: &'a [SpecularProbe],
    pub grid: &'a ProbeGrid,
    /// Where the references traced against it are kept between runs (none: traced anew).
    pub references: Option<&'a crate::trace::store::ReferenceStore>,
}

impl Baked<'_> {
    /// The warp context of this bake with `options`.
    pub fn warp(&self, options: WarpOptions) -> Warp {
        let mut w = warp(self.scene, self.probe, options);
        w.others = self.others.iter().map(SpecularProbe::warp_probe).collect::<Vec<_>>().into();
        w
    }

    /// Probe A, then the others: every probe a lookup can read.
    pub fn probes(&self) -> impl Iterator<Item = &SpecularProbe> {
        std::iter::once(self.probe).chain(self.others)
    }
}

/// What a bake of a scene will take, from its settings alone (before anything is traced).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Peak memory: probe mips, grid maps, geometry and its BVH.
    pub bytes: u64,
    /// Primary rays (each adds shadow and bounce rays).
    pub rays: u64,
}

impl Estimate {
    #[must_use]
    pub fn of(scene: &Scene) -> Estimate {
        let c = &scene.config;
        let r = c.probe.resolution as u64;
        let cells: u64 = c.grid.counts.iter().map(|&n| n as u64).product();
        let (ir, dr) = (c.grid.irradiance_resolution as u64, c.grid.depth_resolution as u64);
        // probe: radiance (RGB) and distance mips (×4/3), plus the supersampling buffer
        let probe = r * r * (12 + 4) * 4 / 3 + r * r * 12;
        // grid: irradiance (RGB) and three moment maps per cell, plus the inside flags
        let grid = cells * (ir * ir * 12 + dr * dr * 12 + 1);
        let geometry = scene.triangles.len() as u64 * 160 + scene.spheres.len() as u64 * 64;
        let rays = r * r * c.probe.samples_per_texel as u64 + cells * dr * dr * c.grid.depth_samples as u64;
        Estimate { bytes: probe + grid + geometry, rays }
    }
}

/// The warp context of a bake: probe A, the scene's bounds as the box proxy, an 18-DOP
/// fitted to the probe's depth, and `options`.
pub fn warp(scene: &Scene, probe: &SpecularProbe, options: WarpOptions) -> Warp {
    let (lo, hi) = scene.bounds();
    let kdop = proxy::Kdop::fit(probe.position, probe.distance());
    Warp {
        probe: probe.warp_probe(),
        others: Default::default(),
        proxies: Proxies { aabb: proxy::BoxProxy::aabb(lo, hi), kdop },
        options,
    }
}

/// Rays and time of a bake's stages.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq, Default)]
pub struct BakeStats {
    pub probe_rays: u64,
    pub grid_rays: u64,
    pub bvh_build_s: f64,
    pub probe_s: f64,
    pub grid_s: f64,
    pub total_s: f64,
    pub rays_per_s: f64,
    pub threads: usize,
    /// The share of the placement's sampled reflection hits probe A does not see, and
    /// that no probe sees (`placement::Placement`).
    #[serde(default)]
    pub hidden_probe_a: f64,
    #[serde(default)]
    pub hidden_probes: f64,
    /// Probes placed automatically.
    #[serde(default)]
    pub placed_probes: usize,
}

/// Everything a bake produces.
#[derive(Clone, Debug)]
pub struct Bake {
    pub probe: SpecularProbe,
    /// The other specular probes, in placement order (empty: probe A alone).
    pub others: Vec<SpecularProbe>,
    pub grid: ProbeGrid,
    pub stats: BakeStats,
}

impl Bake {
    /// Every probe's position, probe A first.
    pub fn positions(&self) -> Vec<Vec3> {
        std::iter::once(&self.probe).chain(&self.others).map(|p| p.position).collect()
    }

    /// The bake's stages' view of it with its scene and tracer.
    pub fn baked<'a>(&'a self, scene: &'a Scene, tracer: &'a Tracer) -> Baked<'a> {
        Baked { scene, tracer, probe: &self.probe, others: &self.others, grid: &self.grid, references: None }
    }
}

/// The probe settings of a scene file.
pub fn probe_settings(scene: &Scene) -> probe::ProbeSettings {
    let cfg = &scene.config;
    probe::ProbeSettings {
        position: Vec3::from_array(cfg.probe.position),
        resolution: cfg.probe.resolution,
        samples_per_texel: cfg.probe.samples_per_texel,
        ggx_samples: cfg.probe.ggx_samples,
        min_mip_resolution: cfg.probe.min_mip_resolution,
        seed: cfg.seed,
    }
}

/// The settings of the scene's probe `k` at `position`: probe A's (`k` = 0), or probe A's
/// resolution and samples with a seed of its own.
pub fn probe_settings_at(scene: &Scene, k: usize, position: Vec3) -> probe::ProbeSettings {
    let a = probe_settings(scene);
    let seed = if k == 0 { a.seed } else { crate::sampling::hash_pair(a.seed, 0x5052_0000 + k as u64) };
    probe::ProbeSettings { position, seed, ..a }
}

/// The scene's other probes (after probe A) at `positions[1..]`, baked as probe A is.
pub fn bake_others(renderer: &Renderer, positions: &[Vec3], progress: &Progress) -> (Vec<SpecularProbe>, u64) {
    let mut rays = 0;
    let mut out = Vec::new();
    for (k, &p) in positions.iter().enumerate().skip(1) {
        let (probe, r) = probe::bake_probe(renderer, &probe_settings_at(renderer.scene, k, p), progress);
        rays += r;
        out.push(probe);
    }
    (out, rays)
}

/// The grid settings of a scene file.
pub fn grid_settings(scene: &Scene) -> grid::GridSettings {
    let cfg = &scene.config;
    grid::GridSettings {
        geometry: GridGeometry {
            min: Vec3::from_array(cfg.grid.min),
            max: Vec3::from_array(cfg.grid.max),
            counts: UVec3::from_array(cfg.grid.counts),
        },
        irradiance_resolution: cfg.grid.irradiance_resolution,
        depth_resolution: cfg.grid.depth_resolution,
        depth_samples: cfg.grid.depth_samples,
        inside_backface_fraction: cfg.grid.inside_backface_fraction,
        relocate_clearance: cfg.grid.relocate_clearance,
        far_distance: 4.0 * scene.extent(),
        seed: cfg.seed,
    }
}

/// The grid cells shard `k` of `n` of a bake works on, the probe going with shard 0:
/// contiguous ranges of equal estimated cost (rays), the probe's rays counted against shard
/// 0's share; a probe that costs more than a share leaves shard 0 nothing else, and the
/// cells are split evenly over the other shards.
pub fn shard_cells(scene: &Scene, k: usize, n: usize) -> std::ops::Range<usize> {
    let cfg = &scene.config;
    let cells = cfg.grid.counts.iter().map(|&c| c as usize).product::<usize>();
    let cell_rays = (cfg.grid.depth_resolution as f64).powi(2) * cfg.grid.depth_samples.max(1) as f64;
    let probe_rays = (cfg.probe.resolution as f64).powi(2) * cfg.probe.samples_per_texel.max(1) as f64;
    let probe = probe_rays / cell_rays.max(1.0);
    let n = n.max(1);
    let k = k.min(n - 1);
    if n > 1 && probe >= (cells as f64 + probe) / n as f64 {
        let (k, n) = (k as isize - 1, n - 1);
        if k < 0 {
            return 0..0;
        }
        let k = k as usize;
        return cells * k / n..cells * (k + 1) / n;
    }
    let total = cells as f64 + probe;
    // shard j starts where the cost j·total/n is reached, the probe being [0, probe)
    let edge = |j: usize| -> usize {
        match j {
            0 => 0,
            j if j >= n => cells,
            j => ((j as f64 * total / n as f64 - probe).max(0.0).round() as usize).min(cells),
        }
    };
    edge(k)..edge(k + 1)
}

/// Bakes the scene's probe and grid with the settings of its scene file.
pub fn bake(scene: &Scene, tracer: &Tracer, progress: &Progress) -> Bake {
    let t0 = Instant::now();
    let renderer = Renderer::new(scene, tracer);
    crate::trace::streams::set_stage(crate::trace::streams::Stage::ProbeBake);
    let (probe, mut probe_rays) = probe::bake_probe(&renderer, &probe_settings(scene), progress);
    let placement = placement::place(&renderer, &grid_settings(scene));
    let (others, other_rays) = bake_others(&renderer, &placement.positions, progress);
    probe_rays += other_rays + placement.rays;
    let probe_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    crate::trace::streams::set_stage(crate::trace::streams::Stage::GridBake);
    let (grid, grid_rays) = grid::bake_grid(&renderer, &grid_settings(scene), progress);
    let grid_s = t1.elapsed().as_secs_f64();
    let total_s = t0.elapsed().as_secs_f64();
    let stats = BakeStats {
        probe_rays,
        grid_rays,
        bvh_build_s: tracer.build_time.as_secs_f64(),
        probe_s,
        grid_s,
        total_s,
        rays_per_s: (probe_rays + grid_rays) as f64 / total_s.max(1e-9),
        threads: rayon::current_num_threads(),
        hidden_probe_a: placement.hidden_probe_a,
        hidden_probes: placement.hidden,
        placed_probes: placement.placed,
    };
    Bake { probe, others, grid, stats }
}
