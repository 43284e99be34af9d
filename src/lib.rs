//! # warpfit
//!
//! Offline parallax correction for reflection probes. warpfit raytraces a scene, bakes a
//! specular probe (radiance + distance on an octahedral map, GGX mip chain) and a dense
//! probe grid, and measures and fits warps that let probe A be used anywhere in the level.
//!
//! This is the offline library behind the `warpfit` command; it makes the grids. A game
//! links the crate `warpfit-runtime` alone (glam, libm, serde, serde_json and exr), loads a
//! fitted grid once and samples it:
//!
//! ```
//! use warpfit::glam::Vec3;
//! use warpfit::runtime::FittedGrid;
//! let grid = FittedGrid::load(concat!(env!("CARGO_MANIFEST_DIR"), "/fits/tiny"))?;
//! let mirror = grid.specular(Vec3::new(0.2, 1.0, 0.1), Vec3::new(1.0, 0.2, 0.0), 0.0);
//! let rough = grid.specular(Vec3::new(0.2, 1.0, 0.1), Vec3::new(1.0, 0.2, 0.0), 0.5);
//! let diffuse = grid.irradiance(Vec3::new(0.2, 1.0, 0.1), Vec3::Y);
//! assert!([mirror, rough, diffuse].iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
//! # Ok::<(), warpfit::runtime::LoadError>(())
//! ```
//!
//! From code, `jobs::run` does what `warpfit run` does.
//!
//! Pipeline: `scene` → `trace` → `bake` → (`fit`, `eval`) → `gridfile` → `runtime`, with
//! `report` writing what the others produce and `jobs` chaining them as the CLI runs them.
//! See ARCHITECTURE.md.

// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

/// The runtime crate a game links.
pub use warpfit_runtime;
/// The glam this crate's API speaks (`Vec3` positions and directions): use it as
/// `warpfit::glam` so a game's glam version cannot disagree with the sampler's.
pub use warpfit_runtime::glam;

// The runtime's modules as this library uses them (`warpfit-runtime`: the math, the grid
// file's reader and the sampler); where the offline tool adds to one (writers, fits, the
// evaluation's warps), a module here re-exports the runtime's and adds its part.
pub mod files;
pub use warpfit_runtime::{grid, octa, runtime, sh, tonemap};
pub mod gridfile;
pub mod roughness;
pub mod sampling;
pub mod warp;

// The offline tool: scenes, raytracing, bake, fit, eval, reports and jobs.
pub mod bake;
pub mod bakefile;
pub mod eval;
pub mod export;
pub mod fit;
pub mod jobs;
pub mod partfile;
pub mod perceptual;
pub mod preview;
pub mod progress;
pub mod render;
pub mod report;
pub mod scene;
pub mod trace;
