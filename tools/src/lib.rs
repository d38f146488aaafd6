//! # raybatch-tools
//!
//! What surrounds the `raybatch` library without being part of it: the built-in benchmark
//! scenes and ray sets ([`scenes`]) and the binary ray and hit files of the command line
//! ([`formats`]), shared by the `raybatch` command (`bench`, `query`), the fuzz targets and
//! the peer comparison (`peers/`). A game that links `raybatch` never compiles any of this.
//! [`judge`] is the `f64` reference that scores how wrong a mode's answers are, and
//! [`report`] the benchmark report.
//!
//! The command itself lives in `src/cli/` (a binary target, not part of this library).

#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod formats;
pub mod judge;
pub mod report;
pub mod scenes;
