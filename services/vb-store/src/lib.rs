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
//! - a lease handed back unrun by a stopping worker (or refused by one that cannot run it) uses no attempt, and is
//!   recorded against its token (`lease_hand_backs`) so the coordinator can limit a token's rate of them as it
//!   limits drops;
//! - cancelling keeps finished episodes and marks everything that never ran as `not_run`.

use sha2::{Digest, Sha256};
use sqlx::any::AnyPoolOptions;
use sqlx::AnyPool;

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
    UnknownEpisode {
        submission: String,
        task: contracts::TaskId,
    },
    #[error("system random number generator failed: {0}")]
    Random(String),
    #[error("corrupt row: {0}")]
    Corrupt(String),
    /// User-given text the store refuses to keep (a token name with control, bidirectional or invisible
    /// characters: it is shown as a submission's owner).
    #[error("{0}")]
    Input(#[from] contracts::input::InputError),
}

impl contracts::ServiceError for StoreError {
    fn error_code(&self) -> contracts::ServiceErrorCode {
        use contracts::ServiceErrorCode as C;
        match self {
            Self::UnknownSubmission(_) | Self::UnknownEpisode { .. } => C::NotFound,
            Self::Input(_) | Self::Url(_) => C::BadRequest,
            Self::Db(_) | Self::Migrate(_) | Self::Random(_) | Self::Corrupt(_) => C::Internal,
        }
    }
}

pub type Result<T> = std::result::Result<T, StoreError>;

pub mod aggregate;
mod blobs;
mod metrics;
mod planner_spec;
mod reader;
mod report;
mod schedule;
mod summaries;
mod tokens;
mod types;

pub use metrics::Counts;
pub use reader::{FinishedSince, MIN_RATE_EPISODES};
pub use summaries::StoredSummary;
pub use types::*;

pub(crate) fn random_hex(bytes: usize) -> Result<String> {
    let mut buf = vec![0u8; bytes];
    getrandom::getrandom(&mut buf).map_err(|e| StoreError::Random(e.to_string()))?;
    Ok(buf.iter().map(|b| format!("{b:02x}")).collect())
}

/// Hex SHA-256 of a token.
pub fn hash_token(token: &str) -> String {
    let d = Sha256::digest(token.as_bytes());
    d.iter().map(|b| format!("{b:02x}")).collect()
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
                    // In WAL mode NORMAL syncs at checkpoints, not at every commit: a crash of the process loses
                    // nothing, a power loss may roll back the last commits, and the database never corrupts (SQLite,
                    // "PRAGMA synchronous"). Every lease and result is a commit.
                    sqlx::query("PRAGMA synchronous = NORMAL")
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
        blobs::move_inline(&pool).await?;
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
}
