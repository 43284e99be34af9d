//! Jobs: the work the command line runs, as library functions that tests and benches call
//! too. `run` (bake or reuse, fit, write the grid, evaluate, report) and its stages,
//! `sweep` (error against fit effort) and `stability` (stiff and extreme cases). Each job
//! composes the stages; none holds logic of its own that a stage should own.

pub mod check;
pub mod cluster;
pub mod farm;
pub mod init;
pub mod run;
pub mod stability;
pub mod sweep;

use crate::files::FileError;
use crate::scene::SceneError;

/// Why a job stopped: a scene that does not load, or a file that cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    File(#[from] FileError),
}
