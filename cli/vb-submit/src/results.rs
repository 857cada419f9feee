//! A submission's results in `vb eval`'s formats: the finished episodes as evaluation rows, written as the same
//! directory `vb eval` writes (so `vb compare` and `vb leaderboard-static` take service and local runs alike) or
//! streamed as the same CSV columns and JSON rows.

use crate::SubmitError;
use contracts::{
    ElevationLevel, EndReason, EpisodeMetrics, EpisodeState, ObstacleDensity, RecordedOutcome,
    Rules, SemanticsKind, SubmissionState,
};
use results::summary::Summary;
use results::{EpisodeRow, EpisodeValues, RunFacts};
use std::path::Path;
use vb_proto::v1 as pb;
use vb_proto::ProtoEnum;

/// The facts every row of the submission shares, from its status.
fn facts(r: &pb::ResultsResponse) -> Result<RunFacts, SubmitError> {
    let s = r.status.clone().unwrap_or_default();
    let rules = Rules::from_wire(s.rules)
        .map_err(|e| SubmitError::Protocol(format!("the submission's episode rules: {e}")))?;
    Ok(RunFacts {
        planner: s.name.into(),
        vehicle: s.vehicle.into(),
        scale: s.scale,
        seed: s.seed,
        task_set_version: s.task_set_version,
        sim_version: s.sim_version.into(),
        rules,
        // Empty from a coordinator that predates perception profiles: it evaluated under ground truth.
        perception: if s.perception.is_empty() {
            contracts::PerceptionId::ideal()
        } else {
            s.perception.into()
        },
    })
}

/// The finished episodes of `r` as `vb eval`'s rows (each world's terrain group, for the matched density contrasts,
/// as the coordinator read it from the task set).
pub fn rows(r: &pb::ResultsResponse) -> Result<Vec<EpisodeRow>, SubmitError> {
    let facts = facts(r)?;
    let mut rows = Vec::new();
    for e in &r.episodes {
        let bad = |what: &str, err: &dyn std::fmt::Display| {
            SubmitError::Protocol(format!("{what} of {}: {err}", e.task_id))
        };
        if EpisodeState::from_wire(e.state).map_err(|err| bad("state", &err))? != EpisodeState::Done
        {
            continue;
        }
        let outcome = e.outcome.ok_or_else(|| bad("outcome", &"none given"))?;
        let reason = e.reason.ok_or_else(|| bad("reason", &"none given"))?;
        rows.push(facts.row(EpisodeValues {
            task_id: e.task_id.parse().map_err(|err| bad("task id", &err))?,
            level: ElevationLevel::from_wire(e.level).map_err(|err| bad("level", &err))?,
            semantics:
                SemanticsKind::from_wire(e.semantics).map_err(|err| bad("semantics", &err))?,
            density: ObstacleDensity::from_wire(e.density).map_err(|err| bad("density", &err))?,
            terrain: e.terrain,
            sim_version: (!e.sim_version.is_empty()).then(|| e.sim_version.as_str().into()),
            outcome: RecordedOutcome::from_wire(outcome).map_err(|err| bad("outcome", &err))?,
            reason: EndReason::from_wire(reason).map_err(|err| bad("reason", &err))?,
            detail: e.detail.clone(),
            // None when no worker could run the episode: zeros, as the service's own summaries read it.
            metrics: e.metrics.map(EpisodeMetrics::from).unwrap_or_default(),
            wall_time_s: e.wall_time_s,
        }));
    }
    Ok(rows)
}

/// Episodes of `r` that have not finished (queued, running or not run): `(task id, state)`.
pub fn unfinished(r: &pb::ResultsResponse) -> Result<Vec<(String, EpisodeState)>, SubmitError> {
    let mut out = Vec::new();
    for e in &r.episodes {
        let state = EpisodeState::from_wire(e.state)
            .map_err(|err| SubmitError::Protocol(format!("state of {}: {err}", e.task_id)))?;
        if state != EpisodeState::Done {
            out.push((e.task_id.clone(), state));
        }
    }
    Ok(out)
}

/// The summary of the finished rows, named and described as the submission.
pub fn summary(r: &pb::ResultsResponse, rows: &[EpisodeRow]) -> Result<Summary, SubmitError> {
    Ok(facts(r)?.summary(rows))
}

/// Writes what `vb eval` writes into `dir` (results.jsonl, episodes.csv, episodes.parquet, summary.json,
/// summary.txt, charts.svg) from the finished episodes. Refuses a directory that already holds an evaluation.
pub fn write_dir(dir: &Path, r: &pb::ResultsResponse) -> Result<Summary, SubmitError> {
    let io = |p: &Path, e: std::io::Error| SubmitError::Io(format!("{}: {e}", p.display()));
    if dir.join("results.jsonl").exists() || dir.join("summary.json").exists() {
        return Err(SubmitError::Io(format!(
            "{} already holds an evaluation; give an empty or new directory",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let rows = rows(r)?;
    let mut jsonl = String::new();
    for row in &rows {
        jsonl += &serde_json::to_string(row).map_err(|e| SubmitError::Io(e.to_string()))?;
        jsonl.push('\n');
    }
    let p = dir.join("results.jsonl");
    std::fs::write(&p, jsonl).map_err(|e| io(&p, e))?;
    let summary = summary(r, &rows)?;
    results::report::write(dir, &rows, &summary).map_err(|e| SubmitError::Io(e.to_string()))?;
    Ok(summary)
}

/// The finished episodes as `vb eval`'s `episodes.csv` (the same columns).
pub fn csv(r: &pb::ResultsResponse) -> Result<String, SubmitError> {
    Ok(results::report::episodes_csv(&rows(r)?))
}

/// The submission's status, its finished episodes as `vb eval`'s rows (the fields of `results.jsonl`) and its
/// unfinished episodes with their state.
pub fn json(r: &pb::ResultsResponse) -> Result<String, SubmitError> {
    let s = r.status.clone().unwrap_or_default();
    let state = SubmissionState::from_wire(s.state)
        .map_err(|e| SubmitError::Protocol(format!("the submission's state: {e}")))?;
    let rules = facts(r)?.rules;
    let unfinished: Vec<serde_json::Value> = unfinished(r)?
        .into_iter()
        .map(|(task_id, state)| serde_json::json!({ "task_id": task_id, "state": state }))
        .collect();
    let v = serde_json::json!({
        "submission_id": s.submission_id, "name": s.name, "state": state, "planner": s.planner,
        "planner_identity": s.planner_identity, "vehicle": s.vehicle, "scale": s.scale, "seed": s.seed,
        "task_set_version": s.task_set_version, "sim_version": s.sim_version, "rules": rules,
        "perception": facts(r)?.perception, "family": s.family,
        "total": s.total, "finished": s.finished, "not_run": s.not_run, "success_rate": s.success_rate,
        "episodes": rows(r)?, "unfinished": unfinished,
    });
    serde_json::to_string_pretty(&v)
        .map(|t| t + "\n")
        .map_err(|e| SubmitError::Io(e.to_string()))
}
