//! Generating the datasets (paper, section III-G) on a training task set: episodes are simulated in parallel and
//! handed, in index order, to an [`EpisodeSink`] (the LeRobot v3 writer, or a test's vector).
//!
//! - `random`: the paper's random exploration. Episode `i` drives world `i mod n` (so every kind of ground is
//!   covered) from a start drawn uniformly over the world's free area, in a uniformly drawn heading, with sinusoidal
//!   steering and a commanded 2 m/s through the baselines' speed loop ([`random`]); with
//!   [`SpeedProfile::StopAndGo`] that command stops periodically, braked or coasting, and with [`SpeedProfile::Fast`]
//!   it is drawn per episode ([`random::FAST_SPEED`]). Every episode is kept, whatever its end (rollover, stuck, off
//!   map, time limit, or success if it happens to reach its goal).
//! - `expert`: successful episodes of a built-in planner (default `pid`): first the task set's tasks, then start/goal
//!   pairs drawn on the same worlds the way the task generator draws them ([`expert`]).
//! - `failures`: the last 10 s before every rollover and stuck ([`failures`]) of the built-in planners' evaluation
//!   runs on the task set's tasks (default `pid` and `eh`); random and expert runs also feed a failures sink.
//!
//! **Determinism.** Episode `i` is a pure function of the configuration and `i`: its randomness comes from a
//! ChaCha8 generator seeded with [`episode_seed`]`(seed, i)`. Episodes are simulated on a pool of
//! [`GenerateConfig::threads`] threads and appended in index order; a run stops at the first index at which the
//! main sink's kept time reaches [`GenerateConfig::hours`] (that episode included), so the output is the same at any
//! thread count, and a resumed run ([`Resume`]) continues exactly where an uninterrupted one would be.
//!
//! **Training worlds only.** The benchmark's own task set is refused ([`source::check_training_set`]) unless
//! [`GenerateConfig::allow_benchmark_tasks`] is set, which marks the dataset `analysis_only`.

pub mod expert;
pub mod failures;
mod plan;
pub mod random;
pub mod recorder;
mod run;
pub mod sinks;
pub mod source;
mod stream;

pub use plan::{contact_count, failures_spec, spec};
pub use run::run;

use crate::record::{DatasetKind, EpisodeMeta, RecordedEpisode};
use crate::spec::{SpeedProfile, Variant};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Where a run puts its episodes (the writer implements it; tests collect into a vector).
pub trait EpisodeSink {
    /// Appends one episode; episodes come in index order.
    fn append(&mut self, rec: &RecordedEpisode) -> Result<(), SinkError>;
}

/// A sink's failure, as the sink words it.
pub type SinkError = Box<dyn std::error::Error + Send + Sync>;

impl EpisodeSink for Vec<RecordedEpisode> {
    fn append(&mut self, rec: &RecordedEpisode) -> Result<(), SinkError> {
        self.push(rec.clone());
        Ok(())
    }
}

/// Everything a generation run needs (`vb dataset generate`'s options).
#[derive(Clone, Debug, PartialEq)]
pub struct GenerateConfig {
    pub kind: DatasetKind,
    /// The task set whose worlds (and, for `expert` and `failures`, tasks) the episodes use.
    pub task_dir: PathBuf,
    /// Simulated hours to keep in the main sink (the run ends at the first episode that reaches them; a
    /// `failures` run also ends when its evaluation runs are done).
    pub hours: f64,
    pub vehicle: contracts::VehicleId,
    /// World scale; `None`: the vehicle's own.
    pub scale: Option<f64>,
    /// The run's seed: episode `i` draws from [`episode_seed`]`(seed, i)` alone.
    pub seed: u64,
    /// Control steps (frames) per simulated second as asked; the physics step rounds the period
    /// ([`sim_core::runner::control_every`]), and the dataset records the rate it ran at.
    pub control_rate_hz: f64,
    pub variant: Variant,
    /// Crop side in cells; resolution in m a cell (`None`: 1 m times the world scale, as the Python SDK).
    pub crop_size: usize,
    pub crop_resolution: Option<f64>,
    /// Time limit of a random episode, s (expert and evaluation episodes follow the benchmark's 60 s).
    pub max_time: f64,
    /// Built-in planners: `expert` drives with the one given (default `pid`); `failures` scans the evaluation
    /// runs of each (default `pid`, `eh`); `random` uses none.
    pub planners: Vec<String>,
    /// Random exploration's speed command: the paper's constant one, or with stops ([`random::Stops`]).
    pub speed_profile: SpeedProfile,
    /// Accept the benchmark's own task set, for an analysis-only dataset (`DatasetSpec::analysis_only`).
    pub allow_benchmark_tasks: bool,
    /// Worker threads (0: one per core).
    pub threads: usize,
}

/// Default time limit of a random episode, s.
pub const DEFAULT_MAX_TIME: f64 = 120.0;
/// Default crop side, cells.
pub const DEFAULT_CROP_SIZE: usize = 32;

