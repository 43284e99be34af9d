//! `warpfit-grid`, the fitted-grid folder, as the offline tool sees it: everything the
//! runtime's `gridfile` has (the schema, the decoder and the distrustful reader), plus the
//! EXR encoder (`exr`) and the writers (`write`, `surface::write`).

pub mod exr;
pub mod surface;
pub mod write;

pub use warpfit_runtime::gridfile::*;
