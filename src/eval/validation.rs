//! The validation set: held-out queries drawn in their own sampler domain, independent of
//! anything a fitter sees. Positions are uniformly random inside grid cells that are not
//! inside geometry (never at cell centres; positions the inside rule rejects are redrawn),
//! with uniformly random directions each; references, oracle directions and the hidden flag
//! come from `trace::truth`.

use super::EvalSettings;
use crate::bake::ProbeGrid;
use crate::grid::GridGeometry;
use crate::sampling::{Sampler, hash_pair};
use crate::scene::Scene;
use crate::trace::store::{self, ReferenceStore};
use crate::trace::truth::{self, Oracle, QueryStreams, TracedQueries};
use crate::trace::{Renderer, Tracer};
use crate::warp::glossy::Aim;
use glam::Vec3;
use rayon::prelude::*;

/// Sampler domain of everything the evaluation draws.
pub const DOMAIN_EVAL: u64 = 0x4556_414C; // "EVAL"

/// Held-out queries and their ground truth.
pub struct ValidationSet {
    pub queries: TracedQueries,
    /// Direction from A towards the true hit point (the query direction on a miss).
    pub oracle_dir: Vec<Vec3>,
    /// The true hit point is hidden from A: no single fetch of A can be right.
    pub hidden: Vec<bool>,
    /// Of several probes, the fetch of the nearest that sees the true hit (`Oracle::any`).
    pub oracle_any: Vec<Aim>,
    /// The true hit point is hidden from every probe.
    pub hidden_all: Vec<bool>,
}

impl std::ops::Deref for ValidationSet {
    type Target = TracedQueries;
    fn deref(&self) -> &TracedQueries {
        &self.queries
    }
}

impl ValidationSet {
    /// Fraction of the queries whose true hit is hidden from probe A.
    pub fn hidden_fraction(&self) -> f64 {
        self.hidden.iter().filter(|h| **h).count() as f64 / self.hidden.len().max(1) as f64
    }

    /// Fraction of the queries whose true hit is hidden from every probe.
    pub fn hidden_fraction_all(&self) -> f64 {
        self.hidden_all.iter().filter(|h| **h).count() as f64 / self.hidden_all.len().max(1) as f64
    }

    /// The oracles of query `k`.
    #[inline]
    pub fn oracle(&self, k: usize) -> Oracle {
        Oracle { a: self.oracle_dir[k], any: self.oracle_any[k] }
    }
}

/// The validation set's streams, for the positions from `first` on. The mirror set and
/// every roughness bucket share the directions (a bucket's queries are the mirror set's,
/// with a rough lobe); each traces its references with streams of its own.
struct Streams {
    seed: u64,
    dirs_per_position: usize,
    first: usize,
    roughness: f32,
    /// 0 for the mirror set, the bucket's number for a rough one.
    bucket: u64,
}

impl QueryStreams for Streams {
    fn direction(&self, p: usize, d: usize) -> Sampler {
        Sampler::new(self.seed, hash_pair(DOMAIN_EVAL, 2 + (self.first + p) as u64), d as u32)
    }
    fn reference(&self, p: usize, d: usize, k: u32) -> Sampler {
        let ray = ((self.first + p) * self.dirs_per_position + d) as u64;
        match self.bucket {
            0 => Sampler::new(self.seed, hash_pair(DOMAIN_EVAL, 0) + ray, k),
            b => Sampler::new(self.seed, hash_pair(hash_pair(DOMAIN_EVAL, 0x5200 + b), ray), k),
        }
    }
    fn roughness(&self, _p: usize, _d: usize) -> f32 {
        self.roughness
    }
}

/// Draws the validation set and traces its references and oracle directions.
pub fn validation_set(
    scene: &Scene,
    tracer: &Tracer,
    grid: &ProbeGrid,
    probes: &[Vec3],
    s: &EvalSettings,
    store: Option<&ReferenceStore>,
) -> ValidationSet {
    let renderer = Renderer::new(scene, tracer);
    let active: Vec<usize> = (0..grid.geometry.cell_count()).filter(|&c| !grid.inside[c]).collect();
    let positions = positions(scene, tracer, (&grid.geometry, &active), s.positions, s.seed);
    let dpp = s.dirs_per_position as usize;
    let queries = trace_at((&renderer, store), &positions, (dpp, dpp), s.reference_spp, (s.seed, 0.0, 0));
    let truths: Vec<(Oracle, bool, bool)> = (0..queries.dirs.len())
        .into_par_iter()
        .map(|k| truth::oracles(scene, tracer, probes, queries.position_of(k), queries.dirs[k]))
        .collect();
    ValidationSet {
        queries,
        oracle_dir: truths.iter().map(|t| t.0.a).collect(),
        hidden: truths.iter().map(|t| t.1).collect(),
        oracle_any: truths.iter().map(|t| t.0.any).collect(),
        hidden_all: truths.iter().map(|t| t.2).collect(),
    }
}

