//! The store's values: tokens, submissions, episodes, leases, reports and progress, and how rows become them.

pub use crate::planner_spec::PlannerSpec;
use crate::{Result, StoreError};
use contracts::{
    ElevationLevel, EndReason, EpisodeMetrics, ObstacleDensity, PerceptionEntry, SemanticsKind,
    SimVersion, TaskId, VehicleId,
};
pub use contracts::{EpisodeState, PlannerKind, RecordedOutcome, SubmissionState};
use serde::{Deserialize, Serialize};
use sqlx::any::AnyRow;
use sqlx::Row;

/// The episode rules of every episode the service runs (results carry them; the service has no other variant).
pub const SERVICE_RULES: contracts::Rules = contracts::Rules::Paper;

/// What a token may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TokenRole {
    /// Submits planners and sees, follows and cancels its own submissions.
    User,
    /// Everything a user may, on every submission.
    Admin,
    /// The worker API only: registers workers, leases, renews and reports for them.
    Worker,
}

impl TokenRole {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::User => "user",
            Self::Admin => "admin",
            Self::Worker => "worker",
        }
    }

    pub fn parse(s: &str) -> Option<TokenRole> {
        match s {
            "user" => Some(Self::User),
            "admin" => Some(Self::Admin),
            "worker" => Some(Self::Worker),
            _ => None,
        }
    }
}

/// A valid token: its id (what submissions and workers are bound to), name and role.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Token {
    pub id: String,
    pub name: String,
    pub role: TokenRole,
}

/// Which database a store runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    Postgres,
}

/// A new submission as the coordinator accepted it.
#[derive(Clone, Debug)]
pub struct NewSubmission {
    pub name: String,
    pub owner: String,
    /// Id of the token that submitted it: only that token (and admins) may see and cancel it.
    pub owner_token: String,
    pub planner: PlannerSpec,
    pub planner_identity: String,
    pub vehicle: VehicleId,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    pub task_set_version: String,
    pub sim_version: SimVersion,
    /// The perception profile its episodes run under.
    pub perception: PerceptionEntry,
}

/// One task of a new submission, with the factors the leaderboard breaks results down by.
#[derive(Clone, Debug)]
pub struct NewEpisode {
    pub task_id: TaskId,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
}

impl NewEpisode {
    /// Task `id` of `catalog`'s set (`None` when its world is not in the set).
    pub fn of(catalog: &contracts::Catalog, id: contracts::TaskId) -> Option<NewEpisode> {
        let facts = catalog.worlds.get(&id.world)?;
        Some(NewEpisode {
            task_id: id,
            level: facts.level,
            semantics: facts.semantics,
            density: facts.density,
        })
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Submission {
    pub id: String,
    pub seq: i64,
    pub name: String,
    pub owner: String,
    /// Id of the token that submitted it (empty for submissions made before owners were recorded).
    pub owner_token: String,
    pub planner: PlannerSpec,
    pub planner_identity: String,
    pub vehicle: VehicleId,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    pub task_set_version: String,
    pub sim_version: SimVersion,
    pub perception: PerceptionEntry,
    /// The id of the first submission of the request that made it (one per perception profile); its own id when
    /// it was alone.
    pub family: String,
    pub state: SubmissionState,
    pub created_at: f64,
    pub finished_at: Option<f64>,
    /// How many tasks it has (episodes, whatever their state).
    pub tasks: u32,
}

/// Progress of a submission.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    pub total: u32,
    pub finished: u32,
    pub running: u32,
    pub queued: u32,
    pub not_run: u32,
    pub successes: u32,
    /// Submissions created earlier that still have queued or running episodes.
    pub queue_position: u32,
    /// Episodes that will run before this submission's last one: queued/leased episodes of earlier submissions plus
    /// this submission's own unfinished ones.
    pub episodes_ahead: u32,
}

/// Which untrusted planner kinds a worker runs (built-in and endpoint planners every worker runs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlannerKinds {
    /// Commands started as processes.
    pub exec: bool,
    /// Container images (the worker has a Docker daemon).
    pub image: bool,
}

/// An episode handed to a worker.
#[derive(Clone, Debug, PartialEq)]
pub struct Lease {
    pub lease_id: String,
    /// The worker holding it.
    pub worker_id: String,
    pub submission: Submission,
    pub task_id: TaskId,
    pub attempt: i64,
}

/// A finished episode as a worker reported it (the coordinator has checked its outcome, reason and metrics).
#[derive(Clone, Debug)]
pub struct EpisodeResultIn {
    pub lease_id: String,
    pub submission_id: String,
    pub task_id: TaskId,
    pub outcome: RecordedOutcome,
    pub reason: EndReason,
    pub detail: String,
    /// `None` for an episode no worker could run.
    pub metrics: Option<EpisodeMetrics>,
    pub trajectory_csv: String,
    /// The trajectory already gzip-compressed (as workers send it): stored as it is, instead of compressing
    /// `trajectory_csv`.
    pub trajectory_gz: Option<Vec<u8>>,
    pub planner_log: String,
    pub sim_version: SimVersion,
    pub planner_identity: String,
    pub wall_time_s: f64,
}

/// What happened to a reported result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReportOutcome {
    /// Stored: the first result of this (submission, task).
    Accepted,
    /// This (submission, task) already has a result; the report was ignored.
    Duplicate,
    /// The episode is not leased (cancelled and marked not run, or unknown); the report was ignored.
    Rejected,
}

