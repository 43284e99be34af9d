//! The validation set: held-out queries drawn in their own sampler domain, independent of
//! anything a fitter sees. Positions are uniformly random inside grid cells that are not
//! inside geometry (never at cell centres; positions the inside rule rejects are redrawn),
//! with uniformly random directions each; references, oracle directions and the hidden flag
//! come from `trace::truth`.

use super::EvalSettings;
use crate::bake::ProbeGrid;
use crate::sampling::{Sampler, hash_pair};
use crate::scene::Scene;
use crate::trace::truth::{self, QueryStreams, TracedQueries};
use crate::trace::{Renderer, Tracer};
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
}

/// The validation set's streams, for the positions from `first` on.
struct Streams {
    seed: u64,
    dirs_per_position: usize,
    first: usize,
}

impl QueryStreams for Streams {
    fn direction(&self, p: usize, d: usize) -> Sampler {
        Sampler::new(self.seed, hash_pair(DOMAIN_EVAL, 2 + (self.first + p) as u64), d as u32)
    }
    fn reference(&self, p: usize, d: usize, k: u32) -> Sampler {
        let ray = (self.first + p) * self.dirs_per_position + d;
        Sampler::new(self.seed, hash_pair(DOMAIN_EVAL, 0) + ray as u64, k)
    }
}

/// Draws the validation set and traces its references and oracle directions.
pub fn validation_set(
    scene: &Scene,
    tracer: &Tracer,
    grid: &ProbeGrid,
    probe_pos: Vec3,
    s: &EvalSettings,
) -> ValidationSet {
    let renderer = Renderer::new(scene, tracer);
    let threshold = scene.config.grid.inside_backface_fraction;
    let active: Vec<usize> = (0..grid.geometry.cell_count()).filter(|&c| !grid.inside[c]).collect();
    let mut positions = Vec::with_capacity(s.positions as usize);
    let mut attempt = 0u32;
    while positions.len() < s.positions as usize && !active.is_empty() && attempt < s.positions * 64 {
        let mut sampler = Sampler::new(s.seed, hash_pair(DOMAIN_EVAL, 1), attempt);
        attempt += 1;
        let cell = active[((sampler.next_1d() * active.len() as f32) as usize).min(active.len() - 1)];
        let c = grid.geometry.cell_coords(cell).as_vec3();
        let u = Vec3::new(sampler.next_1d(), sampler.next_1d(), sampler.next_1d());
        let p = grid.geometry.min + (c + u) * grid.geometry.cell_size();
        let stream = hash_pair(DOMAIN_EVAL, 0xB ^ attempt as u64);
        if truth::is_inside(tracer, p, threshold, |k| Sampler::new(s.seed, stream, k)) {
            continue;
        }
        positions.push(p);
    }
    let dpp = s.dirs_per_position as usize;
    let parts: Vec<TracedQueries> = positions
        .par_iter()
        .enumerate()
        .map(|(p, b)| {
            let streams = Streams { seed: s.seed, dirs_per_position: dpp, first: p };
            truth::trace_queries(&renderer, std::slice::from_ref(b), dpp, s.reference_spp, &streams)
        })
        .collect();
    let queries = TracedQueries::concat(parts);
    let (oracle_dir, hidden): (Vec<Vec3>, Vec<bool>) = (0..queries.dirs.len())
        .into_par_iter()
        .map(|k| truth::oracle(scene, tracer, probe_pos, queries.position_of(k), queries.dirs[k]))
        .unzip();
    ValidationSet { queries, oracle_dir, hidden }
}
