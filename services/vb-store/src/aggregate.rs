//! A submission's aggregates: its finished episodes as evaluation rows, summarised by `eval` exactly as `vb eval`
//! summarises a local run (overall and per factor, with intervals and the matched density contrasts). The
//! coordinator stores them ([`crate::Store::refresh_summary`]); the leaderboard reads them.

use crate::{EpisodeRecord, Submission, SERVICE_RULES};
use results::summary::Summary;
use results::{EpisodeRow, RunFacts};
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
/// task set, gives each world's terrain group (for the matched density contrasts).
pub fn rows(sub: &Submission, eps: &[EpisodeRecord], set: Option<&TaskSet>) -> Vec<EpisodeRow> {
    let set = set.filter(|s| s.version() == sub.task_set_version);
    let facts = facts(sub);
    eps.iter()
        .filter(|e| e.state == crate::EpisodeState::Done)
        .map(|e| EpisodeRow {
            task_id: e.task_id.clone(),
            world_id: e.world_id,
            task_index: e.task_index,
            level: e.level.clone(),
            semantics: e.semantics.clone(),
            density: e.density.clone(),
            terrain: set
                .and_then(|s| s.world_meta(e.world_id).ok())
                .and_then(|m| m.terrain),
            sim_version: e
                .sim_version
                .clone()
                .unwrap_or_else(|| sub.sim_version.clone()),
            outcome: e
                .outcome
                .map(|o| o.as_str().to_string())
                .unwrap_or_default(),
            reason: e.reason.clone().unwrap_or_default(),
            detail: e.detail.clone().unwrap_or_default(),
            metrics: e
                .metrics_json
                .as_deref()
                .and_then(|m| serde_json::from_str(m).ok())
                .unwrap_or_default(),
            wall_time_s: e.wall_time_s.unwrap_or(0.0),
            ..facts.row()
        })
        .collect()
}

/// The summary of a submission's finished episodes, named after the submission.
pub fn summary_of(sub: &Submission, eps: &[EpisodeRecord], set: Option<&TaskSet>) -> Summary {
    facts(sub).summary(&rows(sub, eps, set))
}
