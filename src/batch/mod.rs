//! The batched engine's machinery, shared by every structure: a whole array of rays is
//! prepared once and handed to the structure as ray streams.
//!
//! - [`options`]: [`BatchOptions`] and [`BatchOrdering`].
//! - `chunks`: large batches split into chunks over rayon's pool, one workspace per thread.
//! - `group`: a chunk's rays validated, prepared and grouped by direction octant into lanes.
//! - `mixing`: whether a thread's closest-hit chunks walk their small octants mixed, judged
//!   from the hits its last chunks reported.
//! - `lanes`: the structure-of-arrays ray lanes a [`crate::accel::RayStream`] wraps for
//!   structures that partition rays (binary trees, scenes).
//! - `rays`: the same rays as an array of prepared records, for structures that walk rays by
//!   index (the 4-wide tree, grids, the kd-tree).
//! - `slots`: where each of a chunk's rays goes in its group, and back.
//! - `prepare_avx2`: the grouping's validity checks and prepared records eight rays at a time.
//! - [`partition`]: one box against many lanes with move-to-front (AVX-512, AVX2, portable).
//! - `scratch`: the per-thread arrays, kept in the thread's workspace.
//!
//! The queries that drive it (closest, any, all hits) are in [`crate::query::batched`]; how a
//! binary BVH walks a stream is in `crate::traverse::stream`.

pub(crate) mod chunks;
pub(crate) mod group;
pub(crate) mod lanes;
pub(crate) mod mixing;
pub mod options;
pub mod partition;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub(crate) mod prepare_avx2;
pub(crate) mod rays;
pub(crate) mod scratch;
pub(crate) mod slots;

pub use options::{BatchOptions, BatchOrdering, Interleave};
pub use partition::PartitionKernel;
