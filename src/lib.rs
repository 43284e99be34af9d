//! # warpfit
//!
//! Offline parallax correction for reflection probes. warpfit raytraces a scene, bakes a
//! specular probe (radiance + distance on an octahedral map, GGX mip chain) and a dense
//! probe grid, and measures and fits warps that let probe A be used anywhere in the level.
//!
//! ```
//! use warpfit::{scene::Scene, trace::Tracer, bake, progress::Progress};
//! let scene = Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/sphere.toml"))).unwrap();
//! let tracer = Tracer::new(&scene);
//! // A ray from the sphere's centre hits the inward-facing sphere at its radius.
//! let hit = tracer.closest_hit(glam::Vec3::new(0.0, 1.0, 0.0), glam::Vec3::X, f32::INFINITY).unwrap();
//! assert!((hit.t - 2.0).abs() < 1e-5);
//! # let _ = (bake::bake, Progress::quiet());
//! ```
//!
//! Pipeline: `scene` → `trace` → `bake` → (`fit`, `eval`) → `gridfile` → `runtime`, with
//! `report` writing what the others produce and `jobs` chaining them as the CLI runs them.
//! See ARCHITECTURE.md.

// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

// Always built: the math, the grid file and the runtime sampler (glam, libm, serde, exr only).
pub mod files;
pub mod grid;
pub mod gridfile;
pub mod octa;
pub mod roughness;
pub mod runtime;
pub mod sampling;
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
pub mod fit;
#[cfg(feature = "bake")]
pub mod jobs;
#[cfg(feature = "bake")]
pub mod partfile;
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
