//! Shared helpers of the integration tests, by theme:
//!
//! - [`rng`]: the one seeded random generator every test draws from;
//! - [`meshes`]: icospheres, transformed and duplicated meshes, small literal meshes, the bunny;
//! - [`rays`]: hard rays, invalid rays, incoherent rays;
//! - [`zoo`]: every structure of `AccelKind::ALL` x leaf size x child ordering, as `AnyAccel`;
//! - [`oracles`]: the brute-force reference, bit-for-bit comparisons, agreement checks;
//! - [`strategies`]: proptest strategies for meshes and rays;
//! - [`batch`]: the option space and single-ray reference of the batched queries;
//! - [`scenes`]: scene layouts and the scene oracle (brute force over every instance);
//! - [`tier`]: a heavy case's deterministic sample (default run) or all of it (ignored tier).
//!
//! Each test binary uses only part of them, hence `dead_code` is allowed.
#![allow(dead_code)]

pub mod batch;
pub mod meshes;
pub mod oracles;
pub mod rays;
pub mod rng;
pub mod scenes;
pub mod strategies;
pub mod tier;
pub mod zoo;
