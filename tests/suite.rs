//! The test suite, one binary: each file of `tests/` is a module here, so that the test build
//! links wgpu and Rerun once instead of once a file. `tests/layers.rs` checks that every file of
//! `tests/` is named below; a file that is not would never run. Run one file's tests with
//! `cargo test --release --test suite -- gpu::` (a module's name, or any part of a test's).

mod common;

mod accuracy;
mod bench_scenes;
mod cli;
mod cli_bad_input;
mod cli_bench;
mod cli_bench_throughput;
mod compare;
mod effects;
mod energy;
mod fused;
mod fuzz_scenes;
mod gpu;
mod gpu_fused;
mod gpu_implicit;
mod hard_cases;
mod hard_conditions;
mod hard_limits;
mod layers;
mod meshes;
mod physics;
mod preconditioner;
mod recording;
mod recording_options;
mod remote;
mod self_collision;
mod shaders;
mod stability;
mod sweep;
mod vbd;
mod xpbd;