/// `count` validation positions: uniformly random in the `active` cells of `geometry`,
/// redrawn where the inside rule says they lie in geometry (at most 64 draws a position).
pub fn positions(
    scene: &Scene,
    tracer: &Tracer,
    (geometry, active): (&GridGeometry, &[usize]),
    count: u32,
    seed: u64,
) -> Vec<Vec3> {
    let threshold = scene.config.grid.inside_backface_fraction;
    let mut positions = Vec::with_capacity(count as usize);
    let mut attempt = 0u32;
    while positions.len() < count as usize && !active.is_empty() && attempt < count * 64 {
        let mut sampler = Sampler::new(seed, hash_pair(DOMAIN_EVAL, 1), attempt);
        attempt += 1;
        let cell = active[((sampler.next_1d() * active.len() as f32) as usize).min(active.len() - 1)];
        let c = geometry.cell_coords(cell).as_vec3();
        let u = Vec3::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d());
        let p = geometry.min + (c + u) * geometry.cell_size();
        let stream = hash_pair(DOMAIN_EVAL, 0xB ^ attempt as u64);
        if truth::is_inside(scene, tracer, p, threshold, |k| Sampler::new(seed, stream, k)) {
            continue;
        }
        positions.push(p);
    }
    positions
}

/// A roughness bucket of the validation set: the mirror set's first `positions` positions
/// and first `dirs` directions at each, with GGX lobe references of perceptual roughness `r`
/// (`spp` samples each; `bucket` > 0 names their streams). Oracle directions and hidden
/// flags are the mirror set's for the same rays.
pub fn rough_set(
    (scene, tracer, store): (&Scene, &Tracer, Option<&ReferenceStore>),
    mirror: &ValidationSet,
    (r, bucket): (f32, u64),
    (positions, dirs): (usize, usize),
    spp: u32,
    seed: u64,
) -> ValidationSet {
    let renderer = Renderer::new(scene, tracer);
    let base_dpp = mirror.dirs_per_position;
    let (positions, dirs) = (positions.min(mirror.positions.len()), dirs.min(base_dpp));
    let queries =
        trace_at((&renderer, store), &mirror.positions[..positions], (dirs, base_dpp), spp, (seed, r, bucket));
    let base = |k: usize| (k / dirs) * base_dpp + k % dirs;
    let oracle_dir = (0..queries.dirs.len()).map(|k| mirror.oracle_dir[base(k)]).collect();
    let hidden = (0..queries.dirs.len()).map(|k| mirror.hidden[base(k)]).collect();
    let oracle_any = (0..queries.dirs.len()).map(|k| mirror.oracle_any[base(k)]).collect();
    let hidden_all = (0..queries.dirs.len()).map(|k| mirror.hidden_all[base(k)]).collect();
    ValidationSet { queries, oracle_dir, hidden, oracle_any, hidden_all }
}

/// Streams of the quiet references: apart from the mirror set's (0) and the rough
/// buckets' (1 to 5).
const QUIET_BUCKET: u64 = 0x51E7;

/// The mirror set's first `positions` positions, every direction, traced again with `spp`
/// samples each from streams of their own: the same queries (the same directions), with
/// references independent of the set's and quieter (see `bound::NoiseCeiling`).
pub fn quiet_references(
    scene: &Scene,
    tracer: &Tracer,
    mirror: &ValidationSet,
    positions: usize,
    spp: u32,
    seed: u64,
    store: Option<&ReferenceStore>,
) -> TracedQueries {
    let renderer = Renderer::new(scene, tracer);
    let dpp = mirror.dirs_per_position;
    let positions = positions.min(mirror.positions.len());
    trace_at((&renderer, store), &mirror.positions[..positions], (dpp, dpp), spp, (seed, 0.0, QUIET_BUCKET))
}

/// The queries of the validation set's first `positions.len()` positions, `dirs` of each
/// position's `dirs_per_position` directions, traced with `spp`-sample references of
/// roughness `r` from the streams of `bucket` (0: the mirror set's), in parallel over the
/// positions.
fn trace_at(
    (renderer, store): (&Renderer, Option<&ReferenceStore>),
    positions: &[Vec3],
    (dirs, dirs_per_position): (usize, usize),
    spp: u32,
    (seed, roughness, bucket): (u64, f32, u64),
) -> TracedQueries {
    let trace = || {
        let parts: Vec<TracedQueries> = positions
            .par_iter()
            .enumerate()
            .map(|(p, b)| {
                let streams = Streams { seed, dirs_per_position, first: p, roughness, bucket };
                truth::trace_queries(renderer, std::slice::from_ref(b), dirs, spp, &streams)
            })
            .collect();
        TracedQueries::concat(parts)
    };
    match store {
        Some(store) => {
            let key = store.key("queries").vec3s(positions).words([
                dirs as u64,
                dirs_per_position as u64,
                u64::from(spp),
                seed,
                u64::from(roughness.to_bits()),
                bucket,
            ]);
            let codec = (store::queries_to_words, |w: &[u32]| {
                store::queries_from_words(w).filter(|q| q.positions == positions)
            });
            store.cached("queries", key, codec, trace)
        }
        None => trace(),
    }
}