/// A stored episode (everything but the trajectory and the planner log, which [`Reader::episode_detail`] adds).
/// Reason and metrics are `None` until it has its result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    pub submission_id: String,
    pub task_id: TaskId,
    pub world_id: u32,
    pub task_index: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    pub state: EpisodeState,
    pub attempts: i64,
    pub outcome: Option<RecordedOutcome>,
    pub reason: Option<EndReason>,
    pub detail: Option<String>,
    pub metrics: Option<EpisodeMetrics>,
    pub sim_version: Option<SimVersion>,
    pub planner_identity: Option<String>,
    pub wall_time_s: Option<f64>,
    pub finished_at: Option<f64>,
}

/// One episode with its trajectory (CSV) and the planner's log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeDetail {
    pub record: EpisodeRecord,
    pub trajectory_csv: String,
    pub planner_log: String,
}

pub(crate) fn submission_from_row(r: &AnyRow) -> Result<Submission> {
    let id: String = r.try_get("id")?;
    Ok(Submission {
        family: r
            .try_get::<Option<String>, _>("family")?
            .unwrap_or_else(|| id.clone()),
        id,
        perception: PerceptionEntry {
            id: r.try_get::<String, _>("perception")?.into(),
            params: r.try_get("perception_params")?,
        },
        seq: r.try_get("seq")?,
        name: r.try_get("name")?,
        owner: r.try_get("owner")?,
        owner_token: r.try_get("owner_token")?,
        planner: PlannerSpec::from_columns(
            PlannerKind::parse(&r.try_get::<String, _>("planner_kind")?)
                .map_err(|e| StoreError::Corrupt(e.to_string()))?,
            &r.try_get::<String, _>("planner_spec")?,
        )?,
        planner_identity: r.try_get("planner_identity")?,
        vehicle: r.try_get::<String, _>("vehicle")?.into(),
        scale: r.try_get("scale")?,
        seed: r.try_get::<i64, _>("seed")? as u64,
        step_deadline_s: r.try_get("step_deadline_s")?,
        task_set_version: r.try_get("task_set_version")?,
        sim_version: r.try_get::<String, _>("sim_version")?.into(),
        state: SubmissionState::parse(&r.try_get::<String, _>("state")?)
            .map_err(|e| StoreError::Corrupt(e.to_string()))?,
        created_at: r.try_get("created_at")?,
        finished_at: r.try_get("finished_at")?,
        tasks: r.try_get::<i64, _>("tasks")? as u32,
    })
}

pub(crate) const EPISODE_COLUMNS: &str = "submission_id, task_id, world_id, task_index, level, semantics, density, state, \
     attempts, outcome, reason, detail, metrics_json, sim_version, planner_identity, wall_time_s, finished_at";

/// A text column holding one of a type's string forms.
fn parse_column<T>(
    r: &AnyRow,
    column: &str,
    parse: fn(&str) -> std::result::Result<T, contracts::UnknownName>,
) -> Result<T> {
    parse(&r.try_get::<String, _>(column)?).map_err(|e| StoreError::Corrupt(e.to_string()))
}

pub(crate) fn episode_from_row(r: &AnyRow) -> Result<EpisodeRecord> {
    let submission_id: String = r.try_get("submission_id")?;
    let task: String = r.try_get("task_id")?;
    let corrupt = |what: &str, e: &dyn std::fmt::Display| {
        StoreError::Corrupt(format!(
            "episode {task} of {submission_id}: stored {what}: {e}"
        ))
    };
    let outcome = r
        .try_get::<Option<String>, _>("outcome")?
        .map(|o| RecordedOutcome::parse(&o))
        .transpose()
        .map_err(|e| corrupt("outcome", &e))?;
    // Reports were checked for their outcome only before reasons were typed: a stored reason that is none of
    // EndReason's names reads as its outcome's own reason.
    let reason = r
        .try_get::<Option<String>, _>("reason")?
        .filter(|t| !t.is_empty())
        .map(|t| match EndReason::parse(&t) {
            Ok(reason) => Ok(reason),
            Err(e) => outcome.map(RecordedOutcome::plain_reason).ok_or(e),
        })
        .transpose()
        .map_err(|e| corrupt("reason", &e))?;
    let metrics = r
        .try_get::<Option<String>, _>("metrics_json")?
        .filter(|m| !m.is_empty())
        .map(|m| serde_json::from_str(&m))
        .transpose()
        .map_err(|e| corrupt("metrics", &e))?;
    Ok(EpisodeRecord {
        task_id: task.parse().map_err(|e| corrupt("task id", &e))?,
        world_id: r.try_get::<i64, _>("world_id")? as u32,
        task_index: r.try_get::<i64, _>("task_index")? as u32,
        level: parse_column(r, "level", ElevationLevel::parse)?,
        semantics: parse_column(r, "semantics", SemanticsKind::parse)?,
        density: parse_column(r, "density", ObstacleDensity::parse)?,
        state: EpisodeState::parse(&r.try_get::<String, _>("state")?)
            .map_err(|e| corrupt("state", &e))?,
        attempts: r.try_get("attempts")?,
        outcome,
        reason,
        detail: r.try_get("detail")?,
        metrics,
        sim_version: r
            .try_get::<Option<String>, _>("sim_version")?
            .map(SimVersion::from),
        planner_identity: r.try_get("planner_identity")?,
        wall_time_s: r.try_get("wall_time_s")?,
        finished_at: r.try_get("finished_at")?,
        submission_id,
    })
}
