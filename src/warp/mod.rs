//! Warps as the offline tool sees them: every per-lookup method of the runtime's `warp`
//! (re-exported), plus the evaluation's per-location reprojection (`reproject`).

pub mod reproject;

pub use warpfit_runtime::warp::*;
