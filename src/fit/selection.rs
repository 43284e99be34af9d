//! Model selection: what a cell stores, decided on held-out queries.
//!
//! Level 0 stores nothing (the grid's proxy as it is); level 2 stores the cell's fitted
//! shift map of the proxy. Level 1 (one origin
//! offset, depth mip and relaxation per cell) is measured on request
//! (`FitSettings::level1`, `summary::Level1Summary`), not stored: see docs/architecture.md.

use serde::{Deserialize, Serialize};

/// What a cell stores. Serialised as its number (0, 2) in `residuals.json`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "u8", try_from = "u8")]
pub enum Level {
    /// Nothing: the grid's fallback method.
    Fallback,
    /// The cell's shift map.
    Map,
}

impl Level {
    pub const ALL: [Level; 2] = [Level::Fallback, Level::Map];

    /// The level's number in the corrective model (0 or 2).
    #[must_use]
    pub fn number(self) -> u8 {
        match self {
            Level::Fallback => 0,
            Level::Map => 2,
        }
    }
}

impl From<Level> for u8 {
    fn from(l: Level) -> u8 {
        l.number()
    }
}

impl TryFrom<u8> for Level {
    type Error = String;
    fn try_from(n: u8) -> Result<Level, String> {
        match n {
            0 => Ok(Level::Fallback),
            2 => Ok(Level::Map),
            _ => Err(format!("level {n} is not 0 or 2")),
        }
    }
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// Why a cell got its level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Selection {
    /// The cell sees only sky: nothing to shift the proxy towards, nothing to store.
    SeesOnlySky,
    /// The fallback method meets the tolerance.
    FallbackMeetsTolerance,
    /// The fitted map beats the fallback method on held-out queries.
    MapBeatsFallback,
    /// The fitted map is not better than the fallback method on held-out queries: the
    /// fallback is kept.
    KeptFallback,
}

impl Selection {
    #[must_use]
    pub fn level(self) -> Level {
        match self {
            Selection::MapBeatsFallback => Level::Map,
            _ => Level::Fallback,
        }
    }
}

impl std::fmt::Display for Selection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Selection::SeesOnlySky => "sees only sky: nothing to shift the proxy towards, nothing to store",
            Selection::FallbackMeetsTolerance => "the fallback method meets the tolerance",
            Selection::MapBeatsFallback => "fitted map beats the proxy alone on held-out queries",
            Selection::KeptFallback => "kept the proxy alone: the fitted map is not better on held-out queries",
        })
    }
}

/// A stored map must beat the proxy alone by this factor on held-out queries. 1: any win.
/// When maps held planes of their own and level-0 cells read another method, a map that won
/// by noise left a seam, and 0.95 was kept; a map now shifts the proxy's surface and is
/// pulled towards its anchor unless the data pays, so one that wins by noise costs little, and the
/// margin only discarded maps that helped: on `courtyard` 0.95 stored 183 maps and lost to
/// the box at r = 0.25 (tone-mapped RMSE), 1.0 stored 833 and did not; `cornell` and
/// `torture` were unchanged within 1% (docs/architecture.md).
pub const SELECTION_MARGIN: f64 = 1.0;

/// Model selection on held-out errors: nothing is stored when the fallback method meets the
/// tolerance, and a fitted map is stored only if it beats the fallback by `margin` (the
/// map's error below `margin` times the fallback's; never worse).
#[must_use]
pub fn choose_level(check_err_fallback: f64, check_err_fitted: f64, tol: f64, margin: f64) -> Selection {
    if check_err_fallback <= tol {
        Selection::FallbackMeetsTolerance
    } else if check_err_fitted < margin.min(1.0) * check_err_fallback {
        Selection::MapBeatsFallback
    } else {
        Selection::KeptFallback
    }
}

/// Standard errors by which the check positions' paired difference must separate the
/// fitted maps from the fallback for the choice to stand without more check positions.
pub const DECIDED_AT: f64 = 2.0;

/// Whether a cell's check positions cannot tell its fitted maps from the fallback: per
/// position p, `fallback[p]` and `fitted[p]` are the sums of the squared errors of its
/// queries (what the selection's RMSE adds up), and the mean of their differences lies
/// within [`DECIDED_AT`] standard errors of 0 (positions, not queries, are the samples:
/// a position's queries share its surroundings). A cell's errors are dominated by a few
/// positions where one bright thing is close (a lamp in the cell): those are exactly the
/// cells where sixteen positions decide by chance.
#[must_use]
pub fn undecided(fallback: &[f64], fitted: &[f64]) -> bool {
    let n = fallback.len().min(fitted.len());
    if n < 2 {
        return n == 1;
    }
    let d: Vec<f64> = fallback.iter().zip(fitted).map(|(a, b)| a - b).collect();
    if d.iter().all(|x| *x == 0.0) {
        return false; // the same errors everywhere: more positions would not tell them apart
    }
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let se = (var / n as f64).sqrt();
    !(mean.abs() > DECIDED_AT * se)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_difference_is_decided_when_it_stands_out_of_its_scatter() {
        // the map better at every position by about the same: decided
        assert!(!undecided(&[2.0, 2.1, 1.9, 2.0], &[1.0, 1.1, 0.9, 1.0]));
        // the same mean difference carried by one position: undecided
        assert!(undecided(&[1.0, 1.0, 1.0, 5.0], &[1.0, 1.0, 1.0, 1.0]));
        // identical errors: nothing more positions could tell apart
        assert!(!undecided(&[1.0, 2.0], &[1.0, 2.0]));
        // one position, or none
        assert!(undecided(&[1.0], &[0.0]));
        assert!(!undecided(&[], &[]));
    }
}
