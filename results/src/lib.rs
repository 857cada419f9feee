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

use contracts::{EpisodeMetrics, Rules};
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
    pub task_id: String,
    pub world_id: u32,
    pub task_index: u32,
    pub level: String,
    pub semantics: String,
    pub density: String,
    /// Terrain group of the world: worlds of one group share heights and patches and differ only in obstacle
    /// density (nested layouts). `None` for sets without groups (imported worlds).
    #[serde(default)]
    pub terrain: Option<u32>,
    pub planner: String,
    pub vehicle: String,
    pub scale: f64,
    pub seed: u64,
    pub task_set_version: String,
    pub sim_version: String,
    /// The episode rules (`--release-rules`: release); older rows without it followed the paper's.
    #[serde(default)]
    pub rules: Rules,
    pub outcome: String,
    pub reason: String,
    pub detail: String,
    pub metrics: EpisodeMetrics,
    pub wall_time_s: f64,
}

#[cfg(test)]
impl EpisodeRow {
    /// A PID episode with the HMMWV on a low, rigid, sparse world of task set `v`, for unit tests to override field
    /// by field.
    pub(crate) fn for_test(task_id: &str, outcome: &str) -> Self {
        EpisodeRow {
            task_id: task_id.into(),
            world_id: 1,
            task_index: 0,
            level: "low".into(),
            semantics: "rigid".into(),
            density: "sparse".into(),
            terrain: None,
            planner: "pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            task_set_version: "v".into(),
            sim_version: "s".into(),
            rules: Default::default(),
            outcome: outcome.into(),
            reason: String::new(),
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
    pub planner: String,
    pub vehicle: String,
    pub scale: f64,
    pub seed: u64,
    pub task_set_version: String,
    pub sim_version: String,
    pub rules: Rules,
}

impl RunFacts {
    /// A row of this run with the episode's own values still empty (to be filled in by struct update).
    pub fn row(&self) -> EpisodeRow {
        EpisodeRow {
            task_id: String::new(),
            world_id: 0,
            task_index: 0,
            level: String::new(),
            semantics: String::new(),
            density: String::new(),
            terrain: None,
            planner: self.planner.clone(),
            vehicle: self.vehicle.clone(),
            scale: self.scale,
            seed: self.seed,
            task_set_version: self.task_set_version.clone(),
            sim_version: self.sim_version.clone(),
            rules: self.rules,
            outcome: String::new(),
            reason: String::new(),
            detail: String::new(),
            metrics: EpisodeMetrics::default(),
            wall_time_s: 0.0,
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
            ..summary::summarise(rows)
        }
    }
}
