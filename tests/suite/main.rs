//! The integration tests, one binary: each module holds the tests of one theme, `common`
//! what they share. Heavy cases run in full under `cargo test --release -- --ignored` and as a
//! deterministic sample in the default run.

mod common;

mod audio_occlusion;
mod batched_large;
mod batched_options;
mod batched_proptest;
mod batched_rays;
mod cooked;
mod custom_visitor;
mod hard_builds;
mod hard_degenerate;
mod hard_invalid_rays;
mod hard_precision;
mod hard_ranges;
mod hard_shared_edges;
mod hard_ties;
mod los_queue;
mod mesh_errors;
mod no_threads;
mod node_visits;
mod option_extremes;
mod proptest_vs_brute_force;
mod quantized_vertices;
mod scene_edits;
mod scene_filters;
mod scene_resolved;
mod scene_vs_brute_force;
mod shape_queries;
mod small_thread_stack;
mod typed_api;
mod watertight;
mod zbt;
