//! The GGX distance-ratio roughness correction (seed 002): the runtime's tables and
//! formula (re-exported), and their fit (`fit`, argmin).

mod fit;

pub use fit::*;
pub use warpfit_runtime::roughness::*;
