//! Whole episodes beside a reference simulator's (`vb sim episodes --reference FILE`, issue 59 item 4): the
//! reference (the Chrono harness's `episodes`, driven by `vb sim drive`, [`crate::external`]) says which planner and
//! rules drove which tasks and how each ended; sim-core drives the same tasks with the same planner and rules, and
//! the two are listed outcome by outcome with their agreement.

use crate::external::DriverIdentity;
use crate::EvalError;
use contracts::TaskId;
use rayon::prelude::*;
use serde_json::Value;
use sim_core::episode::Outcome;
use sim_core::vehicle::VehicleSpec;
use std::collections::BTreeMap;
use std::sync::Arc;
use tasks::TaskSet;

/// The reference's episodes: who drove, and how each task ended there.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceEpisodes {
    pub simulator: String,
    pub driver: DriverIdentity,
    /// Task, outcome, simulated time at the end (s), in the file's order.
    pub tasks: Vec<(TaskId, Outcome, f64)>,
}

/// Why a reference's episodes could not be read.
#[derive(Debug, thiserror::Error)]
pub enum EpisodesError {
    #[error("the reference is not JSON: {0}")]
    Json(#[from] serde_json::Error),
    #[error("the reference's episodes.driver is not what `vb sim drive` says it is: {0}")]
    Driver(serde_json::Error),
    #[error("the reference's episodes.tasks[{index}] is not {{\"task\": \"wNNN-tK\", \"outcome\": ..., \"time\": s}}: {why}")]
    BadTask { index: usize, why: String },
}

/// The `episodes` object of a reference, if it has one.
pub fn reference_episodes(text: &str) -> Result<Option<ReferenceEpisodes>, EpisodesError> {
    let v: Value = serde_json::from_str(text)?;
    let Some(e) = v.get("episodes").filter(|e| !e.is_null()) else {
        return Ok(None);
    };
    let driver: DriverIdentity =
        serde_json::from_value(e["driver"].clone()).map_err(EpisodesError::Driver)?;
    let list = e["tasks"].as_array().ok_or(EpisodesError::BadTask {
        index: 0,
        why: "episodes.tasks is not a list".into(),
    })?;
    let mut tasks = Vec::with_capacity(list.len());
    for (index, t) in list.iter().enumerate() {
        let bad = |why: String| EpisodesError::BadTask { index, why };
        let id: TaskId = t["task"]
            .as_str()
            .ok_or_else(|| bad("no task".into()))?
            .parse()
            .map_err(|e: contracts::TaskIdError| bad(format!("task `{}`", e.0)))?;
        let outcome: Outcome = serde_json::from_value(t["outcome"].clone())
            .map_err(|e| bad(format!("outcome: {e}")))?;
        let time = t["time"]
            .as_f64()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| bad("no time".into()))?;
        tasks.push((id, outcome, time));
    }
    let simulator = v["reference"]["simulator"]
        .as_str()
        .unwrap_or("the reference")
        .to_string();
    Ok(Some(ReferenceEpisodes {
        simulator,
        driver,
        tasks,
    }))
}

/// One task, ours beside the reference's.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EpisodePair {
    pub task: TaskId,
    pub ours: Outcome,
    pub ours_time: f64,
    pub reference: Outcome,
    pub reference_time: f64,
}

/// Drives the reference's tasks in sim-core with its planner and rules (the vehicle `spec` at its own step), in
/// parallel, in the reference's order.
pub fn run_beside(
    set: &TaskSet,
    spec: &VehicleSpec,
    reference: &ReferenceEpisodes,
) -> Result<Vec<EpisodePair>, EvalError> {
    let builtin = registry::Builtin::resolve(&reference.driver.planner, None)?;
    let mut worlds = BTreeMap::new();
    let mut jobs = Vec::with_capacity(reference.tasks.len());
    for &(id, outcome, time) in &reference.tasks {
        if let std::collections::btree_map::Entry::Vacant(e) = worlds.entry(id.world) {
            e.insert(Arc::new(set.world(id.world, spec.scale)?));
        }
        let task = set
            .tasks(id.world, spec.scale)?
            .into_iter()
            .find(|t| t.index == id.index)
            .ok_or_else(|| EvalError::Param {
                field: "reference".into(),
                message: format!("task {id} is not in the task set"),
            })?;
        jobs.push((worlds[&id.world].clone(), task, outcome, time));
    }
    let cfg = &reference.driver.config;
    Ok(jobs
        .par_iter()
        .map(|(world, task, outcome, time)| {
            let mut planner = builtin.make();
            let r = sim_core::run_episode(world, task, spec, planner.as_mut(), cfg);
            EpisodePair {
                task: TaskId::new(task.world_id, task.index),
                ours: r.outcome,
                ours_time: r.metrics.time,
                reference: *outcome,
                reference_time: *time,
            }
        })
        .collect())
}

/// The pairs as a table (one row a task), then how often the outcomes agree and the counts of each pair of
/// outcomes (ours first).
pub fn pairs_table(pairs: &[EpisodePair], simulator: &str) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "{:<9} {:<16} {:>7}  {:<16} {:>7}\n",
        "task", "ours", "s", simulator, "s"
    );
    let mut counts: BTreeMap<(&str, &str), usize> = BTreeMap::new();
    for p in pairs {
        let _ = writeln!(
            s,
            "{:<9} {:<16} {:>7.1}  {:<16} {:>7.1}{}",
            p.task.to_string(),
            p.ours.as_str(),
            p.ours_time,
            p.reference.as_str(),
            p.reference_time,
            if p.ours == p.reference {
                ""
            } else {
                "  differ"
            }
        );
        *counts
            .entry((p.ours.as_str(), p.reference.as_str()))
            .or_default() += 1;
    }
    let same = pairs.iter().filter(|p| p.ours == p.reference).count();
    let _ = writeln!(
        s,
        "same outcome on {same} of {} tasks; ours / {simulator}: {}",
        pairs.len(),
        counts
            .iter()
            .map(|((o, r), n)| format!("{o} / {r}: {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    s
}
