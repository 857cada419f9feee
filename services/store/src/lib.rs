//! The results store of the evaluation service: submissions, one row per (submission, task) with its lease and
//! result, workers and hashed submission tokens.
//!
//! sqlx's `Any` driver runs the same queries on SQLite (the embedded default) and PostgreSQL (the cluster store);
//! the schema in `migrations/` uses only portable types. Only the coordinator holds a [`Store`] (the writer); the
//! leaderboard gets a [`Reader`], which cannot write.
//!
//! Scheduling invariants kept here:
//! - an episode row is `queued`, `leased` (to one worker, until `lease_expires`), `done` or `not_run`;
//! - a result is accepted once per (submission, task), only from the worker holding the episode's current lease; a
//!   later duplicate is acknowledged and ignored, anything else rejected;
//! - an expired lease returns its episode to the queue (a dead worker's episodes are retried), up to
//!   [`MAX_ATTEMPTS`] times, after which the episode is recorded as an infrastructure failure; every lease that ends
//!   without a result is recorded against its worker's token (`lease_drops`), and a token's repeated drops of one
//!   episode count as one attempt, so one token cannot use up an episode's attempts;
//! - cancelling keeps finished episodes and marks everything that never ran as `not_run`.

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use sqlx::any::{AnyPoolOptions, AnyRow};
use sqlx::{AnyPool, Row};

/// How many times an episode is leased before a worker failure is recorded as the episode's result.
pub const MAX_ATTEMPTS: i64 = 4;

static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("../../migrations");

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("database error: {0}")]
    Db(#[from] sqlx::Error),
    #[error("database migration failed: {0}")]
    Migrate(#[from] sqlx::migrate::MigrateError),
    #[error("unsupported database URL `{0}` (use sqlite://PATH or postgres://...)")]
    Url(String),
    #[error("no submission `{0}`")]
    UnknownSubmission(String),
    #[error("no episode `{task}` in submission `{submission}`")]
    UnknownEpisode { submission: String, task: String },
    #[error("system random number generator failed: {0}")]
    Random(String),
    #[error("corrupt row: {0}")]
    Corrupt(String),
}

pub type Result<T> = std::result::Result<T, StoreError>;

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
    pub planner_kind: String,
    pub planner_spec: String,
    pub planner_identity: String,
    pub vehicle: String,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    pub task_set_version: String,
    pub sim_version: String,
}

