//! Values that cross crates, with one string form each: a world's factors ([`ElevationLevel`],
//! [`SemanticsKind`], [`ObstacleDensity`]), how an episode ended ([`Outcome`], [`EndReason`], and
//! [`RecordedOutcome`] as the service records it), how a submission gives its planner ([`PlannerKind`]), under which rules ([`Rules`]), its metrics
//! ([`EpisodeMetrics`]), a task's id ([`TaskId`], `wNNN-tK`), the simulator's version, a vehicle's and a planner's name ([`SimVersion`],
//! [`VehicleId`], [`PlannerName`]), the states of the service's episodes and submissions
//! ([`EpisodeState`], [`SubmissionState`]), the trajectory codec ([`trajectory`]), and the checks of user-given
//! names and image references ([`input`]).
//!
//! A leaf crate (serde and thiserror only): the simulator produces these values and re-exports them; the service,
//! the store, the leaderboard and `vb-submit` read them without linking the simulator.

#[macro_use]
mod named;
pub mod catalog;
pub mod input;
mod names;
mod service_error;
mod state;
mod task_id;
pub mod trajectory;
mod vocab;

pub use catalog::{
    Catalog, CatalogProfile, PerceptionEntry, TaskGeometry, WorldFacts, WorldPicture,
};
pub use named::UnknownName;
pub use names::{PerceptionId, PlannerName, SimVersion, VehicleId};
pub use service_error::{ServiceError, ServiceErrorCode};
pub use state::{EpisodeState, RecordedOutcome, SubmissionState};
pub use task_id::{TaskId, TaskIdError};
pub use vocab::{ElevationLevel, EndReason, ObstacleDensity, Outcome, PlannerKind, SemanticsKind};

use serde::{Deserialize, Serialize};

named!(
    /// Which named set of rules an episode configuration follows (results carry it: runs under different rules
    /// are different runs).
    #[derive(Default)]
    Rules, "rules", {
        /// The paper's definitions (sim-core's `EpisodeConfig::default`); the default.
        #[default]
        Paper = "paper",
        /// The original release's (`EpisodeConfig::release`).
        Release = "release",
        /// Anything else (a changed time limit, goal radius, ...).
        Custom = "custom",
    }
);

/// Mean, variance and maximum of a signal sampled at every physics step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SignalStats {
    pub mean: f64,
    pub var: f64,
    pub max: f64,
}

/// Metrics of one episode. A metric missing from stored JSON reads as zero (rows written before it existed).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EpisodeMetrics {
    /// Simulated time at the end of the episode, s (the traversal time when successful).
    pub time: f64,
    /// Roll and pitch, degrees: raw (signed) and absolute.
    pub roll: SignalStats,
    pub roll_abs: SignalStats,
    pub pitch: SignalStats,
    pub pitch_abs: SignalStats,
    /// Throttle and steering commands: mean, variance, total variation.
    pub throttle_mean: f64,
    pub throttle_var: f64,
    pub throttle_tv: f64,
    pub steering_mean: f64,
    pub steering_var: f64,
    pub steering_tv: f64,
    /// Distance travelled by the chassis, m.
    pub path_length: f64,
    /// Positive mechanical energy delivered by the powertrain to the wheels, J.
    pub energy: f64,
    /// Number of distinct contacts with obstacles.
    pub obstacle_contacts: u32,
    /// Final distance to the goal, m.
    pub final_goal_distance: f64,
    /// Physics steps taken.
    pub steps: u64,
}

/// One recorded sample of the trajectory.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrajectorySample {
    pub time: f64,
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub roll: f64,
    pub pitch: f64,
    pub yaw: f64,
    pub speed: f64,
    pub throttle: f64,
    pub steering: f64,
    pub brake: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Metrics cross processes as JSON (the store's rows, the results API) and must come back to the last bit, so
    /// a service's summary equals a local `vb eval`'s: serde_json's `float_roundtrip` (its default parser may be
    /// one ulp off on such values, seen on 3.9066006773336635 and 9.992706353594361).
    #[test]
    fn metrics_survive_json_to_the_last_bit() {
        let mut m = EpisodeMetrics {
            time: 28.768000000002946,
            throttle_tv: 3.9066006773336635,
            final_goal_distance: 9.992706353594361,
            steering_mean: 0.47018710466033653,
            ..Default::default()
        };
        m.pitch.mean = -2.0042475476114894;
        m.roll.var = 13.808526635729677;
        let back: EpisodeMetrics =
            serde_json::from_str(&serde_json::to_string(&m).unwrap()).unwrap();
        assert_eq!(back, m);
    }
}
