//! What one recorded episode is, before it is written: its metadata ([`EpisodeMeta`]) and its frames, one per
//! control step, stored column-wise ([`Frames`]) so recording allocates once per episode, not per step.
//! Generators ([`crate::generate`]) make [`RecordedEpisode`]s; the writer ([`crate::writer`]) writes them.

use contracts::{ElevationLevel, EndReason, ObstacleDensity, Outcome, SemanticsKind, TaskId};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The SDK's 15 state fields and the goal in the vehicle's heading frame, in order (sim-core's, which the SDK's
/// `vertibench.STATE_FIELDS` and `GOAL_FIELDS` are too).
pub use sim_core::observe::{GOAL_FIELDS, STATE_FIELDS};
/// Per wheel (or track contact), in the vehicle's wheel order.
pub const WHEEL_FIELDS: [&str; 4] = ["sinkage", "slip", "normal_load", "contact"];
pub const ACTION_FIELDS: [&str; 3] = ["steering", "throttle", "brake"];
/// The reward's terms (`vertibench.REWARD_TERMS`); the reward is their sum.
pub const REWARD_TERMS: [&str; 4] = ["progress", "roll", "pitch", "terminal"];

/// Which dataset an episode belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DatasetKind {
    /// Successful episodes of a built-in planner.
    Expert,
    /// The paper's random exploration: sinusoidal steering at a commanded 2 m/s.
    Random,
    /// The last 10 s before a rollover or a stuck.
    Failures,
}

/// The paper's two failure classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureClass {
    /// More than 30 degrees of roll at the end.
    Rollover,
    /// Moved less than 1 m (scaled) in the last 10 s.
    Stuck,
}

/// Where a failure window came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailureWindow {
    pub class: FailureClass,
    /// The source run (`random`, `expert`, or `eval:<planner>`) and its episode index there.
    pub source: String,
    pub source_episode: u64,
    /// Time of the window's first frame in the source episode, s.
    pub start_time: f64,
    /// True when the source episode was shorter than the window (10 s): the window is the whole episode.
    pub short: bool,
}

/// Everything known about one episode but its frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeMeta {
    pub kind: DatasetKind,
    /// The task, when the episode drove one of the task set's tasks; `None` for drawn starts and goals.
    pub task_id: Option<TaskId>,
    pub world_id: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// The semantic class under the start (`clay` ... `snow`).
    pub start_ground: String,
    /// Start pose `(x, y, yaw)` and goal `(x, y)`, world frame, m and rad.
    pub start: [f64; 3],
    pub goal: [f64; 2],
    /// The driving policy (`pid`, `eh`, `sinusoid`, ...) and its parameters (for `sinusoid`: amplitude, period,
    /// phase, speed).
    pub policy: String,
    pub policy_params: BTreeMap<String, f64>,
    /// The episode's own seed (drawn from the run's seed and the episode's index in the run).
    pub seed: u64,
    pub outcome: Outcome,
    pub reason: EndReason,
    /// For the failures dataset: the window's label and source.
    pub failure: Option<FailureWindow>,
    /// The episode's final observation, the one after its last action (gymnasium's terminal observation; with the
    /// frames' observations, the T+1 observations a Minari export needs): [`STATE_FIELDS`] and [`GOAL_FIELDS`].
    /// A failure window's is its source episode's (its frames are the source's last ones).
    pub final_state: [f64; 15],
    pub final_goal: [f64; 3],
}

/// An episode's frames, column-wise; frame `t` holds the observation at control step `t`, the action taken then,
/// and what the step produced (`next.*`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frames {
    /// [`STATE_FIELDS`] per frame, as the SDK observes it (float64, unrounded).
    pub state: Vec<[f64; 15]>,
    /// [`GOAL_FIELDS`] per frame.
    pub goal: Vec<[f64; 3]>,
    /// [`WHEEL_FIELDS`] per wheel per frame: `wheels * 4` values a frame.
    pub wheels: Vec<f32>,
    pub action: Vec<[f32; 3]>,
    /// [`REWARD_TERMS`] per frame; `next.reward` is their sum.
    pub reward_terms: Vec<[f32; 4]>,
    pub terminated: Vec<bool>,
    pub truncated: Vec<bool>,
    /// Full variant only: heading-aligned crops, `crop * crop` a frame (row 0 ahead, column 0 left), elevation
    /// relative to the vehicle's height (m) and semantics label ids (255 off the map), stored as float16.
    pub elevation: Option<Vec<f32>>,
    pub semantics: Option<Vec<f32>>,
}

impl Frames {
    pub fn len(&self) -> usize {
        self.state.len()
    }
    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }
}

/// One episode, ready to write.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedEpisode {
    pub meta: EpisodeMeta,
    pub frames: Frames,
}