/// One task of a new submission, with the factors the leaderboard breaks results down by.
#[derive(Clone, Debug)]
pub struct NewEpisode {
    pub task_id: String,
    pub world_id: u32,
    pub task_index: u32,
    pub level: String,
    pub semantics: String,
    pub density: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Submission {
    pub id: String,
    pub seq: i64,
    pub name: String,
    pub owner: String,
    /// Id of the token that submitted it (empty for submissions made before owners were recorded).
    #[serde(default)]
    pub owner_token: String,
    pub planner_kind: String,
    pub planner_spec: String,
    pub planner_identity: String,
    pub vehicle: String,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    pub task_set_version: String,
    pub sim_version: String,
    pub state: String,
    pub created_at: f64,
    pub finished_at: Option<f64>,
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

/// An episode handed to a worker.
#[derive(Clone, Debug, PartialEq)]
pub struct Lease {
    pub lease_id: String,
    /// The worker holding it.
    pub worker_id: String,
    pub submission: Submission,
    pub task_id: String,
    pub attempt: i64,
}

/// A finished episode as a worker reported it.
#[derive(Clone, Debug, Default)]
pub struct EpisodeResultIn {
    pub lease_id: String,
    pub submission_id: String,
    pub task_id: String,
    pub outcome: String,
    pub reason: String,
    pub detail: String,
    pub metrics_json: String,
    pub trajectory_csv: String,
    pub planner_log: String,
    pub sim_version: String,
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
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    pub submission_id: String,
    pub task_id: String,
    pub world_id: u32,
    pub task_index: u32,
    pub level: String,
    pub semantics: String,
    pub density: String,
    pub state: String,
    pub attempts: i64,
    pub outcome: Option<String>,
    pub reason: Option<String>,
    pub detail: Option<String>,
    pub metrics_json: Option<String>,
    pub sim_version: Option<String>,
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

fn random_hex(bytes: usize) -> Result<String> {
    let mut buf = vec![0u8; bytes];
    getrandom::getrandom(&mut buf).map_err(|e| StoreError::Random(e.to_string()))?;
    Ok(buf.iter().map(|b| format!("{b:02x}")).collect())
}

/// Hex SHA-256 of a token.
pub fn hash_token(token: &str) -> String {
    let d = Sha256::digest(token.as_bytes());
    d.iter().map(|b| format!("{b:02x}")).collect()
}

fn submission_from_row(r: &AnyRow) -> Result<Submission> {
    Ok(Submission {
        id: r.try_get("id")?,
        seq: r.try_get("seq")?,
        name: r.try_get("name")?,
        owner: r.try_get("owner")?,
        owner_token: r.try_get("owner_token")?,
        planner_kind: r.try_get("planner_kind")?,
        planner_spec: r.try_get("planner_spec")?,
        planner_identity: r.try_get("planner_identity")?,
        vehicle: r.try_get("vehicle")?,
        scale: r.try_get("scale")?,
        seed: r.try_get::<i64, _>("seed")? as u64,
        step_deadline_s: r.try_get("step_deadline_s")?,
        task_set_version: r.try_get("task_set_version")?,
        sim_version: r.try_get("sim_version")?,
        state: r.try_get("state")?,
        created_at: r.try_get("created_at")?,
        finished_at: r.try_get("finished_at")?,
    })
}

const EPISODE_COLUMNS: &str = "submission_id, task_id, world_id, task_index, level, semantics, density, state, \
     attempts, outcome, reason, detail, metrics_json, sim_version, planner_identity, wall_time_s, finished_at";

fn episode_from_row(r: &AnyRow) -> Result<EpisodeRecord> {
    Ok(EpisodeRecord {
        submission_id: r.try_get("submission_id")?,
        task_id: r.try_get("task_id")?,
        world_id: r.try_get::<i64, _>("world_id")? as u32,
        task_index: r.try_get::<i64, _>("task_index")? as u32,
        level: r.try_get("level")?,
        semantics: r.try_get("semantics")?,
        density: r.try_get("density")?,
        state: r.try_get("state")?,
        attempts: r.try_get("attempts")?,
        outcome: r.try_get("outcome")?,
        reason: r.try_get("reason")?,
        detail: r.try_get("detail")?,
        metrics_json: r.try_get("metrics_json")?,
        sim_version: r.try_get("sim_version")?,
        planner_identity: r.try_get("planner_identity")?,
        wall_time_s: r.try_get("wall_time_s")?,
        finished_at: r.try_get("finished_at")?,
    })
}

/// Read access to the store (the leaderboard's view).
#[derive(Clone, Debug)]
pub struct Reader {
    pool: AnyPool,
}

/// Read-write access to the store (the coordinator's).
#[derive(Clone, Debug)]
pub struct Store {
    pool: AnyPool,
    backend: Backend,
    /// Serialises this process's writes. SQLite allows one writer at a time and answers a transaction that read
    /// before writing with an immediate "database is locked" when another write slipped in; one writer at a time
    /// avoids that (and costs nothing on PostgreSQL: the coordinator is the only writer anyway).
    write: std::sync::Arc<tokio::sync::Mutex<()>>,
}

async fn open_pool(url: &str, max_connections: u32) -> Result<(AnyPool, Backend)> {
    sqlx::any::install_default_drivers();
    let backend = if url.starts_with("sqlite:") {
        Backend::Sqlite
    } else if url.starts_with("postgres:") || url.starts_with("postgresql:") {
        Backend::Postgres
    } else {
        return Err(StoreError::Url(url.into()));
    };
    let url = if backend == Backend::Sqlite && !url.contains("mode=") {
        // Create the database file when it does not exist yet.
        let sep = if url.contains('?') { '&' } else { '?' };
        format!("{url}{sep}mode=rwc")
    } else {
        url.to_string()
    };
    let pool = AnyPoolOptions::new()
        .max_connections(max_connections)
        .after_connect(move |conn, _| {
            Box::pin(async move {
                if backend == Backend::Sqlite {
                    // WAL lets the leaderboard read while the coordinator writes; wait instead of failing on a lock.
                    sqlx::query("PRAGMA journal_mode = WAL")
                        .execute(&mut *conn)
                        .await?;
                    sqlx::query("PRAGMA busy_timeout = 10000")
                        .execute(&mut *conn)
                        .await?;
                    sqlx::query("PRAGMA foreign_keys = ON")
                        .execute(&mut *conn)
                        .await?;
                }
                Ok(())
            })
        })
        .connect(&url)
        .await?;
    Ok((pool, backend))
}

impl Store {
    /// Opens (creating a SQLite file if needed) and migrates the store at `url`.
    pub async fn open(url: &str) -> Result<Store> {
        let (pool, backend) = open_pool(url, 8).await?;
        MIGRATOR.run(&pool).await?;
        Ok(Store {
            pool,
            backend,
            write: Default::default(),
        })
    }

    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// A read-only view sharing this store's connections.
    pub fn reader(&self) -> Reader {
        Reader {
            pool: self.pool.clone(),
        }
    }

    // ---- tokens ----

    /// Creates a token named `name` with `role`; returns the token, which is shown once and stored only as a hash.
    pub async fn create_token(&self, name: &str, role: TokenRole, now: f64) -> Result<String> {
        let _w = self.write.lock().await;
        let token = format!("vbt_{}", random_hex(24)?);
        sqlx::query(
            "INSERT INTO tokens (id, name, hash, created_at, revoked, role) VALUES ($1, $2, $3, $4, 0, $5)",
        )
        .bind(random_hex(8)?)
        .bind(name)
        .bind(hash_token(&token))
        .bind(now)
        .bind(role.as_str())
        .execute(&self.pool)
        .await?;
        Ok(token)
    }

    /// The (unrevoked) token `token` is, if any.
    pub async fn check_token(&self, token: &str) -> Result<Option<Token>> {
        let row = sqlx::query("SELECT id, name, role FROM tokens WHERE hash = $1 AND revoked = 0")
            .bind(hash_token(token))
            .fetch_optional(&self.pool)
            .await?;
        let Some(r) = row else { return Ok(None) };
        let role: String = r.try_get("role")?;
        Ok(Some(Token {
            id: r.try_get("id")?,
            name: r.try_get("name")?,
            role: TokenRole::parse(&role)
                .ok_or_else(|| StoreError::Corrupt(format!("token role `{role}`")))?,
        }))
    }

    /// Revokes every token named `name`; returns how many.
    pub async fn revoke_tokens(&self, name: &str) -> Result<u64> {
        let _w = self.write.lock().await;
        let r = sqlx::query("UPDATE tokens SET revoked = 1 WHERE name = $1")
            .bind(name)
            .execute(&self.pool)
            .await?;
        Ok(r.rows_affected())
    }

    // ---- workers ----

    /// Registers a worker under the token `token_id`; returns its id.
    pub async fn register_worker(
        &self,
        name: &str,
        slots: u32,
        sim_version: &str,
        token_id: &str,
        now: f64,
    ) -> Result<String> {
        let _w = self.write.lock().await;
        let id = format!("wk-{}", random_hex(6)?);
        sqlx::query(
            "INSERT INTO workers (id, name, slots, sim_version, registered_at, last_seen, token_id)              VALUES ($1, $2, $3, $4, $5, $5, $6)",
        )
        .bind(&id)
        .bind(name)
        .bind(slots as i64)
        .bind(sim_version)
        .bind(now)
        .bind(token_id)
        .execute(&self.pool)
        .await?;
        Ok(id)
    }

    /// Whether `id` is a worker registered under the token `token_id` (and marks it seen).
    pub async fn touch_worker(&self, id: &str, token_id: &str, now: f64) -> Result<bool> {
        let _w = self.write.lock().await;
        let r = sqlx::query("UPDATE workers SET last_seen = $1 WHERE id = $2 AND token_id = $3")
            .bind(now)
            .bind(id)
            .bind(token_id)
            .execute(&self.pool)
            .await?;
        Ok(r.rows_affected() == 1)
    }

    // ---- submissions ----

    /// Stores a submission and one queued episode per task, atomically.
    pub async fn create_submission(
        &self,
        s: &NewSubmission,
        episodes: &[NewEpisode],
        now: f64,
    ) -> Result<String> {
        let _w = self.write.lock().await;
        let id = format!("sub-{}", random_hex(6)?);
        let mut tx = self.pool.begin().await?;
        let seq: i64 = sqlx::query(
            "SELECT CAST(COALESCE(MAX(seq), 0) + 1 AS BIGINT) AS next FROM submissions",
        )
        .fetch_one(&mut *tx)
        .await?
        .try_get("next")?;
        sqlx::query(
            "INSERT INTO submissions (id, seq, name, owner, planner_kind, planner_spec, planner_identity, vehicle, \
             scale, seed, step_deadline_s, task_set_version, sim_version, state, created_at, owner_token) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, 'queued', $14, $15)",
        )
        .bind(&id)
        .bind(seq)
        .bind(&s.name)
        .bind(&s.owner)
        .bind(&s.planner_kind)
        .bind(&s.planner_spec)
        .bind(&s.planner_identity)
        .bind(&s.vehicle)
        .bind(s.scale)
        .bind(s.seed as i64)
        .bind(s.step_deadline_s)
        .bind(&s.task_set_version)
        .bind(&s.sim_version)
        .bind(now)
        .bind(&s.owner_token)
        .execute(&mut *tx)
        .await?;
        for (i, e) in episodes.iter().enumerate() {
            sqlx::query(
                "INSERT INTO episodes (submission_id, task_id, ord, world_id, task_index, level, semantics, density, \
                 state, attempts) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, 'queued', 0)",
            )
            .bind(&id)
            .bind(&e.task_id)
            .bind(i as i64)
            .bind(e.world_id as i64)
            .bind(e.task_index as i64)
            .bind(&e.level)
            .bind(&e.semantics)
            .bind(&e.density)
            .execute(&mut *tx)
            .await?;
        }
        tx.commit().await?;
        Ok(id)
    }

    /// Cancels a submission: queued episodes become `not_run`; leased ones may still report (their results are
    /// kept), and become `not_run` when their lease expires. Returns false when it had already ended.
    pub async fn cancel(&self, id: &str, now: f64) -> Result<bool> {
        let _w = self.write.lock().await;
        let sub = self.reader().submission(id).await?;
        if sub.state == "done" || sub.state == "cancelled" {
            return Ok(false);
        }
        let mut tx = self.pool.begin().await?;
        sqlx::query("UPDATE submissions SET state = 'cancelled', finished_at = $1 WHERE id = $2")
            .bind(now)
            .bind(id)
            .execute(&mut *tx)
            .await?;
        sqlx::query(
            "UPDATE episodes SET state = 'not_run' WHERE submission_id = $1 AND state = 'queued'",
        )
        .bind(id)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(true)
    }

    /// Returns expired leases to the queue (or marks them `not_run` for cancelled submissions, or records an
    /// infrastructure failure after [`MAX_ATTEMPTS`]). Returns how many leases expired.
    pub async fn expire_leases(&self, now: f64) -> Result<u64> {
        let _w = self.write.lock().await;
        self.expire_leases_locked(now).await
    }

    async fn expire_leases_locked(&self, now: f64) -> Result<u64> {
        let mut tx = self.pool.begin().await?;
        // A token that already dropped this episode does not use up another of its attempts ...
        sqlx::query(
            "UPDATE episodes SET attempts = attempts - 1 WHERE state = 'leased' AND lease_expires < $1 \
             AND EXISTS (SELECT 1 FROM lease_drops d JOIN workers w ON w.token_id = d.token_id \
             WHERE w.id = episodes.worker_id AND d.submission_id = episodes.submission_id \
             AND d.task_id = episodes.task_id)",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        // ... and every drop is recorded against the token of the worker that held the lease.
        sqlx::query(
            "INSERT INTO lease_drops (token_id, worker_id, submission_id, task_id, at) \
             SELECT w.token_id, e.worker_id, e.submission_id, e.task_id, $1 FROM episodes e \
             JOIN workers w ON w.id = e.worker_id WHERE e.state = 'leased' AND e.lease_expires < $1",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        let a = sqlx::query(
            "UPDATE episodes SET state = 'not_run', lease_id = NULL, worker_id = NULL, lease_expires = NULL \
             WHERE state = 'leased' AND lease_expires < $1 \
             AND submission_id IN (SELECT id FROM submissions WHERE state = 'cancelled')",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        let b = sqlx::query(
            "UPDATE episodes SET state = 'done', outcome = 'error', reason = 'infrastructure', \
             detail = 'the episode was lost by a worker ' || CAST(attempts AS TEXT) || ' times (worker died or \
             could not run it)' || CASE WHEN detail IS NULL THEN '' ELSE '; last error: ' || detail END, \
             lease_id = NULL, lease_expires = NULL, finished_at = $1 \
             WHERE state = 'leased' AND lease_expires < $1 AND attempts >= $2",
        )
        .bind(now)
        .bind(MAX_ATTEMPTS)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        let c = sqlx::query(
            "UPDATE episodes SET state = 'queued', lease_id = NULL, worker_id = NULL, lease_expires = NULL \
             WHERE state = 'leased' AND lease_expires < $1",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        tx.commit().await?;
        if a + b + c > 0 {
            self.finish_submissions(now).await?;
        }
        Ok(a + b + c)
    }

    /// Leases up to `max` queued episodes to `worker_id` for `lease_s` seconds, oldest submission first (exec and
    /// image planners only to a worker that `runs_exec`). The caller serialises calls (the coordinator holds a lock),
    /// so two workers never lease the same row.
    pub async fn lease(
        &self,
        worker_id: &str,
        max: u32,
        lease_s: f64,
        runs_exec: bool,
        now: f64,
    ) -> Result<Vec<Lease>> {
        let _w = self.write.lock().await;
        if max == 0 {
            return Ok(Vec::new());
        }
        let rows = sqlx::query(
            "SELECT e.submission_id, e.task_id, e.attempts FROM episodes e JOIN submissions s ON s.id = e.submission_id \
             WHERE e.state = 'queued' AND s.state IN ('queued', 'running') \
             AND ($2 = 1 OR s.planner_kind NOT IN ('exec', 'image')) ORDER BY s.seq, e.ord LIMIT $1",
        )
        .bind(max as i64)
        .bind(i64::from(runs_exec))
        .fetch_all(&self.pool)
        .await?;
        let mut out = Vec::with_capacity(rows.len());
        let mut tx = self.pool.begin().await?;
        for r in &rows {
            let submission_id: String = r.try_get("submission_id")?;
            let task_id: String = r.try_get("task_id")?;
            let attempts: i64 = r.try_get("attempts")?;
            let lease_id = format!("ls-{}", random_hex(8)?);
            let n = sqlx::query(
                "UPDATE episodes SET state = 'leased', lease_id = $1, worker_id = $2, lease_expires = $3, \
                 attempts = attempts + 1 WHERE submission_id = $4 AND task_id = $5 AND state = 'queued'",
            )
            .bind(&lease_id)
            .bind(worker_id)
            .bind(now + lease_s)
            .bind(&submission_id)
            .bind(&task_id)
            .execute(&mut *tx)
            .await?
            .rows_affected();
            if n == 1 {
                sqlx::query(
                    "UPDATE submissions SET state = 'running' WHERE id = $1 AND state = 'queued'",
                )
                .bind(&submission_id)
                .execute(&mut *tx)
                .await?;
                out.push((lease_id, submission_id, task_id, attempts + 1));
            }
        }
        tx.commit().await?;
        let reader = self.reader();
        let mut leases = Vec::with_capacity(out.len());
        for (lease_id, sid, task_id, attempt) in out {
            leases.push(Lease {
                lease_id,
                worker_id: worker_id.to_string(),
                submission: reader.submission(&sid).await?,
                task_id,
                attempt,
            });
        }
        Ok(leases)
    }

    /// Extends the leases `lease_ids` held by `worker_id`; returns those that are no longer this worker's to run
    /// (expired and handed to someone else, finished, or cancelled), which the worker must abandon.
    pub async fn renew(
        &self,
        worker_id: &str,
        lease_ids: &[String],
        lease_s: f64,
        now: f64,
    ) -> Result<Vec<String>> {
        let _w = self.write.lock().await;
        let mut gone = Vec::new();
        for id in lease_ids {
            let n = sqlx::query(
                "UPDATE episodes SET lease_expires = $1 WHERE lease_id = $2 AND worker_id = $3 AND state = 'leased' \
                 AND submission_id IN (SELECT id FROM submissions WHERE state <> 'cancelled')",
            )
            .bind(now + lease_s)
            .bind(id)
            .bind(worker_id)
            .execute(&self.pool)
            .await?
            .rows_affected();
            if n == 0 {
                gone.push(id.clone());
            }
        }
        Ok(gone)
    }

    /// How many leases the workers of token `token_id` dropped since `since`.
    pub async fn drops_since(&self, token_id: &str, since: f64) -> Result<u64> {
        let n: i64 = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM lease_drops WHERE token_id = $1 AND at > $2",
        )
        .bind(token_id)
        .bind(since)
        .fetch_one(&self.pool)
        .await?
        .try_get("n")?;
        Ok(n as u64)
    }

    /// Worker `worker_id` could not run its leased episode (not the planner's fault; `why`, kept for the record if
    /// the episode finally fails this way): it goes back to the queue.
    pub async fn release(
        &self,
        worker_id: &str,
        lease_id: &str,
        why: &str,
        now: f64,
    ) -> Result<()> {
        let _w = self.write.lock().await;
        sqlx::query(
            "UPDATE episodes SET lease_expires = $1, detail = $4 WHERE lease_id = $2 AND worker_id = $3 \
             AND state = 'leased'",
        )
        .bind(now - 1.0)
        .bind(lease_id)
        .bind(worker_id)
        .bind(why)
        .execute(&self.pool)
        .await?;
        self.expire_leases_locked(now).await?;
        Ok(())
    }

    /// Records a finished episode reported by worker `worker_id`. It is taken only for an episode that worker holds
    /// the lease `r.lease_id` on; a report for an episode that already has a result is a duplicate (ignored), any
    /// other (not leased, leased to another worker or under another lease, cancelled) is rejected.
    pub async fn report(
        &self,
        worker_id: &str,
        r: &EpisodeResultIn,
        now: f64,
    ) -> Result<ReportOutcome> {
        let _w = self.write.lock().await;
        let row = sqlx::query(
            "SELECT state, lease_id, worker_id FROM episodes WHERE submission_id = $1 AND task_id = $2",
        )
        .bind(&r.submission_id)
        .bind(&r.task_id)
        .fetch_optional(&self.pool)
        .await?;
        let Some(row) = row else {
            return Ok(ReportOutcome::Rejected);
        };
        let state: String = row.try_get("state")?;
        let lease: Option<String> = row.try_get("lease_id")?;
        let holder: Option<String> = row.try_get("worker_id")?;
        match state.as_str() {
            "done" => return Ok(ReportOutcome::Duplicate),
            "leased"
                if lease.as_deref() == Some(r.lease_id.as_str())
                    && holder.as_deref() == Some(worker_id) => {}
            _ => return Ok(ReportOutcome::Rejected),
        }
        let n = sqlx::query(
            "UPDATE episodes SET state = 'done', outcome = $1, reason = $2, detail = $3, metrics_json = $4, \
             trajectory_csv = $5, planner_log = $6, sim_version = $7, planner_identity = $8, wall_time_s = $9, \
             finished_at = $10, lease_id = NULL, lease_expires = NULL \
             WHERE submission_id = $11 AND task_id = $12 AND state = 'leased' AND lease_id = $13",
        )
        .bind(&r.outcome)
        .bind(&r.reason)
        .bind(&r.detail)
        .bind(&r.metrics_json)
        .bind(&r.trajectory_csv)
        .bind(&r.planner_log)
        .bind(&r.sim_version)
        .bind(&r.planner_identity)
        .bind(r.wall_time_s)
        .bind(now)
        .bind(&r.submission_id)
        .bind(&r.task_id)
        .bind(&r.lease_id)
        .execute(&self.pool)
        .await?
        .rows_affected();
        if n == 0 {
            return Ok(ReportOutcome::Duplicate);
        }
        if !r.planner_identity.is_empty() {
            sqlx::query("UPDATE submissions SET planner_identity = $1 WHERE id = $2")
                .bind(&r.planner_identity)
                .bind(&r.submission_id)
                .execute(&self.pool)
                .await?;
        }
        self.finish_submissions(now).await?;
        Ok(ReportOutcome::Accepted)
    }

    /// Marks running submissions with nothing left to run as done.
    async fn finish_submissions(&self, now: f64) -> Result<()> {
        sqlx::query(
            "UPDATE submissions SET state = 'done', finished_at = $1 WHERE state IN ('queued', 'running') AND NOT EXISTS \
             (SELECT 1 FROM episodes e WHERE e.submission_id = submissions.id AND e.state IN ('queued', 'leased'))",
        )
        .bind(now)
        .execute(&self.pool)
        .await?;
        Ok(())
    }
}

impl Reader {
    /// Opens a read-only view of the store at `url` (the leaderboard run apart from the coordinator). The schema
    /// must already exist: the coordinator creates and migrates it.
    pub async fn open(url: &str) -> Result<Reader> {
        let (pool, _) = open_pool(url, 4).await?;
        Ok(Reader { pool })
    }

    pub async fn submission(&self, id: &str) -> Result<Submission> {
        let row = sqlx::query("SELECT * FROM submissions WHERE id = $1")
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
            .ok_or_else(|| StoreError::UnknownSubmission(id.into()))?;
        submission_from_row(&row)
    }

    /// Every submission, newest first.
    pub async fn submissions(&self) -> Result<Vec<Submission>> {
        let rows = sqlx::query("SELECT * FROM submissions ORDER BY seq DESC")
            .fetch_all(&self.pool)
            .await?;
        rows.iter().map(submission_from_row).collect()
    }

    pub async fn progress(&self, id: &str) -> Result<Progress> {
        let sub = self.submission(id).await?;
        let r = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS total, \
             CAST(COALESCE(SUM(CASE WHEN state = 'done' THEN 1 ELSE 0 END), 0) AS BIGINT) AS finished, \
             CAST(COALESCE(SUM(CASE WHEN state = 'leased' THEN 1 ELSE 0 END), 0) AS BIGINT) AS running, \
             CAST(COALESCE(SUM(CASE WHEN state = 'queued' THEN 1 ELSE 0 END), 0) AS BIGINT) AS queued, \
             CAST(COALESCE(SUM(CASE WHEN state = 'not_run' THEN 1 ELSE 0 END), 0) AS BIGINT) AS not_run, \
             CAST(COALESCE(SUM(CASE WHEN outcome = 'success' THEN 1 ELSE 0 END), 0) AS BIGINT) AS successes \
             FROM episodes WHERE submission_id = $1",
        )
        .bind(id)
        .fetch_one(&self.pool)
        .await?;
        let get = |c: &str| -> Result<u32> { Ok(r.try_get::<i64, _>(c)? as u32) };
        let ahead = sqlx::query(
            "SELECT CAST(COUNT(DISTINCT e.submission_id) AS BIGINT) AS subs, CAST(COUNT(*) AS BIGINT) AS eps \
             FROM episodes e JOIN submissions s ON s.id = e.submission_id \
             WHERE e.state IN ('queued', 'leased') AND s.seq < $1 AND s.state IN ('queued', 'running')",
        )
        .bind(sub.seq)
        .fetch_one(&self.pool)
        .await?;
        let mut p = Progress {
            total: get("total")?,
            finished: get("finished")?,
            running: get("running")?,
            queued: get("queued")?,
            not_run: get("not_run")?,
            successes: get("successes")?,
            queue_position: ahead.try_get::<i64, _>("subs")? as u32,
            episodes_ahead: ahead.try_get::<i64, _>("eps")? as u32,
        };
        if sub.state == "done" || sub.state == "cancelled" {
            p.queue_position = 0;
            p.episodes_ahead = 0;
        } else {
            p.episodes_ahead += p.queued + p.running;
        }
        Ok(p)
    }

    /// Episodes finished (by any submission) since `since`, and when the first of them finished: the service's
    /// recent throughput.
    pub async fn finished_since(&self, since: f64) -> Result<(u64, Option<f64>)> {
        let r = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n, MIN(finished_at) AS first FROM episodes \
             WHERE state = 'done' AND finished_at >= $1",
        )
        .bind(since)
        .fetch_one(&self.pool)
        .await?;
        Ok((r.try_get::<i64, _>("n")? as u64, r.try_get("first")?))
    }

    /// Every episode of a submission, in task order.
    pub async fn episodes(&self, submission_id: &str) -> Result<Vec<EpisodeRecord>> {
        let rows = sqlx::query(&format!(
            "SELECT {EPISODE_COLUMNS} FROM episodes WHERE submission_id = $1 ORDER BY ord"
        ))
        .bind(submission_id)
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(episode_from_row).collect()
    }

    pub async fn episode_detail(
        &self,
        submission_id: &str,
        task_id: &str,
    ) -> Result<EpisodeDetail> {
        let row = sqlx::query(&format!(
            "SELECT {EPISODE_COLUMNS}, trajectory_csv, planner_log FROM episodes WHERE submission_id = $1 AND task_id = $2"
        ))
        .bind(submission_id)
        .bind(task_id)
        .fetch_optional(&self.pool)
        .await?
        .ok_or_else(|| StoreError::UnknownEpisode {
            submission: submission_id.into(),
            task: task_id.into(),
        })?;
        Ok(EpisodeDetail {
            record: episode_from_row(&row)?,
            trajectory_csv: row
                .try_get::<Option<String>, _>("trajectory_csv")?
                .unwrap_or_default(),
            planner_log: row
                .try_get::<Option<String>, _>("planner_log")?
                .unwrap_or_default(),
        })
    }
}
