//! The f64 judge: an independent reference that scores how wrong a mode's answers are.
//!
//! [`Reference`] answers closest-hit queries in `f64` over the original mesh (a tree with
//! padded `f64` boxes, so it visits every triangle a ray may hit; the watertight kernel's
//! edge functions in `f64`, so it is watertight too); [`score`] compares a mode's `f32`
//! answers with it, per ray set: hit/miss disagreements (split into hits the mode missed and
//! hits it invented), wrong triangles (true ties excluded, see [`TIE_EPS`]) and the relative
//! error of `t`. On rays that must hit (from inside a closed mesh), the hits a mode missed are
//! its **leaks**.
//!
//! "Exact enough": `f32` inputs are exact in `f64`, and the only roundings left are the
//! shear (one division per ray) and a few products, about 1e-16 relative, nine orders below
//! the `f32` errors being measured.

mod reference;
mod score;

pub use reference::{JudgeHit, Reference};
pub use score::{Score, TIE_EPS, score};