impl GenerateConfig {
    /// The defaults for `kind` on the task set at `task_dir`: HMMWV at its own scale, 20 Hz, seed 0, lite
    /// variant, 32-cell crops, 120 s random episodes, `pid` for experts and `pid`, `eh` for failures.
    pub fn new(kind: DatasetKind, task_dir: impl Into<PathBuf>, hours: f64) -> Self {
        let planners = match kind {
            DatasetKind::Random => vec![],
            DatasetKind::Expert => vec!["pid".to_string()],
            DatasetKind::Failures => vec!["pid".to_string(), "eh".to_string()],
        };
        GenerateConfig {
            kind,
            task_dir: task_dir.into(),
            hours,
            vehicle: "hmmwv".into(),
            scale: None,
            seed: 0,
            control_rate_hz: 20.0,
            variant: Variant::Lite,
            crop_size: DEFAULT_CROP_SIZE,
            crop_resolution: None,
            max_time: DEFAULT_MAX_TIME,
            planners,
            speed_profile: SpeedProfile::Constant,
            allow_benchmark_tasks: false,
            threads: 0,
        }
    }
}

/// Every way a run can fail; messages name the option or file at fault.
#[derive(Debug, thiserror::Error)]
pub enum GenerateError {
    #[error(transparent)]
    Tasks(#[from] tasks::TasksError),
    #[error(transparent)]
    Vehicle(#[from] sim_core::vehicle::VehicleError),
    /// Reading what a dataset holds (resuming).
    #[error(transparent)]
    Dataset(#[from] crate::DatasetError),
    #[error("invalid parameter `{field}`: {message}")]
    Param { field: String, message: String },
    /// The benchmark's own task set without `allow_benchmark_tasks`.
    #[error("{0}")]
    BenchmarkTasks(String),
    #[error("episode {index}: {message}")]
    Episode { index: u64, message: String },
    #[error("episode {index}: the {which} sink refused it: {source}")]
    Sink {
        index: u64,
        which: &'static str,
        source: SinkError,
    },
    #[error("thread pool: {0}")]
    Pool(String),
}

impl GenerateError {
    pub(crate) fn param(field: &str, message: impl Into<String>) -> Self {
        GenerateError::Param {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Where a run starts: from scratch ([`Resume::default`]) or after what its sinks already hold
/// ([`Resume::from_writers`] reads it from the dataset writers, [`Resume::from_sinks`] from the last records).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Resume {
    /// The first episode index whose record the main sink does not hold.
    pub main_next: u64,
    /// Frames the main sink holds (its kept time, in control steps).
    pub main_frames: u64,
    /// The first episode index whose failure window the failures sink does not hold (ignored without one).
    pub failures_next: u64,
}

impl Resume {
    /// Where a run continues from what its sinks hold: the last episode of the main sink and its frame count,
    /// and the failures sink's last window of this run's source ([`failures::source_name`]; windows of other
    /// sources or seeds in the same sink are skipped by the caller or passed as `None`).
    pub fn from_sinks(
        cfg: &GenerateConfig,
        main_last: Option<&EpisodeMeta>,
        main_frames: u64,
        failures_last: Option<&EpisodeMeta>,
    ) -> Resume {
        let next = |m: &EpisodeMeta| episode_index(cfg.seed, m.seed) + 1;
        Resume {
            main_next: main_last.map_or(0, next),
            main_frames,
            failures_next: failures_last.map_or(0, next),
        }
    }
}

/// What a run reports as it goes (after every episode index it has dealt with).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GenerateProgress {
    /// Episode indices dealt with so far (the next one to run).
    pub next_index: u64,
    /// Frames in the main sink, and the frames that end the run.
    pub kept_frames: u64,
    pub target_frames: u64,
    /// Episodes and failure windows appended by this call.
    pub kept_episodes: u64,
    pub failure_windows: u64,
}

/// What a finished run did.
#[derive(Clone, Debug, PartialEq)]
pub struct GenerateSummary {
    /// Episodes simulated by this call.
    pub episodes_run: u64,
    /// Episodes and failure windows appended by this call.
    pub kept_episodes: u64,
    pub failure_windows: u64,
    /// Frames (and simulated seconds) in the main sink, resumed ones included.
    pub kept_frames: u64,
    pub kept_seconds: f64,
    /// Simulated seconds of every episode this call ran, kept or not.
    pub simulated_seconds: f64,
    /// Whether the main sink reached `hours` (a `failures` run may run out of evaluation episodes first).
    pub reached_hours: bool,
    /// Records (episodes or windows) dropped because their frames held non-finite values (a diverged
    /// simulation, `numerical_failure`), or none.
    pub dropped: u64,
    /// Where a later run would continue.
    pub next: Resume,
    /// How the episodes simulated by this call ended (outcome after the rollover rule), and the windows' classes.
    pub outcomes: BTreeMap<String, u64>,
    pub windows: BTreeMap<String, u64>,
}

/// The seed of episode `index` of a run with seed `seed`: a fixed offset (SplitMix64 of the run's seed) plus the
/// index, so [`episode_index`] recovers the index from a record's seed (how a run resumes).
pub fn episode_seed(seed: u64, index: u64) -> u64 {
    splitmix64(seed).wrapping_add(index)
}

/// The index of the episode of a run with seed `seed` whose seed is `episode_seed`.
pub fn episode_index(seed: u64, episode_seed: u64) -> u64 {
    episode_seed.wrapping_sub(splitmix64(seed))
}

fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
