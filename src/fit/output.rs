//! Provisional on-disk form of a fit (until the fitted-grid format is defined): `fit.json`
//! (grid geometry, map resolution, the sparse list of stored cells, settings and summary),
//! `correctives.exr` (layer `warp_maps`, channel `W`: each stored cell's N×N map of inverse
//! distance from the cell centre, side by side in slot order; absent when no cell stores
//! anything) and `residuals.json` (every cell's held-out errors before and after, solver
//! iterations, evaluations, termination and time).

use super::{CellFit, Fit, FitSettings};
use crate::format::exr_io::{ExrLayer, write_exr};
use crate::format::{FormatError, write_atomic};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const FIT_FORMAT: &str = "warpfit-fit-provisional";
pub const FIT_VERSION: u32 = 0;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitSummary {
    pub active_cells: usize,
    pub cells_level0: usize,
    pub cells_level2: usize,
    pub fallbacks: usize,
    pub bytes_level2: usize,
    pub fit_seconds: f64,
    pub reference_rays: u64,
    pub evaluations: u64,
    pub fallback_method: String,
    pub mean_check_err_warp1: f64,
    pub mean_check_err_fallback: f64,
    pub mean_check_err_celldepth: f64,
    pub mean_check_err_stored: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitManifest {
    pub format: String,
    pub version: u32,
    pub grid_min: [f32; 3],
    pub grid_max: [f32; 3],
    pub grid_counts: [u32; 3],
    pub map_res: u32,
    pub map_encoding: String,
    /// Grid cell index of each stored map, in slot order.
    pub stored_cells: Vec<u32>,
    pub summary: FitSummary,
    pub settings: FitSettings,
}

pub fn summary(fit: &Fit) -> FitSummary {
    let n = fit.cells.len().max(1) as f64;
    let stored = |c: &CellFit| if c.level == 2 { c.check_err_fitted } else { c.check_err_fallback };
    FitSummary {
        active_cells: fit.cells.len(),
        cells_level0: fit.cells.iter().filter(|c| c.level == 0).count(),
        cells_level2: fit.cells.iter().filter(|c| c.level == 2).count(),
        fallbacks: fit.cells.iter().filter(|c| c.reason.starts_with("fallback")).count(),
        bytes_level2: fit.correctives.maps.len() * 4,
        fit_seconds: fit.seconds,
        reference_rays: fit.reference_rays,
        evaluations: fit.cells.iter().map(|c| c.evaluations).sum(),
        fallback_method: fit.correctives.fallback.name().to_string(),
        mean_check_err_warp1: fit.cells.iter().map(|c| c.check_err_warp1).sum::<f64>() / n,
        mean_check_err_fallback: fit.cells.iter().map(|c| c.check_err_fallback).sum::<f64>() / n,
        mean_check_err_celldepth: fit.cells.iter().map(|c| c.check_err_celldepth).sum::<f64>() / n,
        mean_check_err_stored: fit.cells.iter().map(stored).sum::<f64>() / n,
    }
}

/// Writes fit.json, correctives.exr and residuals.json into `dir`, each atomically.
pub fn write_fit(dir: &Path, fit: &Fit) -> Result<FitManifest, FormatError> {
    let c = &fit.correctives;
    let n = c.map_res as usize;
    let mut stored: Vec<(u32, u32)> =
        c.slot.iter().enumerate().filter(|(_, s)| **s != u32::MAX).map(|(cell, s)| (*s, cell as u32)).collect();
    stored.sort();
    let manifest = FitManifest {
        format: FIT_FORMAT.into(),
        version: FIT_VERSION,
        grid_min: c.geometry.min.to_array(),
        grid_max: c.geometry.max.to_array(),
        grid_counts: c.geometry.counts.to_array(),
        map_res: c.map_res,
        map_encoding: "per stored cell, an N×N octahedral map (crate convention) of inverse distance from the cell centre; 0 = sky".into(),
        stored_cells: stored.iter().map(|(_, cell)| *cell).collect(),
        summary: summary(fit),
        settings: fit.settings.clone(),
    };
    if !stored.is_empty() {
        let count = stored.len();
        let mut atlas = vec![0.0f32; n * n * count];
        for (slot, _) in &stored {
            let src = &c.maps[*slot as usize * n * n..(*slot as usize + 1) * n * n];
            for j in 0..n {
                for i in 0..n {
                    atlas[j * n * count + *slot as usize * n + i] = src[j * n + i];
                }
            }
        }
        write_exr(
            &dir.join("correctives.exr"),
            &[ExrLayer { name: "warp_maps".into(), width: n * count, height: n, channels: vec![("W".into(), atlas)] }],
        )?;
    }
    write_json(&dir.join("fit.json"), &manifest)?;
    write_json(&dir.join("residuals.json"), &fit.cells)?;
    Ok(manifest)
}

/// Pretty JSON, written atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), FormatError> {
    let bytes = serde_json::to_vec_pretty(value)
        .map_err(|e| FormatError::Json { path: path.to_path_buf(), message: e.to_string() })?;
    write_atomic(path, &bytes).map_err(|source| FormatError::Io { path: path.to_path_buf(), source })
}
