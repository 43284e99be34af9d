//! The `warpfit` command line: argument types (`args`), one function per command
//! (`commands`) and what they print (`print`). No logic of the pipeline lives here.

pub mod args;
pub mod commands;
pub mod print;
