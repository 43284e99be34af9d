//! The warp1 option sweep: seed 000's warp at each depth mip it could read and each UV
//! relaxation radius, on the validation set.

use super::methods::fetch_dirs;
use super::metrics::error_stats;
use super::validation::ValidationSet;
use crate::warp::{Method, Warp, WarpOptions};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// One row of the warp1 option sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Warp1OptionRow {
    pub depth_lod: f32,
    pub relax_texels: f32,
    pub rel_rmse: f64,
}

/// warp1 at depth mips 0..=min(4, last) × relaxation 0, 1, 2 texels.
pub fn warp1_options(warp: &Warp, set: &ValidationSet, exposure: f32) -> Vec<Warp1OptionRow> {
    let mut rows = Vec::new();
    let max_lod = (warp.probe.inv_depth.levels.len() - 1).min(4);
    let mut w = warp.clone();
    for lod in 0..=max_lod {
        for relax in [0.0f32, 1.0, 2.0] {
            w.options = WarpOptions { depth_lod: lod as f32, relax_texels: relax, ..warp.options };
            let est: Vec<Vec3> = fetch_dirs(&w, set, Method::Warp1).iter().map(|&d| w.probe.radiance(d)).collect();
            rows.push(Warp1OptionRow {
                depth_lod: lod as f32,
                relax_texels: relax,
                rel_rmse: error_stats(&est, &set.reference, exposure).rel_rmse,
            });
        }
    }
    rows
}
