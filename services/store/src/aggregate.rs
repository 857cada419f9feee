//! A submission's aggregates: its finished episodes as evaluation rows, summarised by `eval` exactly as `vb eval`
//! summarises a local run (overall and per factor, with intervals and the matched density contrasts). The
//! coordinator stores them ([`crate::Store::refresh_summary`]); the leaderboard reads them.

use crate::{EpisodeRecord, Submission};
use results::summary::Summary;
use results::EpisodeRow;
use tasks::TaskSet;

/// Stored finished episodes as the evaluation rows summaries are computed from. `set`, when it is the submission's
/// task set, gives each world's terrain group (for the matched density contrasts).
pub fn rows(sub: &Submission, eps: &[EpisodeRecord], set: Option<&TaskSet>) -> Vec<EpisodeRow> {
    let set = set.filter(|s| s.version() == sub.task_set_version);
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
            planner: sub.name.clone(),
            vehicle: sub.vehicle.clone(),
            scale: sub.scale,
            seed: sub.seed,
            task_set_version: sub.task_set_version.clone(),
            sim_version: e
                .sim_version
                .clone()
                .unwrap_or_else(|| sub.sim_version.clone()),
            // The service runs every episode under the paper's rules.
            rules: Default::default(),
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
        })
        .collect()
}

/// The summary of a submission's finished episodes, named after the submission.
pub fn summary_of(sub: &Submission, eps: &[EpisodeRecord], set: Option<&TaskSet>) -> Summary {
    let mut summary = results::summary::summarise(&rows(sub, eps, set));
    summary.planner = sub.name.clone();
    summary.vehicle = sub.vehicle.clone();
    summary.scale = sub.scale;
    summary.task_set_version = sub.task_set_version.clone();
    summary.sim_version = sub.sim_version.clone();
    summary
}
