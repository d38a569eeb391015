//! hsph's integration tests, one module per file of `tests/`, linked into one test binary.
//!
//! Many of these tests drive the library's generic engine (`Simulation<D>` for D = 2 and 3)
//! directly. A separate test crate per file instantiated and optimised that whole engine once
//! per file — seven times over, about 11 of the 15 CPU-minutes of a cold `cargo test --release`
//! build — and linked 33 binaries; one crate does it once. Select a file's tests by its module
//! path: `cargo test --release --test suite solids::` (or `-- --exact solids::name`).
//! Three files stay crates of their own because CI builds them again with a cargo feature,
//! and a feature build of this crate would cost as much as the first: `comm_mpi.rs` and
//! `engine_mpi.rs` (`--features mpi`, under `mpirun`) and `affinity.rs` (`--features hwloc`).

mod common;

mod bad_input;
mod cavity;
mod conservation;
mod determinism;
mod docs;
mod fidelity;
mod frames;
mod fuzz;
mod geometry;
mod hardening;
mod hardening_ii;
mod hardening_iii;
mod initial_fields;
mod injection;
mod jobscript;
mod lagged_gradient;
mod layers;
mod layout_report;
mod lean;
mod lobovsky;
mod mesh;
mod method_sites;
mod multirate;
mod neighbours;
mod output;
mod pairs;
mod parallel;
mod physics_validation;
mod plan;
mod pressure_loads;
mod probes;
mod refinement;
mod report;
mod restart;
mod restart_property;
mod restart_transaction;
mod scaleout;
mod scene_limits;
mod settle;
mod shifting;
mod shipped_bits;
mod signals;
mod solids;
mod solitary;
mod splitting;
mod validate;
mod verlet;
mod wall_volume;
