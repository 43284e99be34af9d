//! # warpfit
//!
//! Offline parallax correction for reflection probes. warpfit raytraces a scene, bakes a
//! specular probe (radiance + distance on an octahedral map, GGX mip chain) and a dense
//! probe grid, and measures and fits warps that let probe A be used anywhere in the level.
//!
//! A game links the runtime alone (`default-features = false`: glam, libm, serde,
//! serde_json and exr), loads a fitted grid once and samples it:
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
//! The offline tool (feature `bake`, on by default) makes such grids: `warpfit run`, or
//! `jobs::run` from code.
//!
//! Pipeline: `scene` → `trace` → `bake` → (`fit`, `eval`) → `gridfile` → `runtime`, with
//! `report` writing what the others produce and `jobs` chaining them as the CLI runs them.
//! See ARCHITECTURE.md.

// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

/// The glam this crate's API speaks (`Vec3` positions and directions): use it as
/// `warpfit::glam` so a game's glam version cannot disagree with the sampler's.
pub use glam;

// Always built: the math, the grid file and the runtime sampler (glam, libm, serde, exr only).
pub mod files;
pub mod grid;
pub mod gridfile;
pub mod octa;
pub mod roughness;
#[warn(missing_docs)]
pub mod runtime;
pub mod sampling;
pub mod sh;
pub mod tonemap;
pub mod warp;

// The offline tool: scenes, raytracing, bake, fit, eval, reports and jobs (feature `bake`).
#[cfg(feature = "bake")]
pub mod bake;
#[cfg(feature = "bake")]
pub mod bakefile;
#[cfg(feature = "bake")]
pub mod eval;
#[cfg(feature = "bake")]
pub mod export;
#[cfg(feature = "bake")]
pub mod fit;
#[cfg(feature = "bake")]
pub mod jobs;
#[cfg(feature = "bake")]
pub mod partfile;
#[cfg(feature = "bake")]
pub mod perceptual;
#[cfg(feature = "bake")]
pub mod preview;
#[cfg(feature = "bake")]
pub mod progress;
#[cfg(feature = "bake")]
pub mod report;
#[cfg(feature = "bake")]
pub mod scene;
#[cfg(feature = "bake")]
pub mod trace;
