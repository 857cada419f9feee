//! A dataset's identity: what every episode in it shares. A run into a directory that holds a dataset of another
//! spec is refused; the spec is written into `meta/info.json` (under `vertibench`).

use crate::record::DatasetKind;
use serde::{Deserialize, Serialize};

/// Whether frames carry map crops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// No crops: the Python reader rebuilds them from the task set and the pose.
    Lite,
    /// Heading-aligned elevation and semantics crops in every frame, float16.
    Full,
}

/// How a random exploration run's speed command varies within an episode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpeedProfile {
    /// The paper's: the commanded speed throughout (every dataset before this field existed).
    #[default]
    Constant,
    /// The commanded speed with periodic stops, alternately braked and coasting, so the data holds a vehicle
    /// standing, held or rolling back on slopes, and starting again (`generate::random::Stops`).
    StopAndGo,
    /// The paper's steering with a faster commanded speed, drawn per episode (`generate::random::FAST_SPEED`), so the
    /// data holds what the paper's 2 m/s rarely reaches: rollovers, hard landings and wheels leaving the ground.
    Fast,
}

impl SpeedProfile {
    /// The paper's profile (left out of `info.json`, so such datasets read as they did before the field).
    pub fn is_constant(&self) -> bool {
        *self == SpeedProfile::Constant
    }
}

/// Heading-aligned map crops: `size x size` cells of `resolution` m (the simulator's own crop shape).
pub use sim_core::observe::CropSpec;

/// What every episode of a dataset shares.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetSpec {
    pub kind: DatasetKind,
    pub variant: Variant,
    /// Vehicle name (LeRobot's `robot_type`) and its number of wheels (track contacts): the wheel features' rows.
    pub vehicle: contracts::VehicleId,
    pub wheels: usize,
    /// World scale.
    pub scale: f64,
    /// Frames per simulated second (LeRobot's `fps`).
    pub control_rate_hz: f64,
    /// The crops' geometry: the full variant stores them, the lite one says how to rebuild them.
    pub crop: CropSpec,
    pub sim_version: contracts::SimVersion,
    pub task_set_version: String,
    /// The task set's master seed (`None` for imported sets).
    pub task_set_seed: Option<u64>,
    /// The run's seed: episode `i` draws from it and `i` alone.
    pub seed: u64,
    /// Random exploration's speed command (`constant` for the other kinds).
    #[serde(default, skip_serializing_if = "SpeedProfile::is_constant")]
    pub speed_profile: SpeedProfile,
    /// True when made from the benchmark's own tasks (`--allow-benchmark-tasks`): for analysis, never for
    /// training a system evaluated on the benchmark.
    pub analysis_only: bool,
}
