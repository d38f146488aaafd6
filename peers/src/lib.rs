//! The peer-comparison harness behind the `peers` binary: raybatch next to Embree 3, obvhs and
//! parry3d on the same mesh and rays (see peers/README.md).

pub mod build_race;
pub mod compare;
pub mod embree_ffi;
pub mod engines;
pub mod race;
pub mod rays;
pub mod shape_race;
