//! A submission's aggregates: its finished episodes as evaluation rows, summarised by `eval` exactly as `vb eval`
//! summarises a local run (overall and per factor, with intervals and the matched density contrasts). The
//! coordinator stores them ([`crate::Store::refresh_summary`]); the leaderboard reads them.

use crate::{EpisodeRecord, StoreError, Submission, SERVICE_RULES};
use contracts::{Catalog, RecordedOutcome};
use results::summary::Summary;
use results::{EpisodeRow, EpisodeValues, RunFacts};

/// The facts every row of a submission shares (the service runs every episode under [`SERVICE_RULES`]).
pub fn facts(sub: &Submission) -> RunFacts {
    RunFacts {
        planner: sub.name.as_str().into(),
        vehicle: sub.vehicle.clone(),
        scale: sub.scale,
        seed: sub.seed,
        task_set_version: sub.task_set_version.clone(),
        sim_version: sub.sim_version.clone(),
        rules: SERVICE_RULES,
        perception: sub.perception.id.clone(),
    }
}

/// Stored finished episodes as the evaluation rows summaries are computed from. `catalog`, when it serves the
/// submission's task set, gives each world's terrain group (for the matched density contrasts). A done episode whose stored
/// values do not parse is a corrupt store, reported as such.
pub fn rows(
    sub: &Submission,
    eps: &[EpisodeRecord],
    catalog: Option<&Catalog>,
) -> Result<Vec<EpisodeRow>, StoreError> {
    rows_of(&facts(sub), eps, catalog)
}

/// [`rows`] of a submission whose facts are `facts`.
pub fn rows_of(
    facts: &RunFacts,
    eps: &[EpisodeRecord],
    catalog: Option<&Catalog>,
) -> Result<Vec<EpisodeRow>, StoreError> {
    eps.iter()
        .filter(|e| e.state == crate::EpisodeState::Done)
        .map(|e| {
            let terrain = catalog.and_then(|c| c.terrain(&facts.task_set_version, e.world_id));
            Ok(facts.row(values(e, terrain)?))
        })
        .collect()
}

/// A done episode's own values. One without an outcome (never stored since the store's first schema) reads as an
/// infrastructure error rather than being dropped, and one without a reason as its outcome's own reason.
fn values(e: &EpisodeRecord, terrain: Option<u32>) -> Result<EpisodeValues, StoreError> {
    let outcome = e.outcome.unwrap_or(RecordedOutcome::InfrastructureError);
    Ok(EpisodeValues {
        task_id: e.task_id,
        level: e.level,
        semantics: e.semantics,
        density: e.density,
        terrain,
        sim_version: e.sim_version.clone(),
        outcome,
        reason: e.reason.unwrap_or(outcome.plain_reason()),
        detail: e.detail.clone().unwrap_or_default(),
        metrics: e.metrics.clone().unwrap_or_default(),
        wall_time_s: e.wall_time_s.unwrap_or(0.0),
    })
}

/// The summary of a submission's finished episodes, named after the submission.
pub fn summary_of(
    sub: &Submission,
    eps: &[EpisodeRecord],
    catalog: Option<&Catalog>,
) -> Result<Summary, StoreError> {
    summary_with(&facts(sub), eps, catalog)
}

/// [`summary_of`] a submission whose facts are `facts`.
pub fn summary_with(
    facts: &RunFacts,
    eps: &[EpisodeRecord],
    catalog: Option<&Catalog>,
) -> Result<Summary, StoreError> {
    Ok(facts.summary(&rows_of(facts, eps, catalog)?))
}
