//! The grid's proxy: the surface every lookup reads probe A through, as it is in cells
//! without a map, and which the maps shift (`warp::corrective`): the box or the 18-DOP
//! (seed 001), or the probe's own depth as seed 000's one-step warp reads it (`warp1`: a
//! room no box fits, a sphere).
//!
//! Chosen before any cell is fitted (a cell's map is a shift of it): the three are measured
//! on their own held-out queries spread over the grid (the cells' query mix of surface and
//! volume positions, mirror and rough lookups; a stream no training or check set uses), each
//! as a cell without a map serves it (the proxy's surface unshifted, a rough lookup's mip
//! from that surface's distance ratio, as `warp::corrective` reads it), and
//! the cheapest (box, then k-DOP, then `warp1`: the box's lookup costs about half the
//! others') whose tone-mapped error is within [`MARGIN`] of the lowest is kept: a proxy
//! that costs more must earn it. The measurement is seeded and cheap, so every shard of a
//! sharded fit and the merge repeat it and agree.

use super::objective::{CellContext, CellProblem};
use super::{Baked, FitSettings, QuerySize, cell_samples, samples};
use crate::trace::Renderer;
use crate::warp::Method;
use crate::warp::glossy::Glossy;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How the proxy is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ProxyChoice {
    /// Measured (see the module docs).
    #[default]
    Measured,
    /// The box, unmeasured.
    Box,
    /// The 18-DOP, unmeasured.
    Kdop,
    /// The probe's own depth (`warp1`), unmeasured.
    Warp1,
}

/// The proxy a fit uses and how it was chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProxyOutcome {
    /// `Method::Box`, `Method::Kdop` or `Method::Warp1`.
    pub method: Method,
    pub choice: ProxyChoice,
    /// Held-out tone-mapped relative RMSE of each of [`CANDIDATES`] (when measured).
    pub measured: Option<[f64; 3]>,
}

/// The proxies, cheapest first.
pub const CANDIDATES: [Method; 3] = [Method::Box, Method::Kdop, Method::Warp1];

/// A costlier proxy is kept only when the cheaper ones' errors are above the lowest by more
/// than this factor's inverse (5%).
pub const MARGIN: f64 = 0.95;

/// Cells the measurement draws from (evenly spread over the active cells), and positions per
/// cell.
const CELLS: usize = 256;
const POSITIONS: u32 = 2;
const DIRS: u32 = 32;
/// Sampler tag of the measurement's queries (training queries are 1, check queries 2).
const TAG: u64 = 3;

/// The proxy of a fit with settings `s` on `baked` (see the module docs).
#[must_use]
pub fn choose(baked: Baked, glossy: Glossy, s: &FitSettings) -> ProxyOutcome {
    let choice = s.proxy;
    match choice {
        ProxyChoice::Box => return ProxyOutcome { method: Method::Box, choice, measured: None },
        ProxyChoice::Kdop => return ProxyOutcome { method: Method::Kdop, choice, measured: None },
        ProxyChoice::Warp1 => return ProxyOutcome { method: Method::Warp1, choice, measured: None },
        ProxyChoice::Measured => {}
    }
    let renderer = Renderer::new(baked.scene, baked.tracer);
    let active = super::active_cells(baked.grid);
    let step = active.len().div_ceil(CELLS).max(1);
    let size = QuerySize {
        positions: POSITIONS,
        dirs: DIRS,
        spp: s.reference_spp,
        rough_fraction: super::rough_fraction(&glossy, s),
        surface_fraction: s.surface_fraction,
    };
    let queries: Vec<_> = active
        .iter()
        .step_by(step)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&&cell| {
            samples(&cell_samples((&renderer, baked.references), &baked.grid.geometry, cell, size, s.seed, TAG))
        })
        .collect::<Vec<_>>()
        .concat();
    let ctx = CellContext {
        glossy,
        exposure: super::exposure_of(glossy.warp),
        proxy: Method::Box,
        origin: glossy.warp.probe.position,
        res: s.map_res,
        probe_map: &[],
    };
    let n2 = (s.map_res * s.map_res) as usize;
    // each candidate as a cell without a map serves it (`Correctives::fetch`: the proxy's
    // surface unshifted, the distance ratio of a rough lookup from that surface), or as the
    // warp serves it with UV relaxation
    let relaxed = glossy.warp.options.relax_texels > 0.0;
    let errors = CANDIDATES.map(|m| {
        let problem = CellProblem::new(CellContext { proxy: m, ..ctx }, vec![0.0; n2], queries.clone());
        if relaxed { problem.relative_error_method(m) } else { problem.relative_error_map(&vec![0.0; n2]) }
    });
    let best = errors.iter().copied().fold(f64::INFINITY, f64::min);
    let pick = (0..CANDIDATES.len()).find(|&k| MARGIN * errors[k] <= best).unwrap_or(0);
    ProxyOutcome { method: CANDIDATES[pick], choice, measured: Some(errors) }
}
