//! Results of an evaluation, wherever it ran (`vb eval`, the service, Python): the episode row ([`EpisodeRow`]), its
//! summary ([`summary`]: success rate with a 95% Wilson interval, traversal time, roll and pitch, failure mix, each
//! broken down by elevation level, semantics and obstacle density, and the paired density contrasts), paired
//! comparison ([`compare`], exact McNemar), the files (`episodes.csv`, `summary.json`, `summary.txt`, [`report`]),
//! the SVG charts ([`charts`]) and, with the `parquet` feature, `episodes.parquet` ([`parquet_file`]).
//!
//! No simulator, no runner, no thread pool: the service's coordinator, store and leaderboard and `vb-submit` read
//! and write results through this crate alone.

pub mod charts;
pub mod compare;
#[cfg(feature = "parquet")]
pub mod parquet_file;
pub mod report;
pub mod summary;

use contracts::{
    ElevationLevel, EndReason, EpisodeMetrics, ObstacleDensity, Outcome, PerceptionId, PlannerName,
    RecordedOutcome, Rules, SemanticsKind, SimVersion, TaskId, VehicleId,
};
use serde::{Deserialize, Serialize};

/// Errors writing results; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    #[error("{path}: {message}")]
    Io { path: String, message: String },
}

#[cfg(feature = "parquet")]
pub(crate) fn io_err(path: &std::path::Path, e: impl std::fmt::Display) -> ResultsError {
    ResultsError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// One finished episode: task factors, outcome, every metric and what makes it reproducible.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRow {
    pub task_id: TaskId,
    pub world_id: u32,
    pub task_index: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// Terrain group of the world: worlds of one group share heights and patches and differ only in obstacle
    /// density (nested layouts). `None` for sets without groups (imported worlds).
    #[serde(default)]
    pub terrain: Option<u32>,
    pub planner: PlannerName,
    pub vehicle: VehicleId,
    pub scale: f64,
    pub seed: u64,
    pub task_set_version: String,
    pub sim_version: SimVersion,
    /// The episode rules (`--release-rules`: release); older rows without it followed the paper's.
    #[serde(default)]
    pub rules: Rules,
    /// The perception profile the planner saw the world through; omitted for ground truth (`ideal`), so rows of
    /// ideal runs read as they always have.
    #[serde(default, skip_serializing_if = "PerceptionId::is_ideal")]
    pub perception: PerceptionId,
    /// The episode's outcome, or the service's infrastructure error (`error`).
    pub outcome: RecordedOutcome,
    pub reason: EndReason,
    pub detail: String,
    pub metrics: EpisodeMetrics,
    pub wall_time_s: f64,
}

impl EpisodeRow {
    /// Whether the episode reached its goal.
    pub fn is_success(&self) -> bool {
        self.outcome == RecordedOutcome::Episode(Outcome::Success)
    }
}

#[cfg(test)]
impl EpisodeRow {
    /// A PID episode with the HMMWV on a low, rigid, sparse world of task set `v`, for unit tests to override field
    /// by field.
    pub(crate) fn for_test(task_id: &str, outcome: &str) -> Self {
        let outcome = RecordedOutcome::parse(outcome).unwrap();
        EpisodeRow {
            task_id: task_id.parse().unwrap(),
            world_id: 1,
            task_index: 0,
            level: ElevationLevel::Low,
            semantics: SemanticsKind::Rigid,
            density: ObstacleDensity::Sparse,
            terrain: None,
            planner: "pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            task_set_version: "v".into(),
            sim_version: "s".into(),
            rules: Default::default(),
            perception: PerceptionId::ideal(),
            outcome,
            reason: outcome.plain_reason(),
            detail: String::new(),
            metrics: EpisodeMetrics::default(),
            wall_time_s: 0.1,
        }
    }
}

/// What every episode of one run shares: who ran it, with which vehicle, on which task set and simulator, under
/// which rules. The service builds its rows and summaries from a submission's facts (the store's and
/// `vb-submit results`' alike).
#[derive(Clone, Debug, PartialEq)]
pub struct RunFacts {
    pub planner: PlannerName,
    pub vehicle: VehicleId,
    pub scale: f64,
    pub seed: u64,
    pub task_set_version: String,
    pub sim_version: SimVersion,
    pub rules: Rules,
    pub perception: PerceptionId,
}

/// One finished episode's own values, as the service keeps them; [`RunFacts::row`] adds what the run shares.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeValues {
    pub task_id: TaskId,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    pub terrain: Option<u32>,
    pub sim_version: Option<SimVersion>,
    pub outcome: RecordedOutcome,
    pub reason: EndReason,
    pub detail: String,
    pub metrics: EpisodeMetrics,
    pub wall_time_s: f64,
}

impl RunFacts {
    /// The row of one of this run's episodes: the one place a stored episode (the store's record, the results
    /// API's row) becomes an evaluation row. An episode without its own simulator version ran on the run's.
    pub fn row(&self, e: EpisodeValues) -> EpisodeRow {
        EpisodeRow {
            task_id: e.task_id,
            world_id: e.task_id.world,
            task_index: e.task_id.index,
            level: e.level,
            semantics: e.semantics,
            density: e.density,
            terrain: e.terrain,
            planner: self.planner.clone(),
            vehicle: self.vehicle.clone(),
            scale: self.scale,
            seed: self.seed,
            task_set_version: self.task_set_version.clone(),
            sim_version: e.sim_version.unwrap_or_else(|| self.sim_version.clone()),
            rules: self.rules,
            perception: self.perception.clone(),
            outcome: e.outcome,
            reason: e.reason,
            detail: e.detail,
            metrics: e.metrics,
            wall_time_s: e.wall_time_s,
        }
    }

    /// The summary of this run's `rows`, named and described by the run (also when it has no rows yet).
    pub fn summary(&self, rows: &[EpisodeRow]) -> summary::Summary {
        summary::Summary {
            planner: self.planner.clone(),
            vehicle: self.vehicle.clone(),
            scale: self.scale,
            task_set_version: self.task_set_version.clone(),
            sim_version: self.sim_version.clone(),
            rules: self.rules,
            perception: self.perception.clone(),
            ..summary::summarise(rows)
        }
    }
}
