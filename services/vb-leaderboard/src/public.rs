//! What the public may see of a submission: its name, planner kind and an identity hash, never its command line,
//! environment, endpoint URL (which may carry credentials), owner token or planner log (a planner prints what it
//! likes, secrets it found included: the owner reads it with `vb-submit log`). An episode's `detail` of a
//! submitted planner is the worker's account, which names the program and the URL and quotes the planner's last
//! output: the public gets the reason's own sentence ([`contracts::EndReason::public_sentence`]) instead, and the
//! owner the whole detail (`vb-submit results`). Every read of the store by the leaderboard goes through here.

use contracts::{PlannerKind, SimVersion, VehicleId};
use results::RunFacts;
use serde::Serialize;
use sha2::{Digest, Sha256};
use vb_store::{
    EpisodeRecord, PlannerSpec, Reader, StoreError, StoredSummary, Submission, SubmissionState,
};

/// One episode as the public sees it: its record and trajectory (the recorded samples, decoded), without the
/// planner's log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PublicEpisode {
    pub record: EpisodeRecord,
    pub trajectory: Vec<contracts::TrajectorySample>,
}

/// A short hash of a planner identity (`sha256:` and 12 hex digits): equal identities, equal hashes.
pub fn identity_hash(identity: &str) -> String {
    let d = Sha256::digest(identity.as_bytes());
    let hex: String = d.iter().take(6).map(|b| format!("{b:02x}")).collect();
    format!("sha256:{hex}")
}

/// The planner as the public sees it: a built-in's name, or the kind and the identity's hash.
fn public_planner(spec: &PlannerSpec, identity: &str) -> (String, String) {
    match spec {
        PlannerSpec::Builtin(name) => (name.to_string(), identity.to_string()),
        _ => (String::new(), identity_hash(identity)),
    }
}

/// A submission as the public sees it: the store's row without its owner's token, the planner's spec shown only
/// for a built-in and its identity only as a hash otherwise (`web/openapi.json`'s `Submission`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PublicSubmission {
    pub id: String,
    pub seq: i64,
    pub name: String,
    pub owner: String,
    pub planner_kind: PlannerKind,
    pub planner_spec: String,
    pub planner_identity: String,
    pub vehicle: VehicleId,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    pub task_set_version: String,
    pub sim_version: SimVersion,
    pub state: SubmissionState,
    pub created_at: f64,
    pub finished_at: Option<f64>,
    pub tasks: u32,
    /// The perception profile it ran under (`ideal`: ground truth).
    pub perception: contracts::PerceptionId,
    /// The first submission of the request that made it (one per perception profile); its own id when alone.
    pub family: String,
    /// What its results' rows share (name, vehicle, versions, rules), for their summaries.
    #[serde(skip)]
    pub facts: RunFacts,
}

fn redact(s: Submission) -> PublicSubmission {
    let (planner_spec, planner_identity) = public_planner(&s.planner, &s.planner_identity);
    PublicSubmission {
        facts: vb_store::aggregate::facts(&s),
        planner_spec,
        planner_identity,
        id: s.id,
        seq: s.seq,
        name: s.name,
        owner: s.owner,
        planner_kind: s.planner.kind(),
        vehicle: s.vehicle,
        scale: s.scale,
        seed: s.seed,
        step_deadline_s: s.step_deadline_s,
        task_set_version: s.task_set_version,
        sim_version: s.sim_version,
        state: s.state,
        created_at: s.created_at,
        finished_at: s.finished_at,
        tasks: s.tasks,
        perception: s.perception.id,
        family: s.family,
    }
}

fn redact_episode(kind: PlannerKind, mut e: EpisodeRecord) -> EpisodeRecord {
    if kind != PlannerKind::Builtin {
        e.planner_identity = e.planner_identity.as_deref().map(identity_hash);
        e.detail = e
            .detail
            .as_ref()
            .map(|_| e.reason.map_or("", |r| r.public_sentence()).to_string());
    }
    e
}

pub async fn submission(r: &Reader, id: &str) -> Result<PublicSubmission, StoreError> {
    r.submission(id).await.map(redact)
}

/// Every submission with its stored aggregates, newest first.
pub async fn board(
    r: &Reader,
) -> Result<Vec<(PublicSubmission, Option<StoredSummary>)>, StoreError> {
    Ok(r.board()
        .await?
        .into_iter()
        .map(|(s, m)| (redact(s), m))
        .collect())
}

/// A page of a submission's episodes (`limit` from `offset`).
pub async fn episodes_range(
    r: &Reader,
    sub: &PublicSubmission,
    offset: usize,
    limit: usize,
) -> Result<Vec<EpisodeRecord>, StoreError> {
    Ok(r.episodes_range(&sub.id, offset, limit)
        .await?
        .into_iter()
        .map(|e| redact_episode(sub.planner_kind, e))
        .collect())
}

/// Every episode of submission `sub` (as [`submission`] read it).
pub async fn episodes(
    r: &Reader,
    sub: &PublicSubmission,
) -> Result<Vec<EpisodeRecord>, StoreError> {
    Ok(r.episodes(&sub.id)
        .await?
        .into_iter()
        .map(|e| redact_episode(sub.planner_kind, e))
        .collect())
}

pub async fn episode_detail(
    r: &Reader,
    id: &str,
    task: contracts::TaskId,
) -> Result<PublicEpisode, StoreError> {
    let kind = r.submission(id).await?.planner.kind();
    let d = r.episode_detail(id, task).await?;
    // An episode without a trajectory (not finished, or failed at its start) has none.
    let trajectory = if d.trajectory_csv.is_empty() {
        Vec::new()
    } else {
        contracts::trajectory::from_csv(&d.trajectory_csv)
            .map_err(|e| StoreError::Corrupt(format!("episode {task}'s trajectory: {e}")))?
    };
    Ok(PublicEpisode {
        record: redact_episode(kind, d.record),
        trajectory,
    })
}
