//! # warpfit-runtime
//!
//! Loads a fitted grid made by the `warpfit` tool and answers, for any position in the
//! level, the reflected radiance along a direction at a roughness (`specular`) and the
//! irradiance around a normal (`irradiance`). It is what a game links: glam, libm, serde,
//! serde_json and exr, nothing else.
//!
//! ```
//! use warpfit_runtime::FittedGrid;
//! use warpfit_runtime::glam::Vec3;
//! # let tiny = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fits/tiny");
//! let grid = FittedGrid::load(tiny)?; // e.g. "fits/mylevel"
//! let p = Vec3::new(0.2, 1.0, 0.1);
//! let mirror = grid.specular(p, Vec3::new(1.0, 0.2, 0.0), 0.0);
//! let rough = grid.specular(p, Vec3::new(1.0, 0.2, 0.0), 0.5);
//! let diffuse = grid.irradiance(p, Vec3::Y);
//! assert!([mirror, rough, diffuse].iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
//! # Ok::<(), warpfit_runtime::LoadError>(())
//! ```
//!
//! Units and conventions: positions are in the scene's units (metres in the built-in
//! scenes), right-handed with +Y up, as the scene file gives them; directions point away from
//! the shaded point (the reflected view direction) and need not be unit length; roughness
//! is perceptual (GGX α = r²). Radiance is linear, in the scene's emitter units. Every
//! answer is finite and ≥ 0; a loaded grid is immutable, `Send + Sync`, and sampling never
//! allocates. [`FittedGrid`] lists the behaviour at the edges (outside the grid, degenerate
//! inputs).
//!
//! The modules hidden from these pages (`octa`, `warp`, `gridfile`, …) are the data layout
//! the `warpfit` tool shares with this crate; they are not a supported API and may change in
//! any release.

#![deny(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

/// The glam this crate's API speaks (`Vec3` positions and directions): use it as
/// `warpfit_runtime::glam` so a game's glam version cannot disagree with the sampler's.
pub use glam;

#[doc(hidden)]
pub mod files;
#[doc(hidden)]
pub mod grid;
#[doc(hidden)]
pub mod gridfile;
#[doc(hidden)]
pub mod octa;
#[doc(hidden)]
pub mod roughness;
#[doc(hidden)]
pub mod runtime;
#[doc(hidden)]
pub mod sh;
#[doc(hidden)]
pub mod tonemap;
#[doc(hidden)]
pub mod warp;

pub use runtime::{
    BatchError, FittedGrid, LoadError, SpecularRead, SurfaceAtlas, load_surface_atlas, load_surface_atlases,
};
