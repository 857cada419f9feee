//! A submission's aggregates: its finished episodes as evaluation rows, summarised by `eval` exactly as `vb eval`
//! summarises a local run (overall and per factor, with intervals and the matched density contrasts). The
//! coordinator stores them ([`crate::Store::refresh_summary`]); the leaderboard reads them.

use crate::{EpisodeRecord, StoreError, Submission, SERVICE_RULES};
use contracts::{ElevationLevel, EndReason, ObstacleDensity, RecordedOutcome, SemanticsKind};
use results::summary::Summary;
use results::{EpisodeRow, EpisodeValues, RunFacts};
use tasks::TaskSet;

/// The facts every row of a submission shares (the service runs every episode under [`SERVICE_RULES`]).
pub fn facts(sub: &Submission) -> RunFacts {
    RunFacts {
        planner: sub.name.clone(),
        vehicle: sub.vehicle.clone(),
        scale: sub.scale,
        seed: sub.seed,
        task_set_version: sub.task_set_version.clone(),
        sim_version: sub.sim_version.clone(),
        rules: SERVICE_RULES,
    }
}

/// Stored finished episodes as the evaluation rows summaries are computed from. `set`, when it is the submission's
/// task set, gives each world's terrain group (for the matched density contrasts). A done episode whose stored
/// values do not parse is a corrupt store, reported as such.
pub fn rows(
    sub: &Submission,
    eps: &[EpisodeRecord],
    set: Option<&TaskSet>,
) -> Result<Vec<EpisodeRow>, StoreError> {
    let set = set.filter(|s| s.version() == sub.task_set_version);
    let facts = facts(sub);
    eps.iter()
        .filter(|e| e.state == crate::EpisodeState::Done)
        .map(|e| {
            let terrain = set
                .and_then(|s| s.world_meta(e.world_id).ok())
                .and_then(|m| m.terrain);
            Ok(facts.row(values(e, terrain)?))
        })
        .collect()
}

/// A done episode's own values. One stored before reasons were recorded, or without an outcome (neither happens
/// since the store's first schema), reads as an infrastructure error rather than being dropped.
fn values(e: &EpisodeRecord, terrain: Option<u32>) -> Result<EpisodeValues, StoreError> {
    let corrupt = |what: &str, err: &dyn std::fmt::Display| {
        StoreError::Corrupt(format!(
            "episode {} of {}: {what}: {err}",
            e.task_id, e.submission_id
        ))
    };
    let outcome = e.outcome.unwrap_or(RecordedOutcome::InfrastructureError);
    let reason = match e.reason.as_deref() {
        None | Some("") => EndReason::Infrastructure,
        Some(r) => EndReason::parse(r).map_err(|err| corrupt("reason", &err))?,
    };
    Ok(EpisodeValues {
        task_id: e.task_id.parse().map_err(|err| corrupt("task id", &err))?,
        level: ElevationLevel::parse(&e.level).map_err(|err| corrupt("level", &err))?,
        semantics: SemanticsKind::parse(&e.semantics).map_err(|err| corrupt("semantics", &err))?,
        density: ObstacleDensity::parse(&e.density).map_err(|err| corrupt("density", &err))?,
        terrain,
        sim_version: e.sim_version.clone(),
        outcome,
        reason,
        detail: e.detail.clone().unwrap_or_default(),
        metrics: match e.metrics_json.as_deref() {
            None | Some("") => Default::default(),
            Some(m) => serde_json::from_str(m).map_err(|err| corrupt("metrics", &err))?,
        },
        wall_time_s: e.wall_time_s.unwrap_or(0.0),
    })
}

/// The summary of a submission's finished episodes, named after the submission.
pub fn summary_of(
    sub: &Submission,
    eps: &[EpisodeRecord],
    set: Option<&TaskSet>,
) -> Result<Summary, StoreError> {
    Ok(facts(sub).summary(&rows(sub, eps, set)?))
}
