//! What the public may see of a submission: its name, planner kind and an identity hash, never its command line,
//! environment, endpoint URL (which may carry credentials), owner token or planner log (a planner prints what it
//! likes, secrets it found included: the owner reads it with `vb-submit log`). An episode's `detail` of a
//! submitted planner is the worker's account, which names the program and the URL and quotes the planner's last
//! output: the public gets the reason's own sentence ([`contracts::EndReason::public_sentence`]) instead, and the
//! owner the whole detail (`vb-submit results`). Every read of the store by the leaderboard goes through here.

use contracts::PlannerKind;
use serde::Serialize;
use sha2::{Digest, Sha256};
use vb_store::{EpisodeRecord, Reader, StoreError, StoredSummary, Submission};

/// One episode as the public sees it: its record and trajectory, without the planner's log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PublicEpisode {
    pub record: EpisodeRecord,
    pub trajectory_csv: String,
}

/// A short hash of a planner identity (`sha256:` and 12 hex digits): equal identities, equal hashes.
pub fn identity_hash(identity: &str) -> String {
    let d = Sha256::digest(identity.as_bytes());
    let hex: String = d.iter().take(6).map(|b| format!("{b:02x}")).collect();
    format!("sha256:{hex}")
}

/// The planner as the public sees it: a built-in's name, or the kind and the identity's hash.
fn public_planner(kind: PlannerKind, spec: &str, identity: &str) -> (String, String) {
    if kind == PlannerKind::Builtin {
        (spec.to_string(), identity.to_string())
    } else {
        (String::new(), identity_hash(identity))
    }
}

fn redact(mut s: Submission) -> Submission {
    let (spec, identity) = public_planner(s.planner_kind, &s.planner_spec, &s.planner_identity);
    s.planner_spec = spec;
    s.planner_identity = identity;
    s.owner_token = String::new();
    s
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

pub async fn submission(r: &Reader, id: &str) -> Result<Submission, StoreError> {
    r.submission(id).await.map(redact)
}

/// Every submission with its stored aggregates, newest first.
pub async fn board(r: &Reader) -> Result<Vec<(Submission, Option<StoredSummary>)>, StoreError> {
    Ok(r.board()
        .await?
        .into_iter()
        .map(|(s, m)| (redact(s), m))
        .collect())
}

/// A page of a submission's episodes (`limit` from `offset`).
pub async fn episodes_range(
    r: &Reader,
    sub: &Submission,
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
pub async fn episodes(r: &Reader, sub: &Submission) -> Result<Vec<EpisodeRecord>, StoreError> {
    Ok(r.episodes(&sub.id)
        .await?
        .into_iter()
        .map(|e| redact_episode(sub.planner_kind, e))
        .collect())
}

pub async fn episode_detail(r: &Reader, id: &str, task: &str) -> Result<PublicEpisode, StoreError> {
    let kind = r.submission(id).await?.planner_kind;
    let d = r.episode_detail(id, task).await?;
    Ok(PublicEpisode {
        record: redact_episode(kind, d.record),
        trajectory_csv: d.trajectory_csv,
    })
}
