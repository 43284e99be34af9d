//! `roughness.json` and `roughness.png`: the GGX distance-ratio correction, α' against k for
//! several α (the table's points and the analytic model, a series each).

use super::folder::RunFolder;
use crate::files::{FileError, write_json};
use crate::roughness::RoughnessCorrection;

/// Writes `roughness.json` and `roughness.png` into `folder`.
pub fn write_roughness(folder: &RunFolder, c: &RoughnessCorrection) -> Result<(), FileError> {
    std::fs::create_dir_all(&folder.dir).map_err(FileError::io(&folder.dir))?;
    write_json(&folder.roughness_json(), c)?;
    let nk = c.ratios.len();
    let mut series = Vec::new();
    for i in [1usize, 4, 7, 11].into_iter().filter(|&i| i < c.alphas.len()) {
        let a = c.alphas[i];
        let fitted: Vec<(f64, f64)> =
            (0..nk).map(|j| (libm::log2(c.ratios[j] as f64), c.table[i * nk + j] as f64)).collect();
        let model: Vec<(f64, f64)> =
            (0..nk).map(|j| (libm::log2(c.ratios[j] as f64), c.analytic(a, c.ratios[j]) as f64)).collect();
        series.push((format!("fit α={a:.2}"), fitted));
        series.push((format!("c0·α·k^-c1, α={a:.2}"), model));
    }
    super::plot::line_plot(
        &folder.roughness_plot(),
        "GGX roughness correction: probe-side α' against distance ratio",
        "log2 k = log2(d_probe / d_surface)",
        "α'",
        &series,
    )
}
