//! `sim-core`: the deterministic vehicle-terrain simulation core of vertibench.
//!
//! Invariants (see ARCHITECTURE.md): no IO, no async, no wall clock, no unseeded randomness, deterministic iteration
//! order, fixed time step, no allocation inside the step loop. Same seed and inputs give bit-identical trajectories
//! at any thread count.
//!
//! Modules:
//! - [`world`]: the world data model (heightmap, semantic patches, obstacles, tasks) and its frames.
//! - [`planner`]: the interface every mobility system implements.
//! - [`episode`]: termination rules, outcomes and metrics.
//! - [`episode_run`]: one episode as a state machine its caller steps (the runner, the Python SDK's environments).
//! - [`terrain_stats`]: relief, slope and roughness statistics of heightmaps.

pub mod characterize;
pub mod climb_trace;
pub mod collide;
pub mod control;
pub mod episode;
pub mod episode_run;
pub mod move_off;
pub mod observe;
pub mod planner;
pub mod referee;
pub mod reward;
pub mod runner;
pub mod soil;
mod stuck;
pub mod terrain_stats;
pub use contracts::trajectory;
pub mod vehicle;

pub use episode_run::{EpisodeRun, Transition};
pub use runner::{
    run_episode, run_episode_hooked, run_episode_observed, ControlHook, EpisodeObserver, Truth,
};

/// Identifies the physics that produced a result: the crate version and a revision bumped with every change that
/// alters trajectories (results carry it; the coordinator refuses workers of another one, and `vb eval` will not
/// resume an output directory written by another one; `tests/golden.rs` pins a hash of a few runs' trajectories
/// to it). What each revision changed: BENCHMARKS.md, "Simulator revisions". r10 (issue 59): the HMMWV's engine is
/// Chrono's `HMMWV_EngineSimpleMap`.
pub const SIM_VERSION: &str = concat!("sim-core ", env!("CARGO_PKG_VERSION"), " r10");
pub use vehicle::{Action, Simulation, VehicleSpec};
pub mod world;
