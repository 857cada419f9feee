//! Local evaluation of a planner on the task set.
//!
//! - [`run`]: episodes in parallel on all cores (rayon), each appended as one JSON line to `results.jsonl` as soon
//!   as it finishes (flushed), so an interrupted evaluation resumes where it stopped: finished task ids are skipped,
//!   a torn last line is ignored and nothing is counted twice; [`identity`] (`planner.json`) keeps another planner
//!   from resuming it. [`prepare`] and [`Prepared::run`] split it for callers that report what a resume keeps or
//!   cancel a running evaluation.
//! - [`summary`]: success rate with a 95% Wilson interval, traversal time (successes only), roll and pitch, failure
//!   mix, each broken down by elevation level, semantics kind and obstacle density; semantics success standardised
//!   over levels; and the paired density contrasts on matched tasks (same terrain group and start/goal pair).
//! - [`report`] and [`parquet_file`]: `episodes.csv` and `episodes.parquet` (the same columns), `summary.json`, `summary.txt` and
//!   [`charts`], SVG charts of the breakdowns (an auto-escaping template).
//! - [`compare`]: paired comparison of two evaluations (difference in success rate with a 95% interval, exact
//!   McNemar test).
//! - [`Builtin`]: the built-in planners by name, re-exported from the `registry` crate (the one lookup).
//! - [`move_off`]: from how many of a task set's starts a vehicle cannot move off at all.
//! - [`catalog`]: the benchmark as the service tier sees it, built from the physics crates for the binary that wires
//!   the services.
//! - [`viz`]: a single episode's `trajectory.csv` and plot (`vb sim run`).

pub mod beside;
pub mod external;
pub mod identity;
pub mod move_off;
pub mod reference;
pub mod run;
pub mod viz;

use contracts::Catalog;

// The results' types and files live in the `results` crate (shared with the service); re-exported here so local
// evaluation reads as one crate.
pub use identity::{PlannerIdentity, PlannerSource, IDENTITY_FILE};
pub use registry::Builtin;
pub use results::{charts, compare, parquet_file, report, summary, EpisodeRow, ResultsError};
pub use run::{
    prepare, run, run_builtin, run_with, EvalConfig, PlannerFactory, Prepared, SIM_VERSION,
};

/// Errors of the evaluator; each names the file or the parameter.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error("{0}")]
    Tasks(#[from] tasks::TasksError),
    #[error("{0}")]
    Vehicle(#[from] sim_core::vehicle::VehicleError),
    #[error("invalid {field}: {message}")]
    Param { field: String, message: String },
    #[error(transparent)]
    Results(#[from] ResultsError),
}

impl From<registry::RegistryError> for EvalError {
    fn from(e: registry::RegistryError) -> Self {
        EvalError::Param {
            field: "planner".into(),
            message: e.message,
        }
    }
}

/// The service tier's view of `set` under this build ([`contracts::Catalog`]): its simulator version, the set's
/// worlds, the built-in vehicles (each with its own scale) and the built-in planners.
pub fn catalog(set: &tasks::TaskSet) -> Catalog {
    Catalog {
        sim_version: SIM_VERSION.into(),
        task_set_version: set.version().to_string(),
        worlds: set.world_facts(),
        vehicles: sim_core::vehicle::builtin_vehicles()
            .into_iter()
            .map(|v| (v.name.into(), v.scale))
            .collect(),
        builtin_planners: registry::names().iter().map(|&n| n.into()).collect(),
        perception: perception::BUILTIN
            .iter()
            .filter_map(|&n| perception::Profile::builtin(n).ok())
            .map(|p| {
                let params = if p.is_ideal() {
                    String::new()
                } else {
                    p.to_json()
                };
                let profile = contracts::CatalogProfile {
                    entry: contracts::PerceptionEntry { id: p.id(), params },
                    degrades_maps: p.degrades_maps(),
                };
                (p.name.clone(), profile)
            })
            .collect(),
        belief_planners: registry::names()
            .into_iter()
            .filter(|n| {
                registry::Builtin::resolve(n, None).is_ok_and(|b| b.make().runs_on_degraded_maps())
            })
            .map(Into::into)
            .collect(),
    }
}

/// A perception profile by name (`ideal`, `nominal`, `degraded`) or from a TOML file (named by its stem unless it
/// names itself); `vb eval --perception`, `vb dataset generate` and Python take it so.
pub fn perception_profile(spec: &str) -> Result<perception::Profile, EvalError> {
    perception::Profile::resolve(spec, |p| std::fs::read_to_string(p))
        .map_err(|e| perception_err(e.to_string()))
}

fn perception_err(message: String) -> EvalError {
    EvalError::Param {
        field: "perception".into(),
        message,
    }
}

pub(crate) fn io_err(path: &std::path::Path, e: impl std::fmt::Display) -> EvalError {
    EvalError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}
