//! `warpfit-grid`, the fitted-grid folder: one JSON manifest and EXR payloads. The schema
//! (`schema`: the manifest, field by field, and the atlas layout), the EXR codec (`exr`),
//! the reader (`read`: distrustful, produces plain data). The writer is the offline tool's
//! (`warpfit::gridfile::write`). The runtime sampler (`runtime`) is assembled from what
//! `read` returns.

pub mod exr;
pub mod read;
pub mod schema;
pub mod surface;

pub use read::{GridData, IrradianceCorrection, IrradianceGrid, read, read_manifest};
pub use schema::*;
