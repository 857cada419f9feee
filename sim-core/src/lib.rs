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
pub mod reward;
pub mod runner;
pub mod soil;
pub mod terrain_stats;
pub use contracts::trajectory;
pub mod vehicle;

pub use episode_run::{EpisodeRun, Transition};
pub use runner::{run_episode, run_episode_observed, EpisodeObserver};

/// Identifies the physics that produced a result: the crate version and a revision bumped with every change that
/// alters trajectories (results carry it; the coordinator refuses workers of another one, and `vb eval` will not
/// resume an output directory written by another one; `tests/golden.rs` pins a hash of a few runs' trajectories
/// to it). Revision 2: wheels climb out of soil ruts onto rigid patches instead of being fired out. Revision 3
/// (issue 13): whole-vehicle translational inertia, wheel vertical DOF implicit in its stiff terms, symmetric wheel
/// contact, the release's HMMWV (mass, CoG, steering), start poses fitted over the footprint and settled at rest,
/// soil pressure along the wheel's surface normal. Revision 4: the handling tyre's Magic Formula has Pacejka's
/// curvature factor E (changes the vehicles on handling tyres only; the rigid-tyre HMMWV's trajectories, and so
/// every quoted benchmark result, are bit-identical to r3). Revision 5: a sinking body's motion is compaction, not
/// shear slip (static sinkage is Bekker's). Revision 6: a rolling rim's damping pressure covers the part of each cell
/// inside its contact, a node's shear accrues from when the rim reached it, and the soil's vertical stiffness takes
/// each node on the branch the rim moves it along (converged in the step at speed). Revision 7 (issue 29): Chrono's
/// SCM force law (pressure along the undeformed terrain's normal, shear in its plane with a growing shear
/// displacement, the spin driven by the soil's moment) and Chrono's 100 N m clutches for "locked" differentials.
/// Revision 8: the damping pressure at a rim's advancing edge carries its Mohr-Coulomb shear, as Chrono's damping is
/// part of every node's shear strength (a spinning wheel had half its traction on mud). Revision 9 (issue 29): the
/// chassis gets the strut force the wheel's implicit update applied (r8 passed it the force from the step's start, a
/// step late, which pumped the pitch and bounce: snow's 20 s distance was 8.6% short at 4 ms against 1 ms).
/// Revision 10 (issue 59): the HMMWV's engine is Chrono's `HMMWV_EngineSimpleMap`, both maps (full load, and the
/// closed throttle's engine braking) read at the engine speed clamped to 2700 rpm, so its full-load map's negative
/// tail governs the top speed; other vehicles, without those maps, are unchanged.
pub const SIM_VERSION: &str = concat!("sim-core ", env!("CARGO_PKG_VERSION"), " r10");
pub use vehicle::{Action, Simulation, VehicleSpec};
pub mod world;
