//! The fit-effort sweep's record (`sweep.json`) and figures: `sweep.png` (held-out error
//! against fit time, a line per knob) and `sweep_convergence.png` (training objective
//! against time per solver). The sweep itself is a job (`jobs::sweep`).

use super::folder::RunFolder;
use crate::files::FileError;
use serde::{Deserialize, Serialize};

/// The knob a sweep row turns (one at a time, the rest at the given settings).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Knob {
    ProbeResolution,
    TrainingDirections,
    Iterations,
    Solver,
}

impl Knob {
    pub const ALL: [Knob; 4] = [Knob::ProbeResolution, Knob::TrainingDirections, Knob::Iterations, Knob::Solver];

    pub fn name(self) -> &'static str {
        match self {
            Knob::ProbeResolution => "probe resolution",
            Knob::TrainingDirections => "training directions",
            Knob::Iterations => "iterations",
            Knob::Solver => "solver",
        }
    }
}

/// One fit of the sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SweepRow {
    pub knob: Knob,
    pub value: String,
    pub fit_seconds: f64,
    /// Runtime `specular` at roughness 0 on the shared validation set: rel RMSE.
    pub rel_rmse: f64,
    /// The same lookups' tone-mapped RMSE (at the scene's key exposure).
    #[serde(default)]
    pub tm_rmse: f64,
    /// Mean ꟻLIP of the shared rendered views through the runtime at roughness 0 and 0.5:
    /// what a player sees (RMSE against noisy references rewards blur; ꟻLIP does less).
    #[serde(default)]
    pub flip_r0: f64,
    #[serde(default)]
    pub flip_r05: f64,
    /// Standard error of this row's ꟻLIP at r = 0 minus that of its knob's row at the given
    /// settings, over 8×8-pixel tiles of the views (paired: the same pixels and
    /// references); absent for that row itself, or when the knob's values miss it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flip_r0_se: Option<f64>,
    pub stored_cells: usize,
    pub payload_bytes: u64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Sweep {
    pub scene: String,
    pub command: String,
    pub validation: String,
    pub rows: Vec<SweepRow>,
    /// Per solver: (fit time s, mean training objective) after each stage.
    pub convergence: Vec<(String, Vec<(f64, f64)>)>,
}

/// Renders `sweep.png` and `sweep_convergence.png` from a sweep.
pub fn plot(folder: &RunFolder, sw: &Sweep) -> Result<(), FileError> {
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    // one line per knob, through its values in sweep order (named in the legend)
    let mut knobs: Vec<Knob> = Vec::new();
    for r in &sw.rows {
        if !knobs.contains(&r.knob) {
            knobs.push(r.knob);
        }
    }
    for k in knobs {
        let rows: Vec<&SweepRow> = sw.rows.iter().filter(|r| r.knob == k).collect();
        let values: Vec<&str> = rows.iter().map(|r| r.value.as_str()).collect();
        series.push((
            format!("{}: {}", k.name(), values.join(" → ")),
            rows.iter().map(|r| (r.fit_seconds, r.flip_r05)).collect(),
        ));
    }
    super::plot::line_plot(
        &folder.sweep_plot(),
        &format!("{}: what a player sees against fit time, one knob at a time", sw.scene),
        "fit time (s)",
        "runtime mean ꟻLIP at roughness 0.5 (held-out views)",
        &series,
    )?;
    super::plot::line_plot(
        &folder.sweep_convergence(),
        &format!("{}: fit convergence per solver", sw.scene),
        "fit time on this machine (s, references excluded)",
        "mean training objective per cell",
        &sw.convergence,
    )?;
    Ok(())
}
