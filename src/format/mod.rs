//! On-disk formats: the bake folder (manifest.json + probe.exr + grid.exr + PNG previews),
//! EXR payloads and atomic writes. Reading validates everything and names the file and field
//! of any problem.

mod atomic;
pub mod bake_io;
pub mod exr_io;
pub mod grid_io;
pub mod manifest;

pub use atomic::write_atomic;
use std::path::PathBuf;

/// Everything that can be wrong with a file warpfit reads or writes.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: not a readable EXR: {message}")]
    Exr { path: PathBuf, message: String },
    #[error("{path}: invalid JSON: {message}")]
    Json { path: PathBuf, message: String },
    #[error("{path}: {field}: {message}")]
    Invalid { path: PathBuf, field: String, message: String },
    #[error("{path}: format {found:?} version {version} is not supported (expected {expected:?} version {supported})")]
    Version { path: PathBuf, found: String, version: u32, expected: String, supported: u32 },
}
