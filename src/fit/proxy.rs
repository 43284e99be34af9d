//! The grid's proxy: the convex shape every lookup reads probe A through (seed 001), as it
//! is in cells without a map, and whose surface the maps shift (`warp::corrective`).
//!
//! The box or the 18-DOP, chosen before any cell is fitted (a cell's map is a shift of it):
//! both are measured on their own held-out queries spread over the grid (the cells' query
//! mix of surface and volume positions, mirror and rough lookups; a stream no training or
//! check set uses), and the k-DOP, which costs about twice the box per lookup, is kept only
//! when its tone-mapped error is below [`KDOP_MARGIN`] × the box's. The measurement is
//! seeded and cheap, so every shard of a sharded fit and the merge repeat it and agree.

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
}

/// The proxy a fit uses and how it was chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProxyOutcome {
    /// `Method::Box` or `Method::Kdop`.
    pub method: Method,
    pub choice: ProxyChoice,
    /// Held-out tone-mapped relative RMSE of the box and of the k-DOP (when measured).
    pub measured: Option<[f64; 2]>,
}

/// The k-DOP is chosen only when its error is below this fraction of the box's: it costs
/// about twice as much per lookup.
pub const KDOP_MARGIN: f64 = 0.95;

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
        .map(|&&cell| samples(&cell_samples(&renderer, &baked.grid.geometry, cell, size, s.seed, TAG)))
        .collect::<Vec<_>>()
        .concat();
    let ctx = CellContext {
        glossy,
        exposure: super::exposure_of(glossy.warp),
        proxy: Method::Box,
        origin: glossy.warp.probe.position,
        res: s.map_res,
    };
    let n2 = (s.map_res * s.map_res) as usize;
    let problem = CellProblem::new(ctx, vec![0.0; n2], queries);
    let errors = [Method::Box, Method::Kdop].map(|m| problem.relative_error_method(m));
    let method = if errors[1] < KDOP_MARGIN * errors[0] { Method::Kdop } else { Method::Box };
    ProxyOutcome { method, choice, measured: Some(errors) }
}
